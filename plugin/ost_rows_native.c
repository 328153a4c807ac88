// ost_rows_native.c: the `native` geometry provider on the CPU for ost_step: thin wrappers that
// hand one mjData's state to core's portable functions (core/ost_rows_native.h) and translate
// their status codes into messages. Invariant: reads d, writes only the context's world.
#include "ost_internal.h"

#include "ost_rows_native.h"

int ost_rowsNative(ostContext* c, mjData* d, mjtNum h) {
  switch (osti_nativeIterate(&c->native, &c->kin, &c->world, d->qpos, c->act_input, c->opt.margin,
                             h)) {
  case OST_ROWS_CONTACT_OVERFLOW:
    return ost_capacityFail(c, "contact", c->ncon_cap);
  case OST_ROWS_ROW_OVERFLOW:
    return ost_capacityFail(c, "row", c->world.nrow_max);
  case OST_ROWS_WIDTH_OVERFLOW:
    return ost_fail(c, OST_ERR_OVERFLOW, "a constraint row touches more than %d dofs (the "
                    "width sized from the model's kinematic tree)", c->world.ncol);
  default:
    return OST_OK;
  }
}


void ost_startNative(ostContext* c, const mjData* d, mjtNum h) {
  osti_nativeStart(&c->native, &c->kin, &c->world, d->qpos, d->qvel, c->act_input,
                   d->qfrc_applied, d->xfrc_applied, h);
}
