// ost_solver.h: the per-world non-smooth Newton step of Ostrich (DESIGN.md section 1; paper
// section III-C). Mirrors engine_solver.c (mj_solNewton): residual evaluation at an iterate,
// the Schur-complement operator applied matrix-free, preconditioned conjugate residual (PCR)
// with a Jacobi preconditioner, and the Newton update with projection.
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
} ostSolverOptions;

OST_STATIC_ASSERT(sizeof(ostSolverOptions) == 4 * sizeof(int) + 3 * sizeof(ostNum),
                  "ostSolverOptions crosses the gcc/nvcc boundary: keep it unpadded");

// One world's arrays. The X-macro is the single description of the layout: it drives the size
// of the allocation and the pointer setup (type, name, rows, cols).
#define OST_WORLD_ARRAYS(X)                                                                     \
  X(ostNum,        qvel_prev,     nv,       1)   /* u- at the start of the step           */   \
  X(ostNum,        qfrc_explicit, nv,       1)   /* f: explicit forces at (q-, u-)         */   \
  X(ostNum,        M,             nv,       nv)  /* M + h D, then its Cholesky factor      */   \
  X(ostNum,        qvel,          nv,       1)   /* current iterate u                      */   \
  X(ostNum,        qvel_best,     nv,       1)   /* best iterate u                         */   \
  X(ostNum,        Minv_rdyn,     nv,       1)   /* Mt^-1 r_dyn at the iterate             */   \
  X(ostNum,        tmp,           nv,       2)   /* scratch                                */   \
  X(ostRow,        rows,          nrow_max, 1)   /* rows of the current iterate            */   \
  X(ostRow,        rows_prev,     nrow_max, 1)   /* rows of the previous iterate           */   \
  X(ostNum,        J,             nrow_max, nv)  /* row Jacobians at q(u)                  */   \
  X(ostNum,        lambda,        nrow_max, 1)   /* multipliers (forces, N or N m)         */   \
  X(ostNum,        lambda_prev,   nrow_max, 1)   /* multipliers of the previous iterate    */   \
  X(ostNum,        lambda_best,   nrow_max, 1)   /* multipliers of the best iterate        */   \
  X(ostNum,        W,             nrow_max, 1)   /* friction mode (contact), direction (fr)*/   \
  X(ostNum,        W_prev,        nrow_max, 1)   /* friction state of the previous iterate */   \
  X(ostNum,        diag,          nrow_max, 1)   /* J_i Mt^-1 J_i'                         */   \
  X(ostNum,        Ju,            nrow_max, 1)   /* J_i u                                  */   \
  X(ostNum,        c,             nrow_max, 1)   /* compliance of the linearized row       */   \
  X(ostNum,        rho,           nrow_max, 1)   /* residual of the linearized row         */   \
  X(ostNum,        pcr,           nrow_max, 7)   /* PCR vectors b x r z p Az Ap            */   \
  X(unsigned char, used,          nrow_max, 1)   /* matching scratch                       */

typedef struct ostWorld_ {        // one world: sizes and pointers into one allocation
  int    nv;                      // degrees of freedom
  int    nrow;                    // rows of the current iterate
  int    nrow_max;                // row capacity
  int    nrow_prev;               // rows of the previous iterate
  ostNum h;                       // timestep (s)
#define X(type, name, r, c) type* name;
  OST_WORLD_ARRAYS(X)
#undef X
} ostWorld;


// bytes needed by one world, each array 64-byte aligned
OST_HD size_t ostu_worldSize(int nv, int nrow_max) {
  size_t sz = 0;
#define X(type, name, r, c) sz += (((size_t)(r) * (c) * sizeof(type) + 63) / 64) * 64;
  OST_WORLD_ARRAYS(X)
#undef X
  return sz;
}


// point a world's arrays into buf (64-byte aligned, ostu_worldSize bytes)
OST_HD void ostu_worldInit(ostWorld* w, void* buf, int nv, int nrow_max, ostNum h) {
  char* p = (char*)buf;
  w->nv = nv;
  w->nrow = 0;
  w->nrow_max = nrow_max;
  w->nrow_prev = 0;
  w->h = h;
#define X(type, name, r, c)                                         \
  w->name = (type*)p;                                               \
  p += (((size_t)(r) * (c) * sizeof(type) + 63) / 64) * 64;
  OST_WORLD_ARRAYS(X)
#undef X
}


// factor Mt = M + h D in place (the caller filled w->M); returns 0 or 1 + failing column
OST_HD int osti_factorMass(ostWorld* w) {
  return ostu_cholFactor(w->M, w->nv);
}


// evaluate the iterate (qvel, lambda, W) with the rows and J filled for q(qvel): fills
// Minv_rdyn, diag, Ju and the row form (c, rho); returns the squared merit residual
//   |Mt^-1 r_dyn|^2 + sum_i m_i^2,  every term a velocity (m/s or rad/s)
OST_HD ostNum osti_evaluate(ostWorld* w, const ostSolverOptions* opt) {
  int nv = w->nv, nrow = w->nrow;
  ostNum h = w->h;
  ostNum* t = w->tmp;
  ostNum* t2 = w->tmp + nv;

  // Mt^-1 r_dyn = (u - u-) - h Mt^-1 (f + J' lambda)                              (eq. 9)
  ostu_mulMatTVec(t, w->J, w->lambda, nrow, nv);
  for (int j = 0; j < nv; j++) {
    t[j] += w->qfrc_explicit[j];
  }
  ostu_cholSolve(t, w->M, t, nv);
  ostNum merit = 0;
  for (int j = 0; j < nv; j++) {
    w->Minv_rdyn[j] = w->qvel[j] - w->qvel_prev[j] - h * t[j];
    merit += w->Minv_rdyn[j] * w->Minv_rdyn[j];
  }

  // per-row J u and the Jacobi diagonal J_i Mt^-1 J_i'
  for (int i = 0; i < nrow; i++) {
    const ostNum* Ji = w->J + (size_t)i * nv;
    w->Ju[i] = ostu_dot(Ji, w->qvel, nv);
    ostNum d = ostu_cholNormSqr(t2, w->M, Ji, nv);
    w->diag[i] = d > 1e-300 ? d : 1e-300;
  }

  // row forms; FB rows are divided by h*phi_a so that all rows share J_i as their Jacobian
  for (int i = 0; i < nrow; i++) {
    const ostRow* r = w->rows + i;
    ostNum lam = w->lambda[i];
    ostNum m_i;
    switch (r->type) {
    case OST_ROW_EQUALITY: {
      // c(q+) + E lambda = 0, linearized as h J du + E dlambda = -r                   (eq. 3)
      w->c[i] = r->alpha / h;
      w->rho[i] = (r->pos + r->alpha * lam) / h;
      m_i = w->rho[i];
      break;
    }
    case OST_ROW_LIMIT:
    case OST_ROW_CONTACT: {
      // FB(gap, k lambda) = 0 with the effective-mass scale k = h^2 J_i Mt^-1 J_i' (m/N):
      // the displacement an impulse h*lambda causes in one step, so both arguments are metres
      ostNum k = h * h * w->diag[i];
      ostNum fa, fb;
      ostNum phi = osti_fb(r->pos, k * lam, opt->fb_eps, &fa, &fb);
      ostNum a = fa > 1e-12 ? fa : 1e-12;
      w->c[i] = fb * k / (h * a);
      w->rho[i] = phi / (h * a);
      m_i = phi / h;
      break;
    }
    case OST_ROW_FRICTION: {
      // stick (W[normal] = 0): J_f u = 0.  slide (W[normal] = 1): the force is fixed on the
      // cone, lambda_f = mu lambda_n d with d = W[i] opposing the slip (maximal dissipation),
      // a decoupled row scaled by k = h J_i Mt^-1 J_i' (velocity per force)      (eq. 5-7)
      if (w->W[r->normal] == 0) {
        w->c[i] = 0;
        w->rho[i] = w->Ju[i];
        m_i = w->rho[i];
      } else {
        ostNum ln = w->lambda[r->normal] > 0 ? w->lambda[r->normal] : 0;
        ostNum k = h * w->diag[i];
        m_i = k * (lam - w->rows[r->normal].mu * ln * w->W[i]);
        w->c[i] = k / 1e-12;
        w->rho[i] = m_i / 1e-12;
      }
      break;
    }
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
  }
  return merit;
}


// y = A x = J Mt^-1 J' x + (c / h) x, applied matrix-free
OST_HD void osti_schurApply(ostWorld* w, ostNum* OST_RESTRICT y, const ostNum* x) {
  int nv = w->nv, nrow = w->nrow;
  ostNum* t = w->tmp;
  ostu_mulMatTVec(t, w->J, x, nrow, nv);
  ostu_cholSolve(t, w->M, t, nv);
  for (int i = 0; i < nrow; i++) {
    y[i] = ostu_dot(w->J + (size_t)i * nv, t, nv) + w->c[i] / w->h * x[i];
  }
}


// preconditioned conjugate residual for A x = b (A symmetric), Jacobi preconditioner
// P = diag(A)^-1; x starts at 0; returns the iterations used
OST_HD int osti_pcr(ostWorld* w, ostNum* x, const ostNum* b, int maxit, ostNum rtol) {
  int n = w->nrow;
  ostNum* r = w->pcr + 2 * (size_t)w->nrow_max;
  ostNum* z = r + w->nrow_max;
  ostNum* p = z + w->nrow_max;
  ostNum* Az = p + w->nrow_max;
  ostNum* Ap = Az + w->nrow_max;
  // P_i = 1 / (J_i Mt^-1 J_i' + c_i / h)
#define OST_PREC(i) (1 / (w->diag[i] + w->c[i] / w->h))
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
  osti_schurApply(w, Az, z);
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
    osti_schurApply(w, Az, z);
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


// one Newton update after osti_evaluate: solve the Schur system by PCR, back-substitute du,
// refresh the friction modes from the updated (unprojected) iterate, then project the
// multipliers (cone clamp, lambda_n >= 0, force range); returns the PCR iterations
OST_HD int osti_newtonUpdate(ostWorld* w, const ostSolverOptions* opt) {
  int nv = w->nv, nrow = w->nrow;
  ostNum h = w->h;
  ostNum* b = w->pcr;
  ostNum* dlam = w->pcr + w->nrow_max;

  // right-hand side (J Mt^-1 r_dyn - rho) / h                                        (eq. 11)
  for (int i = 0; i < nrow; i++) {
    b[i] = (ostu_dot(w->J + (size_t)i * nv, w->Minv_rdyn, nv) - w->rho[i]) / h;
  }
  int it = osti_pcr(w, dlam, b, opt->pcr_iter, opt->pcr_tol);

  // du = h Mt^-1 J' dlambda - Mt^-1 r_dyn                                            (eq. 12)
  ostNum* t = w->tmp;
  ostu_mulMatTVec(t, w->J, dlam, nrow, nv);
  ostu_cholSolve(t, w->M, t, nv);
  for (int j = 0; j < nv; j++) {
    w->qvel[j] += h * t[j] - w->Minv_rdyn[j];
  }
  for (int i = 0; i < nrow; i++) {
    w->lambda[i] += dlam[i];
  }

  // friction modes from the unprojected iterate: a sticking force outside the cone starts
  // sliding along it; a sliding contact whose slip turns along its force sticks again
  for (int i = 0; i + 2 < nrow; i++) {
    const ostRow* r = w->rows + i;
    if (r->type != OST_ROW_CONTACT || w->rows[i + 1].type != OST_ROW_FRICTION) {
      continue;
    }
    ostNum s1 = ostu_dot(w->J + (size_t)(i + 1) * nv, w->qvel, nv);
    ostNum s2 = ostu_dot(w->J + (size_t)(i + 2) * nv, w->qvel, nv);
    ostNum f1 = w->lambda[i + 1], f2 = w->lambda[i + 2];
    ostNum slip = sqrt(s1 * s1 + s2 * s2), lf = sqrt(f1 * f1 + f2 * f2);
    ostNum bound = r->mu * (w->lambda[i] > 0 ? w->lambda[i] : 0);
    int slide = w->W[i] != 0;
    if (!slide && lf > bound * (1 + 1e-6) && lf > 0) {
      w->W[i] = 1;
      w->W[i + 1] = f1 / lf;
      w->W[i + 2] = f2 / lf;
    } else if (slide && slip > 1e-7) {
      if (s1 * w->W[i + 1] + s2 * w->W[i + 2] > 0) {
        w->W[i] = 0;  // slip along the force: the contact sticks
      } else {
        w->W[i + 1] = -s1 / slip;
        w->W[i + 2] = -s2 / slip;
      }
    }
  }
  osti_projectRows(w->lambda, w->rows, nrow);
  return it;
}


// save the current iterate's rows and multipliers as "previous", for matching after the
// geometry provider refills the rows at the next iterate
OST_HD void osti_savePrevious(ostWorld* w) {
  for (int i = 0; i < w->nrow; i++) {
    w->rows_prev[i] = w->rows[i];
    w->lambda_prev[i] = w->lambda[i];
    w->W_prev[i] = w->W[i];
  }
  w->nrow_prev = w->nrow;
}


// carry multipliers from the previous iterate onto the freshly filled rows
OST_HD void osti_matchPrevious(ostWorld* w) {
  osti_matchRows(w->lambda, w->W, w->rows, w->nrow, w->lambda_prev, w->W_prev, w->rows_prev,
                 w->nrow_prev, w->used);
}

#ifdef __cplusplus
}
#endif

#endif  // OSTRICH_CORE_OST_SOLVER_H_
