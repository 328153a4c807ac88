// ost_geometric.h: the geometric terms of the Newton model (core/README.md section 1, "Geometric
// term"). The step's residual moves with u through the iterate's geometry q = q- (+) h u in
// two places the fixed-J model of ost_solver.h holds still:
//   T du = h Mt^-1 d(J(q)' lambda)/du du   (lambda held): how the rows' forces turn with q, the
//          geometric stiffness of loaded constraints (a tensioned string's whole transverse
//          stiffness; a contact force on a chain of bodies, whose points roll and whose joint
//          axes turn under it);
//   R du = d(J(q) u)/du du - J du          (u held in the product): how the slip that friction
//          and dry-friction rows read, J(q) u, moves with the geometry.
// Where they matter (tendon and equality networks under load, MuJoCo's rope, loop and cloth
// lying on the floor, long steps of jointed bodies in contact) the fixed-J Newton converges
// linearly or not at all. With them the direction solves
//   (I - P [T; R]) du = du0,
// du0 the fixed-J direction and P [y; s] = -du(osti_directionSolve with Mt^-1 r_dyn = y and
// rho = -s), by GMRES in the nv-dimensional u space (Saad, alg. 6.9, no restart); dlambda then
// follows from one more fixed-J solve with Mt^-1 r_dyn - T du and rho + R du on the right.
// T v and R v are central differences through the iterate's geometry provider, with each base
// row's multiplier carried onto the perturbed rows by key (rows that come or go between the two
// sides keep their base Jacobian, so they contribute nothing). The geometry is left as it was
// found.
// Host only (OST_GEO_HOST): the GPU batch (osti_stepNative under nvcc) keeps the fixed-J model,
// and a world without work arrays (w->geo == NULL, every batch world) never takes this path.
// Invariant: writes only the world's direction (dqvel, dlambda), its scratch, and geo's arrays.
#ifndef OSTRICH_CORE_OST_GEOMETRIC_H_
#define OSTRICH_CORE_OST_GEOMETRIC_H_

#include <math.h>

#include "ost_constraint.h"
#include "ost_hd.h"
#include "ost_solver.h"

#ifdef __cplusplus
extern "C" {
#endif

// GMRES iterations per geometric direction (no restart: an unfinished solve returns the
// minimal-residual iterate of the space built so far, still a descent-aiming direction)
#define OST_GEO_KRYLOV 24
// Krylov budget of the Schur solves inside a geometric direction, in multiples of pcr_iter
#define OST_GEO_PCR 4
// a geometric direction that differs from the fixed-J one by less than this fraction of it
// leaves the term off for the rest of the loop (mode 1)
#define OST_GEO_SMALL 0.1

// One world's geometric-Newton arrays; the X-macro drives size and pointer setup
#define OST_GEO_ARRAYS(X)                                                                      \
  X(ostRow, rows_s,  nrow_max, 1)     /* the iterate's rows as the solver holds them */       \
  X(ostNum, J_s,     nrow_max, ncol)  /* and their Jacobians (slip frames)           */       \
  X(int,    nnz_s,   nrow_max, 1)                                                              \
  X(int,    ind_s,   nrow_max, ncol)                                                           \
  X(ostRow, rows_f,  nrow_max, 1)     /* the iterate's rows fresh from the geometry  */       \
  X(ostNum, J_f,     nrow_max, ncol)  /* (contact frames)                            */       \
  X(int,    nnz_f,   nrow_max, 1)                                                              \
  X(int,    ind_f,   nrow_max, ncol)                                                           \
  X(ostNum, lam_f,   nrow_max, 1)     /* multipliers on rows_f                       */       \
  X(ostNum, key,     nrow_max, 1)     /* matching scratch: base row index + 1        */       \
  X(int,    at,      nrow_max, 1)     /* base row -> row of the perturbed geometry   */       \
  X(ostNum, dl,      nrow_max, 1)     /* dlambda of the inner solves (discarded)     */       \
  X(ostNum, ju_p,    nrow_max, 1)     /* J u on rows_f, + side (u: the base's)       */       \
  X(ostNum, ju_m,    nrow_max, 1)     /* and at the - side                           */       \
  X(ostNum, dju_f,   nrow_max, 1)     /* R v on rows_f                               */       \
  X(ostNum, dju_s,   nrow_max, 1)     /* +- R v on the solver's rows (rows_s)        */       \
  X(ostNum, V,       nv, OST_GEO_KRYLOV + 1)  /* Krylov basis                        */       \
  X(ostNum, Hg,      OST_GEO_KRYLOV + 1, OST_GEO_KRYLOV + 3) /* Hessenberg, rotations */      \
  X(ostNum, vec,     nv, 4)           /* u of a side, J' lambda of a side, T v, du   */      \
  X(ostNum, yrow,    nrow_max, ncol)  /* ostWorld.yrow's storage (host row cache)    */       \
  X(ostNum, yrow_sqrtd, nv, 1)        /* ostWorld.yrow_sqrtd's (sqrt D per dof)       */

typedef struct ostGeoWork_ {      // geometric Newton state of one world (host only)
  int    mode;                    // 0 off; T over equality rows: 1 from a slow iterate on, 2 at
                                  // every iterate; 3 T over every row and R, every iterate
  int    retry_on;                // 1: the step driver may retry a failed loop with all rows
  int    engaged;                 // 1 once this Newton loop's merit fell by less than half
  int    refused;                 // 1 once mode 1 found the term small in this loop
  int    retry;                   // 1 while the step driver retries a failed loop (all rows;
                                  // osti_stepDriven)
  int    all_rows;                // 1: T over every loaded row, and R; 0: T over equality rows
  ostNum merit_last;              // merit of the loop's last iterate (m/s)
  ostNum dq;                      // difference step of q (m or rad) for T v
  int    directions;              // geometric directions taken (counter, never reset here)
  int    evals;                   // geometry evaluations they took (counter)
  int    nrow_max;                // capacity the arrays were sized for
  int    ncol;                    // columns of a stored row
#define X(type, name, r, c) type* name;
  OST_GEO_ARRAYS(X)
#undef X
} ostGeoWork;


// the geometric term runs on the host in plain double only: not in CUDA kernels (batches keep
// the fixed-J model) and not in the dual-number builds of the adjoint (OST_NUM_TYPE), which
// evaluate residuals, not Newton directions
#if !defined(__CUDACC__) && !defined(OST_NUM_TYPE)
#define OST_GEO_HOST 1
#else
#define OST_GEO_HOST 0
#endif

#if OST_GEO_HOST
// bytes of a geometric-Newton work area for a world of these sizes
OST_HD size_t ostu_geoSize(int nv, int ncol, int nrow_max) {
  size_t sz = 0;
#define X(type, name, r, c) sz += (((size_t)(r) * (c) * sizeof(type) + 63) / 64) * 64;
  OST_GEO_ARRAYS(X)
#undef X
  return sz;
}


// point g's arrays into buf (64-byte aligned, ostu_geoSize bytes); mode as ostGeoWork.mode
OST_HD void ostu_geoInit(ostGeoWork* g, void* buf, int nv, int ncol, int nrow_max, int mode) {
  char* p = (char*)buf;
  g->mode = mode;
  g->retry_on = 0;
  g->engaged = 0;
  g->refused = 0;
  g->retry = 0;
  g->all_rows = 0;
  g->merit_last = 0;
  g->dq = 1e-4;
  g->directions = 0;
  g->evals = 0;
  g->nrow_max = nrow_max;
  g->ncol = ncol;
#define X(type, name, r, c)                      \
  g->name = (type*)p;                            \
  p += (((size_t)(r) * (c) * sizeof(type) + 63) / 64) * 64;
  OST_GEO_ARRAYS(X)
#undef X
}


// Newton iterate k of a loop has merit `merit`. Mode 1 engages T over the equality rows from the
// third iterate on whose merit fell by less than half, since a fixed-J Newton converging
// linearly is what the missing term causes. Linear convergence has other causes (contacts that
// slide and stick, active sets that change): a geometric direction that differs from the
// fixed-J one by less than OST_GEO_SMALL of it shows that the term is not what slows this loop,
// and mode 1 leaves it off until the next loop (osti_geoDirection checks the first-order share
// |P T du0| / |du0| after GMRES's first product, before paying for the rest). Measured relative
// differences between the two directions: 0.11-0.99 on MuJoCo's grid2pin, 0.07-0.84 on its
// hammock and 0.19-0.75 on a tendon string, where the term decides convergence; medians 0.04
// and 0.07 on its loop and cloth samples, where engaging it on every slow iterate cost 2-11
// times the fixed-J step and saved no iterate. Mode 2 engages T over the equality rows at once
// and keeps it. Mode 3, and a loop that the step driver retries after a failure (g->retry,
// osti_stepDriven's geometric retry), take T over every loaded row and R from the first iterate
// on, and keep them (core/README.md section 1, "Geometric term").
OST_HD void osti_geoTrack(ostGeoWork* g, int k, ostNum merit) {
  if (k == 0) {
    g->all_rows = g->mode == 3 || g->retry;
    g->engaged = g->mode >= 2 || g->retry;
    g->refused = 0;
  } else if (g->mode == 1 && !g->all_rows) {
    if (!g->refused && k >= 2 && merit > 0.5 * g->merit_last) {
      g->engaged = 1;
    }
  }
  g->merit_last = merit;
}


// copy the world's rows and Jacobians into (rows, J, nnz, ind), or back with `load`
OST_HD void osti_geoRows(ostWorld* w, ostRow* rows, ostNum* J, int* nnz, int* ind, int* n,
                         int load) {
  size_t len = (size_t)(load ? *n : w->nrow) * w->ncol;
  if (load) {
    w->nrow = *n;
  } else {
    *n = w->nrow;
  }
  for (int i = 0; i < w->nrow; i++) {
    if (load) w->rows[i] = rows[i], w->Jnnz[i] = nnz[i];
    else rows[i] = w->rows[i], nnz[i] = w->Jnnz[i];
  }
  for (size_t i = 0; i < len; i++) {
    if (load) w->J[i] = J[i], w->Jind[i] = ind[i];
    else J[i] = w->J[i], ind[i] = w->Jind[i];
  }
}


// g = sum over the nf fresh base rows of J_j' lambda_j, J_j taken from the world's current
// geometry where row j is there (matched by key) and from the base where it is not; ju_j =
// J_j u with u the base iterate's velocity (R's side, osti_geoApplyT)
OST_HD void osti_geoForce(ostWorld* w, ostGeoWork* gw, int nf, ostNum* g, ostNum* ju) {
  for (int j = 0; j < nf; j++) {
    gw->key[j] = j + 1;
    gw->at[j] = -1;
  }
  osti_matchRowsSorted(gw->dl, w->rows, w->nrow, gw->key, gw->rows_f, nf, w->used,
                       w->match_order);
  for (int i = 0; i < w->nrow; i++) {
    int j = (int)gw->dl[i] - 1;
    if (j >= 0 && j < nf) gw->at[j] = i;
  }
  for (int c = 0; c < w->nv; c++) g[c] = 0;
  for (int j = 0; j < nf; j++) {
    int i = gw->at[j], r = i >= 0 ? i : j;
    const ostNum* J = i >= 0 ? w->J : gw->J_f;
    const int* nnz = i >= 0 ? w->Jnnz : gw->nnz_f;
    const int* ind = i >= 0 ? w->Jind : gw->ind_f;
    ostNum s = 0;
    for (int k = 0; k < nnz[r]; k++) {
      int c = ind[(size_t)r * w->ncol + k];
      ostNum Jk = J[(size_t)r * w->ncol + k];
      g[c] += Jk * gw->lam_f[j];
      s += Jk * w->qvel[c];
    }
    ju[j] = s;
  }
}


// out = T v = h Mt^-1 (g(u + e v) - g(u - e v)) / (2 e), e = dq / (h vn), and gw->dju_f = R v =
// (J(u + e v) u - J(u - e v) u) / (2 e) on the fresh rows, by two geometry evaluations; vn is
// |v| (1 for the Krylov basis): the step moves q by dq whatever |v|, so the difference's rounding
// stays relative to T v (a final direction du of 1e-8 m/s moved q by 1e-12 m, and on MuJoCo's
// grid2pin at 10 times its step the merit then stalled at 2e-8 m/s instead of reaching 2e-12).
// Returns the geometry's status (nonzero: out is not valid).
OST_HD int osti_geoApplyT(ostWorld* w, ostGeoWork* gw, int nf,
                          int (*geom)(void*, const ostNum*), void* ctx, const ostNum* v,
                          ostNum vn, ostNum* out) {
  int nv = w->nv, status = 0;
  ostNum e = gw->dq / w->h / vn;
  ostNum* u = gw->vec;
  ostNum* gm = gw->vec + nv;
  for (int side = 1; side >= -1 && !status; side -= 2) {
    for (int j = 0; j < nv; j++) u[j] = w->qvel[j] + side * e * v[j];
    status = geom(ctx, u);
    gw->evals++;
    osti_geoForce(w, gw, nf, side > 0 ? out : gm, side > 0 ? gw->ju_p : gw->ju_m);
  }
  for (int j = 0; j < nv; j++) out[j] = (out[j] - gm[j]) / (2 * e);
  for (int j = 0; j < nf; j++) gw->dju_f[j] = (gw->ju_p[j] - gw->ju_m[j]) / (2 * e);
  osti_massSolve(w, out);
  for (int j = 0; j < nv; j++) out[j] *= w->h;
  return status;
}


// gw->dju_s = sign R v on the solver's ns rows (zero unless gw->all_rows; rows_s, as the base's
// evaluation left them), from
// R v on the fresh rows (osti_geoApplyT): carried by key, kept where the row's residual reads
// J u with unit weight (friction rows, stick and slide, and dry-friction rows: osti_frictionRows,
// osti_dryRow) and zero elsewhere (equality, limit and contact rows read the gap at q, whose
// derivative h J the fixed-J model has whole; servo rows are left out). A sliding contact's
// friction rows are reflected into its slip frame (W, osti_slideRows), as its J and J u are.
OST_HD void osti_geoRowTerm(ostWorld* w, ostGeoWork* gw, int nf, int ns, ostNum sign) {
  ostNum* r = gw->dju_s;
  for (int i = 0; i < ns; i++) r[i] = 0;
  if (!gw->all_rows) {
    return;
  }
  osti_matchRowsSorted(r, gw->rows_s, ns, gw->dju_f, gw->rows_f, nf, w->used, w->match_order);
  for (int i = 0; i < ns; i++) {
    int t = gw->rows_s[i].type;
    r[i] = t == OST_ROW_FRICTION || t == OST_ROW_DRY ? sign * r[i] : 0;
  }
  for (int i = 0; i < ns; i++) {
    if (gw->rows_s[i].type != OST_ROW_CONTACT || w->W[i] == 0) {
      continue;
    }
    int nfr = osti_frictionCount(gw->rows_s, ns, i);
    ostNum H[OST_MAXFRIC * OST_MAXFRIC];
    osti_householder(H, w->W + i + 1, nfr);
    osti_reflect(r + i + 1, H, nfr);
  }
}


// 1 if a geometric term can be nonzero at the iterate: an equality row carries force, or, with
// all rows (ostGeoWork.all_rows), any row does (T) or a friction or dry-friction row is there (R)
OST_HD int osti_geoLoaded(const ostWorld* w) {
  int all = w->geo->all_rows;
  for (int i = 0; i < w->nrow; i++) {
    int t = w->rows[i].type;
    if (w->lambda[i] != 0 && (all || t == OST_ROW_EQUALITY)) return 1;
    if (all && (t == OST_ROW_FRICTION || t == OST_ROW_DRY)) return 1;
  }
  return 0;
}


// replace the evaluated iterate's fixed-J direction (dqvel, dlambda; slip frames, before
// osti_directionFinish) by the direction with the geometric terms; the caller checked that a
// term can be nonzero (osti_geoLoaded). The geometry is evaluated again at u and the world's
// rows and Jacobians are restored as found. Returns the inner Krylov iterations; on a geometry
// failure the fixed-J direction is kept.
OST_HD int osti_geoDirection(ostWorld* w, const ostSolverOptions* so,
                             int (*geom)(void*, const ostNum*), void* ctx) {
  ostGeoWork* gw = w->geo;
  int nv = w->nv, m = OST_GEO_KRYLOV, it = 0, ns = 0, nf = 0, k = 0;
  ostNum beta = 0;
  for (int j = 0; j < nv; j++) beta += w->dqvel[j] * w->dqvel[j];
  beta = sqrt(beta);
  if (!(beta > 0)) {
    return 0;
  }
  osti_geoRows(w, gw->rows_s, gw->J_s, gw->nnz_s, gw->ind_s, &ns, 0);
  for (int i = 0; i < ns; i++) gw->dl[i] = w->lambda[i];
  if (w->env) w->env->active = 1;
  gw->evals++;
  int status = geom(ctx, w->qvel);  // the base rows in contact frames, multipliers matched on
  osti_geoRows(w, gw->rows_f, gw->J_f, gw->nnz_f, gw->ind_f, &nf, 0);
  osti_matchRowsSorted(gw->lam_f, gw->rows_f, nf, gw->dl, gw->rows_s, ns, w->used,
                       w->match_order);
  for (int j = 0; j < nf && !gw->all_rows; j++) {  // equality rows' term only (osti_geoTrack)
    if (gw->rows_f[j].type != OST_ROW_EQUALITY) gw->lam_f[j] = 0;
  }

  // GMRES on (I - P [T; R]) du = du0 from du = 0 (Hessenberg H(i, k) at Hg[i * (m + 3) + k]; the
  // rotations' cosines and sines in its last two columns, the rotated residual in e)
  ostNum* H = gw->Hg;
  int ld = m + 3;
  ostNum e[OST_GEO_KRYLOV + 1];
  for (int i = 0; i <= m; i++) e[i] = 0;
  e[0] = beta;
  for (int j = 0; j < nv; j++) gw->V[j] = w->dqvel[j] / beta;
  ostNum* Tv = gw->vec + 2 * nv;
  // inexact Newton (Eisenstat and Walker, SIAM J. Sci. Comput. 17, 1996): the relative GMRES
  // residual need only fall with the merit (m/s), which keeps the outer convergence superlinear
  ostNum eta = gw->merit_last < 1e-2 ? gw->merit_last : 1e-2;
  eta = eta > so->pcr_tol ? eta : so->pcr_tol;
  while (k < m && !status) {
    ostNum* v = gw->V + (size_t)k * nv;
    ostNum* z = gw->V + (size_t)(k + 1) * nv;
    status = osti_geoApplyT(w, gw, nf, geom, ctx, v, 1, Tv);
    osti_geoRows(w, gw->rows_s, gw->J_s, gw->nnz_s, gw->ind_s, &ns, 1);
    if (status) break;
    osti_geoRowTerm(w, gw, nf, ns, -1);
    it += osti_directionSolve(w, so, Tv, gw->dju_s, gw->dl, z);  // z = -P [T; R] v
    if (k == 0 && gw->mode == 1 && !gw->all_rows) {
      // |P [T; R] v0| (v0 = du0 / |du0|) is the terms' first-order share of the direction: below
      // OST_GEO_SMALL the term is not what slows this loop (osti_geoTrack), and it is left off
      ostNum pt = 0;
      for (int j = 0; j < nv; j++) pt += z[j] * z[j];
      if (sqrt(pt) < OST_GEO_SMALL) {
        gw->engaged = 0;
        gw->refused = 1;
        status = -1;  // the fixed-J direction stays; the base's geometry is put back below
        break;
      }
    }
    for (int j = 0; j < nv; j++) z[j] += v[j];             // (I - P [T; R]) v
    for (int i = 0; i <= k; i++) {                          // modified Gram-Schmidt
      ostNum d = 0;
      for (int j = 0; j < nv; j++) d += gw->V[(size_t)i * nv + j] * z[j];
      H[i * ld + k] = d;
      for (int j = 0; j < nv; j++) z[j] -= d * gw->V[(size_t)i * nv + j];
    }
    ostNum nz = 0;
    for (int j = 0; j < nv; j++) nz += z[j] * z[j];
    nz = sqrt(nz);
    for (int i = 0; i < k; i++) {
      osti_givens(&H[i * ld + k], &H[(i + 1) * ld + k], H[i * ld + m + 1], H[i * ld + m + 2]);
    }
    ostNum a = H[k * ld + k], r = sqrt(a * a + nz * nz);
    H[k * ld + m + 1] = r > 0 ? a / r : 1;
    H[k * ld + m + 2] = r > 0 ? nz / r : 0;
    H[k * ld + k] = r;
    e[k + 1] = -H[k * ld + m + 2] * e[k];
    e[k] = H[k * ld + m + 1] * e[k];
    k++;
    if (!(nz > 0) || !(r > 0) || fabs(e[k]) <= eta * beta) break;
    for (int j = 0; j < nv; j++) z[j] /= nz;
  }
  if (!status && k > 0) {
    ostNum y[OST_GEO_KRYLOV];
    for (int i = k - 1; i >= 0; i--) {
      ostNum t = e[i];
      for (int l = i + 1; l < k; l++) t -= H[i * ld + l] * y[l];
      y[i] = H[i * ld + i] != 0 ? t / H[i * ld + i] : 0;
    }
    ostNum* du = gw->vec + 3 * nv;
    for (int j = 0; j < nv; j++) du[j] = 0;
    for (int i = 0; i < k; i++) {
      for (int j = 0; j < nv; j++) du[j] += y[i] * gw->V[(size_t)i * nv + j];
    }
    // the consistent pair (du, dlambda): the fixed-J solve with Mt^-1 r_dyn - T du, rho + R du
    ostNum dun = sqrt(ostu_dot(du, du, nv));
    status = osti_geoApplyT(w, gw, nf, geom, ctx, du, dun > 0 ? dun : 1, Tv);
    if (!status) {
      status = geom(ctx, w->qvel);
      gw->evals++;
    }
    osti_geoRows(w, gw->rows_s, gw->J_s, gw->nnz_s, gw->ind_s, &ns, 1);
    if (!status) {
      for (int j = 0; j < nv; j++) Tv[j] = w->Minv_rdyn[j] - Tv[j];
      osti_geoRowTerm(w, gw, nf, ns, 1);
      for (int i = 0; i < ns; i++) gw->dju_s[i] += w->rho[i];
      it += osti_directionSolve(w, so, Tv, gw->dju_s, w->dlambda, w->dqvel);
      gw->directions++;
    }
  }
  if (status) {  // keep the fixed-J direction; put the base's geometry back
    geom(ctx, w->qvel);
    gw->evals++;
    osti_geoRows(w, gw->rows_s, gw->J_s, gw->nnz_s, gw->ind_s, &ns, 1);
  }
  if (w->env) w->env->active = 0;
  return it;
}

#endif  // OST_GEO_HOST

#ifdef __cplusplus
}
#endif

#endif  // OSTRICH_CORE_OST_GEOMETRIC_H_
