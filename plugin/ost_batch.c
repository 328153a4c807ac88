// ost_batch.c: the batched API of ostrich.h (many worlds of one model) and its CPU driver. The
// model is packed once (core's ostModel, margins widened by the look-ahead as for ost_step); the
// worlds and the lanes that step them are laid out by core/ost_batch.h, on the host (`cpu`: a
// lane per thread, each thread a contiguous chunk of worlds) or on the GPU (`cuda`,
// cuda/ost_batch.cu: a lane per GPU thread, each looping over worlds). Both run
// osti_batchRollout forward and core/ost_batch_adjoint.h's four phases backward.
// Mirrors MAGMA's batched drivers: the host validates arguments, the per-world code never does.
// Invariant: a world's result depends only on its own state and controls, never on the number
// of threads, the device or its neighbours.
#define _GNU_SOURCE  // sysconf(_SC_NPROCESSORS_ONLN)

#include <pthread.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "ost_adjoint.h"
#include "ost_batch_adjoint.h"
#include "ost_internal.h"

#ifdef OSTRICH_HAVE_CUDA
#include "ost_batch_gpu.h"
#endif

#define OST_BATCH_MAX_THREADS 256

// lanes of the cuda batch's forward kernels: GPU threads, each stepping worlds l, l + nlane, ..
#define OST_CUDA_LANES 32768

// most lanes of the cuda batch's backward pass (fewer if the GPU's memory is short)
#define OST_CUDA_ADJOINT_LANES 16384

// substeps a backward segment of S steps may record: 2 S + 8 (a step split once takes 2, a
// step split three levels deep 8)
#define OST_RECORDS_PER_STEP 2
#define OST_RECORDS_EXTRA 8

struct ostBatch_ {
  int             cuda;           // 1: worlds live on the GPU
  int             nthread;        // CPU threads (cpu device)
  int             nq, nv, nu;     // the model's sizes
  ostStepSettings set;            // solver settings from the model's options
  ostOptions      opt;            // the model's options
  ostModel        model;          // packed model (host)
  void*           model_block;    // its allocation
  size_t          model_bytes;    // its size
  ostModel        model_dev;      // the device copy (cuda)
  void*           model_dev_block;
  ostBatchLayout  L;              // world and lane layout
  char*           worlds;         // L.total bytes: host (cpu) or device (cuda)
  char*           lanes;          // L.lane_total bytes, same place
  ostNum*         qpos0;          // the model's qpos0 (nq)
  int             fresh;          // 1: no step since ost_batchSetState
  int             rec_nstep;      // steps of the last rollout from a set state (0: none)
  char*           rec_start;      // its start: a copy of the worlds (host or device)
  ostNum*         rec_ctrl;       // its controls, rec_nstep x nworld x nu (NULL: the worlds')
  void*           adj_work;       // dual model for the backward pass (ostd_workCreate; cuda:
                                  // its device copy)
  void*           adj_dev_block;  // cuda: the device dual model's block
  char*           adj_lanes;      // adjoint lanes (host or device)
  size_t          adj_bytes;      // their size
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
  b->opt = o;
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
  int nlane = cuda ? (nworld < OST_CUDA_LANES ? nworld : OST_CUDA_LANES) : b->nthread;
  ostu_batchLayout(&b->L, b->model.s, ost_rowCapacity(m), nworld, nlane);
  b->qpos0 = (ostNum*)malloc(sizeof(ostNum) * (m->nq > 0 ? m->nq : 1));
  b->adj_work = b->qpos0 ? ostd_workCreate(&b->model, b->L.nrow_max) : NULL;
  if (!b->qpos0 || !b->adj_work) {
    snprintf(err, err_sz, "ost_batchCreate: out of memory");
    ost_batchDelete(b);
    return NULL;
  }
  memcpy(b->qpos0, m->qpos0, sizeof(ostNum) * m->nq);
  int bad = 0;
  if (cuda) {
#ifdef OSTRICH_HAVE_CUDA
    bad = ost_batchModel_gpu(&b->model, b->model_block, b->model_bytes, &b->model_dev,
                             &b->model_dev_block, err, err_sz)
          || ost_batchAlloc_gpu((void**)&b->worlds, b->L.total, err, err_sz)
          || ost_batchAlloc_gpu((void**)&b->lanes, b->L.lane_total, err, err_sz);
#endif
  } else {
    b->worlds = (char*)aligned_alloc(64, b->L.total);
    b->lanes = (char*)aligned_alloc(64, b->L.lane_total);
    bad = !b->worlds || !b->lanes;
    if (bad) {
      snprintf(err, err_sz, "ost_batchCreate: cannot allocate %zu bytes for %d worlds",
               b->L.total + b->L.lane_total, nworld);
    } else {
      memset(b->worlds, 0, b->L.total);
      memset(b->lanes, 0, b->L.lane_total);
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


// free host or device memory of the batch
static void batchFree(const ostBatch* b, void* p) {
#ifdef OSTRICH_HAVE_CUDA
  if (b->cuda) {
    ost_batchFree_gpu(p);
    return;
  }
#endif
  free(p);
}


void ost_batchDelete(ostBatch* b) {
  if (!b) {
    return;
  }
  batchFree(b, b->worlds);
  batchFree(b, b->lanes);
  batchFree(b, b->rec_start);
  batchFree(b, b->rec_ctrl);
  batchFree(b, b->adj_lanes);
#ifdef OSTRICH_HAVE_CUDA
  if (b->cuda) {
    ost_batchFree_gpu(b->model_dev_block);
    ost_batchFree_gpu(b->adj_dev_block);
  }
#endif
  ostd_workFree(b->adj_work);
  free(b->model_block);
  free(b->qpos0);
  free(b);
}


int ost_batchWorlds(const ostBatch* b) {
  return b ? b->L.nworld : 0;
}


size_t ost_batchBytes(const ostBatch* b) {
  return b ? b->L.total + b->L.lane_total : 0;
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
  *used = b->L.total + b->L.lane_total + b->model_bytes + b->adj_bytes
          + (b->rec_start ? b->L.total : 0);
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


typedef struct cpuChunk_ {        // one thread's share: worlds [w0, w1) in lane `lane`
  const ostBatch*       b;
  int                   lane;
  int                   w0, w1;
  int                   nstep;
  const ostNum*         ctrl;
  ostNum*               qpos;
  ostNum*               qvel;
  // backward pass only
  const ostAdjointLayout*   A;
  const ostAdjointSettings* as;
  const ostNum*         gq;
  const ostNum*         gu;
  ostNum*               gctrl;
  ostNum*               gq0;
  ostNum*               gu0;
} cpuChunk;


static void* cpuChunkRun(void* arg) {
  const cpuChunk* c = (const cpuChunk*)arg;
  for (int i = c->w0; i < c->w1; i++) {
    osti_batchRollout(&c->b->model, &c->b->L, c->b->worlds, c->b->lanes, i, c->lane, &c->b->set,
                      c->nstep, c->ctrl, c->qpos, c->qvel);
  }
  return NULL;
}


// fn on every world: nthread threads, contiguous chunks, thread t in lane t
static void runChunks(ostBatch* b, void* (*fn)(void*), cpuChunk proto) {
  int nt = b->nthread > 0 ? b->nthread : 1, nw = b->L.nworld;
  cpuChunk chunk[OST_BATCH_MAX_THREADS];
  for (int t = 0; t < nt; t++) {
    chunk[t] = proto;
    chunk[t].lane = t;
    chunk[t].w0 = (int)((long)nw * t / nt);
    chunk[t].w1 = (int)((long)nw * (t + 1) / nt);
  }
  runThreads(nt, fn, chunk, sizeof(cpuChunk));
}


// keep what a backward pass replays: the worlds at the start of a rollout from a set state,
// and its controls (a later rollout continues it: its record is dropped). ctrl is where the
// rollout reads its controls (host; the device copy for cuda), NULL: the worlds' own.
static int recordInputs(ostBatch* b, int nstep, const ostNum* ctrl) {
  size_t nctrl = (size_t)nstep * b->L.nworld * b->nu;
  int fresh = b->fresh;
  b->fresh = 0;
  b->rec_nstep = 0;
  batchFree(b, b->rec_ctrl);
  b->rec_ctrl = NULL;
  if (!fresh) {
    return OST_OK;
  }
  int bad = 0;
  if (!b->rec_start) {
#ifdef OSTRICH_HAVE_CUDA
    if (b->cuda) {
      bad = ost_batchAlloc_gpu((void**)&b->rec_start, b->L.total, b->err, sizeof(b->err));
    }
#endif
    if (!b->cuda) {
      b->rec_start = (char*)aligned_alloc(64, b->L.total);
      bad = !b->rec_start;
    }
  }
#ifdef OSTRICH_HAVE_CUDA
  if (b->cuda) {
    bad = bad || ost_batchCopy_gpu(b->rec_start, b->worlds, b->L.total, b->err, sizeof(b->err))
          || (ctrl && nctrl && ost_batchUpload_gpu((void**)&b->rec_ctrl, ctrl,
                                                   nctrl * sizeof(ostNum), b->err,
                                                   sizeof(b->err)));
  }
#endif
  if (!b->cuda && !bad) {
    memcpy(b->rec_start, b->worlds, b->L.total);
    if (ctrl && nctrl) {
      b->rec_ctrl = (ostNum*)malloc(nctrl * sizeof(ostNum));
      bad = !b->rec_ctrl;
      if (!bad) {
        memcpy(b->rec_ctrl, ctrl, nctrl * sizeof(ostNum));
      }
    }
  }
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
    // the controls on the device: the backward record's copy, or a temporary one
    ostNum* ctrl_dev = b->rec_ctrl;
    size_t nctrl = (size_t)nstep * b->L.nworld * b->nu;
    int bad = ctrl && nctrl && !ctrl_dev
              && ost_batchUpload_gpu((void**)&ctrl_dev, ctrl, nctrl * sizeof(ostNum), b->err,
                                     sizeof(b->err));
    bad = bad || ost_batchRollout_gpu(&b->model_dev, &b->L, b->worlds, b->lanes, &b->set, nstep,
                                      ctrl ? ctrl_dev : NULL, qpos, qvel, b->err, sizeof(b->err));
    if (ctrl_dev != b->rec_ctrl) {
      ost_batchFree_gpu(ctrl_dev);
    }
    return bad ? OST_ERR_MEMORY : OST_OK;
  }
#endif
  runChunks(b, cpuChunkRun, (cpuChunk){.b = b, .nstep = nstep, .ctrl = ctrl, .qpos = qpos, .qvel = qvel});
  return OST_OK;
}


int ost_batchStep(ostBatch* b) {
  return ost_batchRollout(b, 1, NULL, NULL, NULL);
}


//---------------------------------- Backward ------------------------------------------------------

// the four phases of core/ost_batch_adjoint.h for each world of a thread's chunk, in its lane
static void* backChunkRun(void* arg) {
  const cpuChunk* c = (const cpuChunk*)arg;
  const ostBatch* b = c->b;
  const ostAdjointLayout* A = c->A;
  int T = b->rec_nstep, nw = b->L.nworld;
  for (int i = c->w0; i < c->w1; i++) {
    osti_adjointForward(&b->model, &b->L, A, b->rec_start + (size_t)i * b->L.stride,
                        b->adj_lanes, c->lane, i, &b->set, T, b->rec_ctrl, c->gq, c->gu);
    for (int k = A->nseg - 1; k >= 0; k--) {
      osti_adjointReplay(&b->model, &b->L, A, b->adj_lanes, c->lane, i, &b->set, T, k,
                         b->rec_ctrl);
      for (int j = 0; j < A->rec_cap; j++) {
        ostd_adjointRecord(b->adj_work, A, b->adj_lanes, c->lane, i, nw, j, c->as, c->gq, c->gu,
                           c->gctrl);
      }
    }
    ostBatchView v;
    ostu_batchView(&v, &b->L, b->worlds + (size_t)i * b->L.stride);
    osti_adjointFinish(A, b->adj_lanes, c->lane, i, nw, T, c->gq, c->gu, c->gctrl, c->gq0,
                       c->gu0, v.status);
  }
  return NULL;
}


// the adjoint lanes' layout for segments of `seg` steps and nlane lanes; (re)allocates them
static int adjointLanes(ostBatch* b, int seg, int nlane_max, ostAdjointLayout* A) {
  int T = b->rec_nstep;
  memset(A, 0, sizeof(*A));
  A->s = b->L.s;
  A->nrow_max = b->L.nrow_max;
  A->seg = seg;
  A->nseg = (T + seg - 1) / seg;
  A->rec_cap = OST_RECORDS_PER_STEP * seg + OST_RECORDS_EXTRA;
  A->world_stride = b->L.stride;
  A->lane_stride = b->L.lane_stride;
  A->jac_size = ostd_jacWorkSize(&b->model, b->L.nrow_max);
  ostu_adjointLayout(A, 1);
  int nlane = nlane_max < b->L.nworld ? nlane_max : b->L.nworld;
#ifdef OSTRICH_HAVE_CUDA
  if (b->cuda) {
    // at most half the free memory, so that the cotangent arrays fit beside
    size_t free_bytes = 0, total = 0;
    ost_batchFree_gpu(b->adj_lanes);
    b->adj_lanes = NULL;
    b->adj_bytes = 0;
    if (ost_batchMemInfo_gpu(&free_bytes, &total)) {
      return batchFail(b, OST_ERR_MEMORY, "ost_batchBackward: cannot query the GPU's memory");
    }
    size_t fit = free_bytes / 2 / A->stride;
    nlane = (size_t)nlane < fit ? nlane : (int)fit;
    if (nlane < 1) {
      return batchFail(b, OST_ERR_MEMORY, "ost_batchBackward: no GPU memory for one lane");
    }
  }
#endif
  ostu_adjointLayout(A, nlane);
  if (b->adj_lanes && b->adj_bytes >= A->total) {
    return OST_OK;
  }
  batchFree(b, b->adj_lanes);
  b->adj_lanes = NULL;
  b->adj_bytes = 0;
  int bad = 0;
#ifdef OSTRICH_HAVE_CUDA
  if (b->cuda) {
    bad = ost_batchAlloc_gpu((void**)&b->adj_lanes, A->total, b->err, sizeof(b->err));
  }
#endif
  if (!b->cuda) {
    b->adj_lanes = (char*)aligned_alloc(64, A->total);
    bad = !b->adj_lanes;
    if (!bad) {
      memset(b->adj_lanes, 0, A->total);
    }
  }
  if (bad) {
    b->adj_lanes = NULL;
    return batchFail(b, OST_ERR_MEMORY, "ost_batchBackward: cannot allocate the adjoint lanes");
  }
  b->adj_bytes = A->total;
  return OST_OK;
}


#ifdef OSTRICH_HAVE_CUDA
// the backward pass on the GPU: the cotangents go to the device, the worlds run in waves of
// A->nlane, each wave through the four phases (one kernel each), the gradients come back
static int backwardCuda(ostBatch* b, const ostAdjointLayout* A, const ostAdjointSettings* as,
                        const ostNum* gq, const ostNum* gu, ostNum* gctrl, ostNum* gq0,
                        ostNum* gu0) {
  int T = b->rec_nstep, nw = b->L.nworld, nv = b->nv, nu = b->nu;
  size_t nseq = (size_t)(T + 1) * nw * nv, nctrl = (size_t)T * nw * nu;
  ostNum *gq_d = NULL, *gu_d = NULL, *gctrl_d = NULL, *g0_d = NULL;
  char* e = b->err;
  int es = sizeof(b->err);
  int bad = (gq && ost_batchUpload_gpu((void**)&gq_d, gq, nseq * sizeof(ostNum), e, es))
            || (gu && ost_batchUpload_gpu((void**)&gu_d, gu, nseq * sizeof(ostNum), e, es))
            || ost_batchAlloc_gpu((void**)&gctrl_d, (nctrl + 1) * sizeof(ostNum), e, es)
            || ost_batchAlloc_gpu((void**)&g0_d, 2 * (size_t)nw * nv * sizeof(ostNum) + 8, e, es);
  if (!bad && !b->adj_dev_block) {
    bad = ost_adjointModel_gpu(&b->model, &b->adj_dev_block, e, es);
  }
  for (int w0 = 0; !bad && w0 < nw; w0 += A->nlane) {
    bad = ost_adjointForward_gpu(&b->model_dev, &b->L, A, b->rec_start, b->adj_lanes, w0,
                                 &b->set, T, b->rec_ctrl, gq_d, gu_d, e, es);
    for (int k = A->nseg - 1; !bad && k >= 0; k--) {
      bad = ost_adjointReplay_gpu(&b->model_dev, &b->L, A, b->adj_lanes, w0, &b->set, T, k,
                                  b->rec_ctrl, e, es);
      for (int j = 0; !bad && j < A->rec_cap; j++) {
        bad = ost_adjointRecord_gpu(b->adj_dev_block, A, b->adj_lanes, w0, nw, j, as, gq_d, gu_d,
                                    gctrl_d, e, es);
      }
    }
    bad = bad || ost_adjointFinish_gpu(&b->L, A, b->adj_lanes, b->worlds, w0, T, gq_d, gu_d,
                                       gctrl_d, g0_d, g0_d + (size_t)nw * nv, e, es);
  }
  bad = bad || (gctrl && ost_batchDownload_gpu(gctrl, gctrl_d, nctrl * sizeof(ostNum), e, es))
        || (gq0 && ost_batchDownload_gpu(gq0, g0_d, (size_t)nw * nv * sizeof(ostNum), e, es))
        || (gu0 && ost_batchDownload_gpu(gu0, g0_d + (size_t)nw * nv,
                                         (size_t)nw * nv * sizeof(ostNum), e, es));
  ost_batchFree_gpu(gq_d);
  ost_batchFree_gpu(gu_d);
  ost_batchFree_gpu(gctrl_d);
  ost_batchFree_gpu(g0_d);
  return bad ? OST_ERR_MEMORY : OST_OK;
}
#endif


int ost_batchBackward(ostBatch* b, const ostGradOptions* go, int checkpoint, const mjtNum* gq,
                      const mjtNum* gu, mjtNum* gctrl, mjtNum* gq0, mjtNum* gu0) {
  if (!b) return -1;
  if (checkpoint < 0) return -3;
  b->err[0] = 0;
  if (b->rec_nstep == 0) {
    return batchFail(b, OST_ERR_INPUT, "ost_batchBackward: no rollout recorded (call "
                     "ost_batchRollout right after ost_batchSetState)");
  }
  if (go && go->params) {
    return batchFail(b, OST_ERR_INPUT, "ost_batchBackward: parameter gradients are not "
                     "available for batches (use ost_tapeBackward)");
  }
  int T = b->rec_nstep, seg = checkpoint > 0 && checkpoint < T ? checkpoint : T, status;
  ostAdjointLayout A;
  if ((status = adjointLanes(b, seg, b->cuda ? OST_CUDA_ADJOINT_LANES : b->nthread, &A))) {
    return status;
  }
  ostAdjointSettings as = {b->set.h, b->opt.margin, b->opt.regularization,
                           b->opt.friction_creep, b->opt.fb_eps, go ? go->truncate : 0, 0};
#ifdef OSTRICH_HAVE_CUDA
  if (b->cuda) {
    return backwardCuda(b, &A, &as, gq, gu, gctrl, gq0, gu0);
  }
#endif
  if (gctrl) {
    memset(gctrl, 0, sizeof(ostNum) * (size_t)T * b->L.nworld * b->nu);
  }
  cpuChunk proto = {b, 0, 0, 0, T, NULL, NULL, NULL, &A, &as, gq, gu, gctrl, gq0, gu0};
  runChunks(b, backChunkRun, proto);
  return OST_OK;
}
