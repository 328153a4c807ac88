// ost_python.c: the flat C API that the Python package `ostrich` loads with ctypes
// (plugin/python/ostrich/_lib.py). It is the only code that touches mjModel/mjData for Python:
// loading, array pointers and shapes (from MuJoCo's own X-macro tables in mjxmacro.h, so Python
// never re-declares a struct layout), names, stepping with either engine, Ostrich's options and
// statistics, and recorded rollouts with their backward pass.
//
// Invariant: nothing here exits or lets MuJoCo's default error handler run. ostpy_init installs
// handlers for mju_user_error / mju_user_warning that record the message (per thread) and
// return; every call returns a status and leaves its message in the physics' or the tape's
// error buffer (ostpy_error, ostpy_tapeError).
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <mujoco/mjxmacro.h>
#include <mujoco/mujoco.h>

#include "ostrich.h"

#if defined(__GNUC__) || defined(__clang__)
  #define OSTPY_API __attribute__((visibility("default")))
#else
  #define OSTPY_API
#endif

#define OSTPY_MSG_SZ 1024

typedef enum ostpyKind_ {         // element type of an array (ostpy_array)
  OSTPY_MJTNUM = 0,               // double
  OSTPY_INT    = 1,               // int32
  OSTPY_FLOAT  = 2,               // float32
  OSTPY_BYTE   = 3,               // uint8 (mjtByte)
  OSTPY_CHAR   = 4,               // char
  OSTPY_OTHER  = 5                // a struct (mjContact): not exposed
} ostpyKind;

typedef struct ostpyPhysics_ {    // one model and its data
  mjModel*   m;
  mjData*    d;
  ostOptions opt;                 // the options steps of d use (model's, then ostpy_setOptions)
  char       err[OSTPY_MSG_SZ];   // message of the last failure ("" if none)
} ostpyPhysics;

typedef struct ostpyTape_ {       // a recorded rollout (ost_tape) and its states' qpos
  ostTape* tape;
  int      nstep;                 // steps recorded
  int      cap;                   // capacity of qpos in states
  mjtNum*  qpos;                  // qpos of every state, the start included ((nstep + 1) x nq)
  char     err[OSTPY_MSG_SZ];     // message of the last failure ("" if none)
} ostpyTape;


//---------------------------------- MuJoCo's messages ---------------------------------------------

static _Thread_local char g_mjError[OSTPY_MSG_SZ];  // first MuJoCo error since the last clear
static _Thread_local char g_mjWarning[OSTPY_MSG_SZ];  // last MuJoCo warning since the last clear


static void onMujocoError(const char* msg) {
  if (!g_mjError[0]) {
    snprintf(g_mjError, sizeof(g_mjError), "%s", msg);
  }
}


static void onMujocoWarning(const char* msg) {
  snprintf(g_mjWarning, sizeof(g_mjWarning), "%s", msg);
}


// Set buf to the formatted message (one line, at most OSTPY_MSG_SZ) and return status.
static int fail(char* buf, int status, const char* msg) {
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
    snprintf(err, err_sz, "%s", msg[0] ? msg : g_mjError[0] ? g_mjError : "cannot load the model");
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
// ...: the objects its rows belong to); "time" is mjData's scalar time as a 1 x 1 array, and
// "opt.timestep", "opt.gravity" the model's. Returns 0, or 1 if there is no such array.
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
  static const char* kData = MJDATA_POINTERS "time";
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
  X(regularization) X(friction_creep) X(geometry) X(depenetration_speed)

// ostStats' and ostTotals' fields, in this order for ostpy_stats
#define OSTPY_STATS(X) X(status) X(newton_iter) X(best_iter) X(pcr_iter) X(substeps)             \
  X(geometry_evals) X(ncon) X(nrow) X(residual) X(residual_first) X(max_penetration)            \
  X(initial_violation) X(islands)
#define OSTPY_TOTALS(X) X(steps) X(failed) X(unconverged) X(depenetrated) X(overflow)            \
  X(worst_residual) X(worst_initial_violation) X(last_failure) X(model_packs)

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
    return fail(p->err, status, ost_lastError(p->d)[0] ? ost_lastError(p->d) : "bad options");
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
        return fail(p->err, status, ost_lastError(p->d));
      }
    }
    if (g_mjError[0]) {
      return fail(p->err, OST_ERR_NUMERIC, g_mjError);
    }
  }
  return result;
}


// mj_forward at p's state; returns 0 or OST_ERR_NUMERIC with MuJoCo's error.
OSTPY_API int ostpy_forward(ostpyPhysics* p) {
  g_mjError[0] = 0;
  mj_forward(p->m, p->d);
  return g_mjError[0] ? fail(p->err, OST_ERR_NUMERIC, g_mjError) : OST_OK;
}


// Reset the data to qpos0 at rest (key = -1) or to keyframe key, then mj_forward. Returns 0, or
// OST_ERR_INPUT for a keyframe out of range.
OSTPY_API int ostpy_reset(ostpyPhysics* p, int key) {
  if (key < -1 || key >= p->m->nkey) {
    char msg[128];
    snprintf(msg, sizeof(msg), "keyframe %d out of range: the model has %d", key, p->m->nkey);
    return fail(p->err, OST_ERR_INPUT, msg);
  }
  if (key < 0) {
    mj_resetData(p->m, p->d);
  } else {
    mj_resetDataKeyframe(p->m, p->d, key);
  }
  return ostpy_forward(p);
}


//---------------------------------- Recorded rollouts ---------------------------------------------

// New tape for p's model (checkpoint as ost_tapeCreate); NULL if out of memory.
OSTPY_API ostpyTape* ostpy_tapeCreate(ostpyPhysics* p, int checkpoint) {
  ostpyTape* t = (ostpyTape*)calloc(1, sizeof(ostpyTape));
  if (!t) {
    return NULL;
  }
  t->tape = ost_tapeCreate(p->m, checkpoint);
  if (!t->tape) {
    free(t);
    return NULL;
  }
  return t;
}


// Release a tape (NULL is ignored).
OSTPY_API void ostpy_tapeFree(ostpyTape* t) {
  if (t) {
    ost_tapeDelete(t->tape);
    free(t->qpos);
    free(t);
  }
}


// Message of the tape's last failure ("" if none).
OSTPY_API const char* ostpy_tapeError(const ostpyTape* t) {
  return t ? t->err : "no tape";
}


// Record nstep Ostrich steps from p's state with controls ctrl (nstep x nu; NULL: keep d's),
// after forgetting the tape's last rollout. qpos ((nstep + 1) x nq) and qvel ((nstep + 1) x nv)
// receive every state, the start first; status (nstep) each step's ost_step status; any may be
// NULL. Returns OST_OK, OST_WARN_NOT_CONVERGED if a step warned (the rollout went on; the
// backward pass will refuse it), or the error of the step that failed (message in
// ostpy_tapeError; the rollout stops there and t->nstep counts the steps taken).
OSTPY_API int ostpy_rollout(ostpyPhysics* p, ostpyTape* t, int nstep, const mjtNum* ctrl,
                            mjtNum* qpos, mjtNum* qvel, int* status) {
  const mjModel* m = p->m;
  mjData* d = p->d;
  int nq = m->nq, nv = m->nv, nu = m->nu, result = OST_OK;
  t->err[0] = 0;
  t->nstep = 0;
  ost_tapeClear(t->tape);
  if (nstep < 0) {
    return fail(t->err, -3, "the number of steps is negative");
  }
  if (t->cap < nstep + 1) {
    mjtNum* grown = (mjtNum*)realloc(t->qpos, sizeof(mjtNum) * (size_t)(nstep + 1) * nq);
    if (!grown) {
      return fail(t->err, OST_ERR_MEMORY, "out of memory for the rollout's states");
    }
    t->qpos = grown;
    t->cap = nstep + 1;
  }
  g_mjError[0] = 0;
  mju_copy(t->qpos, d->qpos, nq);
  if (qpos) {
    mju_copy(qpos, d->qpos, nq);
  }
  if (qvel) {
    mju_copy(qvel, d->qvel, nv);
  }
  for (int k = 0; k < nstep; k++) {
    if (ctrl) {
      mju_copy(d->ctrl, ctrl + (size_t)k * nu, nu);
    }
    int s = ost_tapeStep(t->tape, m, d);
    if (status) {
      status[k] = s;
    }
    if (s != OST_OK && !OST_IS_WARNING(s)) {
      char msg[OSTPY_MSG_SZ];
      snprintf(msg, sizeof(msg), "step %d of the rollout failed: %.900s", k + 1, ost_lastError(d));
      return fail(t->err, s, msg);
    }
    if (g_mjError[0]) {
      char msg[OSTPY_MSG_SZ];
      snprintf(msg, sizeof(msg), "step %d of the rollout: MuJoCo error: %.900s", k + 1, g_mjError);
      return fail(t->err, OST_ERR_NUMERIC, msg);
    }
    if (OST_IS_WARNING(s)) {
      result = s;
    }
    t->nstep = k + 1;
    mju_copy(t->qpos + (size_t)(k + 1) * nq, d->qpos, nq);
    if (qpos) {
      mju_copy(qpos + (size_t)(k + 1) * nq, d->qpos, nq);
    }
    if (qvel) {
      mju_copy(qvel + (size_t)(k + 1) * nv, d->qvel, nv);
    }
  }
  return result;
}


// Tangent cotangent gt (nv) of a coordinate cotangent gc (nq) at qpos: gt = G(qpos)^T gc, where
// G is the derivative of qpos along mj_integratePos's tangent (identity for slides, hinges and
// free positions; d(q * exp(delta / 2))/d delta_i = 1/2 q * (0, e_i) for ball and free
// rotations, delta in the local frame).
static void coordToTangent(const mjModel* m, const mjtNum* qpos, const mjtNum* gc, mjtNum* gt) {
  for (int j = 0; j < m->njnt; j++) {
    int padr = m->jnt_qposadr[j], vadr = m->jnt_dofadr[j], type = m->jnt_type[j];
    if (type == mjJNT_FREE) {
      mju_copy3(gt + vadr, gc + padr);
      padr += 3;
      vadr += 3;
    }
    if (type == mjJNT_FREE || type == mjJNT_BALL) {
      for (int i = 0; i < 3; i++) {
        mjtNum e[4] = {0, 0, 0, 0}, dq[4];
        e[i + 1] = 0.5;
        mju_mulQuat(dq, qpos + padr, e);
        gt[vadr + i] = mju_dot(gc + padr, dq, 4);
      }
    } else {
      gt[vadr] = gc[padr];
    }
  }
}


// Coordinate gradient gc (nq) of a tangent gradient gt (nv) at qpos: the one tangent to the
// unit sphere of each quaternion, gc = G (G^T G)^-1 gt = 4 G gt (the columns of G are
// orthogonal with norm 1/2), so that gc . (G delta) = gt . delta for every tangent delta.
static void tangentToCoord(const mjModel* m, const mjtNum* qpos, const mjtNum* gt, mjtNum* gc) {
  for (int j = 0; j < m->njnt; j++) {
    int padr = m->jnt_qposadr[j], vadr = m->jnt_dofadr[j], type = m->jnt_type[j];
    if (type == mjJNT_FREE) {
      mju_copy3(gc + padr, gt + vadr);
      padr += 3;
      vadr += 3;
    }
    if (type == mjJNT_FREE || type == mjJNT_BALL) {
      mju_zero4(gc + padr);
      for (int i = 0; i < 3; i++) {
        mjtNum e[4] = {0, 0, 0, 0}, dq[4];
        e[i + 1] = 2;  // 4 * 1/2
        mju_mulQuat(dq, qpos + padr, e);
        mju_addToScl(gc + padr, dq, gt[vadr + i], 4);
      }
    } else {
      gc[padr] = gt[vadr];
    }
  }
}


// Backward pass of the recorded rollout (ost_tapeBackward). gqpos: dL/dqpos of every state
// ((nstep + 1) x nq coordinates, or (nstep + 1) x nv tangent vectors if tangent), gqvel
// ((nstep + 1) x nv); NULL = zero. Outputs, any may be NULL: gctrl (nstep x nu), gqpos0 (nq
// coordinates, or nv if tangent), gqvel0 (nv) and, with params, gtheta (ost_nparam, set, not
// accumulated). truncate: ostGradOptions.truncate. Returns ost_tapeBackward's status (message
// in ostpy_tapeError: a rollout with an unconverged step is refused, OST_ERR_NOT_CONVERGED).
OSTPY_API int ostpy_backward(ostpyPhysics* p, ostpyTape* t, int tangent, int params,
                             int truncate, const mjtNum* gqpos, const mjtNum* gqvel,
                             mjtNum* gctrl, mjtNum* gqpos0, mjtNum* gqvel0, mjtNum* gtheta) {
  const mjModel* m = p->m;
  int nq = m->nq, nv = m->nv, n = t->nstep, status = OST_OK;
  size_t rows = (size_t)n + 1;
  t->err[0] = 0;
  if (ost_tapeSteps(t->tape) != n) {
    return fail(t->err, OST_ERR_INPUT, "the tape holds no complete rollout");
  }
  mjtNum* gq = (mjtNum*)calloc(rows * nv + nv, sizeof(mjtNum));
  if (!gq) {
    return fail(t->err, OST_ERR_MEMORY, "out of memory");
  }
  mjtNum* gq0 = gq + rows * nv;
  for (size_t k = 0; k < rows && gqpos; k++) {
    if (tangent) {
      mju_copy(gq + k * nv, gqpos + k * nv, nv);
    } else {
      coordToTangent(m, t->qpos + k * nq, gqpos + k * nq, gq + k * nv);
    }
  }
  if (params && gtheta) {
    mju_zero(gtheta, ost_nparam(m));
  }
  ostGradOptions go;
  ost_defaultGradOptions(&go);
  go.truncate = truncate;
  go.params = params && gtheta;
  g_mjError[0] = 0;
  status = ost_tapeBackward(t->tape, m, &go, gq, gqvel, gctrl, gq0, gqvel0,
                            go.params ? gtheta : NULL);
  if (status != OST_OK) {
    fail(t->err, status, ost_tapeError(t->tape));
  } else if (g_mjError[0]) {
    status = fail(t->err, OST_ERR_NUMERIC, g_mjError);
  } else if (gqpos0) {
    if (tangent) {
      mju_copy(gqpos0, gq0, nv);
    } else {
      tangentToCoord(m, t->qpos, gq0, gqpos0);
    }
  }
  free(gq);
  return status;
}


// Tangent cotangents gt (n x nv) of coordinate cotangents gc (n x nq) at the states qpos
// (n x nq): coordToTangent row by row (batches' backward passes take tangent vectors).
OSTPY_API void ostpy_coordToTangent(const ostpyPhysics* p, int n, const mjtNum* qpos,
                                    const mjtNum* gc, mjtNum* gt) {
  int nq = p->m->nq, nv = p->m->nv;
  for (size_t k = 0; k < (size_t)n; k++) {
    coordToTangent(p->m, qpos + k * nq, gc + k * nq, gt + k * nv);
  }
}


// Coordinate gradients gc (n x nq) of tangent gradients gt (n x nv) at the states qpos
// (n x nq): tangentToCoord row by row.
OSTPY_API void ostpy_tangentToCoord(const ostpyPhysics* p, int n, const mjtNum* qpos,
                                    const mjtNum* gt, mjtNum* gc) {
  int nq = p->m->nq, nv = p->m->nv;
  for (size_t k = 0; k < (size_t)n; k++) {
    tangentToCoord(p->m, qpos + k * nq, gt + k * nv, gc + k * nq);
  }
}


// ost_batchBackward with ostGradOptions built here (truncate; no parameters for batches).
OSTPY_API int ostpy_batchBackward(ostBatch* b, int truncate, int checkpoint, const mjtNum* gq,
                                  const mjtNum* gu, mjtNum* gctrl, mjtNum* gq0, mjtNum* gu0) {
  ostGradOptions go;
  ost_defaultGradOptions(&go);
  go.truncate = truncate;
  return ost_batchBackward(b, &go, checkpoint, gq, gu, gctrl, gq0, gu0);
}
