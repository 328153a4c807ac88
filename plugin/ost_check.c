// ost_check.c: what Ostrich models, and a clear refusal naming everything it does not.
// Invariant: a model that passes ost_checkModel is stepped without silently ignoring any of its
// features; everything else is refused here, never skipped inside a step. A refusal names every
// unsupported feature and the elements that use it (grouped per feature, ost_check.h), so one
// run shows all that must change.
#include <stdarg.h>
#include <stdio.h>
#include <string.h>

#include "ost_check.h"
#include "ost_internal.h"


//---------------------------------- Refusal lists -------------------------------------------------

const char* ost_objName(const mjModel* m, int type, int i, char* buf, int sz) {
  const char* n = mj_id2name(m, type, i);
  if (n && n[0]) {
    snprintf(buf, sz, "%s", n);
  } else {
    snprintf(buf, sz, "#%d", i);
  }
  return buf;
}


void ost_refuse(ostRefusalList* l, const char* what, const char* name, const char* fmt, ...) {
  char feature[sizeof(l->item[0].feature)];
  va_list args;
  va_start(args, fmt);
  vsnprintf(feature, sizeof(feature), fmt, args);
  va_end(args);

  // the same feature on the same kind of element: one more of them
  for (int i = 0; i < l->n; i++) {
    ostRefusal* r = l->item + i;
    if (!strcmp(r->what, what) && !strcmp(r->feature, feature)) {
      if (r->count < OST_REFUSAL_NAMES) {
        snprintf(r->name[r->count], sizeof(r->name[0]), "%s", name ? name : "");
      }
      r->count++;
      return;
    }
  }
  if (l->n == l->cap) {
    l->extra++;
    return;
  }
  ostRefusal* r = l->item + l->n++;
  snprintf(r->what, sizeof(r->what), "%s", what);
  snprintf(r->feature, sizeof(r->feature), "%s", feature);
  snprintf(r->name[0], sizeof(r->name[0]), "%s", name ? name : "");
  r->count = 1;
}


// plural of an element kind: "body" -> "bodies", "joint" -> "joints"
static void plural(char* out, int sz, const char* what) {
  size_t n = strlen(what);
  if (n > 1 && what[n - 1] == 'y' && !strchr("aeiou", what[n - 2])) {
    snprintf(out, sz, "%.*sies", (int)(n - 1), what);
  } else {
    snprintf(out, sz, "%ss", what);
  }
}


// one entry: "joint 'a': F", "3 joints ('a', 'b', 'c'): F", "5 joints ('a', 'b', 'c' and 2
// more): F", or F alone for the whole model
static void formatEntry(const ostRefusal* r, char* out, int sz) {
  if (!r->what[0]) {
    snprintf(out, sz, "%s", r->feature);
    return;
  }
  if (r->count == 1) {
    snprintf(out, sz, "%s '%s': %s", r->what, r->name[0], r->feature);
    return;
  }
  char kinds[48];
  plural(kinds, sizeof(kinds), r->what);
  int len = snprintf(out, sz, "%d %s (", r->count, kinds);
  int shown = r->count < OST_REFUSAL_NAMES ? r->count : OST_REFUSAL_NAMES;
  for (int i = 0; i < shown && len < sz; i++) {
    len += snprintf(out + len, sz - len, "%s'%s'", i ? ", " : "", r->name[i]);
  }
  if (r->count > shown && len < sz) {
    len += snprintf(out + len, sz - len, " and %d more", r->count - shown);
  }
  if (len < sz) {
    snprintf(out + len, sz - len, "): %s", r->feature);
  }
}


int ost_refusalMessage(const ostRefusalList* l, const char* prefix, char* err, int err_sz) {
  int total = l->n + l->extra;
  if (!total) {
    return OST_OK;
  }
  if (!err || err_sz <= 0) {
    return OST_ERR_MODEL;
  }
  int len = snprintf(err, err_sz, "%s (%d feature%s): ", prefix, total, total > 1 ? "s" : "");
  if (len >= err_sz) {
    return OST_ERR_MODEL;
  }
  // keep room for the tail "; ... and K more" whenever entries remain after this one
  const int tail = 24;
  for (int i = 0; i < l->n; i++) {
    char entry[512];
    formatEntry(l->item + i, entry, sizeof(entry));
    int last = (i == l->n - 1 && !l->extra);
    int need = (int)strlen(entry) + (i ? 2 : 0) + (last ? 0 : tail);
    if (len + need >= err_sz) {
      snprintf(err + len, err_sz - len, "%s... and %d more", i ? "; " : "", total - i);
      return OST_ERR_MODEL;
    }
    len += snprintf(err + len, err_sz - len, "%s%s", i ? "; " : "", entry);
  }
  if (l->extra) {
    snprintf(err + len, err_sz - len, "; ... and %d more", l->extra);
  }
  return OST_ERR_MODEL;
}


//---------------------------------- Actuators -----------------------------------------------------

// every unsupported feature of actuator i into l
static void actuatorRefusals(const mjModel* m, int i, ostRefusalList* l) {
  static const char* const dyn[] = {"none", "integrator", "filter", "muscle", "user"};
  static const char* const gain[] = {"fixed", "affine", "muscle", "user"};
  static const char* const bias[] = {"none", "affine", "muscle", "user"};
  char nb[64];
  const char* name = ost_objName(m, mjOBJ_ACTUATOR, i, nb, sizeof(nb));
  const mjtNum* b = m->actuator_biasprm + i * mjNBIAS;
  int dt = m->actuator_dyntype[i], gt = m->actuator_gaintype[i], bt = m->actuator_biastype[i];
  // integrator, filter and muscle activations are taken implicitly (core/ost_activation.h),
  // muscle gains and biases as explicit forces (core/ost_muscle.h)
  if (dt != mjDYN_NONE && dt != mjDYN_INTEGRATOR && dt != mjDYN_FILTER && dt != mjDYN_MUSCLE) {
    ost_refuse(l, "actuator", name, "activation dynamics (dyntype %s%s)",
               dt >= 0 && dt <= mjDYN_USER ? dyn[dt] : "unknown",
               dt == mjDYN_USER ? ": the mjcb_act_dyn callback" : "");
  }
  if (gt != mjGAIN_FIXED && gt != mjGAIN_MUSCLE) {
    ost_refuse(l, "actuator", name, "a non-fixed gain (gaintype %s)",
               gt >= 0 && gt <= mjGAIN_USER ? gain[gt] : "unknown");
  }
  if (bt == mjBIAS_AFFINE && (b[1] > 0 || b[2] > 0)) {
    ost_refuse(l, "actuator", name, "an affine bias with positive position or velocity feedback");
  } else if (bt != mjBIAS_NONE && bt != mjBIAS_AFFINE && bt != mjBIAS_MUSCLE) {
    ost_refuse(l, "actuator", name, "a user bias (biastype %s)",
               bt >= 0 && bt <= mjBIAS_USER ? bias[bt] : "unknown");
  }
}


int ost_actuatorKind(const mjModel* m, int i, char* err, int err_sz) {
  ostRefusal item[4];
  ostRefusalList l = {item, 4, 0, 0};
  actuatorRefusals(m, i, &l);
  if (l.n) {
    ost_refusalMessage(&l, "unsupported by Ostrich", err, err_sz);
    return -1;
  }
  // fixed gain, affine bias with feedback: force = g ctrl + b0 + b1 L + b2 V is an implicit
  // servo row; a muscle gain (-F FL FV, nonlinear in L and V) keeps its bias explicit
  const mjtNum* b = m->actuator_biasprm + i * mjNBIAS;
  if (m->actuator_gaintype[i] == mjGAIN_FIXED && m->actuator_biastype[i] == mjBIAS_AFFINE
      && (b[1] < 0 || b[2] < 0)) {
    return 1;
  }
  return 0;  // motor-like: explicit force
}


//---------------------------------- Model check ---------------------------------------------------

void ost_refusalsModel(const mjModel* m, ostRefusalList* l) {
  char nb[64];
  // condim 1, 3, 4 and 6 are MuJoCo's; anything else is refused by MuJoCo's compiler already
  for (int i = 0; i < m->npair; i++) {
    ost_objName(m, mjOBJ_PAIR, i, nb, sizeof(nb));
    const mjtNum* f = m->pair_friction + 5 * i;
    if (f[0] != f[1] || (m->pair_dim[i] >= 6 && f[3] != f[4])) {
      ost_refuse(l, "contact pair", nb, "anisotropic friction");
    }
  }
  for (int i = 0; i < m->nu; i++) {
    actuatorRefusals(m, i, l);
  }
}


int ost_checkModelList(const mjModel* m, ostRefusal* out, int nout) {
  if (!m || nout < 0 || (nout > 0 && !out)) {
    return -1;
  }
  ostRefusal item[OST_REFUSAL_CAP];
  ostRefusalList l = {item, OST_REFUSAL_CAP, 0, 0};
  ost_refusalsModel(m, &l);
  for (int i = 0; i < l.n && i < nout; i++) {
    out[i] = item[i];
  }
  return l.n + l.extra;
}


int ost_checkModel(const mjModel* m, char* err, int err_sz) {
  if (!m) {
    return -1;
  }
  if (mj_version() != 222) {
    if (err) snprintf(err, err_sz, "MuJoCo library version %d is not 2.2.2", mj_version());
    return OST_ERR_VERSION;
  }
  ostRefusal item[OST_REFUSAL_CAP];
  ostRefusalList l = {item, OST_REFUSAL_CAP, 0, 0};
  ost_refusalsModel(m, &l);
  return ost_refusalMessage(&l, "unsupported by Ostrich", err, err_sz);
}


int ost_checkStep(const mjModel* m, const ostOptions* opt, char* err, int err_sz) {
  if (!m) {
    return -1;
  }
  if (!opt) {
    return -2;
  }
  if (mj_version() != 222) {
    if (err) snprintf(err, err_sz, "MuJoCo library version %d is not 2.2.2", mj_version());
    return OST_ERR_VERSION;
  }
  ostRefusal item[OST_REFUSAL_CAP];
  ostRefusalList l = {item, OST_REFUSAL_CAP, 0, 0};
  ost_refusalsModel(m, &l);
  char nb[64];
  if (opt->geometry == OST_GEOMETRY_NATIVE) {
    ost_refusalsNative(m, &l);
  } else {
    // the mujoco provider collides height fields against primitives with core's functions
    // (ost_corePair); against a mesh, with MuJoCo 2.2.2's, whose distances leave out the margin
    for (int g = 0; g < m->ngeom && opt->margin > 0; g++) {
      if (m->geom_type[g] != mjGEOM_HFIELD) {
        continue;
      }
      for (int g2 = 0; g2 < m->ngeom; g2++) {
        if (m->geom_type[g2] == mjGEOM_MESH
            && ((m->geom_contype[g] & m->geom_conaffinity[g2])
                || (m->geom_contype[g2] & m->geom_conaffinity[g]))) {
          ost_refuse(&l, "height field", ost_objName(m, mjOBJ_GEOM, g, nb, sizeof(nb)),
                     "contacts with a mesh and ostrich/margin > 0 with the mujoco geometry "
                     "provider (MuJoCo 2.2.2 reports height-field contact distances without the "
                     "margin, which breaks the look-ahead; use ostrich/margin 0, or "
                     "ostrich/geometry 1, native)");
          break;
        }
      }
    }
    int terrain = ost_terrainGeom(m);
    if (terrain >= 0) {
      ost_refuse(&l, "geom", ost_objName(m, mjOBJ_GEOM, terrain, nb, sizeof(nb)),
                 "an ostrich/terrain mesh with the mujoco geometry provider (MuJoCo 2.2.2 "
                 "collides a mesh as its convex hull; use ostrich/geometry 1, native)");
    }
  }
  return ost_refusalMessage(&l, "unsupported by Ostrich", err, err_sz);
}
