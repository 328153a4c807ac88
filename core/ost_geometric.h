// ost_geometric.h: the geometric term of the Newton model (core/README.md section 1, "Geometric
// Newton"). The step's dynamics residual, in velocity units,
//   Mt^-1 r_dyn(u) = u - u- - h Mt^-1 (f + J(q)' lambda),   q = q- (+) h u,
// moves with u through J(q). The Newton model of ost_solver.h keeps J at the iterate, which
// leaves out
//   T du = h Mt^-1 d(J(q)' lambda)/du du   (lambda held),
// the geometric stiffness of loaded constraints: a tensioned string's whole transverse stiffness.
// Where it matters (tendon and equality networks under load: MuJoCo's cloth, grid and hammock
// samples) the fixed-J Newton converges linearly or not at all. With it the direction solves
//   (I - P T) du = du0,
// du0 the fixed-J direction and P y = -du(osti_directionSolve with Mt^-1 r_dyn = y, rho = 0),
// by GMRES in the nv-dimensional u space (Saad, alg. 6.9, no restart); dlambda then follows from
// one more fixed-J solve with Mt^-1 r_dyn - T du on the right. T v is a central difference of
// J' lambda through the iterate's geometry provider, with each base row's multiplier carried
// onto the perturbed rows by key (rows that come or go between the two sides keep their base
// Jacobian, so they contribute nothing). The geometry is left as it was found.
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
  X(ostNum, V,       nv, OST_GEO_KRYLOV + 1)  /* Krylov basis                        */       \
  X(ostNum, Hg,      OST_GEO_KRYLOV + 1, OST_GEO_KRYLOV + 3) /* Hessenberg, rotations */      \
  X(ostNum, vec,     nv, 4)           /* u of a side, J' lambda of a side, T v, du   */      \
  X(ostNum, yrow,    nrow_max, ncol)  /* ostWorld.yrow's storage (host row cache)    */

typedef struct ostGeoWork_ {      // geometric Newton state of one world (host only)
  int    mode;                    // 0 off; 1 engaged on a slow iterate; 2 every iterate
  int    engaged;                 // 1 once this Newton loop's merit fell by less than half
  int    refused;                 // 1 once mode 1 found the term small in this loop
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
  g->engaged = 0;
  g->refused = 0;
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


// Newton iterate k of a loop has merit `merit`: from the third iterate on, a merit that fell by
// less than half engages the geometric term (mode 1), since a fixed-J Newton converging
// linearly is what the missing term causes. Linear convergence has other causes (contacts that
// slide and stick, active sets that change): a geometric direction that differs from the
// fixed-J one by less than OST_GEO_SMALL of it shows that the term is not what slows this loop,
// and mode 1 leaves it off until the next loop (osti_geoDirection checks the first-order share
// |P T du0| / |du0| after GMRES's first product, before paying for the rest). Measured relative
// differences between the two directions: 0.11-0.99 on MuJoCo's grid2pin, 0.07-0.84 on its
// hammock and 0.19-0.75 on a tendon string, where the term decides convergence; medians 0.04
// and 0.07 on its loop and cloth samples, where engaging it on every slow iterate cost 2-11
// times the fixed-J step and saved no iterate. Mode 2 engages it at once and keeps it.
OST_HD void osti_geoTrack(ostGeoWork* g, int k, ostNum merit) {
  if (k == 0) {
    g->engaged = g->mode == 2;
    g->refused = 0;
  } else if (g->mode == 1) {
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
// geometry where row j is there (matched by key) and from the base where it is not
OST_HD void osti_geoForce(ostWorld* w, ostGeoWork* gw, int nf, ostNum* g) {
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
    for (int k = 0; k < nnz[r]; k++) {
      g[ind[(size_t)r * w->ncol + k]] += J[(size_t)r * w->ncol + k] * gw->lam_f[j];
    }
  }
}


// out = T v = h Mt^-1 (g(u + e v) - g(u - e v)) / (2 e), e = dq / h, by two geometry
// evaluations; returns the geometry's status (nonzero: out is not valid)
OST_HD int osti_geoApplyT(ostWorld* w, ostGeoWork* gw, int nf,
                          int (*geom)(void*, const ostNum*), void* ctx, const ostNum* v,
                          ostNum* out) {
  int nv = w->nv, status = 0;
  ostNum e = gw->dq / w->h;
  ostNum* u = gw->vec;
  ostNum* gm = gw->vec + nv;
  for (int side = 1; side >= -1 && !status; side -= 2) {
    for (int j = 0; j < nv; j++) u[j] = w->qvel[j] + side * e * v[j];
    status = geom(ctx, u);
    gw->evals++;
    osti_geoForce(w, gw, nf, side > 0 ? out : gm);
  }
  for (int j = 0; j < nv; j++) out[j] = (out[j] - gm[j]) / (2 * e);
  osti_massSolve(w, out);
  for (int j = 0; j < nv; j++) out[j] *= w->h;
  return status;
}


// 1 if an equality row of the iterate carries force. The term is taken for equality rows only
// (connect, weld, joint and tendon equalities: the loaded strings and loops where it decides
// convergence); contacts' point sets and frames switch between the two sides of a difference
// and their term is left out, as in the fixed-J model
OST_HD int osti_geoLoaded(const ostWorld* w) {
  for (int i = 0; i < w->nrow; i++) {
    if (w->rows[i].type == OST_ROW_EQUALITY && w->lambda[i] != 0) return 1;
  }
  return 0;
}


// replace the evaluated iterate's fixed-J direction (dqvel, dlambda; slip frames, before
// osti_directionFinish) by the direction with the geometric term; the caller checked that an
// equality row is loaded (osti_geoLoaded). The geometry is evaluated again at u and the world's
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
  for (int j = 0; j < nf; j++) {  // equality rows' term only (see osti_geoLoaded)
    if (gw->rows_f[j].type != OST_ROW_EQUALITY) gw->lam_f[j] = 0;
  }

  // GMRES on (I - P T) du = du0 from du = 0 (Hessenberg H(i, k) at Hg[i * (m + 3) + k]; the
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
    status = osti_geoApplyT(w, gw, nf, geom, ctx, v, Tv);
    osti_geoRows(w, gw->rows_s, gw->J_s, gw->nnz_s, gw->ind_s, &ns, 1);
    if (status) break;
    it += osti_directionSolve(w, so, Tv, NULL, gw->dl, z);  // z = -P T v
    if (k == 0 && gw->mode == 1) {
      // |P T v0| (v0 = du0 / |du0|) is the term's first-order share of the direction: below
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
    for (int j = 0; j < nv; j++) z[j] += v[j];             // (I - P T) v
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
    // the consistent pair (du, dlambda): the fixed-J solve with Mt^-1 r_dyn - T du
    status = osti_geoApplyT(w, gw, nf, geom, ctx, du, Tv);
    if (!status) {
      status = geom(ctx, w->qvel);
      gw->evals++;
    }
    osti_geoRows(w, gw->rows_s, gw->J_s, gw->nnz_s, gw->ind_s, &ns, 1);
    if (!status) {
      for (int j = 0; j < nv; j++) Tv[j] = w->Minv_rdyn[j] - Tv[j];
      it += osti_directionSolve(w, so, Tv, w->rho, w->dlambda, w->dqvel);
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
