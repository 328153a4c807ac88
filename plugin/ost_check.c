// ost_check.c: what Ostrich models, and a clear refusal naming anything it does not.
// Invariant: a model that passes ost_checkModel is stepped without silently ignoring any of its
// features; everything else is refused here, never skipped inside a step.
#include <stdio.h>

#include "ost_internal.h"

// name of object i of a type, or "#i" when unnamed
static const char* objName(const mjModel* m, int type, int i, char* buf, int sz) {
  const char* n = mj_id2name(m, type, i);
  if (n && n[0]) {
    return n;
  }
  snprintf(buf, sz, "#%d", i);
  return buf;
}


int ost_actuatorKind(const mjModel* m, int i, char* err, int err_sz) {
  char nb[32];
  const char* name = objName(m, mjOBJ_ACTUATOR, i, nb, sizeof(nb));
  const mjtNum* b = m->actuator_biasprm + i * mjNBIAS;
  const char* why = NULL;
  if (m->actuator_dyntype[i] != mjDYN_NONE) {
    why = "activation dynamics (dyntype other than none: intvelocity, cylinder, muscle, filter)";
  } else if (m->actuator_gaintype[i] != mjGAIN_FIXED) {
    why = "a non-fixed gain (gaintype affine, muscle or user)";
  } else if (m->actuator_trntype[i] == mjTRN_BODY) {
    why = "a body (adhesion) transmission";
  } else if (m->actuator_biastype[i] == mjBIAS_AFFINE && (b[1] > 0 || b[2] > 0)) {
    why = "an affine bias with positive position or velocity feedback";
  } else if (m->actuator_biastype[i] != mjBIAS_NONE && m->actuator_biastype[i] != mjBIAS_AFFINE) {
    why = "a muscle or user bias";
  }
  if (why) {
    if (err) snprintf(err, err_sz, "actuator '%s' has %s, which Ostrich does not model", name, why);
    return -1;
  }
  // affine bias with feedback: force = g ctrl + b0 + b1 L + b2 V is an implicit servo row
  if (m->actuator_biastype[i] == mjBIAS_AFFINE && (b[1] < 0 || b[2] < 0)) {
    return 1;
  }
  return 0;  // motor-like: explicit force
}


int ost_checkModel(const mjModel* m, char* err, int err_sz) {
  char nb[32];
  if (!m) {
    return -1;
  }
  if (mj_version() != 222) {
    if (err) snprintf(err, err_sz, "MuJoCo library version %d is not 2.2.2", mj_version());
    return OST_ERR_VERSION;
  }
#define REFUSE(...)                                  \
  do {                                               \
    if (err) snprintf(err, err_sz, __VA_ARGS__);     \
    return OST_ERR_MODEL;                            \
  } while (0)

  for (int i = 0; i < m->nv; i++) {
    if (m->dof_frictionloss[i] > 0) {
      REFUSE("joint '%s' has frictionloss (dry joint friction), which Ostrich does not model",
             objName(m, mjOBJ_JOINT, m->dof_jntid[i], nb, sizeof(nb)));
    }
  }
  for (int i = 0; i < m->ntendon; i++) {
    if (m->tendon_limited[i]) {
      REFUSE("tendon '%s' has limits, which Ostrich does not model",
             objName(m, mjOBJ_TENDON, i, nb, sizeof(nb)));
    }
    if (m->tendon_frictionloss[i] > 0) {
      REFUSE("tendon '%s' has frictionloss, which Ostrich does not model",
             objName(m, mjOBJ_TENDON, i, nb, sizeof(nb)));
    }
  }
  for (int i = 0; i < m->ngeom; i++) {
    int cd = m->geom_condim[i];
    if (cd != 1 && cd != 3 && (m->geom_contype[i] || m->geom_conaffinity[i])) {
      REFUSE("geom '%s' has condim %d (torsional/rolling friction), which Ostrich does not "
             "model; use condim 1 or 3", objName(m, mjOBJ_GEOM, i, nb, sizeof(nb)), cd);
    }
  }
  for (int i = 0; i < m->npair; i++) {
    if (m->pair_dim[i] != 1 && m->pair_dim[i] != 3) {
      REFUSE("contact pair #%d has condim %d, which Ostrich does not model", i, m->pair_dim[i]);
    }
    if (m->pair_friction[i * 5] != m->pair_friction[i * 5 + 1]) {
      REFUSE("contact pair #%d has anisotropic friction, which Ostrich does not model", i);
    }
  }
  for (int i = 0; i < m->nu; i++) {
    if (ost_actuatorKind(m, i, err, err_sz) < 0) {
      return OST_ERR_MODEL;
    }
  }
#undef REFUSE
  return OST_OK;
}
