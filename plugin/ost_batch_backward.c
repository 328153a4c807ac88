// ost_batch_backward.c: the batch's backward pass (ost_batchBackward): the adjoint lanes'
// layout and memory, and the four phases of core/ost_batch_adjoint.h for every world, on the
// CPU's threads (a lane each) or on the GPU in waves (cuda/ost_batch.cu, ost_batch_adjoint.cu).
// Invariant: a world's gradients depend only on its own rollout, never on the device, the
// number of threads or lanes, or its neighbours.
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "ost_batch_internal.h"

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
                         b->rec_ctrl, A->nckpt ? NULL : b->kept);
      for (int j = 0; j < A->rec_cap; j++) {
        ostd_recordStructure(b->adj_work, A, b->adj_lanes, c->lane, i, nw, j, c->as, c->gq,
                             c->gu);
        ostd_recordColumns(b->adj_work, A, b->adj_lanes, c->lane, 0, j, c->as);
        osti_recordSolve(A, b->adj_lanes, c->lane, i, nw, j, c->gctrl, c->gtheta);
      }
    }
    ostBatchView v;
    ostu_batchView(&v, &b->L, b->worlds + (size_t)i * b->L.stride);
    osti_adjointFinish(A, b->adj_lanes, c->lane, i, nw, T, c->gq, c->gu, c->gctrl, c->gtheta,
                       c->gq0, c->gu0, v.status);
  }
  return NULL;
}


#ifdef OSTRICH_HAVE_CUDA
// the pool of dual works of the GPU's column threads (phase 3b), one per thread the device
// holds at once (fewer if the worlds need fewer), each jac_size bytes; kept across calls
static int columnPool(ostBatch* b, size_t jac_size) {
  int n = ost_adjointColumnSlots_gpu();
  long long need = (long long)b->L.nworld * OST_CUDA_JAC_THREADS;
  n = need < n ? (int)need : n;
  size_t have = (size_t)b->adj_pool_n * jac_size;
  if (n < OST_CUDA_JAC_THREADS || ost_batchGrow(b, &b->adj_pool, &have, (size_t)n * jac_size)) {
    b->adj_pool_n = 0;
    return OST_ERR_MEMORY;
  }
  b->adj_pool_n = (int)(have / jac_size);
  return OST_OK;
}
#endif


int ost_batchParamsPrepare(ostBatch* b, const mjModel* m) {
  b->nparam = ost_nparam(m);
  for (int g = 0; g < OST_PARAM_ADR; g++) {
    b->param_adr[g] = ost_paramAddress(m, g);
  }
  int npair = b->model.s.npair > 0 ? b->model.s.npair : 1;
  b->param_diff = (signed char*)malloc(b->nparam > 0 ? b->nparam : 1);
  b->fric_geom = (int*)malloc(2 * npair * sizeof(int));
  b->fric_weight = (mjtNum*)malloc(2 * npair * sizeof(mjtNum));
  if (!b->param_diff || !b->fric_geom || !b->fric_weight) {
    return OST_ERR_MEMORY;
  }
  for (int i = 0; i < b->nparam; i++) {
    b->param_diff[i] = (signed char)ost_paramDifferentiable(m, i);
  }
  ost_paramFrictionMap(m, &b->model, b->fric_geom, b->fric_weight);
  return OST_OK;
}


// the adjoint lanes' layout for segments of `seg` steps and nlane lanes, with nparam parameter
// columns; (re)allocates them
static int adjointLanes(ostBatch* b, int seg, int nlane_max, int nparam, ostAdjointLayout* A) {
  int T = b->rec_nstep;
  memset(A, 0, sizeof(*A));
  A->s = b->L.s;
  A->nparam = nparam;
  A->nrow_max = b->L.nrow_max;
  A->seg = seg;
  A->nseg = (T + seg - 1) / seg;
  // the rollout's own checkpoints, if it kept them at this interval: no replay to make them
  int kept = b->kept_every > 0 && (b->kept_every < T ? b->kept_every : T) == seg;
  A->nckpt = kept ? 0 : A->nseg;
  A->rec_cap = OST_RECORDS_PER_STEP * seg + OST_RECORDS_EXTRA + b->set.deep_splits;
  A->world_stride = b->L.stride;
  A->lane_stride = b->L.lane_stride;
  A->jac_size = ostd_jacWorkSize(&b->model, b->L.nrow_max);
  A->njac = 1;
#ifdef OSTRICH_HAVE_CUDA
  if (b->cuda) {
    A->jac_size = ost_adjointJacSize_gpu(&b->model, b->L.nrow_max);
    A->njac = OST_CUDA_JAC_THREADS;
    if (columnPool(b, A->jac_size)) {
      return ost_batchFail(b, OST_ERR_MEMORY, "ost_batchBackward: cannot allocate the dual "
                           "works of the Jacobian's column threads");
    }
  }
#endif
  ostu_adjointLayout(A, 1);
  int nlane = nlane_max < b->L.nworld ? nlane_max : b->L.nworld;
#ifdef OSTRICH_HAVE_CUDA
  if (b->cuda) {
    // at most half the free memory (the lanes we hold counted as free), so that the cotangent
    // arrays fit beside; lanes that are large enough are kept from the last call
    size_t free_bytes = 0, total = 0;
    if (ost_batchMemInfo_gpu(&free_bytes, &total)) {
      return ost_batchFail(b, OST_ERR_MEMORY, "ost_batchBackward: cannot query the GPU's memory");
    }
    size_t fit = (free_bytes + b->adj_bytes) / 2 / A->stride;
    nlane = (size_t)nlane < fit ? nlane : (int)fit;
    if (nlane < 1) {
      return ost_batchFail(b, OST_ERR_MEMORY, "ost_batchBackward: no GPU memory for one lane");
    }
  }
#endif
  ostu_adjointLayout(A, nlane);
  if (ost_batchGrow(b, &b->adj_lanes, &b->adj_bytes, A->total)) {
    return ost_batchFail(b, OST_ERR_MEMORY, "ost_batchBackward: cannot allocate the adjoint lanes");
  }
  return OST_OK;
}


#ifdef OSTRICH_HAVE_CUDA
// the friction map on the device, once (geoms, then the weights at an 8-byte boundary), and
// *as pointing there
static int frictionMapDevice(ostBatch* b, ostAdjointSettings* as) {
  size_t n = 2 * (size_t)(b->model.s.npair > 0 ? b->model.s.npair : 1);
  size_t wofs = OST_ALIGN64(n * sizeof(int));
  char* e = b->err;
  int es = sizeof(b->err);
  if (!b->fric_dev) {
    char* host = (char*)calloc(1, wofs + n * sizeof(mjtNum));
    int bad = !host;
    if (host) {
      memcpy(host, b->fric_geom, n * sizeof(int));
      memcpy(host + wofs, b->fric_weight, n * sizeof(mjtNum));
      bad = ost_batchUpload_gpu((void**)&b->fric_dev, host, wofs + n * sizeof(mjtNum), e, es);
    }
    free(host);
    if (bad) {
      return OST_ERR_MEMORY;
    }
  }
  as->pair_fric_geom = (const int*)b->fric_dev;
  as->pair_fric_weight = (const double*)(b->fric_dev + wofs);
  return OST_OK;
}


// the backward pass on the GPU: the cotangents go to the device, the worlds run in waves of
// A->nlane, each wave through the four phases (one kernel each), the gradients come back
static int backwardCuda(ostBatch* b, const ostAdjointLayout* A, const ostAdjointSettings* as_host,
                        const ostNum* gq, const ostNum* gu, ostNum* gctrl, ostNum* gtheta,
                        ostNum* gq0, ostNum* gu0) {
  int T = b->rec_nstep, nw = b->L.nworld, nv = b->nv, nu = b->nu;
  size_t nseq = (size_t)(T + 1) * nw * nv, nctrl = (size_t)T * nw * nu;
  size_t ntheta = (size_t)nw * A->nparam;
  ostNum *gq_d = NULL, *gu_d = NULL, *gctrl_d = NULL, *g0_d = NULL, *gtheta_d = NULL;
  ostAdjointSettings as = *as_host;
  char* e = b->err;
  int es = sizeof(b->err);
  int bad = (gq && ost_batchUpload_gpu((void**)&gq_d, gq, nseq * sizeof(ostNum), e, es))
            || (gu && ost_batchUpload_gpu((void**)&gu_d, gu, nseq * sizeof(ostNum), e, es))
            || ost_batchAlloc_gpu((void**)&gctrl_d, (nctrl + 1) * sizeof(ostNum), e, es)
            || ost_batchAlloc_gpu((void**)&g0_d, 2 * (size_t)nw * nv * sizeof(ostNum) + 8, e, es)
            || (ntheta && (ost_batchAlloc_gpu((void**)&gtheta_d, ntheta * sizeof(ostNum), e, es)
                           || frictionMapDevice(b, &as)));
  if (!bad && !b->adj_dev_block) {
    bad = ost_adjointModel_gpu(&b->model, &b->adj_dev_block, e, es);
  }
  for (int w0 = 0; !bad && w0 < nw; w0 += A->nlane) {
    bad = ost_adjointForward_gpu(&b->model_dev, &b->L, A, b->rec_start, b->adj_lanes, w0,
                                 &b->set, T, b->rec_ctrl, gq_d, gu_d, e, es);
    for (int k = A->nseg - 1; !bad && k >= 0; k--) {
      bad = ost_adjointReplay_gpu(&b->model_dev, &b->L, A, b->adj_lanes, w0, &b->set, T, k,
                                  b->rec_ctrl, A->nckpt ? NULL : b->kept, e, es);
      for (int j = 0; !bad && j < A->rec_cap; j++) {
        bad = ost_adjointRecord_gpu(b->adj_dev_block, A, b->adj_lanes, w0, nw, j, &as, gq_d,
                                    gu_d, b->adj_pool, b->adj_pool_n, e, es)
              || ost_recordSolve_gpu(A, b->adj_lanes, w0, nw, j, gctrl_d, gtheta_d, e, es);
      }
    }
    bad = bad || ost_adjointFinish_gpu(&b->L, A, b->adj_lanes, b->worlds, w0, T, gq_d, gu_d,
                                       gctrl_d, gtheta_d, g0_d, g0_d + (size_t)nw * nv, e, es);
  }
  bad = bad || (gctrl && ost_batchDownload_gpu(gctrl, gctrl_d, nctrl * sizeof(ostNum), e, es))
        || (gtheta_d && ost_batchDownload_gpu(gtheta, gtheta_d, ntheta * sizeof(ostNum), e, es))
        || (gq0 && ost_batchDownload_gpu(gq0, g0_d, (size_t)nw * nv * sizeof(ostNum), e, es))
        || (gu0 && ost_batchDownload_gpu(gu0, g0_d + (size_t)nw * nv,
                                         (size_t)nw * nv * sizeof(ostNum), e, es));
  ost_batchFree_gpu(gq_d);
  ost_batchFree_gpu(gu_d);
  ost_batchFree_gpu(gctrl_d);
  ost_batchFree_gpu(gtheta_d);
  ost_batchFree_gpu(g0_d);
  return bad ? OST_ERR_MEMORY : OST_OK;
}
#endif


int ost_batchBackwardParams(ostBatch* b, const ostGradOptions* go, int checkpoint,
                            const mjtNum* gq, const mjtNum* gu, mjtNum* gctrl, mjtNum* gq0,
                            mjtNum* gu0, mjtNum* gtheta) {
  if (!b) return -1;
  if (checkpoint < 0) return -3;
  b->err[0] = 0;
  if (b->rec_nstep == 0) {
    return ost_batchFail(b, OST_ERR_INPUT, "ost_batchBackward: no rollout recorded (call "
                     "ost_batchRollout right after ost_batchSetState)");
  }
  int T = b->rec_nstep, seg = checkpoint > 0 && checkpoint < T ? checkpoint : T, status;
  int nparam = go && go->params && gtheta ? b->nparam : 0, nw = b->L.nworld;
  ostAdjointLayout A;
  if ((status = adjointLanes(b, seg, b->cuda ? OST_CUDA_ADJOINT_LANES : b->nthread, nparam,
                             &A))) {
    return status;
  }
  ostAdjointSettings as;
  memset(&as, 0, sizeof(as));
  as.h = b->set.h;
  as.lookahead = b->opt.margin;
  as.reg = b->opt.regularization;
  as.creep = b->opt.friction_creep;
  as.fb_eps = b->opt.fb_eps;
  as.truncate = go ? go->truncate : 0;
  memcpy(as.param_adr, b->param_adr, sizeof(as.param_adr));
  as.pair_fric_geom = b->fric_geom;
  as.pair_fric_weight = b->fric_weight;
  if (nparam) {
    memset(gtheta, 0, sizeof(ostNum) * (size_t)nw * nparam);
  }
#ifdef OSTRICH_HAVE_CUDA
  if (b->cuda) {
    status = backwardCuda(b, &A, &as, gq, gu, gctrl, nparam ? gtheta : NULL, gq0, gu0);
  }
#endif
  if (!b->cuda) {
    if (gctrl) {
      memset(gctrl, 0, sizeof(ostNum) * (size_t)T * nw * b->nu);
    }
    cpuChunk proto = {b, 0, 0, 0, T, NULL, NULL, NULL, &A, &as, gq, gu, gctrl,
                      nparam ? gtheta : NULL, gq0, gu0, NULL};
    ost_batchRunChunks(b, backChunkRun, proto);
  }
  // entries MuJoCo does not read as parameters have no derivative, those it reads but the
  // adjoint does not differentiate (a muscle's curves) are unknown (ost_paramDifferentiable);
  // a failed world's NaN stays
  for (int i = 0; !status && i < nw * nparam; i++) {
    int diff = b->param_diff[i % nparam];
    if (diff == 0 && !isnan(gtheta[i])) {
      gtheta[i] = 0;
    } else if (diff < 0) {
      gtheta[i] = NAN;
    }
  }
  return status;
}


int ost_batchBackward(ostBatch* b, const ostGradOptions* go, int checkpoint, const mjtNum* gq,
                      const mjtNum* gu, mjtNum* gctrl, mjtNum* gq0, mjtNum* gu0) {
  if (b && go && go->params) {
    b->err[0] = 0;
    return ost_batchFail(b, OST_ERR_INPUT, "ost_batchBackward: parameter gradients need "
                         "somewhere to go: call ost_batchBackwardParams with gtheta");
  }
  return ost_batchBackwardParams(b, go, checkpoint, gq, gu, gctrl, gq0, gu0, NULL);
}
