// ost_batch_backward.c: the batch's backward pass (ost_batchBackward): the adjoint lanes'
// layout and memory, and the four phases of core/ost_batch_adjoint.h for every world, on the
// CPU's threads (a lane each) or on the GPU in waves (cuda/ost_batch.cu, ost_batch_adjoint.cu).
// Invariant: a world's gradients depend only on its own rollout, never on the device, the
// number of threads or lanes, or its neighbours.
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
        osti_recordSolve(A, b->adj_lanes, c->lane, i, nw, j, c->gctrl);
      }
    }
    ostBatchView v;
    ostu_batchView(&v, &b->L, b->worlds + (size_t)i * b->L.stride);
    osti_adjointFinish(A, b->adj_lanes, c->lane, i, nw, T, c->gq, c->gu, c->gctrl, c->gq0,
                       c->gu0, v.status);
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


// the adjoint lanes' layout for segments of `seg` steps and nlane lanes; (re)allocates them
static int adjointLanes(ostBatch* b, int seg, int nlane_max, ostAdjointLayout* A) {
  int T = b->rec_nstep;
  memset(A, 0, sizeof(*A));
  A->s = b->L.s;
  A->nrow_max = b->L.nrow_max;
  A->seg = seg;
  A->nseg = (T + seg - 1) / seg;
  // the rollout's own checkpoints, if it kept them at this interval: no replay to make them
  int kept = b->kept_every > 0 && (b->kept_every < T ? b->kept_every : T) == seg;
  A->nckpt = kept ? 0 : A->nseg;
  A->rec_cap = OST_RECORDS_PER_STEP * seg + OST_RECORDS_EXTRA;
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
                                  b->rec_ctrl, A->nckpt ? NULL : b->kept, e, es);
      for (int j = 0; !bad && j < A->rec_cap; j++) {
        bad = ost_adjointRecord_gpu(b->adj_dev_block, A, b->adj_lanes, w0, nw, j, as, gq_d, gu_d,
                                    b->adj_pool, b->adj_pool_n, e, es)
              || ost_recordSolve_gpu(A, b->adj_lanes, w0, nw, j, gctrl_d, e, es);
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
    return ost_batchFail(b, OST_ERR_INPUT, "ost_batchBackward: no rollout recorded (call "
                     "ost_batchRollout right after ost_batchSetState)");
  }
  if (go && go->params) {
    return ost_batchFail(b, OST_ERR_INPUT, "ost_batchBackward: parameter gradients are not "
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
  ost_batchRunChunks(b, backChunkRun, proto);
  return OST_OK;
}
