// ost_python.c: the flat C API that the Python package `ostrich` loads with ctypes
// (plugin/python/ostrich/_lib.py). It is the only code that touches mjModel/mjData for Python:
// loading, array pointers and shapes (from MuJoCo's own X-macro tables in mjxmacro.h, so Python
// never re-declares a struct layout), names, stepping with either engine, Ostrich's options and
// statistics (ost_python_rollout.c: recorded rollouts and their backward pass).
//
// Invariant: nothing here exits or lets MuJoCo's default error handler run. ostpy_init installs
// handlers for mju_user_error / mju_user_warning that record the message (per thread) and
// return; every call returns a status and leaves its message in the physics' or the tape's
// error buffer (ostpy_error, ostpy_tapeError).
//
// The library's users are Python's ctypes declarations (ostrich/_lib.py): a function marked
// OSTPY_API is exported, everything else is hidden.
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <mujoco/mjxmacro.h>
#include <mujoco/mujoco.h>

#include "ost_python.h"

typedef enum ostpyKind_ {         // element type of an array (ostpy_array)
  OSTPY_MJTNUM = 0,               // double
  OSTPY_INT    = 1,               // int32
  OSTPY_FLOAT  = 2,               // float32
  OSTPY_BYTE   = 3,               // uint8 (mjtByte)
  OSTPY_CHAR   = 4,               // char
  OSTPY_OTHER  = 5                // a struct (mjContact): not exposed
} ostpyKind;


//---------------------------------- MuJoCo's messages ---------------------------------------------

static _Thread_local char g_mjError[OSTPY_MSG_SZ];    // first MuJoCo error since the last clear
static _Thread_local char g_mjWarning[OSTPY_MSG_SZ];  // last MuJoCo warning since the last clear


static void onMujocoError(const char* msg) {
  if (!g_mjError[0]) {
    snprintf(g_mjError, sizeof(g_mjError), "%s", msg);
  }
}


static void onMujocoWarning(const char* msg) {
  snprintf(g_mjWarning, sizeof(g_mjWarning), "%s", msg);
}


char* ostpy_mujocoError(void) {
  return g_mjError;
}


int ostpy_fail(char* buf, int status, const char* msg) {
  snprintf(buf, OSTPY_MSG_SZ, "%s", msg);
  for (char* c = buf; *c; c++) {
    if (*c == '\n' || *c == '\r') {
      *c = ' ';
    }
  }
  return status;
}


// Install the recording handlers; return MuJoCo's library version (222 for 2.2.2).
OSTPY_API int ostpy_init(void) {
  mju_user_error = onMujocoError;
  mju_user_warning = onMujocoWarning;
  return mj_version();
}


// Last MuJoCo warning since the previous call ("" if none); the call clears it.
OSTPY_API const char* ostpy_takeWarning(void) {
  static _Thread_local char out[OSTPY_MSG_SZ];
  snprintf(out, sizeof(out), "%s", g_mjWarning);
  g_mjWarning[0] = 0;
  return out;
}


//---------------------------------- Loading -------------------------------------------------------

// Load an MJCF model from a file (is_string = 0) or from the text itself (is_string = 1, as the
// file "model.xml" of a virtual file system: relative asset paths resolve against the current
// directory). Returns NULL with MuJoCo's message in err on failure.
OSTPY_API ostpyPhysics* ostpy_load(const char* src, int is_string, char* err, int err_sz) {
  char msg[OSTPY_MSG_SZ] = "";
  mjModel* m = NULL;
  g_mjError[0] = 0;
  if (!src) {
    snprintf(err, err_sz, "no model given");
    return NULL;
  }
  if (is_string) {
    mjVFS* vfs = (mjVFS*)malloc(sizeof(mjVFS));
    int len = (int)strlen(src);
    if (!vfs) {
      snprintf(err, err_sz, "out of memory");
      return NULL;
    }
    mj_defaultVFS(vfs);
    if (mj_makeEmptyFileVFS(vfs, "model.xml", len) == 0) {
      memcpy(vfs->filedata[mj_findFileVFS(vfs, "model.xml")], src, (size_t)len);
      m = mj_loadXML("model.xml", vfs, msg, sizeof(msg));
    } else {
      snprintf(msg, sizeof(msg), "cannot hold the XML text in a virtual file");
    }
    mj_deleteVFS(vfs);
    free(vfs);
  } else {
    m = mj_loadXML(src, NULL, msg, sizeof(msg));
  }
  if (!m) {
    const char* why = msg[0] ? msg : g_mjError[0] ? g_mjError : "cannot load the model";
    snprintf(err, err_sz, "%s", why);
    return NULL;
  }
  ostpyPhysics* p = (ostpyPhysics*)calloc(1, sizeof(ostpyPhysics));
  mjData* d = p ? mj_makeData(m) : NULL;
  if (!d || g_mjError[0]) {
    snprintf(err, err_sz, "%s", g_mjError[0] ? g_mjError : "out of memory");
    if (d) {
      mj_deleteData(d);
    }
    free(p);
    mj_deleteModel(m);
    return NULL;
  }
  p->m = m;
  p->d = d;

  // the model's ostrich/* options; an error here is reported by the first Ostrich step
  if (ost_readOptions(m, &p->opt, msg, sizeof(msg)) != OST_OK) {
    ost_defaultOptions(&p->opt);
  }
  mj_forward(m, d);
  return p;
}


// Release the data (with Ostrich's state of it) and the model (NULL is ignored).
OSTPY_API void ostpy_free(ostpyPhysics* p) {
  if (!p) {
    return;
  }
  ost_deleteData(p->d);
  mj_deleteModel(p->m);
  free(p);
}


// The mjModel (for the public API's functions, called directly through ctypes).
OSTPY_API mjModel* ostpy_model(ostpyPhysics* p) {
  return p ? p->m : NULL;
}


// The mjData.
OSTPY_API mjData* ostpy_data(ostpyPhysics* p) {
  return p ? p->d : NULL;
}


// Message of the last failed call on p ("" if none).
OSTPY_API const char* ostpy_error(const ostpyPhysics* p) {
  return p ? p->err : "no physics";
}


//---------------------------------- Arrays and names ----------------------------------------------

#define OSTPY_KIND(x) _Generic((x), mjtNum*: OSTPY_MJTNUM, int*: OSTPY_INT, \
                               float*: OSTPY_FLOAT, mjtByte*: OSTPY_BYTE, char*: OSTPY_CHAR, \
                               default: OSTPY_OTHER)


// Value of the mjModel size `name` (nq, nv, nbody, ...: MJMODEL_INTS), or -1 if unknown.
OSTPY_API int ostpy_size(const ostpyPhysics* p, const char* name) {
  #define X(n) if (!strcmp(name, #n)) return p->m->n;
  MJMODEL_INTS
  #undef X
  return -1;
}


// Pointer, shape and element kind (ostpyKind) of the array `name` of mjData (data = 1) or
// mjModel (data = 0), from mjxmacro.h's tables, and the name of its row count ("nbody", "nq",
// ...: the objects its rows belong to); "time" is mjData's scalar time as a 1 x 1 array, "ncon"
// its number of contacts (of MuJoCo's collision) as a 1 x 1 int array, and "opt.timestep",
// "opt.gravity" the model's. Returns 0, or 1 if there is no such array.
OSTPY_API int ostpy_array(ostpyPhysics* p, int data, const char* name, void** ptr, int* rows,
                          int* cols, int* kind, const char** rowdim) {
  const mjModel* m = p->m;
  mjData* d = p->d;
  if (data) {
    MJDATA_POINTERS_PREAMBLE(m)
    (void)nv;
    (void)njmax;
    #define X(type, n, nr, nc)                                                                   \
      if (!strcmp(name, #n)) {                                                                   \
        *ptr = d->n; *rows = m->nr; *cols = nc; *kind = OSTPY_KIND(d->n);                        \
        *rowdim = #nr; return 0;                                                                 \
      }
    MJDATA_POINTERS
    #undef X
    if (!strcmp(name, "time")) {
      *ptr = &d->time; *rows = 1; *cols = 1; *kind = OSTPY_MJTNUM; *rowdim = "";
      return 0;
    }
    if (!strcmp(name, "ncon")) {
      *ptr = &d->ncon; *rows = 1; *cols = 1; *kind = OSTPY_INT; *rowdim = "";
      return 0;
    }
  } else {
    MJMODEL_POINTERS_PREAMBLE(m)
    #define X(type, n, nr, nc)                                                                   \
      if (!strcmp(name, #n)) {                                                                   \
        *ptr = m->n; *rows = m->nr; *cols = nc; *kind = OSTPY_KIND(m->n);                        \
        *rowdim = #nr; return 0;                                                                 \
      }
    MJMODEL_POINTERS
    #undef X
    if (!strcmp(name, "opt.timestep")) {
      *ptr = (void*)&m->opt.timestep; *rows = 1; *cols = 1; *kind = OSTPY_MJTNUM; *rowdim = "";
      return 0;
    }
    if (!strcmp(name, "opt.gravity")) {
      *ptr = (void*)m->opt.gravity; *rows = 1; *cols = 3; *kind = OSTPY_MJTNUM; *rowdim = "";
      return 0;
    }
    (void)nuser_body; (void)nuser_jnt; (void)nuser_geom; (void)nuser_site; (void)nuser_cam;
    (void)nuser_tendon; (void)nuser_actuator; (void)nuser_sensor; (void)nq; (void)nv; (void)na;
    (void)nu; (void)nmocap;
  }
  return 1;
}


// Comma-separated names of every array that ostpy_array gives for mjData (data = 1) or mjModel.
OSTPY_API const char* ostpy_arrayNames(int data) {
  #define X(type, n, nr, nc) #n ","
  static const char* kData = MJDATA_POINTERS "time,ncon";
  static const char* kModel = MJMODEL_POINTERS "opt.timestep,opt.gravity";
  #undef X
  return data ? kData : kModel;
}


// mjtObj value of an object type named as in mjtObj without its prefix ("body", "joint",
// "geom", "site", "actuator", "sensor", ...), or -1.
OSTPY_API int ostpy_objType(const char* name) {
  static const struct { const char* name; int type; } kTypes[] = {
    {"body", mjOBJ_BODY}, {"joint", mjOBJ_JOINT}, {"dof", mjOBJ_DOF}, {"geom", mjOBJ_GEOM},
    {"site", mjOBJ_SITE}, {"camera", mjOBJ_CAMERA}, {"light", mjOBJ_LIGHT},
    {"mesh", mjOBJ_MESH}, {"hfield", mjOBJ_HFIELD}, {"material", mjOBJ_MATERIAL},
    {"equality", mjOBJ_EQUALITY}, {"tendon", mjOBJ_TENDON}, {"actuator", mjOBJ_ACTUATOR},
    {"sensor", mjOBJ_SENSOR}, {"numeric", mjOBJ_NUMERIC}, {"key", mjOBJ_KEY},
  };
  for (size_t i = 0; i < sizeof(kTypes) / sizeof(kTypes[0]); i++) {
    if (!strcmp(name, kTypes[i].name)) {
      return kTypes[i].type;
    }
  }
  return -1;
}


// Name of object id of mjtObj type ("" if unnamed or out of range).
OSTPY_API const char* ostpy_name(const ostpyPhysics* p, int type, int id) {
  const char* s = mj_id2name(p->m, type, id);
  return s ? s : "";
}


//---------------------------------- Options and statistics ----------------------------------------

// ostOptions' fields, in this order for ostpy_getOptions / ostpy_setOptions
#define OSTPY_OPTIONS(X) X(newton_iter) X(pcr_iter) X(k_min) X(linesearch) X(warmstart) X(tol) \
  X(pcr_tol) X(timestep) X(margin) X(fb_eps) X(eq_compliance) X(split_depth) X(split_tol)       \
  X(regularization) X(friction_creep) X(geometry) X(depenetration_speed)    \
  X(geometric_newton) X(cold_retry) X(convex_distance) X(geometric_retry) X(decouple_open)   \
  X(deep_splits)

// ostStats' and ostTotals' fields, in this order for ostpy_stats
#define OSTPY_STATS(X) X(status) X(newton_iter) X(best_iter) X(pcr_iter) X(substeps)             \
  X(geometry_evals) X(ncon) X(nrow) X(residual) X(residual_first) X(max_penetration)            \
  X(initial_violation) X(islands) X(ncon_capacity) X(retries) X(geo_retries)
#define OSTPY_TOTALS(X) X(steps) X(failed) X(unconverged) X(depenetrated) X(retries) X(overflow) \
  X(geo_retries) X(worst_residual) X(worst_initial_violation) X(last_failure) X(model_packs) X(stages_reused)

#define OSTPY_NAME(f) #f ","


// Comma-separated field names: 0 options, 1 stats, 2 totals (each list ends with a comma).
OSTPY_API const char* ostpy_fieldNames(int which) {
  static const char* kNames[3] = {OSTPY_OPTIONS(OSTPY_NAME), OSTPY_STATS(OSTPY_NAME),
                                  OSTPY_TOTALS(OSTPY_NAME)};
  return which >= 0 && which < 3 ? kNames[which] : "";
}


// The options steps of p use, in OSTPY_OPTIONS order.
OSTPY_API void ostpy_getOptions(const ostpyPhysics* p, double* out) {
  int i = 0;
  #define X(f) out[i++] = (double)p->opt.f;
  OSTPY_OPTIONS(X)
  #undef X
}


// Set the options of p's steps (OSTPY_OPTIONS order); returns ost_setOptions' status.
OSTPY_API int ostpy_setOptions(ostpyPhysics* p, const double* in) {
  ostOptions opt = p->opt;
  int i = 0;
  #define X(f) opt.f = _Generic(opt.f, int: (int)in[i], default: in[i]); i++;
  OSTPY_OPTIONS(X)
  #undef X
  int status = ost_setOptions(p->m, p->d, &opt);
  if (status != OST_OK) {
    const char* why = ost_lastError(p->d)[0] ? ost_lastError(p->d) : "bad options";
    return ostpy_fail(p->err, status, why);
  }
  p->opt = opt;
  return OST_OK;
}


// The last Ostrich step's statistics (which = 1, ostStats) or the counts since the data was
// first stepped (which = 2, ostTotals), in OSTPY_STATS / OSTPY_TOTALS order; 1 if d was never
// stepped by Ostrich (out untouched).
OSTPY_API int ostpy_stats(const ostpyPhysics* p, int which, double* out) {
  int i = 0;
  if (which == 1 && ost_stats(p->d)) {
    const ostStats* s = ost_stats(p->d);
    #define X(f) out[i++] = (double)s->f;
    OSTPY_STATS(X)
    #undef X
    return 0;
  }
  if (which == 2 && ost_totals(p->d)) {
    const ostTotals* t = ost_totals(p->d);
    #define X(f) out[i++] = (double)t->f;
    OSTPY_TOTALS(X)
    #undef X
    return 0;
  }
  return 1;
}


//---------------------------------- Stepping ------------------------------------------------------

// Advance nstep steps with Ostrich (engine 0, ost_step) or MuJoCo (engine 1, mj_step). Returns
// OST_OK, OST_WARN_NOT_CONVERGED if any Ostrich step warned (the state advanced), or an error
// status after the step that failed (its state left as it was; message in ostpy_error).
OSTPY_API int ostpy_step(ostpyPhysics* p, int engine, int nstep) {
  int result = OST_OK;
  g_mjError[0] = 0;
  p->err[0] = 0;
  for (int k = 0; k < nstep; k++) {
    if (engine == 1) {
      mj_step(p->m, p->d);
    } else {
      int status = ost_step(p->m, p->d);
      if (OST_IS_WARNING(status)) {
        result = status;
      } else if (status != OST_OK) {
        return ostpy_fail(p->err, status, ost_lastError(p->d));
      }
    }
    if (g_mjError[0]) {
      return ostpy_fail(p->err, OST_ERR_NUMERIC, g_mjError);
    }
  }
  return result;
}


// mj_forward at p's state; returns 0 or OST_ERR_NUMERIC with MuJoCo's error.
OSTPY_API int ostpy_forward(ostpyPhysics* p) {
  g_mjError[0] = 0;
  mj_forward(p->m, p->d);
  return g_mjError[0] ? ostpy_fail(p->err, OST_ERR_NUMERIC, g_mjError) : OST_OK;
}


// Reset the data to qpos0 at rest (key = -1) or to keyframe key, then mj_forward. Returns 0, or
// OST_ERR_INPUT for a keyframe out of range.
OSTPY_API int ostpy_reset(ostpyPhysics* p, int key) {
  if (key < -1 || key >= p->m->nkey) {
    char msg[128];
    snprintf(msg, sizeof(msg), "keyframe %d out of range: the model has %d", key, p->m->nkey);
    return ostpy_fail(p->err, OST_ERR_INPUT, msg);
  }
  if (key < 0) {
    mj_resetData(p->m, p->d);
  } else {
    mj_resetDataKeyframe(p->m, p->d, key);
  }
  return ostpy_forward(p);
}
