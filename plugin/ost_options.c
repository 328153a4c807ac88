// ost_options.c: Ostrich options, their defaults, and their reading from MJCF
// <custom><numeric name="ostrich/KEY" data="VALUE"/></custom> so that a model configured for
// Ostrich still loads in stock MuJoCo 2.2.2. Invariant: one table lists every option.
#include <stdio.h>
#include <string.h>

#include "ostrich.h"

// every option: name, whether it is an integer, its field, its default
#define OST_OPTIONS(X)                      \
  X(newton_iter,   1, 64)                   \
  X(pcr_iter,      1, 32)                   \
  X(k_min,         1, 1)                    \
  X(linesearch,    1, 1)                    \
  X(warmstart,     1, 1)                    \
  X(split_depth,   1, 6)                    \
  X(deep_splits,   1, 6)                    \
  X(split_tol,     0, 1e-10)                \
  X(tol,           0, 1e-10)                \
  X(pcr_tol,       0, 1e-12)                \
  X(timestep,      0, 0)                    \
  X(margin,        0, 0.01)                 \
  X(fb_eps,        0, 1e-9)                 \
  X(eq_compliance, 0, 0)                   \
  X(regularization, 0, 1e-6)               \
  X(friction_creep, 0, 0)                  \
  X(geometry,      1, 0)                    \
  X(depenetration_speed, 0, 1)          \
  X(geometric_newton, 1, 1)               \
  X(cold_retry,    1, 1)                    \
  X(geometric_retry, 1, 0)                  \
  X(convex_distance, 1, 0)                  \
  X(decouple_open, 1, 0)

void ost_defaultOptions(ostOptions* opt) {
#define X(name, isint, def) opt->name = def;
  OST_OPTIONS(X)
#undef X
}


// check ranges; returns 0 or writes a message
static int validate(const ostOptions* o, char* err, int err_sz) {
  const char* bad = NULL;
  if (o->newton_iter < 1 || o->newton_iter > 1000) bad = "newton_iter must be in [1, 1000]";
  else if (o->pcr_iter < 1 || o->pcr_iter > 100000) bad = "pcr_iter must be in [1, 100000]";
  else if (o->k_min < 0 || o->k_min > o->newton_iter) bad = "k_min must be in [0, newton_iter]";
  else if (o->linesearch < 0 || o->linesearch > 30) bad = "linesearch must be in [0, 30]";
  else if (o->warmstart != 0 && o->warmstart != 1) bad = "warmstart must be 0 or 1";
  else if (o->split_depth < 0 || o->split_depth > 10) bad = "split_depth must be in [0, 10]";
  else if (o->deep_splits < 0 || o->deep_splits > 1000) bad = "deep_splits must be in [0, 1000]";
  else if (!(o->split_tol >= 0)) bad = "split_tol must be >= 0";
  else if (!(o->tol >= 0)) bad = "tol must be >= 0";
  else if (!(o->pcr_tol >= 0)) bad = "pcr_tol must be >= 0";
  else if (!(o->timestep >= 0) || o->timestep > 10) bad = "timestep must be in [0, 10] s";
  else if (!(o->margin >= 0) || o->margin > 10) bad = "margin must be in [0, 10] m";
  else if (!(o->fb_eps > 0)) bad = "fb_eps must be > 0";
  else if (!(o->eq_compliance >= 0)) bad = "eq_compliance must be >= 0";
  else if (o->geometry != OST_GEOMETRY_MUJOCO && o->geometry != OST_GEOMETRY_NATIVE) {
    bad = "geometry must be 0 (mujoco) or 1 (native)";
  } else if (!(o->regularization >= 0) || o->regularization > 1) {
    bad = "regularization must be in [0, 1]";
  } else if (!(o->friction_creep >= 0) || o->friction_creep > 1) {
    bad = "friction_creep must be in [0, 1] s/kg";
  } else if (!(o->depenetration_speed >= 0)) {
    bad = "depenetration_speed must be >= 0 m/s (0: remove violations at once)";
  } else if (o->geometric_newton < 0 || o->geometric_newton > 3) {
    bad = "geometric_newton must be 0 (off), 1 (on slow iterates), 2 (every iterate) or 3 "
          "(every iterate, every row)";
  } else if (o->cold_retry != 0 && o->cold_retry != 1) {
    bad = "cold_retry must be 0 or 1";
  } else if (o->geometric_retry != 0 && o->geometric_retry != 1) {
    bad = "geometric_retry must be 0 or 1";
  } else if (o->convex_distance != 0 && o->convex_distance != 1) {
    bad = "convex_distance must be 0 or 1";
  } else if (o->decouple_open != 0 && o->decouple_open != 1) {
    bad = "decouple_open must be 0 or 1";
  }
  if (bad) {
    if (err) snprintf(err, err_sz, "ostrich option: %s", bad);
    return OST_ERR_MODEL;
  }
  return OST_OK;
}


int ost_readOptions(const mjModel* m, ostOptions* opt, char* err, int err_sz) {
  if (!m) return -1;
  if (!opt) return -2;
  ost_defaultOptions(opt);
  for (int i = 0; i < m->nnumeric; i++) {
    const char* name = m->names + m->name_numericadr[i];
    if (strncmp(name, "ostrich/", 8) != 0) {
      continue;
    }
    const char* key = name + 8;
    double v = m->numeric_data[m->numeric_adr[i]];
    if (m->numeric_size[i] < 1) {
      if (err) snprintf(err, err_sz, "ostrich option '%s' has no value", key);
      return OST_ERR_MODEL;
    }
    int known = 0;
#define X(field, isint, def)                     \
    if (!strcmp(key, #field)) {                  \
      opt->field = isint ? (int)v : v;           \
      known = 1;                                 \
    }
    OST_OPTIONS(X)
#undef X
    if (!known) {
      if (err) snprintf(err, err_sz, "unknown ostrich option '%s' in <custom>", key);
      return OST_ERR_MODEL;
    }
  }
  return validate(opt, err, err_sz);
}


// used by ost_setOptions in ost_context.c
int ost_validateOptions(const ostOptions* opt, char* err, int err_sz) {
  return validate(opt, err, err_sz);
}


// 1 if every option of a and b is the same (the table's fields, not the struct's padding)
int ost_optionsEqual(const ostOptions* a, const ostOptions* b) {
#define X(name, isint, def) if (a->name != b->name) return 0;
  OST_OPTIONS(X)
#undef X
  return 1;
}
