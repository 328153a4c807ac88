// ost_batch_adjoint.h: the backward pass of a batch rollout, world by world, in the double
// build (core/README.md section 2; paper section III-D). A world's pass runs in an adjoint lane
// (core/ost_adjoint.h's OST_ADJOINT_LANE_ARRAYS) in four phases, which the CPU batch calls in
// order for each world and the CUDA batch launches as kernels over a wave of worlds:
//   1 osti_adjointForward  replay the rollout from the world's start up to its last segment,
//                          keeping a checkpoint at the start of every segment of A->seg steps
//   2 osti_adjointReplay   replay segment k from its checkpoint, recording each committed
//                          substep (state, controls, rows, multipliers)
//   3 on record j from the end of the segment: ostx_recordStructure and ostx_recordColumns
//                          (ost_adjoint_jacobian.h, dual build; the split passes' units may
//                          be spread over A->njac threads) give the step's exact Jacobian,
//                          and
//                          osti_recordSolve the implicit function theorem
//   4 osti_adjointFinish   the cotangents of the start state; NaN for a failed world
// Phase 2 and 3 run for k = nseg - 1 .. 0. The replay takes the forward pass's exact steps (same
// warm start, splits and bits), so the gradient is that of the rollout the user saw, with
// memory per lane of nseg world slices plus one segment's records (segment checkpointing).
// Cotangent sequences are step-major, world-minor: gq, gu ((T + 1) x nworld x nv, the cotangent
// of the state after step t - 1; NULL: zero), gctrl (T x nworld x nu, zeroed by the caller);
// gtheta (nworld x nparam, zeroed by the caller) is world-major.
// Invariant: world i's pass reads the model, its start slice and the sequences, and writes only
// its lane and its own entries of the outputs.
#ifndef OSTRICH_CORE_OST_BATCH_ADJOINT_H_
#define OSTRICH_CORE_OST_BATCH_ADJOINT_H_

#include <math.h>

#include "ost_adjoint.h"
#include "ost_batch.h"
#include "ost_hd.h"

#ifdef __cplusplus
extern "C" {
#endif

// phase 1: replay world i from its start slice in lane l up to the last segment's start,
// checkpointing each segment's start (the last segment is first stepped by its phase 2); with
// kept checkpoints (the rollout's, osti_batchRollout; A->nckpt = 0) there is nothing to replay.
// The running cotangent starts at time T.
OST_HD void osti_adjointForward(const ostModel* m, const ostBatchLayout* L,
                                const ostAdjointLayout* A, const char* start, char* lanes, int l,
                                int i, const ostStepSettings* set, int T, const ostNum* ctrl_seq,
                                const double* gq, const double* gu) {
  ostAdjointLane al;
  ostu_adjointLane(&al, A, lanes, l);
  size_t ws = A->world_stride;
  if (A->nckpt > 0) {
    ostu_copyWords(al.ckpt, start, ws);
  }
  for (int k = 0; k + 1 < A->nckpt; k++) {
    char* ck = al.ckpt + k * ws;
    ostu_copyWords(al.cur, ck, ws);
    osti_worldRollout(m, L, al.cur, al.work, i, set, k * A->seg, (k + 1) * A->seg, ctrl_seq, NULL,
                      NULL, NULL, NULL);
    ostu_copyWords(ck + ws, al.cur, ws);
  }
  al.info[OST_ADJ_NREC] = 0;
  al.info[OST_ADJ_STEP] = T;
  al.info[OST_ADJ_FAILED] = 0;
  for (int j = 0; j < 2 * A->s.nv + A->s.na; j++) al.g[j] = 0;
  osti_adjointInject(A, &al, i, L->nworld, T, gq, gu);
}


// phase 2: replay segment k of world i from its checkpoint (the lane's, or kept[k nworld + i]
// when the rollout kept them), recording its committed substeps.
// A world whose rollout failed (failure bits are sticky, so the last segment, replayed first,
// ends with them) fails with OST_STEP_NAN; more than A->rec_cap substeps with OST_STEP_OVERFLOW;
// a substep that did not converge or kept part of a violation with its bit (NOT_CONVERGED,
// DEPENETRATED): the implicit function theorem needs a solved step.
OST_HD void osti_adjointReplay(const ostModel* m, const ostBatchLayout* L,
                               const ostAdjointLayout* A, char* lanes, int l, int i,
                               const ostStepSettings* set, int T, int k, const ostNum* ctrl_seq,
                               const char* kept) {
  ostAdjointLane al;
  ostu_adjointLane(&al, A, lanes, l);
  al.info[OST_ADJ_NREC] = 0;
  if (al.info[OST_ADJ_FAILED]) {
    return;
  }
  size_t ws = A->world_stride;
  ostu_copyWords(al.cur, kept ? kept + ((size_t)k * L->nworld + i) * ws : al.ckpt + k * ws, ws);
  ostRecordSink sink = {al.rec, A->s, A->nrow_max, A->rec_cap, 0, 0, 0};
  int t1 = (k + 1) * A->seg < T ? (k + 1) * A->seg : T;
  osti_worldRollout(m, L, al.cur, al.work, i, set, k * A->seg, t1, ctrl_seq, NULL, NULL, NULL,
                    &sink);
  ostBatchView v;
  ostu_batchView(&v, L, al.cur);
  if (*v.status & OST_STEP_FAILED) {
    al.info[OST_ADJ_FAILED] = OST_STEP_NAN;
    return;
  }
  if (sink.n > A->rec_cap) {
    al.info[OST_ADJ_FAILED] = OST_STEP_OVERFLOW;
    return;
  }
  if (sink.bits) {
    // a substep that did not converge (or kept part of a violation) has no exact gradient
    al.info[OST_ADJ_FAILED] = sink.bits;
    return;
  }
  al.info[OST_ADJ_NREC] = sink.n;
}


// phase 3c: the implicit function theorem on the record whose Jacobian phases 3a and 3b left in
// lane l's G (completed here, osti_jacAssemble): g, the cotangent of its (q+, u+), becomes that
// of its (q-, u-), its controls' cotangent accumulates into gctrl ((T x nworld x nu), or NULL)
// and, with A->nparam > 0, its parameters' into gtheta (nworld x nparam, or NULL);
// OST_STEP_NAN if singular
OST_HD void osti_recordSolve(const ostAdjointLayout* A, char* lanes, int l, int i, int nworld,
                             int j, double* gctrl, double* gtheta) {
  ostAdjointLane al;
  ostu_adjointLane(&al, A, lanes, l);
  int ny = al.info[OST_ADJ_NY], nx = 2 * A->s.nv + A->s.na, nu = A->s.nu;
  if (ny == 0 || al.info[OST_ADJ_FAILED]) {
    return;
  }
  ostStepRec r;
  ostu_recordAt(&r, A, &al, j);
  int ncol = ny + nx + nu + A->nparam;
  osti_jacAssemble(al.G, ncol, ny, A->s.nv, A->s.na, nu, al.Rq, al.T);
  if (osti_adjointSolve(al.G, ny, nx, ncol, al.K, al.piv, al.w, al.g, al.gxi)) {
    al.info[OST_ADJ_FAILED] = OST_STEP_NAN;  // singular Jacobian
    return;
  }
  for (int k = 0; k < nx; k++) al.g[k] = al.gxi[k];
  for (int a = 0; gctrl && a < nu; a++) {
    gctrl[((size_t)*r.step * nworld + i) * nu + a] += al.gxi[nx + a];
  }
  for (int p = 0; gtheta && p < A->nparam; p++) {
    gtheta[(size_t)i * A->nparam + p] += al.gxi[nx + nu + p];
  }
}


// phase 4: the cotangents of world i's start state into gq0, gu0 (nworld x nv each, or NULL);
// a failed world gets NaN there and in all its gctrl and gtheta entries, and its failure's bit
// in *status (the world's outcome bits, or NULL): OST_STEP_NAN, or OST_STEP_OVERFLOW if a
// capacity was exceeded
OST_HD void osti_adjointFinish(const ostAdjointLayout* A, char* lanes, int l, int i, int nworld,
                               int T, const double* gq, const double* gu, double* gctrl,
                               double* gtheta, double* gq0, double* gu0, int* status) {
  ostAdjointLane al;
  ostu_adjointLane(&al, A, lanes, l);
  int nv = A->s.nv, nu = A->s.nu;
  while (al.info[OST_ADJ_STEP] > 0) {
    al.info[OST_ADJ_STEP]--;
    osti_adjointInject(A, &al, i, nworld, al.info[OST_ADJ_STEP], gq, gu);
  }
  int failed = al.info[OST_ADJ_FAILED];
  if (failed && status) {
    *status |= failed;
  }
  for (int j = 0; j < nv; j++) {
    if (gq0) gq0[(size_t)i * nv + j] = failed ? NAN : al.g[j];
    if (gu0) gu0[(size_t)i * nv + j] = failed ? NAN : al.g[nv + j];
  }
  for (int t = 0; failed && gctrl && t < T; t++) {
    for (int a = 0; a < nu; a++) gctrl[((size_t)t * nworld + i) * nu + a] = NAN;
  }
  for (int p = 0; failed && gtheta && p < A->nparam; p++) {
    gtheta[(size_t)i * A->nparam + p] = NAN;
  }
}

#ifdef __cplusplus
}
#endif

#endif  // OSTRICH_CORE_OST_BATCH_ADJOINT_H_
