// ost_solver.h: the per-world non-smooth Newton step of Ostrich (core/README.md section 1; paper
// section III-C). Mirrors engine_solver.c (mj_solNewton): residual evaluation at an iterate,
// the Schur-complement operator applied matrix-free, preconditioned conjugate residual (PCR)
// with a Jacobi preconditioner, and the Newton update with projection. Where a sliding contact
// couples its friction force mu lambda_n to its normal force, the Newton system is not symmetric
// and is solved by GMRES with the same operator and preconditioner (osti_gmres).
//
// Unknowns: u = u+ (nv) and lambda (nrow). Backward Euler in generalized coordinates:
//   q+ = q- (+) h u+,   Mt (u+ - u-) = h (f + J(q+)' lambda),   Mt = M(q-) + h D     (eq. 1-2)
// Every row i is linearized to the row form  J_i du + c_i dlambda_i = -rho_i  (velocity units),
// and eliminating du = Mt^-1 (h J' dlambda - r_dyn) gives the Schur system (eq. 11)
//   A dlambda = (J Mt^-1 r_dyn - rho) / h,   A = J Mt^-1 J' + diag(c) / h.
// The geometry (J, gaps, frames) at each iterate is filled by a geometry provider; this file
// never calls MuJoCo. Invariant: osti_ functions write only the world they are given.
#ifndef OSTRICH_CORE_OST_SOLVER_H_
#define OSTRICH_CORE_OST_SOLVER_H_

#include <math.h>
#include <stddef.h>
#include <stdint.h>

#include "ost_constraint.h"
#include "ost_hd.h"
#include "ost_util_dense.h"
#include "ost_util_tree.h"

#ifdef __cplusplus
extern "C" {
#endif

typedef struct ostSolverOptions_ {  // per-step solver settings (see ostOptions in ostrich.h)
  int    newton_iter;               // Newton budget
  int    pcr_iter;                  // PCR budget per Newton iterate
  int    k_min;                     // earliest iterate that may be returned
  int    pad;
  ostNum tol;                       // merit residual for early exit (m/s)
  ostNum pcr_tol;                   // relative PCR residual for early exit
  ostNum fb_eps;                    // FB smoothing
  ostNum reg;                       // relative compliance delta of contact and sticking rows
  ostNum creep;                     // absolute sticking compliance (s/kg): slip = creep force
} ostSolverOptions;

#ifndef OST_NUM_TYPE  // a substituted scalar type never crosses the boundary
OST_STATIC_ASSERT(sizeof(ostSolverOptions) == 4 * sizeof(int) + 5 * sizeof(ostNum),
                  "ostSolverOptions crosses the gcc/nvcc boundary: keep it unpadded");
#endif

// outcome bits of a world's step (osti_stepNative) and backward pass: ostrich.h's
// ostStatusBits, written identically by the CPU and GPU batches
#define OST_STEP_NOT_CONVERGED 1  // best merit above tol after the Newton budget
#define OST_STEP_OVERFLOW      2  // contact or row capacity exceeded (the step was not taken)
#define OST_STEP_NAN           4  // non-finite input or iterate (the step was not taken)
#define OST_STEP_CHOL_FAIL     8  // M + h D not positive definite (the step was not taken)
#define OST_STEP_DEPENETRATED 16  // a violation at q- was removed at the bounded speed only
#define OST_STEP_FAILED (OST_STEP_OVERFLOW | OST_STEP_NAN | OST_STEP_CHOL_FAIL)

// restart length of GMRES, the Krylov solver of Newton systems with sliding friction (below)
#define OST_KRYLOV 32
// islands of at most this many rows solve their Schur system directly (osti_directSet): the
// dense Schur matrix from the rows' half-solves and an LU factor, instead of PCR or GMRES
#define OST_DIRECT_MAX 96
// a host context gives its world separate dense arrays (ostu_denseLargeInit) for islands of up
// to this many rows: an island above OST_DIRECT_MAX rows is solved by PCR or GMRES, and directly
// where a Krylov solve stopped at its budget far from the solution (OST_DIRECT_FALLBACK), as
// are the Newton loop's later large islands (ostWorld.direct_large). Measured on MuJoCo's rope
// lying on its floor (one island of 135 rows, 46 dofs, 1.5 s at its own h): GMRES cut at
// pcr_iter left Newton converging linearly (190 iterates per step, 76 ms, 104 of 750 steps
// unconverged); with direct solves 14 iterates, 4.3 ms, 2 unconverged. The arrays cost
// min(nrow_max, this)^2 doubles (4.7 MB at the cap), allocated once per context, apart from the
// world's own arrays (inside them, the larger layout cost the rope's other solves 15-20 %)
#define OST_DIRECT_HOST_MAX 768
// and only where its dense factor costs at most this many Krylov iterations of the island
// (osti_directAffordable): MuJoCo's softbox (islands of up to 798 rows on 224 dofs) took 63 ms
// per step with each of its islands of at most 768 rows solved directly after an exhausted
// Krylov solve, 12 without; the rope's and the loop's islands (120-400 rows) stay within it
#define OST_DIRECT_KRYLOV 1024
// a Krylov solve of such an island that stopped at its budget with a relative residual above
// this (Jacobi norm; osti_schurSolveSet) is done again directly. Not lower: GMRES's truncated
// answers (median relative residual 0.2) serve a falling cloth's Newton loop, and 1e-4 made its
// steps 2.5 times dearer and grid2pin's 1.5 times, at the rope's and the loop's speed
#define OST_DIRECT_FALLBACK 1e-2
// a Krylov solve of an island above OST_DIRECT_MAX rows that stopped at its budget with a
// relative residual (Jacobi norm) above OST_KRYLOV_FAILED made no progress (GMRES's restarts
// stagnate). Inexact Newton converges at about the rate of its inner solves, so such answers
// stall the loop: when a Newton iterate after one reduced the merit by less than
// OST_KRYLOV_STALL (osti_krylovStall), a host world solves such islands directly for the rest of
// the loop wherever its dense arrays hold them and the factor costs at most OST_STALL_COST times
// the affordable one (OST_DIRECT_KRYLOV). MuJoCo's active_adhesion sample (64 frictionless
// spheres in a crate: one island of 280-370 rows on 3-dof bodies, factors 1.1-1.7 times the
// affordable) under random controls: GMRES cut at 32 iterations left relative residuals of
// 0.99-1.4, and steps ended at residuals of 1e-9 to 4e-6 m/s after 1,000-1,400 Newton iterates
// and 14 substeps (17 of the 476 steps that 60 s of wall time reached of 1 s at h, seed 1);
// with the direct solves none, at h and 5 h. Tried and dropped: four times the Krylov budget
// instead (22 of 500 still unconverged, and stalled hammock steps at 5 h took about 20 s each),
// factors at any cost (hammock steps whose islands of 600-735 rows stall without converging:
// about 13 s each), and factors on the first failure rather than after a stall
// (grid2pin, whose 510-564-row islands stall for an iterate or two and then converge: twice the
// time)
#define OST_KRYLOV_FAILED 0.5
#define OST_KRYLOV_STALL 0.5
#define OST_STALL_COST 4
// a direct answer of an island above OST_DIRECT_MAX rows (dense or envelope factor) is used only
// if its relative residual (Jacobi norm) is at most this; else the island goes to PCR or GMRES.
// Stable factors measured 1e-15 to 1e-10; nearly singular islands 1e-6 to 1 (dense, pivoted)
// and 1e2 to 1e17 (the envelope's LU, which does not pivot)
#define OST_DIRECT_EXACT 1e-6
// the row half-solve cache (ostWorld.yrow) exists in host double builds only: CUDA kernels and
// the dual-number builds of the adjoint compile the code without it
#if !defined(__CUDACC__) && !defined(OST_NUM_TYPE)
#define OST_ROW_CACHE 1
#else
#define OST_ROW_CACHE 0
#endif
#define OST_NDENSE(nrow_max) ((nrow_max) < OST_DIRECT_MAX ? (nrow_max) : OST_DIRECT_MAX)

// One world's arrays. The X-macro is the single description of the layout: it drives the size
// of the allocation and the pointer setup (type, name, rows, cols). Arrays only the Newton
// solver uses have OST_SOLVER_ROWS: a world that only evaluates the step's residual (the dual
// evaluation of core/ost_adjoint_jacobian.h, solver = 0) leaves them out (NULL).
#define OST_SOLVER_ROWS(n) ((solver) ? (n) : 0)
// columns of a stored row of J: a solver world keeps each row compressed to its pattern (at most
// ncol columns, osti_rowStore); the residual-only world keeps dense rows of nv
#define OST_JCOLS ((solver) ? ncol : nv)
#define OST_WORLD_ARRAYS(X)                                                                     \
  X(ostNum,        qvel_prev,     nv,       1)   /* u- at the start of the step           */   \
  X(ostNum,        qfrc_explicit, nv,       1)   /* f: explicit forces at (q-, u-)         */   \
  X(ostNum,        M,             nv,       nv)  /* M + h D, then its Cholesky factor      */   \
  X(ostNum,        qvel,          nv,       1)   /* current iterate u                      */   \
  X(ostNum,        qvel_best,     nv,       1)   /* best iterate u                         */   \
  X(ostNum,        qvel_base,     nv,       1)   /* u where the Newton direction was taken */   \
  X(ostNum, qvel_first, OST_SOLVER_ROWS(nv), 1) /* u of the first iterate (k = 0)       */   \
  X(ostNum,        dqvel,         nv,       1)   /* Newton direction du                    */   \
  X(ostNum,        Minv_rdyn,     nv,       1)   /* Mt^-1 r_dyn at the iterate             */   \
  X(ostNum,        tmp,           nv,       2)   /* scratch                                */   \
  X(ostRow,        rows,          nrow_max, 1)   /* rows of the current iterate            */   \
  X(ostRow, rows_prev, OST_SOLVER_ROWS(nrow_max), 1) /* rows of the previous iterate */            \
  X(ostNum,        J,             nrow_max, OST_JCOLS) /* row Jacobians at q(u) (patterns) */   \
  X(ostNum, J_prev, OST_SOLVER_ROWS(nrow_max), ncol) /* row Jacobians of the previous iterate */   \
  X(int, Jnnz_prev, OST_SOLVER_ROWS(nrow_max), 1) /* their pattern sizes                     */   \
  X(int, Jind_prev, OST_SOLVER_ROWS(nrow_max), ncol) /* and patterns                        */   \
  X(ostNum,        lambda,        nrow_max, 1)   /* multipliers (forces, N or N m)         */   \
  X(ostNum, lambda_prev, OST_SOLVER_ROWS(nrow_max), 1) /* multipliers of the previous iterate */   \
  X(ostNum, dlambda, OST_SOLVER_ROWS(nrow_max), 1) /* Newton direction (contact frame) */          \
  X(ostNum, lambda_trial, OST_SOLVER_ROWS(nrow_max), 1) /* trial multipliers on the previous rows */ \
  X(ostNum, lambda_best, OST_SOLVER_ROWS(nrow_max), 1) /* multipliers of the best iterate */       \
  X(ostRow, rows_warm, OST_SOLVER_ROWS(nrow_max), 1) /* rows of the last step's result */          \
  X(ostNum, lambda_warm, OST_SOLVER_ROWS(nrow_max), 1) /* multipliers of the last step's result */ \
  X(ostNum,        W,             nrow_max, 1)   /* friction: slide flag, slip frame, W    */   \
  X(ostNum,        diag,          nrow_max, 1)   /* J_i Mt^-1 J_i'                         */   \
  X(ostNum,        Ju,            nrow_max, 1)   /* J_i u                                  */   \
  X(ostNum,        c,             nrow_max, 1)   /* compliance of the linearized row       */   \
  X(ostNum,        rho,           nrow_max, 1)   /* residual of the linearized row         */   \
  X(ostNum, pcr, OST_SOLVER_ROWS(nrow_max), 6) /* PCR vectors b r z p Az Ap */                     \
  X(ostNum, krylov, OST_SOLVER_ROWS(nrow_max), OST_KRYLOV + 1) /* GMRES basis */                   \
  X(ostNum, hess, OST_SOLVER_ROWS(OST_KRYLOV + 1), OST_KRYLOV + 4) /* Hessenberg, rotations */     \
  X(ostNum, Ad, OST_SOLVER_ROWS(OST_NDENSE(nrow_max)), OST_NDENSE(nrow_max)) /* dense Schur, LU */ \
  X(ostNum, Yt, OST_SOLVER_ROWS(OST_NDENSE(nrow_max)), nv) /* rows' half-solves L^-T J_i', by dof */ \
  X(int, Apiv, OST_SOLVER_ROWS(OST_NDENSE(nrow_max)), 1) /* the LU's pivots                   */   \
  X(ostRow, rows_relax, OST_SOLVER_ROWS(nrow_max), 1) /* violations kept this step (relax) */     \
  X(int, Jnnz, OST_SOLVER_ROWS(nrow_max), 1) /* columns in row i's pattern (osti_rowStore)  */   \
  X(int, Jind, OST_SOLVER_ROWS(nrow_max), ncol) /* their indices, ascending                  */   \
  X(ostNum, Jrow, OST_SOLVER_ROWS(1 + OST_MAXFRIC), nv) /* dense rows a provider writes */ \
  X(unsigned char, colmark, OST_SOLVER_ROWS(nv), 1) /* pattern scratch, all zero between calls */ \
  X(ostNum, merit_row, OST_SOLVER_ROWS(nrow_max), 2) /* row i's squared merit terms (friction, own) */ \
  X(int, cpl_row, OST_SOLVER_ROWS(nrow_max), 2) /* contact i: coupling void, lagged next */ \
  X(ostNum, xloc, OST_SOLVER_ROWS(nrow_max), 2) /* an island's Schur right-hand side, solution */ \
  X(int, match_order, OST_SOLVER_ROWS(nrow_max), 2) /* osti_matchRowsSorted's scratch       */   \
  /* islands (ost_island.h): at most one per tree, so nv bounds their number */                \
  X(int, tree_end, OST_SOLVER_ROWS(nv), 1)   /* a tree's root dof: one past its last dof   */   \
  X(int, uf, OST_SOLVER_ROWS(nv), 1)         /* union-find scratch over dofs               */   \
  X(int, dof_island, OST_SOLVER_ROWS(nv), 1) /* island of each dof, this iterate           */   \
  X(int, dof_island_base, OST_SOLVER_ROWS(nv), 1) /* and of the line search's base iterate */   \
  X(int, row_island, OST_SOLVER_ROWS(nrow_max), 1) /* island of each row, this iterate     */   \
  X(int, row_island_prev, OST_SOLVER_ROWS(nrow_max), 1) /* of the base iterate's rows      */   \
  X(int, isl_row, OST_SOLVER_ROWS(nrow_max), 1) /* rows grouped by island, ascending       */   \
  X(int, isl_row_adr, OST_SOLVER_ROWS(nv + 1), 1) /* island I's rows start here           */   \
  X(int, isl_tree, OST_SOLVER_ROWS(nv), 1)   /* tree roots grouped by island               */   \
  X(int, isl_tree_adr, OST_SOLVER_ROWS(nv + 1), 1) /* island I's trees start here         */   \
  X(unsigned char, isl_done, OST_SOLVER_ROWS(nv), 1) /* island converged: no more direction */ \
  X(unsigned char, isl_acc, OST_SOLVER_ROWS(nv), 1) /* island's line search accepted        */ \
  X(ostNum, isl_num, OST_SOLVER_ROWS(nv), 6) /* per island: merit, base, alpha, lowest, its alpha, last alpha */ \
  X(ostNum, best_dof, OST_SOLVER_ROWS(nv), 1) /* best merit of the dof's island so far      */   \
  X(int, bestk_dof, OST_SOLVER_ROWS(nv), 1)  /* iterate of that best                        */   \
  X(ostRow, rows_best, OST_SOLVER_ROWS(nrow_max), 1) /* rows of each island's best iterate */    \
  X(int, anchor_best, OST_SOLVER_ROWS(nrow_max), 1) /* their first pattern dof (island key) */  \
  X(unsigned char, used,          nrow_max, 1)   /* matching scratch                       */

struct ostGeoWork_;
struct ostEnvWork_;

// a Newton operator on a row set: ostWorld.op_version and the set's rows pointer and count. A
// factor kept for it, or one that failed for it, is recognized by this key (osti_opKeyIs)
typedef struct ostOpKey_ {
  int        version;             // op_version (-1: none)
  const int* row;
  int        n;
} ostOpKey;

typedef struct ostWorld_ {        // one world: sizes and pointers into one allocation
  int    nv;                      // degrees of freedom
  int    nrow;                    // rows of the current iterate
  int    nrow_max;                // row capacity
  int    nrow_prev;               // rows of the previous iterate
  int    nrow_warm;               // rows of the last step's result (0: none)
  int    prev_jac;                // 1 if J_prev holds the base iterate's Jacobians
  int    nrow_relax;              // entries of rows_relax this step (0: none)
  int    ncol;                    // columns a stored row of J can hold (ostu_rowWidth)
  int    nisland;                 // islands of the evaluated iterate (0: one system, no islands)
  int    nrow_best;               // entries of rows_best
  ostNum h;                       // timestep (s)
  ostNum lookahead;               // contacts are reported up to this gap (m)
  ostNum depen_speed;             // bounded removal speed of violations at q- (0: at once)
  const int* dof_parent;          // parent dof of each dof (-1: root), set with M: M is then
                                  // factored as a tree (ost_util_tree.h); NULL: dense Cholesky
  struct ostGeoWork_* geo;        // geometric Newton arrays (ost_geometric.h); NULL: none
  ostNum* yrow;                   // host cache of each row's half-solve L^-T J_i' on its pattern
                                  // (nrow_max x ncol; osti_rowDiag writes it, osti_directSet
                                  // reads it); NULL: none (GPU, batches, the adjoint)
  ostNum* yrow_sqrtd;             // with yrow: sqrt of the tree factor's diagonal D per dof,
                                  // set by osti_factorMass (the D^-1/2 of the cached half-solves,
                                  // one sqrt per dof and step instead of one per entry and solve)
  struct ostEnvWork_* env;        // host envelope solves of large islands (ost_envelope.h);
                                  // NULL: none (they need yrow)
  int    op_version;              // counts changes of the Newton operator (rows, J, c, the
                                  // sliding couplings) that a kept envelope factor belongs to:
                                  // osti_evaluate, osti_slideRows, osti_couplingFallback
  int    sat_used;                // 1: the last direction used the saturated-sticking model
  int    sat_off;                 // 1: the next direction keeps the sticking model (the last
                                  // saturated direction found no descent; osti_newton)
  int    cpl_used;                // 1: the last direction, coupling a sliding contact's friction
                                  // bound to its normal force, drove that force below zero
                                  // (such contacts marked in cpl_row; osti_newton)
  int    cpl_n;                   // rows of cpl_row in use: the most rows a direction of this
                                  // Newton loop had (entries beyond are stale, never read)
  int    ndense_large;            // rows the large-island dense arrays hold (0: none)
  ostNum* Ad_large;               // the dense Schur matrix, half-solves by dof and pivots of
  ostNum* Yt_large;               // islands above OST_DIRECT_MAX rows (host contexts only,
  int*   Apiv_large;              // ostu_denseLargeInit; NULL: none)
  ostOpKey dense_bad;             // the operator whose dense answer missed OST_DIRECT_EXACT:
                                  // not factored again (osti_directLargeSet)
  int    direct_large;            // 1 once a Krylov solve of an island above OST_DIRECT_MAX
                                  // rows that Ad_large holds stopped at pcr_iter in this Newton
                                  // loop: such islands are then solved directly
                                  // (osti_schurSolveSet)
  int    krylov_failed;           // bit 1: a Krylov solve of an island that Ad_large holds
                                  // (factor within OST_STALL_COST) made no progress
                                  // (OST_KRYLOV_FAILED) in this Newton iterate; bit 2: an
                                  // iterate after such a solve reduced the merit by less than
                                  // OST_KRYLOV_STALL, so such solves are redone directly for the
                                  // rest of the loop; bit 4: one was, so such islands skip
                                  // Krylov (osti_schurSolveSet, osti_krylovStall)
#define X(type, name, r, c) type* name;
  OST_WORLD_ARRAYS(X)
#undef X
} ostWorld;



// the widest row pattern of a dof tree: a row couples at most two bodies, and its pattern is
// closed under the parent map, so it holds at most two root-to-leaf dof chains (at most nv)
OST_HD int ostu_rowWidth(const int* dof_parent, int nv) {
  int deepest = 0;
  for (int k = 0; k < nv; k++) {
    int depth = 0;
    for (int j = k; j >= 0; j = dof_parent[j]) {
      depth++;
    }
    deepest = depth > deepest ? depth : deepest;
  }
  return 2 * deepest < nv ? 2 * deepest : nv;
}


// bytes needed by one world with rows of at most ncol columns, each array 64-byte aligned
// (solver = 0: without the solver's arrays, dense rows of nv)
OST_HD size_t ostu_worldSizeFor(int nv, int ncol, int nrow_max, int solver) {
  size_t sz = 0;
#define X(type, name, r, c) sz += (((size_t)(r) * (c) * sizeof(type) + 63) / 64) * 64;
  OST_WORLD_ARRAYS(X)
#undef X
  return sz;
}


OST_HD size_t ostu_worldSize(int nv, int ncol, int nrow_max) {
  return ostu_worldSizeFor(nv, ncol, nrow_max, 1);
}


// point a world's arrays into buf (64-byte aligned, ostu_worldSizeFor bytes); arrays left out
// are NULL
OST_HD void ostu_worldInitFor(ostWorld* w, void* buf, int nv, int ncol, int nrow_max, ostNum h,
                              int solver) {
  char* p = (char*)buf;
  w->nv = nv;
  w->nrow = 0;
  w->nrow_max = nrow_max;
  w->nrow_prev = 0;
  w->nrow_warm = 0;
  w->prev_jac = 0;
  w->nrow_relax = 0;
  w->ncol = solver ? ncol : nv;
  w->nisland = 0;
  w->nrow_best = 0;
  w->h = h;
  w->lookahead = 0;
  w->depen_speed = 0;
  w->dof_parent = NULL;
  w->geo = NULL;
  w->yrow = NULL;
  w->yrow_sqrtd = NULL;
  w->env = NULL;
  w->op_version = 0;
  w->dense_bad.version = -1;
  w->sat_used = w->sat_off = 0;
  w->cpl_used = w->cpl_n = 0;
  w->ndense_large = 0;
  w->Ad_large = w->Yt_large = NULL;
  w->Apiv_large = NULL;
  w->direct_large = 0;
  w->krylov_failed = 0;
#define X(type, name, r, c)                                         \
  w->name = (size_t)(r) * (size_t)(c) != 0 ? (type*)p : NULL;       \
  p += (((size_t)(r) * (c) * sizeof(type) + 63) / 64) * 64;
  OST_WORLD_ARRAYS(X)
#undef X
  for (int j = 0; w->colmark && j < nv; j++) {
    w->colmark[j] = 0;
  }
}


OST_HD void ostu_worldInit(ostWorld* w, void* buf, int nv, int ncol, int nrow_max, ostNum h) {
  ostu_worldInitFor(w, buf, nv, ncol, nrow_max, h, 1);
}


// rows of the large-island dense arrays of a world with nrow_max rows (0: none needed)
OST_HD int ostu_denseLargeRows(int nrow_max) {
  if (nrow_max <= OST_DIRECT_MAX) {
    return 0;
  }
  return nrow_max < OST_DIRECT_HOST_MAX ? nrow_max : OST_DIRECT_HOST_MAX;
}


// bytes of a world's large-island dense arrays (ostu_denseLargeInit), 64-byte aligned
OST_HD size_t ostu_denseLargeSize(int nv, int nrow_max) {
  size_t n = (size_t)ostu_denseLargeRows(nrow_max);
  return ((n * n * sizeof(ostNum) + 63) / 64 + (n * nv * sizeof(ostNum) + 63) / 64
          + (n * sizeof(int) + 63) / 64) * 64;
}


// give an initialized world its large-island dense arrays in buf (ostu_denseLargeSize bytes)
OST_HD void ostu_denseLargeInit(ostWorld* w, void* buf, int nrow_max) {
  size_t n = (size_t)ostu_denseLargeRows(nrow_max);
  char* p = (char*)buf;
  w->ndense_large = (int)n;
  if (n == 0) {
    return;
  }
  w->Ad_large = (ostNum*)p;
  p += (n * n * sizeof(ostNum) + 63) / 64 * 64;
  w->Yt_large = (ostNum*)p;
  p += (n * w->nv * sizeof(ostNum) + 63) / 64 * 64;
  w->Apiv_large = (int*)p;
}


// factor Mt = M + h D in place (the caller filled w->M, and w->dof_parent for a tree-sparse
// factor); returns 0 or 1 + failing column
OST_HD int osti_factorMass(ostWorld* w) {
  int rc = w->dof_parent ? ostu_treeFactor(w->M, w->dof_parent, w->nv)
                         : ostu_cholFactor(w->M, w->nv);
#if OST_ROW_CACHE
  if (!rc && w->yrow_sqrtd && w->dof_parent) {
    for (int c = 0; c < w->nv; c++) w->yrow_sqrtd[c] = sqrt(w->M[(size_t)c * w->nv + c]);
  }
#endif
  return rc;
}


#if OST_ROW_CACHE
// sqrt(D_c) of the tree factor, the D^-1/2 scale of a cached half-solve's entry at dof c: from
// the step's cache where osti_factorMass filled it, else computed (the same bits either way)
OST_HD ostNum osti_sqrtD(const ostWorld* w, int c) {
  return w->yrow_sqrtd && w->dof_parent ? w->yrow_sqrtd[c]
                                        : sqrt(w->M[(size_t)c * w->nv + c]);
}
#endif


// x = Mt^-1 x with the factor of osti_factorMass
OST_HD void osti_massSolve(const ostWorld* w, ostNum* x) {
  if (w->dof_parent) {
    ostu_treeSolve(x, w->M, w->dof_parent, x, w->nv);
  } else {
    ostu_cholSolve(x, w->M, x, w->nv);
  }
}


// Row storage. A row's Jacobian is zero off the dofs of its bodies' chains, so a solver world
// stores each row compressed: its pattern (the columns where it may be non-zero, closed under
// the dof tree's parent map when M is factored as a tree, so that L^-T J_i' stays within it,
// ost_util_tree.h) and the values there, at most ncol of them. The rows of one contact share
// one pattern, since the friction rows are rotated into each other. A provider writes up to
// 1 + OST_MAXFRIC dense rows into osti_rowScratch and stores them with osti_rowStore. A world
// without pattern arrays (the adjoint's residual evaluation) keeps dense rows of nv.

// dense rows for row n (1 + OST_MAXFRIC consecutive, nv each) that the provider fills
OST_HD ostNum* osti_rowScratch(ostWorld* w, int n) {
  return w->Jnnz ? w->Jrow : w->J + (size_t)n * w->nv;
}


// rows n .. n+g-1 from the g dense rows of osti_rowScratch on the pattern of cnt columns that
// row n's Jind holds in descending order (made ascending here)
OST_HD void osti_rowStorePattern(ostWorld* w, int n, int g, int cnt) {
  int nv = w->nv, ncol = w->ncol;
  int* ind = w->Jind + (size_t)n * ncol;
  for (int a = 0, b = cnt - 1; a < b; a++, b--) {  // ascending
    int t = ind[a];
    ind[a] = ind[b];
    ind[b] = t;
  }
  for (int r = 0; r < g; r++) {
    int* ri = w->Jind + (size_t)(n + r) * ncol;
    ostNum* rv = w->J + (size_t)(n + r) * ncol;
    const ostNum* src = w->Jrow + (size_t)r * nv;
    w->Jnnz[n + r] = cnt;
    for (int k = 0; k < cnt; k++) {
      ri[k] = ind[k];
      rv[k] = src[ind[k]];
    }
  }
}


// store the g dense rows of osti_rowScratch as rows n .. n+g-1 with one shared pattern: the
// columns, ascending, where one of them is non-zero or which are an ancestor of such a column.
// Returns 0, or 1 if the pattern is wider than ncol (the row is not stored).
OST_HD int osti_rowStore(ostWorld* w, int n, int g) {
  if (!w->Jnnz) {
    return 0;
  }
  int nv = w->nv, ncol = w->ncol, cnt = 0;
  int* ind = w->Jind + (size_t)n * ncol;
  const int* parent = w->dof_parent;
  unsigned char* mark = w->colmark;  // set by a descendant column; cleared as it is visited
  for (int c = nv - 1; c >= 0; c--) {
    int nz = mark[c];
    mark[c] = 0;
    for (int r = 0; r < g && !nz; r++) {
      nz = OSTU_NONZERO(w->Jrow[(size_t)r * nv + c]);
    }
    if (nz) {
      if (cnt == ncol) {
        for (int j = c - 1; j >= 0; j--) {
          mark[j] = 0;  // keep the scratch clear for the next call
        }
        return 1;
      }
      ind[cnt++] = c;
      if (parent && parent[c] >= 0) {
        mark[parent[c]] = 1;
      }
    }
  }
  osti_rowStorePattern(w, n, g, cnt);
  return 0;
}


// osti_rowStore for one dense row of osti_rowScratch whose non-zeros all lie in cols[0..k) (in
// any order; a sparse source row's columns, e.g. MuJoCo's efc_J colind): the same pattern, found
// by walking each non-zero column's ancestors, O(k depth) instead of O(nv) (a tendon between two
// beads of a 237-dof grid has 6 columns). Returns 0, or 1 if the pattern is wider than ncol.
#define OST_STORE_SORT_MAX 32  // wider patterns go to osti_rowStore's scan (cheaper than a sort)
OST_HD int osti_rowStoreCols(ostWorld* w, int n, const int* cols, int k) {
  if (!w->Jnnz) {
    return 0;
  }
  int ncol = w->ncol, cnt = 0, wide = 0;
  int* ind = w->Jind + (size_t)n * ncol;
  const int* parent = w->dof_parent;
  unsigned char* mark = w->colmark;  // marks the pattern; cleared before returning
  for (int a = 0; a < k && !wide; a++) {
    int c = cols[a];
    if (!OSTU_NONZERO(w->Jrow[c])) {
      continue;
    }
    while (c >= 0 && !mark[c]) {  // c and its ancestors up to one already in the pattern
      if (cnt == ncol) {
        wide = 1;
        break;
      }
      mark[c] = 1;
      ind[cnt++] = c;
      c = parent ? parent[c] : -1;
    }
  }
  for (int l = 0; l < cnt; l++) mark[ind[l]] = 0;
  if (wide) {
    return 1;
  }
  if (cnt > OST_STORE_SORT_MAX) {
    return osti_rowStore(w, n, 1);
  }
  for (int a = 1; a < cnt; a++) {  // descending, the order osti_rowStore leaves
    int v = ind[a], b = a - 1;
    while (b >= 0 && ind[b] < v) {
      ind[b + 1] = ind[b];
      b--;
    }
    ind[b + 1] = v;
  }
  osti_rowStorePattern(w, n, 1, cnt);
  return 0;
}


// store the g dense rows of osti_rowScratch as rows n .. n+g-1 whose pattern is known: the
// union of the dof chains ending at last1 and last2 (-1: none), which is parent-closed by
// construction, so no column is scanned (a contact's rows; O(depth), not O(nv)). Needs the tree
// (w->dof_parent). Returns 0, or 1 if the union is wider than ncol.
OST_HD int osti_rowStoreChains(ostWorld* w, int n, int g, int last1, int last2) {
  if (!w->Jnnz) {
    return 0;
  }
  int ncol = w->ncol, cnt = 0;
  int* ind = w->Jind + (size_t)n * ncol;
  const int* parent = w->dof_parent;
  // both chains descend towards the root: merge them into one descending list of distinct dofs
  int a = last1, b = last2;
  while (a >= 0 || b >= 0) {
    int c = a > b ? a : b;
    if (cnt == ncol) {
      return 1;
    }
    ind[cnt++] = c;
    if (a == c) a = parent[a];
    if (b == c) b = parent[b];
  }
  osti_rowStorePattern(w, n, g, cnt);
  return 0;
}


// entry (i, col) of J: col's position in row i's pattern (dense rows: col itself), or -1
OST_HD int osti_rowFind(const ostWorld* w, int i, int col) {
  if (!w->Jnnz) {
    return col;
  }
  const int* ind = w->Jind + (size_t)i * w->ncol;
  for (int k = 0; k < w->Jnnz[i]; k++) {
    if (ind[k] == col) {
      return k;
    }
  }
  return -1;
}


// J_i x
OST_HD ostNum osti_rowDot(const ostWorld* w, int i, const ostNum* x) {
  if (!w->Jnnz) {
    return ostu_dot(w->J + (size_t)i * w->nv, x, w->nv);
  }
  const ostNum* v = w->J + (size_t)i * w->ncol;
  const int* ind = w->Jind + (size_t)i * w->ncol;
  ostNum s = 0;
  for (int k = 0; k < w->Jnnz[i]; k++) {
    s += v[k] * x[ind[k]];
  }
  return s;
}


// t = J' x (nv)
OST_HD void osti_mulJT(const ostWorld* w, ostNum* OST_RESTRICT t, const ostNum* x) {
  int nv = w->nv;
  if (!w->Jnnz) {
    ostu_mulMatTVec(t, w->J, x, w->nrow, nv);
    return;
  }
  for (int j = 0; j < nv; j++) {
    t[j] = 0;
  }
  for (int i = 0; i < w->nrow; i++) {
    ostNum xi = x[i];
    if (OSTU_SKIPPABLE(xi)) {
      continue;
    }
    const ostNum* v = w->J + (size_t)i * w->ncol;
    const int* ind = w->Jind + (size_t)i * w->ncol;
    for (int k = 0; k < w->Jnnz[i]; k++) {
      t[ind[k]] += v[k] * xi;
    }
  }
}


// copy stored row j of (Jsrc, its pattern) into row i of (Jdst, its pattern)
OST_HD void osti_rowCopy(ostWorld* w, ostNum* Jdst, int* nnz_dst, int* ind_dst, int i,
                         const ostNum* Jsrc, const int* nnz_src, const int* ind_src, int j) {
  int len = w->Jnnz ? w->ncol : w->nv;
  int n = w->Jnnz ? nnz_src[j] : w->nv;
  for (int k = 0; k < n; k++) {
    Jdst[(size_t)i * len + k] = Jsrc[(size_t)j * len + k];
  }
  if (w->Jnnz) {
    nnz_dst[i] = n;
    for (int k = 0; k < n; k++) {
      ind_dst[(size_t)i * len + k] = ind_src[(size_t)j * len + k];
    }
  }
}


// compliance factor of a row whose force is fixed (its Newton update is dlambda = target - lambda)
#define OST_FIXED_ROW 1e12
// relative excess of |lambda_f|^2 over its cone's bound^2 that osti_saturateSticking acts on
#define OST_SATURATE_SLACK 1e-6
// a sticking contact is saturated when |lambda_f|^2 >= (1 - this) (mu lambda_n)^2
#define OST_SATURATED_ON_CONE 1e-6


// Jacobi diagonal entry of row i, J_i Mt^-1 J_i', kept positive for the divisions that use it
OST_HD void osti_rowDiag(ostWorld* w, int i) {
  int nv = w->nv;
  ostNum d;
  if (w->Jnnz && w->dof_parent) {
    // y = L^-T J_i' stays within the (parent-closed) pattern; d = y' D^-1 y
    const ostNum* v = w->J + (size_t)i * w->ncol;
    const int* ind = w->Jind + (size_t)i * w->ncol;
    const int* parent = w->dof_parent;
    ostNum* y = w->tmp + nv;
    int n = w->Jnnz[i];
    for (int k = 0; k < n; k++) {
      y[ind[k]] = v[k];
    }
    d = 0;
    for (int k = n - 1; k >= 0; k--) {
      int c = ind[k];
      ostNum yc = y[c];
      for (int j = parent[c]; j >= 0; j = parent[j]) {
        y[j] -= w->M[(size_t)c * nv + j] * yc;
      }
      d += yc * yc / w->M[(size_t)c * nv + c];
#if OST_ROW_CACHE
      if (w->yrow) w->yrow[(size_t)i * w->ncol + k] = yc;  // osti_directSet reads it back
#endif
    }
  } else {
    // a dense row (or a compressed one scattered into a dense vector) against either factor
    ostNum* Ji = w->tmp + nv;
    ostNum* y = w->Jrow && w->Jnnz ? w->Jrow : NULL;  // scratch of nv for the solve
    if (w->Jnnz) {
      for (int j = 0; j < nv; j++) Ji[j] = 0;
      const int* ind = w->Jind + (size_t)i * w->ncol;
      for (int k = 0; k < w->Jnnz[i]; k++) Ji[ind[k]] = w->J[(size_t)i * w->ncol + k];
    } else {
      Ji = w->J + (size_t)i * nv;
      y = w->tmp + nv;
    }
    d = w->dof_parent ? ostu_treeNormSqr(y, w->M, w->dof_parent, Ji, nv)
                      : ostu_cholNormSqr(y, w->M, Ji, nv);
  }
  w->diag[i] = d > 1e-300 ? d : 1e-300;
}


// the number of rows from i on (at most max) that share row i's pattern: a contact's normal and
// friction rows, stored from the same two dof chains (osti_rowStoreChains)
OST_HD int osti_patternRun(const ostWorld* w, int i, int max) {
  if (!w->Jnnz || !w->dof_parent || !w->Jrow) {
    return 1;  // osti_rowDiagRun needs the tree factor, patterns and Jrow's scratch
  }
  const int* a = w->Jind + (size_t)i * w->ncol;
  int n = w->Jnnz[i], g = 1;
  if (max > 1 + OST_MAXFRIC) {
    max = 1 + OST_MAXFRIC;
  }
  for (; g < max && w->Jnnz[i + g] == n; g++) {
    const int* b = w->Jind + (size_t)(i + g) * w->ncol;
    int k = 0;
    while (k < n && a[k] == b[k]) k++;
    if (k < n) {
      break;
    }
  }
  return g;
}


// osti_rowDiag of the g rows from i, which share one pattern (osti_patternRun): one walk of
// the pattern's parent chains and one read of each factor entry serve all g half-solves (laid
// out interleaved, y[j g + r]), each row's arithmetic that of osti_rowDiag (the same bits).
// g is a constant where osti_rowDiagRun calls it, so the loops over r unroll.
OST_HD void osti_rowDiagRunG(ostWorld* w, int i, const int g) {
  int nv = w->nv, ncol = w->ncol, n = w->Jnnz[i];
  const int* ind = w->Jind + (size_t)i * ncol;
  const int* parent = w->dof_parent;
  ostNum* y = w->Jrow;  // (1 + OST_MAXFRIC) nv >= g nv
  ostNum d[1 + OST_MAXFRIC];
  for (int r = 0; r < g; r++) {
    const ostNum* v = w->J + (size_t)(i + r) * ncol;
    for (int k = 0; k < n; k++) {
      y[(size_t)ind[k] * g + r] = v[k];
    }
    d[r] = 0;
  }
  for (int k = n - 1; k >= 0; k--) {
    int c = ind[k];
    ostNum yc[1 + OST_MAXFRIC];
    for (int r = 0; r < g; r++) yc[r] = y[(size_t)c * g + r];
    for (int j = parent[c]; j >= 0; j = parent[j]) {
      ostNum Mcj = w->M[(size_t)c * nv + j];
      ostNum* yj = y + (size_t)j * g;
      for (int r = 0; r < g; r++) yj[r] -= Mcj * yc[r];
    }
    ostNum Mcc = w->M[(size_t)c * nv + c];
    for (int r = 0; r < g; r++) {
      d[r] += yc[r] * yc[r] / Mcc;
#if OST_ROW_CACHE
      if (w->yrow) w->yrow[(size_t)(i + r) * ncol + k] = yc[r];  // osti_directSet reads it
#endif
    }
  }
  for (int r = 0; r < g; r++) {
    w->diag[i + r] = d[r] > 1e-300 ? d[r] : 1e-300;
  }
}


OST_HD void osti_rowDiagRun(ostWorld* w, int i, int g) {
  switch (g) {
    case 1: osti_rowDiag(w, i); break;
    case 2: osti_rowDiagRunG(w, i, 2); break;
    case 3: osti_rowDiagRunG(w, i, 3); break;
    case 4: osti_rowDiagRunG(w, i, 4); break;
    case 5: osti_rowDiagRunG(w, i, 5); break;
    default: osti_rowDiagRunG(w, i, 6); break;  // 1 + OST_MAXFRIC, osti_patternRun's cap
  }
}


// the Householder reflection H = I - beta v v' that maps the unit vector e (n <= OST_MAXFRIC)
// onto the first axis: H e = e_1, H = H' = H^-1. v = e - e_1, its first entry computed without
// cancellation (e_1 - 1 = -sum_{k>1} e_k^2 / (1 + e_1) when e_1 > 0). Fills H (n x n).
OST_HD void osti_householder(ostNum* H, const ostNum* e, int n) {
  ostNum v[OST_MAXFRIC], sigma = 0;
  for (int k = 1; k < n; k++) {
    v[k] = e[k];
    sigma += e[k] * e[k];
  }
  v[0] = e[0] > 0 ? -sigma / (1 + e[0]) : e[0] - 1;
  ostNum vv = v[0] * v[0] + sigma;
  ostNum beta = vv > 0 ? 2 / vv : 0;
  for (int r = 0; r < n; r++) {
    for (int k = 0; k < n; k++) {
      H[r * n + k] = (r == k) - beta * v[r] * v[k];
    }
  }
}


// x <- H x for the n-vector x (stride 1)
OST_HD void osti_reflect(ostNum* x, const ostNum* H, int n) {
  ostNum y[OST_MAXFRIC];
  for (int r = 0; r < n; r++) {
    y[r] = 0;
    for (int k = 0; k < n; k++) {
      y[r] += H[r * n + k] * x[k];
    }
  }
  for (int r = 0; r < n; r++) {
    x[r] = y[r];
  }
}


// rows a .. a+n-1 of J (one shared pattern) <- H times them, column by column
OST_HD void osti_reflectFriction(ostWorld* w, int a, int n, const ostNum* H) {
  int len = w->Jnnz ? w->ncol : w->nv;  // stored row length
  int cnt = w->Jnnz ? w->Jnnz[a] : w->nv;
  ostNum* A = w->J + (size_t)a * len;
  for (int j = 0; j < cnt; j++) {
    ostNum x[OST_MAXFRIC];
    for (int k = 0; k < n; k++) {
      x[k] = A[(size_t)k * len + j];
    }
    osti_reflect(x, H, n);
    for (int k = 0; k < n; k++) {
      A[(size_t)k * len + j] = x[k];
    }
  }
}


// k_f = h (J_f Mt^-1 J_f')avg of contact i's nf friction rows (velocity per force; eq. 7)
OST_HD ostNum osti_frictionScale(const ostWorld* w, int i, int nf) {
  ostNum kf = 0;
  for (int k = 0; k < nf; k++) {
    kf += w->diag[i + 1 + k];
  }
  return w->h * kf / nf;
}


// the sliding model of contact i's nf friction rows (osti_frictionRows) for the slip-frame vector
// z (|z| = zn > 0): rows reflected into the frame of e = z / |z|, the force along e pinned to
// the cone bound, the rows across e with the weight W = c_s + k_f (1 - beta) / beta,
// beta = bound / zn. Returns the squared merit of the rows (velocity units).
OST_HD ostNum osti_slideRows(ostWorld* w, int i, int nf, ostNum kf, ostNum cs, ostNum bound,
                             const ostNum* z, ostNum zn) {
  int a = i + 1;
  ostNum H[OST_MAXFRIC * OST_MAXFRIC];
  w->op_version++;  // rows, c and the sliding coupling change: a kept envelope factor is stale
  w->W[i] = 1;
  for (int k = 0; k < nf; k++) {
    w->W[a + k] = z[k] / zn;
  }
  osti_householder(H, w->W + a, nf);
  osti_reflectFriction(w, a, nf, H);
  ostNum lam[OST_MAXFRIC] = {0};
  for (int k = 0; k < nf;) {
    int g = osti_patternRun(w, a + k, nf - k);
    osti_rowDiagRun(w, a + k, g);
    k += g;
  }
  for (int k = 0; k < nf; k++) {
    lam[k] = w->lambda[a + k];
  }
  osti_reflect(w->Ju + a, H, nf);
  osti_reflect(lam, H, nf);  // lam[0] along the slip, the others across it
  ostNum mpar = kf * (lam[0] - bound), m2 = mpar * mpar;
  w->c[a] = kf * OST_FIXED_ROW;
  w->rho[a] = mpar * OST_FIXED_ROW;
  ostNum beta = bound / zn;
  for (int k = 1; k < nf; k++) {
    ostNum mperp = kf * lam[k];
    if (beta * (OST_FIXED_ROW + 1) > 1) {
      w->c[a + k] = cs + kf * (1 - beta) / beta;
      w->rho[a + k] = mperp / beta;
    } else {
      w->c[a + k] = kf * OST_FIXED_ROW;  // no normal force: the tangential force goes to zero
      w->rho[a + k] = mperp * OST_FIXED_ROW;
    }
    m2 += mperp * mperp;
  }
  return m2;
}


// row forms of the nf friction rows i+1 .. i+nf of contact i (paper eq. 5-7), Coulomb friction
// by maximal dissipation written as Alart-Curnier's semismooth equation
//   G = lambda_f - proj_{|.| <= mu lambda_n}(z),   z = lambda_f - (s + c_s lambda_f) / k_f
// with slip s = J_f u, k_f = h (J_f Mt^-1 J_f')avg (velocity per force) and the sticking
// compliance c_s = reg k_f + creep: reg k_f makes the force distribution of redundant contacts
// unique; creep (ostOptions.friction_creep, s/kg) is a physical creep, slip = creep x force while
// sticking, the same at every h (k_f scales with h). The rows are normalized (ost_constraint.h),
// so torsional and rolling rows share the one circular cone (MuJoCo's elliptic cone).
// Stick (|z| <= mu lambda_n): J_f du + c_s dlambda_f = -(s + c_s lambda_f), rotation-invariant.
// Slide: the rows are reflected (Householder H, H z = |z| e_1) into a frame whose first axis is
// e = z / |z| (W[i] = 1, W[i+1..i+nf] = e); along e the force is fixed on the cone (lagged
// lambda_n), across it the compliance weight is
//   W = c_s + k_f (1 - beta) / beta,  beta = mu lambda_n / |z|  (W = slip / |lambda_f| at the
// solution). Returns the squared merit |G|^2 k_f^2 (velocity units).
OST_HD ostNum osti_frictionRows(ostWorld* w, int i, int nf, ostNum reg, ostNum creep) {
  int a = i + 1;
  ostNum kf = osti_frictionScale(w, i, nf);
  ostNum cs = reg * kf + creep;
  ostNum bound = w->rows[i].mu * (w->lambda[i] > 0 ? w->lambda[i] : 0);
  ostNum z[OST_MAXFRIC], zn2 = 0;
  for (int k = 0; k < nf; k++) {
    ostNum l = w->lambda[a + k];
    z[k] = l - (w->Ju[a + k] + cs * l) / kf;
    zn2 += z[k] * z[k];
  }
  ostNum zn = sqrt(zn2);
  if (zn <= bound) {
    w->W[i] = 0;
    ostNum m2 = 0;
    for (int k = 0; k < nf; k++) {
      w->c[a + k] = cs;
      w->rho[a + k] = w->Ju[a + k] + cs * w->lambda[a + k];
      m2 += w->rho[a + k] * w->rho[a + k];
    }
    return m2;
  }
  return osti_slideRows(w, i, nf, kf, cs, bound, z, zn);  // zn > bound >= 0
}


// row form of dry-friction row i (frictionloss; MuJoCo's mjCNSTR_FRICTION_DOF/_TENDON rows as
// hard constraints): the one-dimensional case of osti_frictionRows with a fixed bound,
//   G = lambda - clamp(z, -mu, mu),   z = lambda - (s + c_s lambda) / k_f,   s = J u,
// k_f = h J Mt^-1 J' and c_s = reg k_f (no creep: a joint held by dry friction stays put at any
// h). Stick (|z| <= mu): J du + c_s dlambda = -(s + c_s lambda); slide: the force is fixed at
// the bound on the side of z. Returns the merit term k_f G (a velocity).
OST_HD ostNum osti_dryRow(ostWorld* w, int i, ostNum reg) {
  ostNum kf = w->h * w->diag[i], cs = reg * kf, lam = w->lambda[i], bound = w->rows[i].mu;
  ostNum z = lam - (w->Ju[i] + cs * lam) / kf;
  if (z >= -bound && z <= bound) {
    w->c[i] = cs;
    w->rho[i] = w->Ju[i] + cs * lam;
    return w->rho[i];
  }
  ostNum m = kf * (lam - (z > 0 ? bound : -bound));
  w->c[i] = kf * OST_FIXED_ROW;
  w->rho[i] = m * OST_FIXED_ROW;
  return m;
}


// the effective-mass scale of equality row i: the largest J_k Mt^-1 J_k' over the rows of its
// equality (consecutive, same object), so that a row that moves nothing (a planar loop's
// out-of-plane row) or little still gets the relative compliance of its constraint
OST_HD ostNum osti_equalityScale(const ostWorld* w, int i) {
  int obj = w->rows[i].obj[0], a = i, b = i;
  while (a > 0 && w->rows[a - 1].type == OST_ROW_EQUALITY && w->rows[a - 1].obj[0] == obj) a--;
  while (b + 1 < w->nrow && w->rows[b + 1].type == OST_ROW_EQUALITY && w->rows[b + 1].obj[0] == obj) {
    b++;
  }
  ostNum d = 0;
  for (int k = a; k <= b; k++) {
    d = w->diag[k] > d ? w->diag[k] : d;
  }
  return d;
}


// the largest J Mt^-1 J' of the nf friction rows after contact row i (0 without friction): the
// reference of osti_contactImmobile and osti_contactScale
OST_HD ostNum osti_frictionDiagMax(const ostWorld* w, int i, int nf) {
  ostNum df = 0;
  for (int k = 1; k <= nf; k++) {
    df = w->diag[i + k] > df ? w->diag[i + k] : df;
  }
  return df;
}


// 1 if contact row i, whose friction rows' largest diagonal is df, has a normal that no dof
// moves while its tangents move: J_n Mt^-1 J_n' below OST_IMMOBILE df (|J_n| below 1e-7 of |J_t|
// in the Mt^-1 norm, rounding: a capsule turning about its own axis next to another geom, two
// gripper pads that slide past each other edge to edge). Its gap can neither close nor open, so
// it carries no force: its rows are held at lambda = 0 (osti_immobileRows, with k_f = h df).
// Given their FB function, Newton would scale the force by k ~ 1e-25 m/N and drive it to 1e10 N
// within an iterate. The bound stays far below any physical ratio: a wheel's normal against its
// spin is I_wheel / (M r^2), 1e-5 for a light wheel under a heavy vehicle (OST_IMMOBILE is
// ost_constraint.h's, shared with the frictionless test osti_normalMoves).
OST_HD int osti_contactImmobile(const ostWorld* w, int i, ostNum df) {
  return df > 0 && w->diag[i] < OST_IMMOBILE * df;
}


// the scale k / h^2 of contact row i's FB function: its own J_n Mt^-1 J_n', floored at
// OST_NORMAL_FLOOR times df, its friction rows' largest. The FB's roots do not depend on k > 0,
// but its smoothing does: with fb_eps the root of a contact whose gap stays open has
// k lambda = fb_eps^2 / (2 gap), a force that grows as k shrinks, and friction may act up to mu
// times it. A contact whose normal the dofs move little against its tangents (a sphere turning
// about an axis 2 um off its centre, 4 mm from a box: J_n 1e-4 of J_t) got a spurious 1e-3 N and
// braked the sphere by 17 % in 0.4 s; with the floor its tangents move by at most
// mu fb_eps^2 / (2 gap OST_NORMAL_FLOOR) per step. Ordinary contacts (normal and tangents within
// a factor of 100) keep their scale and their bits.
#define OST_NORMAL_FLOOR 1e-2
OST_HD ostNum osti_contactScale(const ostWorld* w, int i, ostNum df) {
  ostNum f = OST_NORMAL_FLOOR * df;
  return f > w->diag[i] ? f : w->diag[i];
}


// the rows i .. i + nf of an immobile contact (osti_contactImmobile) held at zero force, as the
// fixed friction rows of osti_frictionRows: residual k_f lambda each (velocity units, k_f = h df),
// Newton update dlambda = -lambda. Returns the squared merit.
OST_HD ostNum osti_immobileRows(ostWorld* w, int i, int nf, ostNum kf) {
  ostNum m2 = 0;
  for (int k = 0; k <= nf; k++) {
    ostNum m = kf * w->lambda[i + k];
    w->c[i + k] = kf * OST_FIXED_ROW;
    w->rho[i + k] = m * OST_FIXED_ROW;
    w->W[i + k] = 0;
    m2 += m * m;
  }
  return m2;
}


// The relative compliance of the rows of a step that removes a violation present at its start
// (a joint started beyond its limit, a body placed into its floor, an equality not satisfied:
// the rows the relax table shifts, ost_step.h). Each shifted row asks for its own share h v_d
// of the correction, and in a closed kinematic loop the shares need not fit each other or the
// loop. Agility Cassie from qpos0 starts with its feet and foot cranks 30 degrees beyond their
// limits, inside plantar-rod four-bars at their dead centre; with the default 1e-6 the shifted
// limits and the loops fought with internal forces that only that compliance bounded, the
// dynamics residual floored at 1e-9 to 1e-8 m/s (round-off of those forces) and 191 of 200
// steps at 0.5 ms did not converge (932 Newton iterates per step). With 1e-4 for every row of
// such a step: none of 1,000 (4.6 iterates per step). A row then gives way by 1e-4 of the
// displacement its force would cause on its own in a step (for a resting contact 1e-4 h^2 g,
// 2.5e-11 m at 0.5 ms); such a step is no exact solution anyway (OST_DEPENETRATED, its gradient
// refused). Steps without a violation at their start keep `regularization`.
#define OST_RELAX_REG 1e-4

// the Newton model of saturated sticking, a primal-dual active-set correction of eq. (7): a
// contact classed sticking (|z| <= mu lambda_n) with its force on the cone, whose direction asks
// for a friction force outside the cone, |lambda_f + dlambda_f| > mu max(lambda_n, lambda_n +
// dlambda_n), is not sticking at the next iterate. The line search then projects that force back
// onto the cone, the dynamics residual grows in proportion to the step, and Newton crawls toward
// the same target for many iterates (a humanoid's light foot contact: 10-28 iterates a step).
// Such a contact gets the sliding model of osti_frictionRows with the predicted force in the
// place of z (osti_slideRows): in the frame of e = f / |f|, f = lambda_f + dlambda_f, the force
// along e is pinned to the cone, moving with lambda_n (osti_newtonApplySet), and the rows across
// e get the weight W = c_s + k_f (1 - beta) / beta, beta = mu lambda_n / |f|. Only the Newton
// model changes; residual and merit stay eq. (7)'s. Returns the number of contacts changed
// (their direction must be solved again).
OST_HD int osti_saturateSticking(ostWorld* w, const ostSolverOptions* opt) {
  int nrow = w->nrow, changed = 0;
  for (int i = 0; i + 2 < nrow; i++) {
    if (w->rows[i].type != OST_ROW_CONTACT || w->W[i] != 0 || !(w->lambda[i] > 0)
        || (w->nisland && w->isl_done[w->row_island[i]])) {
      continue;
    }
    int nf = osti_frictionCount(w->rows, nrow, i), a = i + 1;
    if (nf == 0 || osti_contactImmobile(w, i, osti_frictionDiagMax(w, i, nf))) {
      continue;
    }
    ostNum ln = w->lambda[i] + w->dlambda[i], f[OST_MAXFRIC], fn2 = 0, l2 = 0;
    for (int k = 0; k < nf; k++) {
      f[k] = w->lambda[a + k] + w->dlambda[a + k];
      fn2 += f[k] * f[k];
      l2 += w->lambda[a + k] * w->lambda[a + k];
    }
    ostNum bound = w->rows[i].mu * w->lambda[i], bound_next = w->rows[i].mu * (ln > 0 ? ln : 0);
    if (l2 < bound * bound * (1 - OST_SATURATED_ON_CONE)) {
      continue;  // not saturated: its force is inside the cone
    }
    ostNum b = bound > bound_next ? bound : bound_next;
    if (!(fn2 > b * b * (1 + OST_SATURATE_SLACK))) {
      continue;
    }
    ostNum kf = osti_frictionScale(w, i, nf);
    ostNum cs = opt->reg * kf + opt->creep;
    osti_slideRows(w, i, nf, kf, cs, bound, f, sqrt(fn2));
    changed++;
  }
  return changed;
}


// evaluate the iterate (qvel, lambda) with the rows and J filled for q(qvel): fills
// Minv_rdyn, diag, Ju and the row form (c, rho); returns the squared merit residual
//   |Mt^-1 r_dyn|^2 + sum_i m_i^2,  every term a velocity (m/s or rad/s)
// The friction rows of sliding contacts are left rotated into their slip frame (see
// osti_frictionRows); osti_newtonUpdate rotates them back.
OST_HD ostNum osti_evaluate(ostWorld* w, const ostSolverOptions* opt) {
  int nv = w->nv, nrow = w->nrow;
  ostNum h = w->h;
  ostNum* t = w->tmp;
  w->op_version++;  // a new Schur operator: a kept envelope factor is stale
  // the relative compliance of equality, limit and contact rows (eqs. 3, 4): `regularization`,
  // at least OST_RELAX_REG in a step that removes a violation present at its start
  ostNum reg = w->nrow_relax > 0 && opt->reg < OST_RELAX_REG ? (ostNum)OST_RELAX_REG : opt->reg;

  // Mt^-1 r_dyn = (u - u-) - h Mt^-1 (f + J' lambda)                              (eq. 9)
  osti_mulJT(w, t, w->lambda);
  for (int j = 0; j < nv; j++) {
    t[j] += w->qfrc_explicit[j];
  }
  osti_massSolve(w, t);
  ostNum merit = 0;
  for (int j = 0; j < nv; j++) {
    w->Minv_rdyn[j] = w->qvel[j] - w->qvel_prev[j] - h * t[j];
    merit += w->Minv_rdyn[j] * w->Minv_rdyn[j];
  }

  // per-row J u and the Jacobi diagonal J_i Mt^-1 J_i'
  for (int i = 0; i < nrow;) {
    int g = osti_patternRun(w, i, nrow - i);
    for (int k = i; k < i + g; k++) {
      w->Ju[k] = osti_rowDot(w, k, w->qvel);
      w->W[k] = 0;
    }
    osti_rowDiagRun(w, i, g);
    i += g;
  }

  // row forms; FB rows are divided by h*phi_a so that all rows share J_i as their Jacobian
  for (int i = 0; i < nrow; i++) {
    const ostRow* r = w->rows + i;
    ostNum lam = w->lambda[i];
    ostNum m_i, fric2 = 0;
    switch (r->type) {
    case OST_ROW_EQUALITY: {
      // c(q+) + E lambda = 0, linearized as h J du + E dlambda = -r                   (eq. 3)
      ostNum E = r->alpha + reg * h * h * osti_equalityScale(w, i);
      w->c[i] = E / h;
      w->rho[i] = (r->pos + E * lam) / h;
      m_i = w->rho[i];
      break;
    }
    case OST_ROW_LIMIT:
    case OST_ROW_CONTACT: {
      // FB(gap + reg k lambda, k lambda) = 0 with the effective-mass scale k = h^2 J_i Mt^-1 J_i'
      // (m/N; floored by the contact's friction rows, osti_contactScale): the displacement an
      // impulse h*lambda causes in one step, so both arguments are metres; the compliance reg*k
      // makes the forces of redundant contacts unique
      int nf = osti_frictionCount(w->rows, nrow, i);
      ostNum df = osti_frictionDiagMax(w, i, nf);
      if (r->type == OST_ROW_CONTACT && osti_contactImmobile(w, i, df)) {
        ostNum m2 = osti_immobileRows(w, i, nf, h * df);
        merit += m2;
        m_i = 0;
        fric2 = m2;
        break;
      }
      ostNum k = h * h * osti_contactScale(w, i, df);
      ostNum fa, fb;
      ostNum phi = osti_fb(r->pos + reg * k * lam, k * lam, opt->fb_eps, &fa, &fb);
      ostNum a = fa > 1e-12 ? fa : 1e-12;
      w->c[i] = reg * k / h + fb * k / (h * a);
      w->rho[i] = phi / (h * a);
      m_i = phi / h;
      if (nf) {
        ostNum mf = osti_frictionRows(w, i, nf, opt->reg, opt->creep);
        merit += mf;
        fric2 = mf;
      }
      break;
    }
    case OST_ROW_FRICTION:
      m_i = 0;  // filled with its contact row
      break;
    case OST_ROW_DRY:
      m_i = osti_dryRow(w, i, opt->reg);
      break;
    case OST_ROW_SERVO: {
      // force = pos + b2 J u (q+ enters pos through the actuator length), clamped to
      // forcerange; residual alpha (lambda - force) with alpha = 1/(kd + h kp)      (eq. 8)
      ostNum F = r->pos + r->mu * w->Ju[i];
      int clamped = 0;
      if (F < r->lo) {
        F = r->lo;
        clamped = 1;
      } else if (F > r->hi) {
        F = r->hi;
        clamped = 1;
      }
      m_i = r->alpha * (lam - F);
      ostNum a = clamped ? 1e-12 : 1;
      w->c[i] = r->alpha / a;
      w->rho[i] = m_i / a;
      break;
    }
    default:
      m_i = 0;
      w->c[i] = 1;
      w->rho[i] = 0;
      break;
    }
    merit += m_i * m_i;
    if (w->merit_row) {  // per-row terms, in the order merit sums them (islands add them up)
      w->merit_row[2 * i] = fric2;
      w->merit_row[2 * i + 1] = m_i * m_i;
    }
  }
  return merit;
}


//---------------------------------- Row sets and the Schur operator --------------------------------
// The Schur system is block diagonal over islands (ost_island.h): rows that share no degree of
// freedom, through a contact, a joint or a kinematic tree, do not couple. Each island's block is
// solved on its own, in local vectors indexed by the island's rows. A row set names the rows
// (ascending) and the trees (root dofs, whose dofs are contiguous) of one island; the set of the
// whole world has row = NULL (rows 0..n-1) and tree = NULL (every dof).

typedef struct ostRowSet_ {       // rows and trees the Schur operator runs on
  const int* row;                 // rows, ascending (NULL: rows 0 .. n-1)
  int        n;                   // their number
  const int* tree;                // root dofs of the trees (NULL: all dofs)
  int        ntree;               // their number
} ostRowSet;


// 1 if key k is the world's current operator on this set
OST_HD int osti_opKeyIs(const ostOpKey* k, const ostWorld* w, const ostRowSet* set) {
  return k->version == w->op_version && k->row == set->row && k->n == set->n;
}


// key k := the world's current operator on this set
OST_HD void osti_opKeySet(ostOpKey* k, const ostWorld* w, const ostRowSet* set) {
  k->version = w->op_version;
  k->row = set->row;
  k->n = set->n;
}

#define OST_SET_ROW(set, l) ((set)->row ? (set)->row[l] : (l))

// the set of all rows and dofs of the current iterate
OST_HD ostRowSet osti_wholeSet(const ostWorld* w) {
  ostRowSet set = {NULL, w->nrow, NULL, 0};
  return set;
}


// x = Mt^-1 x on the set's trees (x is left untouched elsewhere): the tree factor couples no
// two trees, so each tree's dofs [root, tree_end[root]) solve alone
OST_HD void osti_massSolveSet(const ostWorld* w, const ostRowSet* set, ostNum* x) {
  if (!set->tree || !w->dof_parent) {
    osti_massSolve(w, x);
    return;
  }
  for (int t = 0; t < set->ntree; t++) {
    ostu_treeSolveRange(x, w->M, w->dof_parent, w->nv, set->tree[t], w->tree_end[set->tree[t]]);
  }
}


// t = J' x over the set's rows (x local), zero on the set's other dofs
OST_HD void osti_mulJTSet(const ostWorld* w, const ostRowSet* set, ostNum* OST_RESTRICT t,
                          const ostNum* x) {
  if (!set->row) {
    osti_mulJT(w, t, x);  // the whole world: rows 0 .. nrow-1 in order, every dof
    return;
  }
  // an island: its trees' dofs (every dof for rows without a tree list: a reduced whole set,
  // osti_decoupledSolve), its compressed rows (islands exist only with row patterns)
  if (!set->tree) {
    for (int j = 0; j < w->nv; j++) t[j] = 0;
  }
  for (int k = 0; set->tree && k < set->ntree; k++) {
    for (int j = set->tree[k]; j < w->tree_end[set->tree[k]]; j++) {
      t[j] = 0;
    }
  }
  for (int l = 0; l < set->n; l++) {
    int i = set->row[l];
    ostNum xi = x[l];
    if (OSTU_SKIPPABLE(xi)) {
      continue;
    }
    const ostNum* v = w->J + (size_t)i * w->ncol;
    const int* ind = w->Jind + (size_t)i * w->ncol;
    for (int k = 0; k < w->Jnnz[i]; k++) {
      t[ind[k]] += v[k] * xi;
    }
  }
}


// y = A x = J Mt^-1 J' x + (c / h) x on a set (x, y local), applied matrix-free
OST_HD void osti_schurApplySet(ostWorld* w, const ostRowSet* set, ostNum* OST_RESTRICT y,
                               const ostNum* x) {
  ostNum* t = w->tmp;
  osti_mulJTSet(w, set, t, x);
  osti_massSolveSet(w, set, t);
  for (int l = 0; l < set->n; l++) {
    int i = OST_SET_ROW(set, l);
    y[l] = osti_rowDot(w, i, t) + w->c[i] / w->h * x[l];
  }
}


// y = A x on every row
OST_HD void osti_schurApply(ostWorld* w, ostNum* OST_RESTRICT y, const ostNum* x) {
  ostRowSet set = osti_wholeSet(w);
  osti_schurApplySet(w, &set, y, x);
}


// preconditioned conjugate residual for A x = b (A symmetric) on a set (x, b local), Jacobi
// preconditioner P = diag(A)^-1; x starts at 0; returns the iterations used
OST_HD int osti_pcrSet(ostWorld* w, const ostRowSet* set, ostNum* x, const ostNum* b, int maxit,
                       ostNum rtol) {
  int n = set->n;
  ostNum* r = w->pcr + (size_t)w->nrow_max;
  ostNum* z = r + w->nrow_max;
  ostNum* p = z + w->nrow_max;
  ostNum* Az = p + w->nrow_max;
  ostNum* Ap = Az + w->nrow_max;
  // P_l = 1 / (J_i Mt^-1 J_i' + c_i / h), i the set's l-th row
#define OST_PREC(l) (1 / (w->diag[OST_SET_ROW(set, l)] + w->c[OST_SET_ROW(set, l)] / w->h))
  ostNum bnorm2 = 0;
  for (int i = 0; i < n; i++) {
    x[i] = 0;
    r[i] = b[i];
    z[i] = OST_PREC(i) * r[i];
    p[i] = z[i];
    bnorm2 += b[i] * b[i];
  }
  if (n == 0 || bnorm2 == 0) {
    return 0;
  }
  osti_schurApplySet(w, set, Az, z);
  ostNum rz = ostu_dot(z, Az, n);
  for (int i = 0; i < n; i++) {
    Ap[i] = Az[i];
  }
  int it = 0;
  while (it < maxit) {
    it++;
    // step length alpha = (z, A z) / (A p, P A p)
    ostNum den = 0;
    for (int i = 0; i < n; i++) {
      den += Ap[i] * OST_PREC(i) * Ap[i];
    }
    if (!(den > 0) || !(rz > 0)) {
      break;
    }
    ostNum alpha = rz / den;
    ostNum rnorm2 = 0;
    for (int i = 0; i < n; i++) {
      x[i] += alpha * p[i];
      r[i] -= alpha * Ap[i];
      z[i] -= alpha * OST_PREC(i) * Ap[i];
      rnorm2 += r[i] * r[i];
    }
    if (rnorm2 <= rtol * rtol * bnorm2) {
      break;
    }
    // new direction p = z + beta p, A p = A z + beta A p
    osti_schurApplySet(w, set, Az, z);
    ostNum rz_new = ostu_dot(z, Az, n);
    ostNum beta = rz_new / rz;
    rz = rz_new;
    for (int i = 0; i < n; i++) {
      p[i] = z[i] + beta * p[i];
      Ap[i] = Az[i] + beta * Ap[i];
    }
  }
#undef OST_PREC
  return it;
}


// PCR on every row
OST_HD int osti_pcr(ostWorld* w, ostNum* x, const ostNum* b, int maxit, ostNum rtol) {
  ostRowSet set = osti_wholeSet(w);
  return osti_pcrSet(w, &set, x, b, maxit, rtol);
}


// 1 if row i is a contact sliding under normal force (osti_frictionRows set W[i]): its friction
// force along the slip, mu lambda_n, then moves with lambda_n (0 while its coupling is lagged,
// cpl_row[2 i + 1]: the direction then holds its bound at the iterate's normal force; rows from
// cpl_n on are never marked, and their entries are not read: the allocation is not zeroed)
OST_HD int osti_slidingCoupled(const ostWorld* w, int i) {
  return !(w->cpl_row && i < w->cpl_n && w->cpl_row[2 * i + 1]) && i + 2 < w->nrow
         && w->rows[i].type == OST_ROW_CONTACT && w->W[i] != 0 && w->lambda[i] > 0;
}


// 1 if a row of the set has a sliding coupling: its Newton system is then not symmetric
OST_HD int osti_hasSlidingCouplingSet(const ostWorld* w, const ostRowSet* set) {
  for (int l = 0; l < set->n; l++) {
    if (osti_slidingCoupled(w, OST_SET_ROW(set, l))) {
      return 1;
    }
  }
  return 0;
}


// y = A x plus the coupling of sliding friction on a set (x, y local; a contact's rows are
// consecutive in every set): the row along the slip of a sliding contact linearizes
// G_par = lambda_par - mu lambda_n (osti_frictionRows) completely, c (dlambda_par - mu
// dlambda_n) + J du = -rho, so A gets -(c / h) mu in that row's normal column. Without it the
// normal force is lagged by one iterate, and Newton stalls or cycles when normal loads and
// sliding friction move together (a skid-steered robot turning: merit stuck at 1e-2 m/s).
OST_HD void osti_newtonApplySet(ostWorld* w, const ostRowSet* set, ostNum* OST_RESTRICT y,
                                const ostNum* x) {
  osti_schurApplySet(w, set, y, x);
  for (int l = 0; l + 1 < set->n; l++) {
    int i = OST_SET_ROW(set, l);
    if (osti_slidingCoupled(w, i)) {
      y[l + 1] -= w->c[i + 1] / w->h * w->rows[i].mu * x[l];
    }
  }
}


OST_HD void osti_newtonApply(ostWorld* w, ostNum* OST_RESTRICT y, const ostNum* x) {
  ostRowSet set = osti_wholeSet(w);
  osti_newtonApplySet(w, &set, y, x);
}


// apply the Givens rotation (cs, sn) to the pair (a, b)
OST_HD void osti_givens(ostNum* a, ostNum* b, ostNum cs, ostNum sn) {
  ostNum t = cs * *a + sn * *b;
  *b = -sn * *a + cs * *b;
  *a = t;
}


// restarted GMRES(OST_KRYLOV) for the non-symmetric Newton system (osti_newtonApplySet) x = b
// on a set (x, b local), left-preconditioned by the Jacobi diagonal P = diag(A)^-1 of osti_pcr:
// it minimizes |P (b - A x)| (Saad, Iterative Methods for Sparse Linear Systems, alg. 9.4).
// Left, because a sliding row's coupling entry -(c/h) mu is as large as its diagonal c/h
// (c ~ 1e12 k_f): P A scales that row to dlambda_par - mu dlambda_n, while A P would carry
// 1e12-sized entries. x starts at 0; returns the iterations used
OST_HD int osti_gmresSet(ostWorld* w, const ostRowSet* set, ostNum* x, const ostNum* b, int maxit,
                         ostNum rtol) {
  int n = set->n, ld = w->nrow_max;
  const int hc = OST_KRYLOV + 4;  // row length of hess: H (OST_KRYLOV), then cs, sn, g, y
  ostNum* V = w->krylov;          // basis vectors V_j = V + j ld
  ostNum* H = w->hess;            // H_ij = H[i hc + j]
  ostNum* r = w->pcr + ld;        // scratch: preconditioned residual
#define OST_PRECOND(l) (1 / (w->diag[OST_SET_ROW(set, l)] + w->c[OST_SET_ROW(set, l)] / w->h))
#define OST_CS(j) H[(j) * hc + OST_KRYLOV]
#define OST_SN(j) H[(j) * hc + OST_KRYLOV + 1]
#define OST_G(j) H[(j) * hc + OST_KRYLOV + 2]
#define OST_Y(j) H[(j) * hc + OST_KRYLOV + 3]
  for (int i = 0; i < n; i++) {
    x[i] = 0;
    r[i] = OST_PRECOND(i) * b[i];
  }
  ostNum bnorm = sqrt(ostu_dot(r, r, n));
  if (n == 0 || bnorm == 0) {
    return 0;
  }
  int it = 0;
  ostNum beta = bnorm;
  while (it < maxit) {
    // Arnoldi from V_0 = r / |r|, with Givens rotations keeping the least-squares residual |g_j|
    for (int i = 0; i < n; i++) {
      V[i] = r[i] / beta;
    }
    OST_G(0) = beta;
    int j = 0, done = 0;
    while (j < OST_KRYLOV && it < maxit) {
      it++;
      ostNum* vn = V + (size_t)(j + 1) * ld;
      osti_newtonApplySet(w, set, vn, V + (size_t)j * ld);
      for (int i = 0; i < n; i++) {
        vn[i] *= OST_PRECOND(i);
      }
      for (int k = 0; k <= j; k++) {  // modified Gram-Schmidt
        ostNum hkj = ostu_dot(vn, V + (size_t)k * ld, n);
        H[k * hc + j] = hkj;
        for (int i = 0; i < n; i++) {
          vn[i] -= hkj * V[(size_t)k * ld + i];
        }
      }
      ostNum hn = sqrt(ostu_dot(vn, vn, n));
      for (int i = 0; i < n && hn > 0; i++) {
        vn[i] /= hn;
      }
      for (int k = 0; k < j; k++) {
        osti_givens(&H[k * hc + j], &H[(k + 1) * hc + j], OST_CS(k), OST_SN(k));
      }
      ostNum hjj = H[j * hc + j], den = sqrt(hjj * hjj + hn * hn);
      OST_CS(j) = den > 0 ? hjj / den : 1;
      OST_SN(j) = den > 0 ? hn / den : 0;
      H[j * hc + j] = den;
      OST_G(j + 1) = -OST_SN(j) * OST_G(j);
      OST_G(j) = OST_CS(j) * OST_G(j);
      j++;
      if (fabs(OST_G(j)) <= rtol * bnorm || hn == 0) {
        done = 1;
        break;
      }
    }
    // x += V y with H y = g (upper triangular, j x j)
    for (int k = j - 1; k >= 0; k--) {
      ostNum t = OST_G(k);
      for (int l = k + 1; l < j; l++) {
        t -= H[k * hc + l] * OST_Y(l);
      }
      OST_Y(k) = H[k * hc + k] != 0 ? t / H[k * hc + k] : 0;
    }
    for (int i = 0; i < n; i++) {
      ostNum t = 0;
      for (int k = 0; k < j; k++) {
        t += V[(size_t)k * ld + i] * OST_Y(k);
      }
      x[i] += t;
    }
    if (done || it >= maxit) {
      break;
    }
    // restart from the preconditioned residual P (b - A x)
    osti_newtonApplySet(w, set, r, x);
    for (int i = 0; i < n; i++) {
      r[i] = OST_PRECOND(i) * (b[i] - r[i]);
    }
    beta = sqrt(ostu_dot(r, r, n));
    if (!(beta > rtol * bnorm)) {
      break;
    }
  }
#undef OST_PRECOND
#undef OST_CS
#undef OST_SN
#undef OST_G
#undef OST_Y
  return it;
}


// GMRES on every row
OST_HD int osti_gmres(ostWorld* w, ostNum* x, const ostNum* b, int maxit, ostNum rtol) {
  ostRowSet set = osti_wholeSet(w);
  return osti_gmresSet(w, &set, x, b, maxit, rtol);
}


// the set of island I (w->isl_* lists of the evaluated iterate, ost_island.h)
OST_HD ostRowSet osti_islandSet(const ostWorld* w, int I) {
  ostRowSet set = {w->isl_row + w->isl_row_adr[I], w->isl_row_adr[I + 1] - w->isl_row_adr[I],
                   w->isl_tree + w->isl_tree_adr[I], w->isl_tree_adr[I + 1] - w->isl_tree_adr[I]};
  return set;
}


#ifndef OST_NUM_TYPE  // the forward solver runs in doubles (the LU takes double)
// A = J Mt^-1 J' + c / h on a set (n x n, symmetric) from the rows' half-solves, laid out by
// dof in w->Yt (osti_directSet: dof c's entries of every row, zero off a row's pattern):
// A_lm = sum_c y_l[c] y_m[c] over the columns two patterns share, in ascending c. Row l's sums
// run over its own pattern with the products of all m >= l at once: a contiguous loop the
// compiler vectorizes without reordering any one sum. Each A_lm gets the products of the shared
// columns in ascending c, plus exact zeros where only one pattern has a column, which leave a
// sum unchanged (it starts at +0 and adding +-0 to +0 or to a non-zero gives the same), so A is
// bitwise the sum over the shared columns alone.
OST_HD void osti_directAssemble(ostWorld* w, const ostRowSet* set, ostNum* A) {
  int n = set->n, ncol = w->ncol;
  const ostNum* Yt = w->Yt;
  for (int l = 0; l < n; l++) {
    int i = OST_SET_ROW(set, l);
    const int* il = w->Jind + (size_t)i * ncol;
    ostNum* Al = A + (size_t)l * n;
    for (int m = l; m < n; m++) Al[m] = 0;
    for (int a = 0; a < w->Jnnz[i]; a++) {
      const ostNum* col = Yt + (size_t)il[a] * n;
      ostNum y = col[l];
      for (int m = l; m < n; m++) Al[m] += col[m] * y;
    }
    for (int m = l + 1; m < n; m++) A[(size_t)m * n + l] = Al[m];
    Al[l] += w->c[i] / w->h;
  }
}



// A x = b on a set of at most OST_DIRECT_MAX rows (x, b local), directly: A = J Mt^-1 J' +
// (c / h) plus the sliding couplings of osti_newtonApplySet, assembled from the rows'
// half-solves y_i = D^-1/2 L^-T J_i' (within their parent-closed patterns, as osti_rowDiag) as
// A_lm = sum_c y_l[c] y_m[c] over the columns two patterns share. Without sliding couplings A
// is symmetric positive definite: Cholesky. Otherwise each row
// scaled by its Jacobi preconditioner (the fixed rows' c ~ 1e12 k_f would dwarf the others), then
// an LU factor with partial pivoting. Needs row patterns and the tree factor. Returns 1 (one
// "iteration"), or 0 if the factor failed (the caller falls back to the iterative solve).
OST_HD int osti_directSet(ostWorld* w, const ostRowSet* set, ostNum* x, const ostNum* b) {
  int n = set->n, nv = w->nv, ncol = w->ncol;
  const int* parent = w->dof_parent;
  ostNum* y = w->tmp + nv;  // dense scratch on a pattern
  // the half-solves go to Yt by dof (osti_directAssemble): the set's dofs' columns (every dof
  // for the whole set) zeroed first
  ostNum* Yt = w->Yt;
  if (set->tree) {
    for (int t = 0; t < set->ntree; t++) {
      for (int c = set->tree[t]; c < w->tree_end[set->tree[t]]; c++) {
        for (int m = 0; m < n; m++) Yt[(size_t)c * n + m] = 0;
      }
    }
  } else {
    for (size_t k = 0; k < (size_t)nv * n; k++) Yt[k] = 0;
  }
  for (int l = 0; l < n; l++) {
    int i = OST_SET_ROW(set, l), cnt = w->Jnnz[i];
    const ostNum* v = w->J + (size_t)i * ncol;
    const int* ind = w->Jind + (size_t)i * ncol;
#if OST_ROW_CACHE
    if (w->yrow) {
      // the evaluated iterate's half-solve, as osti_rowDiag computed it from the same J and M
      const ostNum* yr = w->yrow + (size_t)i * ncol;
      for (int k = cnt - 1; k >= 0; k--) {
        Yt[(size_t)ind[k] * n + l] = yr[k] / osti_sqrtD(w, ind[k]);
      }
      continue;
    }
#endif
    for (int k = 0; k < cnt; k++) {
      y[ind[k]] = v[k];
    }
    for (int k = cnt - 1; k >= 0; k--) {
      int c = ind[k];
      ostNum yc = y[c];
      for (int j = parent[c]; j >= 0; j = parent[j]) {
        y[j] -= w->M[(size_t)c * nv + j] * yc;
      }
      Yt[(size_t)c * n + l] = yc / sqrt(w->M[(size_t)c * nv + c]);  // D^-1/2 y
    }
  }
  ostNum* A = w->Ad;
  osti_directAssemble(w, set, A);
  if (!osti_hasSlidingCouplingSet(w, set)) {
    // symmetric positive definite: Cholesky, half the work of the LU below (and, unlike it, not
    // changed by a diagonal scaling); a factor that fails (A semidefinite) goes to the LU
    if (!ostu_cholFactor(A, n)) {
      ostu_cholSolve(x, A, b, n);
      return 1;
    }
    osti_directAssemble(w, set, A);
  }
  for (int l = 0; l + 1 < n; l++) {
    int i = OST_SET_ROW(set, l);
    if (osti_slidingCoupled(w, i)) {
      A[(size_t)(l + 1) * n + l] -= w->c[i + 1] / w->h * w->rows[i].mu;
    }
  }
  for (int l = 0; l < n; l++) {
    int i = OST_SET_ROW(set, l);
    ostNum p = 1 / (w->diag[i] + w->c[i] / w->h);
    for (int m = 0; m < n; m++) {
      A[(size_t)l * n + m] *= p;
    }
    x[l] = p * b[l];
  }
  if (ostu_luFactor(A, w->Apiv, n)) {
    return 0;
  }
  ostu_luSolve(x, A, w->Apiv, x, n);
  return 1;
}
#endif


// 1 if the dense factor of a set costs at most `scale` times OST_DIRECT_KRYLOV Krylov iterations
// on it: n^3 / 3 flops (a Cholesky; the LU of a sliding coupling twice that) against about 4
// times the sum of the rows' pattern sizes per iteration (a product with J, one with J' and a
// tree solve)
OST_HD int osti_directAffordable(const ostWorld* w, const ostRowSet* set, double scale) {
  double krylov = 0, n = set->n;
  for (int l = 0; l < set->n; l++) krylov += 4.0 * w->Jnnz[OST_SET_ROW(set, l)];
  return n * n * n / 3 <= scale * OST_DIRECT_KRYLOV * krylov;
}


// |A x - b|^2 and |b|^2 of a set's Newton system (osti_newtonApplySet) in the Jacobi
// preconditioner's norm, that of PCR, into rr and bb; r: scratch of set->n
OST_HD void osti_residualSet(ostWorld* w, const ostRowSet* set, const ostNum* x, const ostNum* b,
                             ostNum* r, ostNum* rr, ostNum* bb) {
  osti_newtonApplySet(w, set, r, x);
  ostNum sr = 0, sb = 0;
  for (int l = 0; l < set->n; l++) {
    int i = OST_SET_ROW(set, l);
    ostNum p = 1 / (w->diag[i] + w->c[i] / w->h);
    sr += (r[l] - b[l]) * (r[l] - b[l]) * p;
    sb += b[l] * b[l] * p;
  }
  *rr = sr;
  *bb = sb;
}


// 1 if x solves the set's Newton system to OST_DIRECT_EXACT (a direct answer may be used);
// r: scratch of set->n
OST_HD int osti_solvesExactly(ostWorld* w, const ostRowSet* set, const ostNum* x,
                              const ostNum* b, ostNum* r) {
  ostNum rr, bb;
  osti_residualSet(w, set, x, b, r, &rr, &bb);
  return rr <= OST_DIRECT_EXACT * OST_DIRECT_EXACT * bb;
}


#ifndef OST_NUM_TYPE
// osti_directSet on the world's own dense arrays for a set of at most OST_DIRECT_MAX rows, on its
// large-island arrays (ostu_denseLargeInit) for a larger one
OST_HD int osti_directLargeSet(ostWorld* w, const ostRowSet* set, ostNum* x, const ostNum* b) {
  if (set->n <= OST_DIRECT_MAX) {
    return osti_directSet(w, set, x, b);
  }
  if (osti_opKeyIs(&w->dense_bad, w, set)) {
    return 0;  // this operator's dense answer missed already
  }
  ostNum* Ad = w->Ad;
  ostNum* Yt = w->Yt;
  int* piv = w->Apiv;
  w->Ad = w->Ad_large, w->Yt = w->Yt_large, w->Apiv = w->Apiv_large;
  int it = osti_directSet(w, set, x, b);
  w->Ad = Ad, w->Yt = Yt, w->Apiv = piv;
  if (it) {
    // its answer must solve the system to OST_DIRECT_EXACT (osti_envelopeSet's test): nearly
    // singular islands (the loop's: 274 of 66,352 dense solves in 1.5 s when all went dense) got
    // relative residuals of 1e-6 to 1, and Newton on such directions stalled
    if (!osti_solvesExactly(w, set, x, b, w->pcr + (size_t)w->nrow_max)) {
      osti_opKeySet(&w->dense_bad, w, set);
      return 0;
    }
  }
  return it;
}
#endif


#define OSTRICH_CORE_OST_SOLVER_H_INSIDE
#include "ost_envelope.h"
#undef OSTRICH_CORE_OST_SOLVER_H_INSIDE


// A x = b on a set: directly when it is small enough (osti_directSet), or on the host when its
// envelope factor is cheap enough (osti_envelopeSet), else by GMRES where a sliding coupling
// makes A non-symmetric and by PCR otherwise; a Krylov solve that stopped at its budget far from
// the solution is done again directly where the world's dense arrays hold the set and the factor
// is affordable (a host world, OST_DIRECT_HOST_MAX), or by the envelope where it failed outright;
// returns the iterations used (a direct solve counts one)
#if OST_ROW_CACHE
OST_HD int osti_decoupledSolve(ostWorld* w, const ostRowSet* set, ostNum* x, const ostNum* b,
                               const ostSolverOptions* opt);
#endif

OST_HD int osti_schurSolveSet(ostWorld* w, const ostRowSet* set, ostNum* x, const ostNum* b,
                              const ostSolverOptions* opt) {
  int small = set->n <= OST_DIRECT_MAX;
  int held = 0;   // the world's dense arrays hold the set and its factor costs at most
                  // OST_STALL_COST times the affordable one: a direct solve may be made once
                  // Krylov answers stalled Newton (set below in host and GPU double builds)
#ifndef OST_NUM_TYPE
  int dense = 0;  // and the factor is affordable: one may be made whenever Krylov falls short
#endif
#if OST_ROW_CACHE
  if (!small && w->env && w->env->decouple && !w->env->reducing) {
    int it = osti_decoupledSolve(w, set, x, b, opt);
    if (it >= 0) {
      return it;
    }
  }
  if (!small && osti_envelopeSet(w, set, x, b, 0)) {  // a kept factor, or the geometric term's
    return 1;
  }
#endif
#ifndef OST_NUM_TYPE
  // directly: up to OST_DIRECT_MAX rows always; up to the world's dense rows, where the factor
  // is affordable, once a Krylov solve of a larger island stopped at its budget in this Newton
  // loop (direct_large, below)
  held = w->dof_parent && (small ? w->Ad != NULL : w->Ad_large && set->n <= w->ndense_large)
         && (small || osti_directAffordable(w, set, OST_STALL_COST));
  dense = held && (small || osti_directAffordable(w, set, 1));
  if ((dense && (small || w->direct_large)) || (held && (w->krylov_failed & 4))) {
    int it = osti_directLargeSet(w, set, x, b);
    if (it) {
      return it;
    }
  }
#endif
  int it = osti_hasSlidingCouplingSet(w, set)
               ? osti_gmresSet(w, set, x, b, opt->pcr_iter, opt->pcr_tol)
               : osti_pcrSet(w, set, x, b, opt->pcr_iter, opt->pcr_tol);
  if (!small && it >= opt->pcr_iter && (held || w->env)) {
    // the Krylov solve ran out of budget: its relative residual |A x - b| / |b| in the Jacobi
    // preconditioner's norm (that of PCR) decides whether it failed
    ostNum rr, bb;
    osti_residualSet(w, set, x, b, w->pcr + (size_t)w->nrow_max, &rr, &bb);
#ifndef OST_NUM_TYPE
    int failed = held && rr > OST_KRYLOV_FAILED * OST_KRYLOV_FAILED * bb;
    w->krylov_failed |= failed;
    if ((dense && rr > OST_DIRECT_FALLBACK * OST_DIRECT_FALLBACK * bb)
        || (failed && (w->krylov_failed & 2))) {
      // inexact enough to leave Newton converging linearly: this island and the loop's later
      // large ones go direct (affordable ones; once Newton stalled on answers that made no
      // progress, any within OST_STALL_COST)
      w->direct_large |= dense;
      w->krylov_failed |= failed ? 4 : 0;
      ostNum* keep = w->pcr + (size_t)5 * w->nrow_max;  // the Krylov answer, if the factor fails
      for (int l = 0; l < set->n; l++) keep[l] = x[l];
      int itd = osti_directLargeSet(w, set, x, b);
      if (itd) {
        return it + itd;
      }
      for (int l = 0; l < set->n; l++) x[l] = keep[l];
    }
#endif
#if OST_ROW_CACHE
    if (rr > OST_ENV_FALLBACK * OST_ENV_FALLBACK * bb && osti_envelopeSet(w, set, x, b, 1)) {
      return it + 1;
    }
#endif
  }
  return it;
}


// after a Newton iterate with merit `merit` (the iterate before it: merit_prev): where a Krylov
// solve of this iterate made no progress (krylov_failed bit 1) and the merit fell by less than
// OST_KRYLOV_STALL, such solves are redone directly for the rest of the loop (bit 2; bit 4, set
// by osti_schurSolveSet, stays)
OST_HD void osti_krylovStall(ostWorld* w, ostNum merit, ostNum merit_prev) {
  if (w->krylov_failed & 1) {
    w->krylov_failed = (w->krylov_failed & 6) | (merit > OST_KRYLOV_STALL * merit_prev ? 2 : 0);
  }
}


#if OST_ROW_CACHE
// A row whose compliance dwarfs its Schur diagonal, c / h >= OST_DECOUPLED J Mt^-1 J', has its
// force fixed by its own residual: a contact whose gap stays open (its FB derivative on the
// gap, floored at 1e-12, gives c / h ~ 1e12 J Mt^-1 J'), and the friction rows of such a
// contact, held at its (vanishing) cone. Its coupling to every other row is at most
// 1 / OST_DECOUPLED of its diagonal, so within that relative error it is solved alone,
//   x_f = (b_f + (c_f / h) mu x_n) / (J_f Mt^-1 J_f' + c_f / h)
// (mu x_n: a sliding row's coupling to its contact's normal, itself decoupled), and the other
// rows solve the reduced system A_RR x_R = b_R - (A x_F)_R (option decouple_open). A hammock whose neighbouring
// spheres all sit inside the look-ahead got 433-595 rows, 60 % of them open contacts, that
// left its island to PCR and GMRES (relative residuals 0.03-360) and its first step at 25 ms
// unconverged; without them the island is the net's 178 rows, solved exactly.
#define OST_DECOUPLED 1e10

// 1 if row i is a decoupled contact row (above): a contact normal, or a friction row of a
// decoupled normal. Fixed rows of contacts that touch (sliding friction along its slip) stay:
// taken out, they left MuJoCo's cloth lying on its sphere with 80 of 425 steps unconverged
// instead of 24 (0.85 s at its h).
OST_HD int osti_rowDecoupled(const ostWorld* w, int i) {
  const ostRow* r = w->rows + i;
  if (r->type == OST_ROW_FRICTION) {
    if (r->normal < 0 || !osti_rowDecoupled(w, r->normal)) {
      return 0;
    }
  } else if (r->type != OST_ROW_CONTACT) {
    return 0;
  }
  return w->c[i] / w->h >= OST_DECOUPLED * w->diag[i];
}


// A x = b on a large set with its decoupled rows solved alone and the rest reduced (above);
// returns the iterations, or -1 if no row is decoupled or every row is (the caller solves the
// set as it is). Host only: the reduced set's arrays are the envelope work's.
OST_HD int osti_decoupledSolve(ostWorld* w, const ostRowSet* set, ostNum* x, const ostNum* b,
                               const ostSolverOptions* opt) {
  ostEnvWork* e = w->env;
  int n = set->n, nr = 0;
  if (n > e->nrow_max) {
    return -1;
  }
  for (int l = 0; l < n; l++) {
    int i = OST_SET_ROW(set, l);
    e->red_x[l] = 0;
    if (!osti_rowDecoupled(w, i)) {
      e->red_row[nr++] = i;
      continue;
    }
    ostNum d = w->diag[i] + w->c[i] / w->h, t = b[l];
    if (l > 0 && osti_slidingCoupled(w, i - 1)) {
      t += w->c[i] / w->h * w->rows[i - 1].mu * e->red_x[l - 1];  // its normal, solved above
    }
    e->red_x[l] = t / d;
  }
  if (nr == n || nr <= OST_DIRECT_MAX) {
    return -1;  // nothing to take out, or a set the direct solve would take: as it is (above)
  }
  // the reduced right-hand side b_R - (A x_F)_R, then A_RR x_R on the set of the other rows
  osti_newtonApplySet(w, set, e->red_ax, e->red_x);
  for (int l = 0, a = 0; l < n; l++) {
    if (a < nr && OST_SET_ROW(set, l) == e->red_row[a]) {
      e->red_b[a++] = b[l] - e->red_ax[l];
    }
  }
  ostRowSet red = {e->red_row, nr, set->tree, set->ntree};
  e->reducing = 1;
  int it = osti_schurSolveSet(w, &red, e->red_y, e->red_b, opt);
  e->reducing = 0;
  e->reduced++;
  for (int l = 0, a = 0; l < n; l++) {
    if (a < nr && OST_SET_ROW(set, l) == e->red_row[a]) {
      x[l] = e->red_y[a++];
    } else {
      x[l] = e->red_x[l];
    }
  }
  return it;
}
#endif


// the linear part of a Newton direction: the Schur systems of the evaluated iterate with the
// dynamics residual r (Mt^-1 r_dyn, nv) and row residuals rho (nrow; NULL: zero) on the right:
// each island's system by PCR (by GMRES when sliding friction makes it non-symmetric), islands
// marked done (isl_done) get none; then du by back-substitution, zero on done islands. Linear
// in (r, rho); reads the iterate's rows, J, c and W, writes only dlam, du and scratch.
// Returns the Krylov iterations.
OST_HD int osti_directionSolve(ostWorld* w, const ostSolverOptions* opt, const ostNum* r,
                              const ostNum* rho, ostNum* dlam, ostNum* du) {
  int nv = w->nv, nrow = w->nrow, it = 0;
  ostNum h = w->h;
  ostNum* b = w->pcr;

  // right-hand side (J Mt^-1 r_dyn - rho) / h                                        (eq. 11)
  for (int i = 0; i < nrow; i++) {
    b[i] = (osti_rowDot(w, i, r) - (rho ? rho[i] : 0)) / h;
  }
  if (w->nisland == 0) {
    ostRowSet set = osti_wholeSet(w);
    it = osti_schurSolveSet(w, &set, dlam, b, opt);
  } else {
    ostNum* bl = w->xloc;                  // an island's right-hand side and solution, local
    ostNum* xl = w->xloc + w->nrow_max;
    for (int I = 0; I < w->nisland; I++) {
      ostRowSet set = osti_islandSet(w, I);
      if (w->isl_done[I]) {
        for (int l = 0; l < set.n; l++) dlam[set.row[l]] = 0;
        continue;
      }
      for (int l = 0; l < set.n; l++) bl[l] = b[set.row[l]];
      it += osti_schurSolveSet(w, &set, xl, bl, opt);
      for (int l = 0; l < set.n; l++) dlam[set.row[l]] = xl[l];
    }
  }

  // du = h Mt^-1 J' dlambda - Mt^-1 r_dyn                                            (eq. 12)
  ostNum* t = w->tmp;
  osti_mulJT(w, t, dlam);
  osti_massSolve(w, t);
  for (int j = 0; j < nv; j++) {
    du[j] = w->nisland && w->isl_done[w->dof_island[j]] ? 0 : h * t[j] - r[j];
  }
  return it;
}


// the Newton direction (dqvel, dlambda) of the evaluated iterate, solved again with the model of
// saturated sticking where osti_saturateSticking changed a contact's rows (unless sat_off)
OST_HD int osti_directionSaturated(ostWorld* w, const ostSolverOptions* opt) {
  int it = osti_directionSolve(w, opt, w->Minv_rdyn, w->rho, w->dlambda, w->dqvel);
  // coupled sliding contacts whose predicted normal force is negative: the trial projects it to
  // zero and the friction with it, so the coupled prediction is void there (cpl_row[2 i];
  // osti_newton); judged on this model's own direction, before the saturated-sticking correction
  w->cpl_used = 0;
  if (w->cpl_row) {
    for (int i = w->cpl_n; i < w->nrow; i++) {
      w->cpl_row[2 * i + 1] = 0;  // rows new to this Newton loop: not lagged
    }
    w->cpl_n = w->nrow > w->cpl_n ? w->nrow : w->cpl_n;
    for (int i = 0; i < w->cpl_n; i++) {
      w->cpl_row[2 * i] = i < w->nrow && osti_slidingCoupled(w, i)
                          && w->lambda[i] + w->dlambda[i] < 0;
      w->cpl_used |= w->cpl_row[2 * i];
    }
  }
  w->sat_used = !w->sat_off && osti_saturateSticking(w, opt);
  if (w->sat_used) {
    it += osti_directionSolve(w, opt, w->Minv_rdyn, w->rho, w->dlambda, w->dqvel);
  }
  return it;
}


// after the direction (dqvel, dlambda): dlambda and J are rotated back from slip frames to
// contact frames. The iterate becomes the base of the step: its u, rows and multipliers are
// kept for osti_trial and for matching multipliers onto the rows of the next iterate.
OST_HD void osti_directionFinish(ostWorld* w) {
  int nv = w->nv, nrow = w->nrow;
  ostNum* dlam = w->dlambda;
  for (int j = 0; j < nv; j++) {
    w->qvel_base[j] = w->qvel[j];
  }

  // sliding contacts: direction and Jacobian rows back from the slip frame to the contact frame
  // (H is its own inverse)
  for (int i = 0; i + 2 < nrow; i++) {
    if (w->rows[i].type == OST_ROW_CONTACT && w->W[i] != 0) {
      int nf = osti_frictionCount(w->rows, nrow, i);
      ostNum H[OST_MAXFRIC * OST_MAXFRIC];
      osti_householder(H, w->W + i + 1, nf);
      osti_reflect(dlam + i + 1, H, nf);
      osti_reflectFriction(w, i + 1, nf, H);
    }
  }
  for (int i = 0; i < nrow; i++) {
    w->rows_prev[i] = w->rows[i];
    w->lambda_prev[i] = w->lambda[i];
  }
  for (int i = 0; i < nrow; i++) {
    osti_rowCopy(w, w->J_prev, w->Jnnz_prev, w->Jind_prev, i, w->J, w->Jnnz, w->Jind, i);
  }
  w->nrow_prev = nrow;
  w->prev_jac = 1;
}


// the Newton direction at the evaluated iterate: each island's Schur system by PCR (by GMRES
// when sliding friction makes it non-symmetric), islands marked done (isl_done) get none; then
// du by back-substitution, zero on done islands (osti_directionSolve, then osti_directionFinish)
OST_HD int osti_newtonDirection(ostWorld* w, const ostSolverOptions* opt) {
  int it = osti_directionSaturated(w, opt);
  osti_directionFinish(w);
  return it;
}


// the trial point base + alpha * direction: u, and the multipliers on the base rows projected
// onto their admissible sets (cone clamp, lambda_n >= 0, force range). lambda receives them too,
// which is final when the rows are not refilled; else osti_matchPrevious carries them over.
OST_HD void osti_trial(ostWorld* w, ostNum alpha) {
  for (int j = 0; j < w->nv; j++) {
    w->qvel[j] = w->qvel_base[j] + alpha * w->dqvel[j];
  }
  for (int i = 0; i < w->nrow_prev; i++) {
    w->lambda_trial[i] = w->lambda_prev[i] + alpha * w->dlambda[i];
  }
  osti_projectRows(w->lambda_trial, w->rows_prev, w->nrow_prev);
  for (int i = 0; i < w->nrow_prev; i++) {
    w->lambda[i] = w->lambda_trial[i];
  }
}


// the trial point of each base island I at its own step isl_num[6 I + 2] (osti_trial with one
// alpha per island of the line search's base iterate)
OST_HD void osti_trialIslands(ostWorld* w) {
  for (int j = 0; j < w->nv; j++) {
    w->qvel[j] = w->qvel_base[j] + w->isl_num[6 * w->dof_island_base[j] + 2] * w->dqvel[j];
  }
  for (int i = 0; i < w->nrow_prev; i++) {
    ostNum alpha = w->isl_num[6 * w->row_island_prev[i] + 2];
    w->lambda_trial[i] = w->lambda_prev[i] + alpha * w->dlambda[i];
  }
  osti_projectRows(w->lambda_trial, w->rows_prev, w->nrow_prev);
  for (int i = 0; i < w->nrow_prev; i++) {
    w->lambda[i] = w->lambda_trial[i];
  }
}


// a full Newton update at fixed geometry: direction, then the whole step
OST_HD int osti_newtonUpdate(ostWorld* w, const ostSolverOptions* opt) {
  int it = osti_newtonDirection(w, opt);
  osti_trial(w, 1);
  return it;
}


// keep the returned iterate's rows and multipliers to warm-start the next step
OST_HD void osti_saveWarm(ostWorld* w) {
  for (int i = 0; i < w->nrow; i++) {
    w->rows_warm[i] = w->rows[i];
    w->lambda_warm[i] = w->lambda[i];
  }
  w->nrow_warm = w->nrow;
}


// start a step's Newton loop from u (nv): the first iterate's multipliers are matched from the
// last step's result if warm, else they start at zero; call osti_trial(w, 0) next
OST_HD void osti_startStep(ostWorld* w, const ostNum* u, int warm) {
  for (int j = 0; j < w->nv; j++) {
    w->qvel_base[j] = u[j];
    w->dqvel[j] = 0;
  }
  w->nrow_prev = warm ? w->nrow_warm : 0;
  w->prev_jac = 0;  // the last step's rows carry multipliers, not this step's Jacobians
  w->direct_large = 0;
  w->krylov_failed = 0;
  for (int i = 0; i < w->nrow_prev; i++) {
    w->rows_prev[i] = w->rows_warm[i];
    w->lambda_prev[i] = w->lambda_warm[i];
    w->dlambda[i] = 0;
  }
}


// carry the trial multipliers from the base iterate's rows onto the freshly filled rows. A
// contact or limit of the base iterate that the geometry no longer reports (it moved beyond the
// look-ahead distance) is kept within the step as a linearized row, its gap extrapolated by
// h J (u - u_base): the next Newton model still sees the floor a lifted wheel left, instead of
// falling back through it (contact sets would otherwise alternate between iterates). Its gap is
// at least the look-ahead distance (it was not reported), so it never carries force in a
// solution; it only bounds the next Newton step.
OST_HD void osti_matchPrevious(ostWorld* w) {
  osti_matchRowsSorted(w->lambda, w->rows, w->nrow, w->lambda_trial, w->rows_prev, w->nrow_prev,
                       w->used, w->match_order);
  for (int j = 0; j < w->nrow_prev && w->prev_jac; j++) {
    const ostRow* p = w->rows_prev + j;
    if (w->used[j] || (p->type != OST_ROW_CONTACT && p->type != OST_ROW_LIMIT)) {
      continue;
    }
    int nfr = osti_frictionCount(w->rows_prev, w->nrow_prev, j);
    int n = w->nrow;
    if (n + 1 + nfr > w->nrow_max) {
      break;  // no room: the row is dropped (capacity is for reported contacts)
    }
    for (int k = 0; k <= nfr; k++) {
      w->rows[n + k] = w->rows_prev[j + k];
      w->lambda[n + k] = w->lambda_trial[j + k];
      osti_rowCopy(w, w->J, w->Jnnz, w->Jind, n + k, w->J_prev, w->Jnnz_prev, w->Jind_prev,
                   j + k);
      if (k > 0) {
        w->rows[n + k].normal = n;
      }
    }
    ostNum move = 0;  // J_prev,j (u - u_base) over its pattern
    for (int k = 0; k < w->Jnnz_prev[j]; k++) {
      int c = w->Jind_prev[(size_t)j * w->ncol + k];
      move += w->J_prev[(size_t)j * w->ncol + k] * (w->qvel[c] - w->qvel_base[c]);
    }
    ostNum gap = w->rows[n].pos + w->h * move;
    w->rows[n].pos = gap > w->lookahead ? gap : w->lookahead;
    w->nrow = n + 1 + nfr;
  }
}

#ifdef __cplusplus
}
#endif

#endif  // OSTRICH_CORE_OST_SOLVER_H_
