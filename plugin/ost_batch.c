// ost_batch.c: the batched API of ostrich.h (many worlds of one model) and its CPU driver. The
// model is packed once (core's ostModel, margins widened by the look-ahead as for ost_step); the
// worlds and the lanes that step them are laid out by core/ost_batch.h, on the host (`cpu`: a
// lane per thread, each thread a contiguous chunk of worlds) or on the GPU (`cuda`,
// cuda/ost_batch.cu: a lane per GPU thread, each looping over worlds). Both run
// osti_batchRollout forward; the backward pass is ost_batch_backward.c.
// Mirrors MAGMA's batched drivers: the host validates arguments, the per-world code never does.
// Invariant: a world's result depends only on its own state and controls, never on the number
// of threads, the device or its neighbours.
#define _GNU_SOURCE  // sysconf(_SC_NPROCESSORS_ONLN)

#include <pthread.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "ost_adjoint_dual.h"
#include "ost_batch_internal.h"


int ost_batchFail(ostBatch* b, int status, const char* msg) {
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
  ost_setMargins(mo, mo, o.margin);
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
  // a batch splits past 3 levels only where the model asks for it (ostrich/deep_splits): on the
  // GPU a world that fails at every level holds its warp, and its substeps fill the backward
  // pass's records (robot_box, 8,192 random tasks on the H200: 266 world-iterations/s and 4
  // worlds over their record capacity with deep_splits 6, 374 and none with 0)
  s->deep_splits = mj_name2id(m, mjOBJ_NUMERIC, "ostrich/deep_splits") >= 0 ? o.deep_splits : 0;
  s->warmstart = o.warmstart;
  s->cold_retry = o.cold_retry;
  s->h = o.timestep > 0 ? o.timestep : m->opt.timestep;
  s->split_tol = o.split_tol;
  s->lookahead = o.margin;
  s->depen_speed = o.depenetration_speed;
  b->opt = o;
  b->opt.deep_splits = s->deep_splits;
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
  b->na = m->na;
  if (packBatchModel(b, m, err, err_sz)) {
    ost_batchDelete(b);
    return NULL;
  }
  if (ost_batchParamsPrepare(b, m)) {
    snprintf(err, err_sz, "ost_batchCreate: out of memory");
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


void ost_batchFreeMem(const ostBatch* b, void* p) {
#ifdef OSTRICH_HAVE_CUDA
  if (b->cuda) {
    ost_batchFree_gpu(p);
    return;
  }
#endif
  free(p);
}


int ost_batchGrow(ostBatch* b, char** p, size_t* have, size_t bytes) {
  if (*p && *have >= bytes) {
    return OST_OK;
  }
  ost_batchFreeMem(b, *p);
  *p = NULL;
  *have = 0;
  int bad = 0;
#ifdef OSTRICH_HAVE_CUDA
  if (b->cuda) {
    bad = ost_batchAlloc_gpu((void**)p, bytes, b->err, sizeof(b->err));  // zeroed
  }
#endif
  if (!b->cuda) {
    *p = (char*)aligned_alloc(64, OST_ALIGN64(bytes));
    bad = !*p;
    if (!bad) {
      memset(*p, 0, bytes);
    }
  }
  if (bad) {
    *p = NULL;
    return OST_ERR_MEMORY;
  }
  *have = bytes;
  return OST_OK;
}


void ost_batchDelete(ostBatch* b) {
  if (!b) {
    return;
  }
  ost_batchFreeMem(b, b->worlds);
  ost_batchFreeMem(b, b->lanes);
  ost_batchFreeMem(b, b->rec_start);
  ost_batchFreeMem(b, b->rec_ctrl);
  ost_batchFreeMem(b, b->kept);
  ost_batchFreeMem(b, b->adj_lanes);
#ifdef OSTRICH_HAVE_CUDA
  if (b->cuda) {
    ost_batchFree_gpu(b->model_dev_block);
    ost_batchFree_gpu(b->adj_dev_block);
    ost_batchFree_gpu(b->adj_pool);
    ost_batchFree_gpu(b->fric_dev);
  }
#endif
  ostd_workFree(b->adj_work);
  free(b->param_diff);
  free(b->fric_geom);
  free(b->fric_weight);
  free(b->model_block);
  free(b->qpos0);
  free(b);
}


int ost_batchWorlds(const ostBatch* b) {
  return b ? b->L.nworld : 0;
}


size_t ost_batchBytes(const ostBatch* b) {
  return b ? b->L.total + b->L.lane_total + b->kept_bytes : 0;
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
  *used = b->L.total + b->L.lane_total + b->model_bytes + b->adj_bytes + b->kept_bytes
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
  int nzero = b->nv > b->na ? b->nv : b->na;
  ostNum* zero = tiled(nw, nzero > 1 ? nzero : 1, NULL);
  int* izero = (int*)calloc(nw, sizeof(int));
  if ((!qpos && !q) || !zero || !izero) {
    status = ost_batchFail(b, OST_ERR_MEMORY, "ost_batchSetState: out of memory");
  }
  const ostBatchLayout* L = &b->L;
  if (!status) {
    // state, then everything a step carries over: time, warm start, outcome bits
    status = field(b, L->qpos, sizeof(ostNum) * b->nq, qpos ? (void*)qpos : q, 1)
             || field(b, L->qvel, sizeof(ostNum) * b->nv, qvel ? (void*)qvel : zero, 1)
             || field(b, L->act, sizeof(ostNum) * b->na, zero, 1)
             || field(b, L->qacc_warm, sizeof(ostNum) * b->nv, zero, 1)
             || field(b, L->time, sizeof(ostNum), zero, 1)
             || field(b, L->residual, sizeof(ostNum), zero, 1)
             || field(b, L->status, sizeof(int), izero, 1)
             || field(b, L->warm, sizeof(int), izero, 1)
             || field(b, L->nrow_warm, sizeof(int), izero, 1)
             || field(b, L->substeps, sizeof(int), izero, 1)
             || field(b, L->unconverged, sizeof(int), izero, 1) ? OST_ERR_MEMORY : OST_OK;
  }
  free(q);
  free(zero);
  free(izero);
  b->fresh = !status;
  b->rec_nstep = 0;
  b->kept_every = 0;
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


int ost_batchSetAct(ostBatch* b, const mjtNum* act) {
  if (!b) return -1;
  if (!act && b->na > 0) return -2;
  int nw = b->L.nworld;
  int* izero = (int*)calloc(nw, sizeof(int));
  if (!izero) {
    return ost_batchFail(b, OST_ERR_MEMORY, "ost_batchSetAct: out of memory");
  }
  // the warm start belongs to the state it came from (ost_step, too, starts cold after an edit
  // of d->act)
  int status = field(b, b->L.act, sizeof(ostNum) * b->na, (void*)act, 1)
               || field(b, b->L.warm, sizeof(int), izero, 1)
               || field(b, b->L.nrow_warm, sizeof(int), izero, 1) ? OST_ERR_MEMORY : OST_OK;
  free(izero);
  return status;
}


int ost_batchGetAct(const ostBatch* b, mjtNum* act) {
  if (!b) return -1;
  if (!act && b->na > 0) return -2;
  return field((ostBatch*)b, b->L.act, sizeof(ostNum) * b->na, act, 0);
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


int ost_batchUnconverged(const ostBatch* b, int* count) {
  if (!b) return -1;
  if (!count) return -2;
  return field((ostBatch*)b, b->L.unconverged, sizeof(int), count, 0);
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


static void* cpuChunkRun(void* arg) {
  const cpuChunk* c = (const cpuChunk*)arg;
  for (int i = c->w0; i < c->w1; i++) {
    osti_batchRollout(&c->b->model, &c->b->L, c->b->worlds, c->b->lanes, i, c->lane, &c->b->set,
                      c->nstep, c->ctrl, c->qpos, c->qvel, c->act,
                      c->b->rec_nstep ? c->b->kept : NULL,
                      c->b->kept_every);
  }
  return NULL;
}


void ost_batchRunChunks(ostBatch* b, void* (*fn)(void*), cpuChunk proto) {
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


// room for the checkpoints a rollout of nstep steps keeps (ost_batchKeepCheckpoints); a
// larger allocation is reused
static int keptMemory(ostBatch* b, int nstep) {
  b->kept_every = 0;
  if (b->keep_every <= 0) {
    return OST_OK;
  }
  size_t bytes = (size_t)((nstep + b->keep_every - 1) / b->keep_every) * b->L.total;
  if (ost_batchGrow(b, &b->kept, &b->kept_bytes, bytes)) {
    return OST_ERR_MEMORY;
  }
  b->kept_every = b->keep_every;
  return OST_OK;
}


// keep what a backward pass replays: the worlds at the start of a rollout from a set state,
// and its controls (a later rollout continues it: its record is dropped), and room for its
// checkpoints. ctrl is where the rollout reads its controls (host; the device copy for cuda),
// NULL: the worlds' own.
static int recordInputs(ostBatch* b, int nstep, const ostNum* ctrl) {
  size_t nctrl = (size_t)nstep * b->L.nworld * b->nu;
  int fresh = b->fresh;
  b->fresh = 0;
  b->rec_nstep = 0;
  b->kept_every = 0;
  ost_batchFreeMem(b, b->rec_ctrl);
  b->rec_ctrl = NULL;
  if (!fresh) {
    return OST_OK;
  }
  int bad = keptMemory(b, nstep);
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
  return ost_batchRolloutAct(b, nstep, ctrl, qpos, qvel, NULL);
}


int ost_batchRolloutAct(ostBatch* b, int nstep, const mjtNum* ctrl, mjtNum* qpos, mjtNum* qvel,
                        mjtNum* act) {
  if (!b) return -1;
  if (nstep < 0) return -2;
  if (nstep == 0) {
    return OST_OK;
  }
  b->err[0] = 0;
  if (recordInputs(b, nstep, ctrl)) {
    return ost_batchFail(b, OST_ERR_MEMORY, "ost_batchRollout: out of memory for the record of "
                         "the rollout (its start, controls and kept checkpoints)");
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
                                      ctrl ? ctrl_dev : NULL, qpos, qvel, act,
                                      b->rec_nstep ? b->kept : NULL, b->kept_every, b->err,
                                      sizeof(b->err));
    if (ctrl_dev != b->rec_ctrl) {
      ost_batchFree_gpu(ctrl_dev);
    }
    return bad ? OST_ERR_MEMORY : OST_OK;
  }
#endif
  ost_batchRunChunks(b, cpuChunkRun, (cpuChunk){.b = b, .nstep = nstep, .ctrl = ctrl,
                                                 .qpos = qpos, .qvel = qvel, .act = act});
  return OST_OK;
}


int ost_batchKeepCheckpoints(ostBatch* b, int every) {
  if (!b) return -1;
  if (every < 0) return -2;
  b->keep_every = every;
  return OST_OK;
}


int ost_batchStep(ostBatch* b) {
  return ost_batchRollout(b, 1, NULL, NULL, NULL);
}


