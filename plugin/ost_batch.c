// ost_batch.c: the batched API of ostrich.h (many worlds of one model, one allocation) and its
// CPU driver. The model is packed once (core's ostModel, margins widened by the look-ahead as
// for ost_step); the worlds live in one 64-byte-aligned allocation laid out by core's
// OST_BATCH_ARRAYS, on the host (`cpu`, split into contiguous chunks, one thread each) or on the
// GPU (`cuda`, cuda/ost_batch.cu, one thread per world). Both run osti_batchRollout.
// Mirrors MAGMA's batched drivers: the host validates arguments, the per-world code never does.
// Invariant: a world's result depends only on its own state and controls, never on the number
// of threads, the device or its neighbours.
#define _GNU_SOURCE  // sysconf(_SC_NPROCESSORS_ONLN)

#include <pthread.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "ost_batch.h"
#include "ost_internal.h"

#ifdef OSTRICH_HAVE_CUDA
#include "ost_batch_gpu.h"
#endif

#define OST_BATCH_MAX_THREADS 256

struct ostBatch_ {
  int             cuda;           // 1: worlds live on the GPU
  int             nthread;        // CPU threads (cpu device)
  int             nq, nv, nu;     // the model's sizes
  ostStepSettings set;            // solver settings from the model's options
  ostModel        model;          // packed model (host)
  void*           model_block;    // its allocation
  size_t          model_bytes;    // its size
  ostModel        model_dev;      // the device copy (cuda)
  void*           model_dev_block;
  ostBatchLayout  L;              // world layout
  char*           worlds;         // L.total bytes: host (cpu) or device (cuda)
  ostNum*         qpos0;          // the model's qpos0 (nq)
  mjModel*        m;              // the user's model, copied (backward replays)
  int             fresh;          // 1: no step since ost_batchSetState
  int             rec_nstep;      // steps of the last rollout from a set state (0: none)
  ostNum*         rec_start;      // its start states: nworld x (nq + nv)
  ostNum*         rec_ctrl;       // its controls: rec_nstep x nworld x nu
  char            err[1000];      // last failure
};


// record a failure message and return status
static int batchFail(ostBatch* b, int status, const char* msg) {
  snprintf(b->err, sizeof(b->err), "%s", msg);
  return status;
}


// threads for "cpu" (all online cores) or "cpu:N"; 0 if the device string is not a cpu one
static int cpuThreads(const char* device) {
  if (!strcmp(device, "cpu")) {
    long n = sysconf(_SC_NPROCESSORS_ONLN);
    return n < 1 ? 1 : (n > OST_BATCH_MAX_THREADS ? OST_BATCH_MAX_THREADS : (int)n);
  }
  if (!strncmp(device, "cpu:", 4)) {
    char* end;
    long n = strtol(device + 4, &end, 10);
    return (*end || n < 1 || n > OST_BATCH_MAX_THREADS) ? 0 : (int)n;
  }
  return 0;
}


// pack m for native stepping: options, model check, margins widened by the look-ahead
static int packBatchModel(ostBatch* b, const mjModel* m, char* err, int err_sz) {
  ostOptions o;
  int status;
  if ((status = ost_readOptions(m, &o, err, err_sz)) || (status = ost_checkModel(m, err, err_sz))) {
    return status;
  }
  mjModel* mo = mj_copyModel(NULL, m);
  if (!mo) {
    snprintf(err, err_sz, "cannot copy the model");
    return OST_ERR_MEMORY;
  }
  ost_widenMargins(mo, o.margin);
  status = ost_packModel(mo, mo->nconmax, &b->model, &b->model_block, err, err_sz);
  mj_deleteModel(mo);
  if (status) {
    return status;
  }
  b->model_bytes = ostu_modelSize(b->model.s);
  ostStepSettings* s = &b->set;
  memset(s, 0, sizeof(*s));
  s->so = ost_solverOptions(&o);
  s->linesearch = o.linesearch;
  s->split_depth = o.split_depth < OST_SPLIT_MAX ? o.split_depth : OST_SPLIT_MAX;
  s->warmstart = o.warmstart;
  s->h = o.timestep > 0 ? o.timestep : m->opt.timestep;
  s->split_tol = o.split_tol;
  s->lookahead = o.margin;
  return OST_OK;
}


ostBatch* ost_batchCreate(const mjModel* m, int nworld, const char* device, char* err,
                          int err_sz) {
  char scratch[8];
  if (!err || err_sz < 1) {
    err = scratch;
    err_sz = sizeof(scratch);
  }
  err[0] = 0;
  if (!m || nworld < 1 || !device) {
    snprintf(err, err_sz, "ost_batchCreate: %s", !m ? "no model" : nworld < 1
             ? "nworld must be >= 1" : "no device (\"cpu\", \"cpu:N\" or \"cuda\")");
    return NULL;
  }
  int nthread = cpuThreads(device), cuda = !strcmp(device, "cuda");
  if (!nthread && !cuda) {
    snprintf(err, err_sz, "ost_batchCreate: unknown device '%s' (\"cpu\", \"cpu:N\" with "
             "1 <= N <= %d, or \"cuda\")", device, OST_BATCH_MAX_THREADS);
    return NULL;
  }
#ifndef OSTRICH_HAVE_CUDA
  if (cuda) {
    snprintf(err, err_sz, "ost_batchCreate: this Ostrich was built without CUDA "
             "(configure with -DOSTRICH_CUDA=ON)");
    return NULL;
  }
#endif
  ostBatch* b = (ostBatch*)calloc(1, sizeof(ostBatch));
  if (!b) {
    snprintf(err, err_sz, "ost_batchCreate: out of memory");
    return NULL;
  }
  b->cuda = cuda;
  b->nthread = nthread < nworld ? nthread : nworld;
  b->nq = m->nq;
  b->nv = m->nv;
  b->nu = m->nu;
  if (packBatchModel(b, m, err, err_sz)) {
    ost_batchDelete(b);
    return NULL;
  }
  ostu_batchLayout(&b->L, b->model.s, ost_rowCapacity(m), nworld);
  b->qpos0 = (ostNum*)malloc(sizeof(ostNum) * (m->nq > 0 ? m->nq : 1));
  if (!b->qpos0) {
    snprintf(err, err_sz, "ost_batchCreate: out of memory");
    ost_batchDelete(b);
    return NULL;
  }
  memcpy(b->qpos0, m->qpos0, sizeof(ostNum) * m->nq);
  b->m = mj_copyModel(NULL, m);
  if (!b->m) {
    snprintf(err, err_sz, "ost_batchCreate: out of memory");
    ost_batchDelete(b);
    return NULL;
  }
  int bad;
  if (cuda) {
#ifdef OSTRICH_HAVE_CUDA
    bad = ost_batchModel_gpu(&b->model, b->model_block, b->model_bytes, &b->model_dev,
                             &b->model_dev_block, err, err_sz)
          || ost_batchAlloc_gpu((void**)&b->worlds, b->L.total, err, err_sz);
#endif
  } else {
    b->worlds = (char*)aligned_alloc(64, b->L.total);
    bad = !b->worlds;
    if (bad) {
      snprintf(err, err_sz, "ost_batchCreate: cannot allocate %zu bytes for %d worlds",
               b->L.total, nworld);
    } else {
      memset(b->worlds, 0, b->L.total);
    }
  }
  if (bad || ost_batchSetState(b, NULL, NULL)) {
    if (!bad) {
      snprintf(err, err_sz, "%s", b->err);
    }
    ost_batchDelete(b);
    return NULL;
  }
  return b;
}


void ost_batchDelete(ostBatch* b) {
  if (!b) {
    return;
  }
#ifdef OSTRICH_HAVE_CUDA
  if (b->cuda) {
    ost_batchFree_gpu(b->worlds);
    ost_batchFree_gpu(b->model_dev_block);
    b->worlds = NULL;
  }
#endif
  free(b->worlds);
  free(b->model_block);
  free(b->qpos0);
  free(b->rec_start);
  free(b->rec_ctrl);
  if (b->m) {
    mj_deleteModel(b->m);
  }
  free(b);
}


int ost_batchWorlds(const ostBatch* b) {
  return b ? b->L.nworld : 0;
}


size_t ost_batchBytes(const ostBatch* b) {
  return b ? b->L.total : 0;
}


int ost_batchMemory(const ostBatch* b, size_t* used, size_t* total) {
  if (!b) return -1;
  if (!used) return -2;
  if (!total) return -3;
#ifdef OSTRICH_HAVE_CUDA
  if (b->cuda) {
    size_t free_bytes = 0;
    if (ost_batchMemInfo_gpu(&free_bytes, total)) {
      return OST_ERR_MEMORY;
    }
    *used = *total - free_bytes;
    return OST_OK;
  }
#endif
  *used = b->L.total + b->model_bytes;
  *total = 0;
  return OST_OK;
}


const char* ost_batchError(const ostBatch* b) {
  return b ? b->err : "no batch";
}


// copy n bytes of every world's array at offset from (to_worlds) or to the dense array
static int field(ostBatch* b, size_t offset, size_t n, void* dense, int to_worlds) {
  if (n == 0) {
    return OST_OK;
  }
#ifdef OSTRICH_HAVE_CUDA
  if (b->cuda) {
    return ost_batchField_gpu(&b->L, b->worlds, offset, n, dense, to_worlds, b->err,
                              sizeof(b->err)) ? OST_ERR_MEMORY : OST_OK;
  }
#endif
  for (int i = 0; i < b->L.nworld; i++) {
    char* w = b->worlds + (size_t)i * b->L.stride + offset;
    char* x = (char*)dense + (size_t)i * n;
    memcpy(to_worlds ? w : x, to_worlds ? x : w, n);
  }
  return OST_OK;
}


// a dense nworld x n array of doubles, each row src (n) or zero (src NULL)
static ostNum* tiled(int nworld, int n, const ostNum* src) {
  ostNum* x = (ostNum*)calloc((size_t)nworld * (n > 0 ? n : 1), sizeof(ostNum));
  for (int i = 0; x && src && i < nworld; i++) {
    memcpy(x + (size_t)i * n, src, n * sizeof(ostNum));
  }
  return x;
}


int ost_batchSetState(ostBatch* b, const mjtNum* qpos, const mjtNum* qvel) {
  if (!b) return -1;
  int nw = b->L.nworld, status = OST_OK;
  ostNum* q = qpos ? NULL : tiled(nw, b->nq, b->qpos0);
  ostNum* zero = tiled(nw, b->nv > 1 ? b->nv : 1, NULL);
  int* izero = (int*)calloc(nw, sizeof(int));
  if ((!qpos && !q) || !zero || !izero) {
    status = batchFail(b, OST_ERR_MEMORY, "ost_batchSetState: out of memory");
  }
  const ostBatchLayout* L = &b->L;
  if (!status) {
    // state, then everything a step carries over: time, warm start, outcome bits
    status = field(b, L->qpos, sizeof(ostNum) * b->nq, qpos ? (void*)qpos : q, 1)
             || field(b, L->qvel, sizeof(ostNum) * b->nv, qvel ? (void*)qvel : zero, 1)
             || field(b, L->qacc_warm, sizeof(ostNum) * b->nv, zero, 1)
             || field(b, L->time, sizeof(ostNum), zero, 1)
             || field(b, L->residual, sizeof(ostNum), zero, 1)
             || field(b, L->status, sizeof(int), izero, 1)
             || field(b, L->warm, sizeof(int), izero, 1)
             || field(b, L->nrow_warm, sizeof(int), izero, 1)
             || field(b, L->substeps, sizeof(int), izero, 1) ? OST_ERR_MEMORY : OST_OK;
  }
  free(q);
  free(zero);
  free(izero);
  b->fresh = !status;
  b->rec_nstep = 0;
  return status;
}


int ost_batchGetState(const ostBatch* b, mjtNum* qpos, mjtNum* qvel) {
  if (!b) return -1;
  ostBatch* mb = (ostBatch*)b;  // only the error message is written
  if ((qpos && field(mb, b->L.qpos, sizeof(ostNum) * b->nq, qpos, 0))
      || (qvel && field(mb, b->L.qvel, sizeof(ostNum) * b->nv, qvel, 0))) {
    return OST_ERR_MEMORY;
  }
  return OST_OK;
}


int ost_batchSetCtrl(ostBatch* b, const mjtNum* ctrl) {
  if (!b) return -1;
  if (!ctrl && b->nu > 0) return -2;
  return field(b, b->L.ctrl, sizeof(ostNum) * b->nu, (void*)ctrl, 1);
}


int ost_batchStatus(const ostBatch* b, int* status) {
  if (!b) return -1;
  if (!status) return -2;
  return field((ostBatch*)b, b->L.status, sizeof(int), status, 0);
}


//---------------------------------- CPU driver ----------------------------------------------------

// run fn on nt chunks (an array of chunk_sz-byte structs), one thread each: chunk 0 on the
// caller, and a chunk whose thread cannot start on the caller too
static void runThreads(int nt, void* (*fn)(void*), void* chunks, size_t chunk_sz) {
  pthread_t thread[OST_BATCH_MAX_THREADS];
  int started[OST_BATCH_MAX_THREADS];
  for (int t = 1; t < nt; t++) {
    started[t] = !pthread_create(thread + t, NULL, fn, (char*)chunks + t * chunk_sz);
  }
  fn(chunks);
  for (int t = 1; t < nt; t++) {
    if (started[t]) {
      pthread_join(thread[t], NULL);
    } else {
      fn((char*)chunks + t * chunk_sz);
    }
  }
}


typedef struct cpuChunk_ {        // one thread's share of a rollout
  const ostBatch* b;
  int             w0, w1;         // worlds [w0, w1)
  int             nstep;
  const ostNum*   ctrl;
  ostNum*         qpos;
  ostNum*         qvel;
} cpuChunk;


static void* cpuChunkRun(void* arg) {
  const cpuChunk* c = (const cpuChunk*)arg;
  for (int i = c->w0; i < c->w1; i++) {
    osti_batchRollout(&c->b->model, &c->b->L, c->b->worlds, i, &c->b->set, c->nstep, c->ctrl,
                      c->qpos, c->qvel);
  }
  return NULL;
}


// osti_batchRollout for every world on nthread threads, contiguous chunks
static int rolloutCpu(ostBatch* b, int nstep, const ostNum* ctrl, ostNum* qpos, ostNum* qvel) {
  int nt = b->nthread > 0 ? b->nthread : 1, nw = b->L.nworld;
  cpuChunk chunk[OST_BATCH_MAX_THREADS];
  for (int t = 0; t < nt; t++) {
    chunk[t] = (cpuChunk){b, (int)((long)nw * t / nt), (int)((long)nw * (t + 1) / nt), nstep,
                          ctrl, qpos, qvel};
  }
  runThreads(nt, cpuChunkRun, chunk, sizeof(cpuChunk));
  return OST_OK;
}


// keep what a backward pass replays: the start states and every step's controls of a rollout
// from a set state (a later rollout continues it: its record is dropped)
static int recordInputs(ostBatch* b, int nstep, const ostNum* ctrl) {
  int nw = b->L.nworld, nu = b->nu;
  int fresh = b->fresh;
  b->fresh = 0;
  b->rec_nstep = 0;
  if (!fresh || b->cuda) {
    return OST_OK;  // nothing to replay (the cuda batch has no backward pass yet)
  }
  free(b->rec_start);
  free(b->rec_ctrl);
  b->rec_start = (ostNum*)malloc(sizeof(ostNum) * nw * (b->nq + b->nv));
  b->rec_ctrl = (ostNum*)malloc(sizeof(ostNum) * ((size_t)nstep * nw * nu + 1));
  ostNum* cur = (ostNum*)malloc(sizeof(ostNum) * (size_t)nw * (nu + 1));
  int bad = !b->rec_start || !b->rec_ctrl || !cur;
  if (!bad) {
    ostNum* q = (ostNum*)malloc(sizeof(ostNum) * nw * (b->nq + b->nv));
    bad = !q || field(b, b->L.qpos, sizeof(ostNum) * b->nq, q, 0)
          || field(b, b->L.qvel, sizeof(ostNum) * b->nv, q + (size_t)nw * b->nq, 0)
          || (!ctrl && field(b, b->L.ctrl, sizeof(ostNum) * nu, cur, 0));
    for (int i = 0; !bad && i < nw; i++) {
      memcpy(b->rec_start + (size_t)i * (b->nq + b->nv), q + (size_t)i * b->nq,
             sizeof(ostNum) * b->nq);
      memcpy(b->rec_start + (size_t)i * (b->nq + b->nv) + b->nq, q + (size_t)nw * b->nq
             + (size_t)i * b->nv, sizeof(ostNum) * b->nv);
    }
    free(q);
  }
  for (int t = 0; !bad && t < nstep; t++) {
    memcpy(b->rec_ctrl + (size_t)t * nw * nu, ctrl ? ctrl + (size_t)t * nw * nu : cur,
           sizeof(ostNum) * nw * nu);
  }
  free(cur);
  if (bad) {
    return OST_ERR_MEMORY;
  }
  b->rec_nstep = nstep;
  return OST_OK;
}


int ost_batchRollout(ostBatch* b, int nstep, const mjtNum* ctrl, mjtNum* qpos, mjtNum* qvel) {
  if (!b) return -1;
  if (nstep < 0) return -2;
  if (nstep == 0) {
    return OST_OK;
  }
  b->err[0] = 0;
  if (recordInputs(b, nstep, ctrl)) {
    return batchFail(b, OST_ERR_MEMORY, "ost_batchRollout: out of memory");
  }
#ifdef OSTRICH_HAVE_CUDA
  if (b->cuda) {
    return ost_batchRollout_gpu(&b->model_dev, &b->L, b->worlds, &b->set, nstep, ctrl, qpos, qvel,
                                b->err, sizeof(b->err)) ? OST_ERR_MEMORY : OST_OK;
  }
#endif
  return rolloutCpu(b, nstep, ctrl, qpos, qvel);
}


int ost_batchStep(ostBatch* b) {
  return ost_batchRollout(b, 1, NULL, NULL, NULL);
}


//---------------------------------- Backward (CPU) ------------------------------------------------

typedef struct backChunk_ {       // one thread's share of a backward pass
  const ostBatch*       b;
  const ostGradOptions* go;
  int                   checkpoint;
  int                   w0, w1;   // worlds [w0, w1)
  const ostNum*         gq;       // (T + 1) x nworld x nv, or NULL
  const ostNum*         gu;
  ostNum*               gctrl;    // T x nworld x nu, or NULL
  ostNum*               gq0;      // nworld x nv, or NULL
  ostNum*               gu0;
  int*                  failed;   // nworld flags
} backChunk;


// world i's gradients into the step-major outputs (NaN if failed)
static void scatterWorld(const backChunk* c, int i, const ostNum* gc, const ostNum* q0,
                         const ostNum* u0, int failed) {
  const ostBatch* b = c->b;
  int nw = b->L.nworld, nv = b->nv, nu = b->nu, T = b->rec_nstep;
  for (int t = 0; c->gctrl && t < T; t++) {
    for (int a = 0; a < nu; a++) {
      c->gctrl[((size_t)t * nw + i) * nu + a] = failed ? NAN : gc[t * nu + a];
    }
  }
  for (int j = 0; j < nv; j++) {
    if (c->gq0) c->gq0[(size_t)i * nv + j] = failed ? NAN : q0[j];
    if (c->gu0) c->gu0[(size_t)i * nv + j] = failed ? NAN : u0[j];
  }
}


// replay each world's rollout through a tape (native provider: the batch's bits) and run it
// backward; the cotangents are gathered from the step-major arrays
static void* backChunkRun(void* arg) {
  backChunk* c = (backChunk*)arg;
  const ostBatch* b = c->b;
  const mjModel* m = b->m;
  int nw = b->L.nworld, nq = b->nq, nv = b->nv, nu = b->nu, T = b->rec_nstep;
  mjData* d = mj_makeData(m);
  ostTape* tape = ost_tapeCreate(m, c->checkpoint);
  ostNum* buf = (ostNum*)calloc((size_t)(T + 1) * 2 * nv + (size_t)T * nu + 2 * nv + 1,
                                sizeof(ostNum));
  ostNum *gqw = buf, *guw = gqw + (size_t)(T + 1) * nv, *gcw = guw + (size_t)(T + 1) * nv;
  ostNum *q0 = gcw + (size_t)T * nu, *u0 = q0 + nv;
  ostOptions o;
  int ok = d && tape && buf && !ost_readOptions(m, &o, NULL, 0);
  o.geometry = OST_GEOMETRY_NATIVE;
  ok = ok && !ost_setOptions(m, d, &o);
  for (int i = c->w0; i < c->w1; i++) {
    int good = ok;
    if (good) {
      mj_resetData(m, d);
      memcpy(d->qpos, b->rec_start + (size_t)i * (nq + nv), sizeof(ostNum) * nq);
      memcpy(d->qvel, b->rec_start + (size_t)i * (nq + nv) + nq, sizeof(ostNum) * nv);
      ost_tapeClear(tape);
    }
    for (int t = 0; good && t < T; t++) {
      memcpy(d->ctrl, b->rec_ctrl + ((size_t)t * nw + i) * nu, sizeof(ostNum) * nu);
      good = ost_tapeStep(tape, m, d) == OST_OK;
    }
    for (int t = 0; good && t <= T; t++) {
      for (int j = 0; j < nv; j++) {
        gqw[t * nv + j] = c->gq ? c->gq[((size_t)t * nw + i) * nv + j] : 0;
        guw[t * nv + j] = c->gu ? c->gu[((size_t)t * nw + i) * nv + j] : 0;
      }
    }
    good = good && ost_tapeBackward(tape, m, c->go, gqw, guw, gcw, q0, u0, NULL) == OST_OK;
    scatterWorld(c, i, gcw, q0, u0, !good);
    c->failed[i] = !good;
  }
  free(buf);
  ost_tapeDelete(tape);
  if (d) {
    ost_deleteData(d);
  }
  return NULL;
}


int ost_batchBackward(ostBatch* b, const ostGradOptions* go, int checkpoint, const mjtNum* gq,
                      const mjtNum* gu, mjtNum* gctrl, mjtNum* gq0, mjtNum* gu0) {
  if (!b) return -1;
  if (checkpoint < 0) return -3;
  if (b->cuda) {
    return batchFail(b, OST_ERR_INPUT, "ost_batchBackward: the cuda batch has no backward pass "
                     "yet (use a cpu batch)");
  }
  if (b->rec_nstep == 0) {
    return batchFail(b, OST_ERR_INPUT, "ost_batchBackward: no rollout recorded (call "
                     "ost_batchRollout right after ost_batchSetState)");
  }
  ostGradOptions def;
  if (!go) {
    ost_defaultGradOptions(&def);
    go = &def;
  }
  int nt = b->nthread > 0 ? b->nthread : 1, nw = b->L.nworld;
  int* failed = (int*)calloc(nw, sizeof(int));
  if (!failed) {
    return batchFail(b, OST_ERR_MEMORY, "ost_batchBackward: out of memory");
  }
  backChunk chunk[OST_BATCH_MAX_THREADS];
  for (int t = 0; t < nt; t++) {
    chunk[t] = (backChunk){b, go, checkpoint, (int)((long)nw * t / nt),
                           (int)((long)nw * (t + 1) / nt), gq, gu, gctrl, gq0, gu0, failed};
  }
  runThreads(nt, backChunkRun, chunk, sizeof(backChunk));

  // failed worlds get OST_NAN in their outcome bits
  int* status = (int*)malloc(sizeof(int) * nw);
  if (status && !field(b, b->L.status, sizeof(int), status, 0)) {
    for (int i = 0; i < nw; i++) {
      status[i] |= failed[i] ? OST_NAN : 0;
    }
    field(b, b->L.status, sizeof(int), status, 1);
  }
  free(status);
  free(failed);
  return OST_OK;
}
