// ost_adjoint_jacobian.h: the exact Jacobian of one Ostrich step's residual by forward-mode
// dual numbers, for a translation unit that compiles core/ with ostNum = ostDual<OSTX_CHUNK>
// (core/ost_dual.h): plugin/ost_adjoint_dual.cc (the plugin's adjoint and the CPU batch's) and
// cuda/ost_batch_adjoint.cu (the CUDA batch). Each pass seeds OSTX_CHUNK input directions and
// reads their derivatives off every output. Nothing here is hand-differentiated: contact points,
// normals and distances, the mass matrix and bias forces, and ball/free joints' exponential map
// all enter exactly (core/README.md section 2). The evaluation and its dense oracle are in
// ost_adjoint_work.h, the split passes in ost_adjoint_split.h; here the step's Jacobian for a
// tape and the phases of a batch world's backward pass.
// Invariant: reads the step's inputs; writes only the work block, G and the model's parameter
// derivatives (only when parameters are seeded, st->nparam > 0).
#ifndef OSTRICH_CORE_OST_ADJOINT_JACOBIAN_H_
#define OSTRICH_CORE_OST_ADJOINT_JACOBIAN_H_

#ifndef OST_NUM_TYPE
#error "ost_adjoint_jacobian.h needs ostNum = ostDual<OSTX_CHUNK> (define OST_NUM_TYPE)"
#endif
#ifndef OSTX_CHUNK
#error "define OSTX_CHUNK, the directions of one dual pass (OST_NUM_TYPE = ostDual<OSTX_CHUNK>)"
#endif

#include "ost_adjoint_split.h"

// Exact Jacobian of the step's residual and outputs: the structure pass, then every column
// chunk; n = nv + the count of the rows at q+. G ((n + 2 nv + na) x ncol, row-major, ncol = n +
// 2 nv + na + nu + nparam) receives the rows R (n) then O = (dq+, u+, act+) (2 nv + na),
// differentiated by the columns y = (u, lambda) (n) then xi = (dq-, u-, act-, ctrl, theta).
// *resid gets |R| at the solution. dense: 1 every column through the whole evaluation (the
// oracle, ostx_jacColumns), 0 ostx_jacColumnsSplit (2: split as 3 threads, for tests; 3: split
// without the columns of the start's inputs, ostx_jacColumnsSplit's skip_start). Returns
// 0, 1 if G needs more than G_cap doubles (*n still set), 2 if the rows overflow or differ
// between evaluations.
OST_HD int ostx_stepJacobian(ostJacWork* wk, const ostdStep* st, double* G, size_t G_cap,
                             int* n_out, double* resid, int dense) {
  int nx = 2 * wk->m->s.nv + wk->m->s.na, nu = wk->m->s.nu, ny;
  if (ostx_jacStructure(wk, st, NULL, &ny)) {
    return 2;
  }
  *n_out = ny;
  int nout = ny + nx, ncol = ny + nx + nu + st->nparam;
  if ((size_t)nout * ncol > G_cap) {
    return 1;
  }
  double r2 = 0;
  if (dense == 1) {
    if (ostx_jacColumns(wk, st, NULL, ny, 0, OSTX_CHUNK, G, ncol, &r2)) {
      return 2;
    }
  } else {
    // the split passes, in one thread (dense == 2: as 3 threads one after another, in this
    // work, for the tests); the first reuses the structure pass's rows
    int nt = dense == 2 ? 3 : 1;
    for (int t = 0; t < nt; t++) {
      if (ostx_jacColumnsSplit(wk, st, NULL, ny, G, ncol, t == 0 ? &r2 : NULL, t == 0, t, nt,
                               wk->Rq, wk->T, dense == 3)) {
        return 2;
      }
    }
    osti_jacAssemble(G, ncol, ny, wk->m->s.nv, wk->m->s.na, wk->m->s.nu, wk->Rq, wk->T);
  }
  *resid = sqrt(r2);
  return 0;
}


// Phase 3 of a batch world's backward pass (core/ost_batch_adjoint.h), on record nrec - 1 - j of
// lane l's segment (nothing if j >= nrec or the world failed), in three parts so that a record's
// column chunks can run in parallel: 3a ostx_recordStructure (in the lane's dual work),
// 3b ostx_recordColumns (column thread t of njac), 3c osti_recordSolve (double build). m: the dual
// model, shared by all lanes (no parameters are seeded).

// 3a: the cotangents of the steps after the record's are injected; the structure pass sets
// info[OST_ADJ_NY] (0: nothing to do) and the lane's matched multipliers
OST_HD void ostx_recordStructure(ostModel* m, const ostAdjointLayout* A, char* lanes, int l,
                                 int i, int nworld, int j, const ostAdjointSettings* as,
                                 const double* gq, const double* gu) {
  ostAdjointLane al;
  ostu_adjointLane(&al, A, lanes, l);
  int* info = al.info;
  info[OST_ADJ_NY] = 0;
  if (info[OST_ADJ_FAILED] || j >= info[OST_ADJ_NREC]) {
    return;
  }
  ostStepRec r;
  ostdStep st;
  ostu_recordStep(&st, &r, A, &al, j, as);
  while (info[OST_ADJ_STEP] > *r.step + 1) {
    info[OST_ADJ_STEP]--;
    osti_adjointInject(A, &al, i, nworld, info[OST_ADJ_STEP], gq, gu);
  }
  ostJacWork jw;
  ostx_jacWorkInit(&jw, al.jac, m, A->nrow_max);
  int ny;
  if (ostx_jacStructure(&jw, &st, al.lam, &ny) || ny > A->ny_max) {
    info[OST_ADJ_FAILED] = OST_STEP_OVERFLOW;  // the rows at q+ exceed the capacity
    return;
  }
  info[OST_ADJ_NY] = ny;
}


// 3b: thread t of A->njac of the record's split passes (ostx_jacColumnsSplit) into the lane's
// G, Rq and T, in the dual work block `work` (NULL: the lane's own; the rows are made again, as
// 3a's world struct is gone); 3c assembles G (osti_jacAssemble). OST_STEP_OVERFLOW if the rows
// differ from the structure pass's.
OST_HD void ostx_recordColumns(ostModel* m, const ostAdjointLayout* A, char* lanes, int l, int t,
                               int j, const ostAdjointSettings* as, char* work) {
  ostAdjointLane al;
  ostu_adjointLane(&al, A, lanes, l);
  int ny = al.info[OST_ADJ_NY];
  if (ny == 0) {
    return;
  }
  ostStepRec r;
  ostdStep st;
  ostu_recordStep(&st, &r, A, &al, j, as);
  ostJacWork jw;
  ostx_jacWorkInit(&jw, work ? work : al.jac, m, A->nrow_max);
  if (A->nparam > 0) {
    ostx_jacOwnParams(&jw);
  }
  int ncol = ny + 2 * A->s.nv + A->s.na + A->s.nu + A->nparam;
  if (ostx_jacColumnsSplit(&jw, &st, al.lam, ny, al.G, ncol, NULL, 0, t, A->njac, al.Rq, al.T,
                           0)) {
    al.info[OST_ADJ_FAILED] = OST_STEP_OVERFLOW;
  }
}

#endif  // OSTRICH_CORE_OST_ADJOINT_JACOBIAN_H_
