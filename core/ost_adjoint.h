// ost_adjoint.h: the residual of one Ostrich step as a function of all its inputs, written once
// for any scalar type, so that plugin/ost_adjoint_dual.cc can differentiate it exactly with
// forward-mode dual numbers (ostNum = ostDual<N>, core/ost_dual.h) and the implicit function
// theorem gives the step's gradients (core/README.md section 2; paper section III-D). Mirrors
// engine_derivative.c's role; also the exponential-map integration of qpos (mj_integratePos)
// and its first-order inverse, which define the tangent space of ball and free joints.
//
// The step's unknowns y = (u, lambda) (u = u+, nv; lambda, nrow) solve R(y; q-, u-, act-, ctrl,
// theta) = 0 (act- enters through the actuators' act+, ost_activation.h) with, for every row
// kind, the root that osti_evaluate's Newton model drives to zero:
//   dynamics   Mt (u - u-) - h (f + J(q+)' lambda)                               (eq. 2)
//   equality   (c(q+) + (E + reg h^2 d_eq) lambda) / h, d_eq osti_equalityScale  (eq. 3)
//   contact    FB(gap + reg k lambda, k lambda) / h,  k = h^2 J_i Mt^-1 J_i'     (eq. 4)
//              (floored by its friction rows', osti_contactScale; k_f lambda on each row of
//              a contact whose normal cannot move, osti_contactImmobile)
//   friction   k_f (lambda_f - proj_{|.| <= mu lambda_n}(z)),
//              z = lambda_f - (J_f u + c_s lambda_f) / k_f                       (eq. 5-7)
//   servo      alpha (lambda - clamp(pos + b2 J u))                              (eq. 8)
//   dry        k_f (lambda - clamp(z, -mu, mu)), z = lambda - (J u + c_s lambda) / k_f
// with q+ = q- (+) h u. Scaling a row does not move the root, only conditions the Jacobian.
// The step's outputs are O = (dq+, u+, act+) (2 nv + na): act+ is explicit in (act-, ctrl).
// Invariant: functions here write only their outputs and the world they are given.
#ifndef OSTRICH_CORE_OST_ADJOINT_H_
#define OSTRICH_CORE_OST_ADJOINT_H_

#include <math.h>

#include "ost_constraint.h"
#include "ost_hd.h"
#include "ost_kinematics.h"
#include "ost_math.h"
#include "ost_model.h"
#include "ost_solver.h"
#include "ost_util_dense.h"

#ifdef __cplusplus
extern "C" {
#endif

// entries of a parameter offset table (ostdStep.param_adr): the offsets in theta of the six
// ostParam groups of ostrich.h (friction, mass, damping, gain, biaspos, biasvel), then their total
#define OST_PARAM_ADR 7

typedef struct ostdStep_ {        // one committed (sub)step, as its backward pass needs it
  const void*   model;            // the packed ostModel (double) the step was taken with
  const double* qpos_prev;        // q-                                                 (nq)
  const double* qvel_prev;        // u-                                                 (nv)
  const double* qvel;             // u+, the step's solution                            (nv)
  const double* ctrl;             // controls                                           (nu)
  const double* qfrc_applied;     // applied generalized forces (NULL: none)            (nv)
  const double* xfrc_applied;     // applied body wrenches (NULL: none)          (nbody x 6)
  const void*   rows;             // the solution's rows (ostRow, double)             (nrow)
  const double* lambda;           // the solution's multipliers                       (nrow)
  int           nrow;             // rows of the solution
  int           truncate;         // 1: contact geometry held fixed within the step
  double        h;                // step size (s)
  double        lookahead;        // Ostrich's look-ahead distance (m)
  double        reg;              // relative compliance (ostOptions.regularization)
  double        creep;            // sticking creep (ostOptions.friction_creep, s/kg)
  double        fb_eps;           // Fischer-Burmeister smoothing
  int           nparam;           // parameter columns (0: none)
  const int*    param_adr;        // offsets of the ostParam groups in theta (OST_PARAM_ADR)
  const int*    pair_fric_geom;   // per candidate pair: the geoms whose friction it takes
                                  // (-1: none), so dmu/dtheta                  (npair x 2)
  const double* pair_fric_weight; // their weights (1, or 1/2 each at a tie)     (npair x 2)
  const double* act_prev;         // act-, the activations at the start (NULL if na = 0)  (na)
} ostdStep;


// the implicit function theorem on one step's Jacobian G (ost_adjoint_jacobian.h's layout: ny
// residual rows then nx = 2 nv + na output rows, ncol columns y then xi): with g (nx) the
// cotangents of O = (dq+, u+, act+),  K' w = -O_y' g  (K = R_y),  gxi = O_xi' g + R_xi' w
// (ncol - ny entries). Plain doubles whatever ostNum is. K (ny x ny), piv (ny) and w (ny) are
// scratch. Returns 0, or 1 + the column where K is singular.
OST_HD int osti_adjointSolve(const double* G, int ny, int nx, int ncol, double* K, int* piv,
                             double* w, const double* g, double* gxi) {
  for (int i = 0; i < ny; i++) {
    for (int j = 0; j < ny; j++) {
      K[(size_t)i * ny + j] = G[(size_t)i * ncol + j];
    }
  }
  int rc = ostu_luFactor(K, piv, ny);
  if (rc) {
    return rc;
  }
  for (int j = 0; j < ny; j++) {
    double s = 0;
    for (int i = 0; i < nx; i++) {
      s += G[(size_t)(ny + i) * ncol + j] * g[i];
    }
    w[j] = -s;
  }
  ostu_luSolveT(w, K, piv, w, ny);
  for (int j = 0; j < ncol - ny; j++) {
    int col = ny + j;
    double s = 0;
    for (int i = 0; i < nx; i++) {
      s += G[(size_t)(ny + i) * ncol + col] * g[i];
    }
    for (int i = 0; i < ny; i++) {
      s += G[(size_t)i * ncol + col] * w[i];
    }
    gxi[j] = s;
  }
  return 0;
}


//---------------------------------- Substep records and the batch's adjoint lanes ----------------
// Both are plain doubles and ints, whatever ostNum is: core/ost_batch_adjoint.h writes them in a
// double translation unit and ost_adjoint_jacobian.h reads them in a dual one.

// bytes of one ostRow of the double build
#define OST_ROW_BYTES (4 * sizeof(int) + 8 * sizeof(double))

typedef struct ostStepRec_ {      // one committed substep (pointers into a record block)
  int*    step;                   // the step it belongs to
  int*    nrow;                   // rows of its solution
  double* h;                      // its size (s)
  double* qpos_prev;              // q-                                                   (nq)
  double* qvel_prev;              // u-                                                   (nv)
  double* qvel;                   // u+                                                   (nv)
  double* ctrl;                   // controls                                             (nu)
  double* act_prev;               // act-                                                 (na)
  double* lambda;                 // multipliers                                    (nrow_max)
  void*   rows;                   // rows (ostRow of the double build)              (nrow_max)
} ostStepRec;


// bytes of one record for sizes s and row capacity nrow_max (a 64-byte multiple)
OST_HD size_t ostu_stepRecSize(ostSizes s, int nrow_max) {
  size_t nd = 1 + (size_t)s.nq + 2 * (size_t)s.nv + s.nu + s.na + nrow_max;
  return OST_ALIGN64(2 * sizeof(int) + nd * sizeof(double) + nrow_max * OST_ROW_BYTES);
}


// the record at p
OST_HD void ostu_stepRecView(ostStepRec* r, char* p, ostSizes s, int nrow_max) {
  r->step = (int*)p;
  r->nrow = r->step + 1;
  double* d = (double*)(p + 2 * sizeof(int));
  r->h = d;              d += 1;
  r->qpos_prev = d;      d += s.nq;
  r->qvel_prev = d;      d += s.nv;
  r->qvel = d;           d += s.nv;
  r->ctrl = d;           d += s.nu;
  r->act_prev = d;       d += s.na;
  r->lambda = d;         d += nrow_max;
  r->rows = d;
}


typedef struct ostAdjointSettings_ { // what a record's backward pass needs besides the record
  double h;                       // the step (s): substeps are recorded with their own size
  double lookahead;               // look-ahead distance (m)
  double reg;                     // relative compliance (ostOptions.regularization)
  double creep;                   // sticking creep (s/kg)
  double fb_eps;                  // Fischer-Burmeister smoothing
  int    truncate;                // 1: contact geometry held fixed within a step
  int    param_adr[OST_PARAM_ADR];  // offsets of the parameter groups in theta (with
                                  // ostAdjointLayout.nparam > 0; ostdStep.param_adr)
  const int*    pair_fric_geom;   // per candidate pair, the geoms whose friction it takes
  const double* pair_fric_weight; // and their weights (ostdStep; device memory on the GPU)
} ostAdjointSettings;

// one adjoint lane's arrays (type, name, count): the world it replays, its segment checkpoints
// and records, the dual work, the Jacobian and its solve, the running cotangent; sizes from an
// ostAdjointLayout A
#define OST_ADJOINT_LANE_ARRAYS(X)                                                               \
  X(char,   work,  A->lane_stride)                  /* a batch lane: the step's work arrays  */ \
  X(char,   cur,   A->world_stride)                 /* the world being replayed              */ \
  X(char,   ckpt,  A->world_stride * A->nckpt)      /* the world at each segment's start     */ \
  X(char,   rec,   A->rec_size * A->rec_cap)        /* the segment's substep records         */ \
  X(char,   jac,   A->jac_size)                     /* dual work (ostJacWork's block)        */ \
  X(double, lam,   A->nrow_max)                     /* multipliers matched onto the rows     */ \
  X(double, G,     (size_t)(A->ny_max + 2 * A->s.nv + A->s.na) * A->ncol_max) /* Jacobian     */ \
  X(double, Rq,    (size_t)A->ny_max * A->s.nv)     /* dR/dq+ of the split passes            */ \
  X(double, T,     2 * (size_t)A->s.nv * A->s.nv)   /* d(dq+)/d(u, dq-)                      */ \
  X(double, K,     (size_t)A->ny_max * A->ny_max)   /* its y block, LU-factored              */ \
  X(int,    piv,   A->ny_max)                       /* pivots                                */ \
  X(double, w,     A->ny_max)                       /* K' w = -O_y' g                        */ \
  X(double, gxi,   A->ncol_max)                     /* cotangent of (dq-, u-, act-, ctrl, theta) */ \
  X(double, g,     2 * A->s.nv + A->s.na)           /* running cotangent of (q, u, act)      */ \
  X(int,    info,  4)                               /* records, step, failed, ny             */

#define OST_ADJ_NREC   0          // info[]: records of the current segment
#define OST_ADJ_STEP   1          // the step whose records are being processed (T: none yet)
#define OST_ADJ_FAILED 2          // OST_STEP_* bit of a failed rollout or backward pass (0: none)
#define OST_ADJ_NY     3          // unknowns of the record being differentiated (0: none)

typedef struct ostAdjointLayout_ {  // where each array of an adjoint lane sits
  ostSizes s;                     // the model's sizes
  int    nrow_max;                // row capacity
  int    nseg;                    // segments of the rollout
  int    seg;                     // steps per segment (the checkpoint interval)
  int    rec_cap;                 // records a segment may hold
  int    ny_max;                  // nv + nrow_max
  int    ncol_max;                // ny_max + 2 nv + na + nu + nparam
  int    nparam;                  // parameter columns (0: no parameter gradients)
  int    nlane;                   // lanes
  int    njac;                    // threads sharing a record's columns (phase 3b)
  int    nckpt;                   // checkpoints a lane keeps: nseg, or 0 if the rollout kept them
  size_t world_stride;            // bytes of one world (ostBatchLayout.stride)
  size_t lane_stride;             // bytes of one batch lane (ostBatchLayout.lane_stride)
  size_t rec_size;                // bytes of one record
  size_t jac_size;                // bytes of the dual work (ostx_jacWorkSize)
  size_t stride;                  // bytes from one lane to the next (64-byte multiple)
  size_t total;                   // bytes of all lanes
#define X(type, name, n) size_t name;
  OST_ADJOINT_LANE_ARRAYS(X)
#undef X
} ostAdjointLayout;

typedef struct ostAdjointLane_ {  // one lane's arrays
#define X(type, name, n) type* name;
  OST_ADJOINT_LANE_ARRAYS(X)
#undef X
} ostAdjointLane;


// the layout of nlane adjoint lanes (A->s, nrow_max, nseg, seg, rec_cap, world_stride,
// lane_stride, jac_size, njac, nckpt and nparam set by the caller)
OST_HD void ostu_adjointLayout(ostAdjointLayout* A, int nlane) {
  A->nlane = nlane;
  A->ny_max = A->s.nv + A->nrow_max;
  A->ncol_max = A->ny_max + 2 * A->s.nv + A->s.na + A->s.nu + A->nparam;
  A->rec_size = ostu_stepRecSize(A->s, A->nrow_max);
  size_t off = 0;
#define X(type, name, n)                 \
  A->name = off;                         \
  off += OST_ALIGN64((size_t)(n) * sizeof(type));
  OST_ADJOINT_LANE_ARRAYS(X)
#undef X
  A->stride = off;
  A->total = off * (size_t)nlane;
}


// lane l's arrays in the allocation at base
OST_HD void ostu_adjointLane(ostAdjointLane* v, const ostAdjointLayout* A, char* base, int l) {
  char* p = base + (size_t)l * A->stride;
#define X(type, name, n) v->name = (type*)(p + A->name);
  OST_ADJOINT_LANE_ARRAYS(X)
#undef X
}


// record j from the end of lane al's segment
OST_HD void ostu_recordAt(ostStepRec* r, const ostAdjointLayout* A, const ostAdjointLane* al,
                          int j) {
  ostu_stepRecView(r, al->rec + (size_t)(al->info[OST_ADJ_NREC] - 1 - j) * A->rec_size, A->s,
                   A->nrow_max);
}


// record j from the end of lane al's segment as the step its Jacobian differentiates
OST_HD void ostu_recordStep(ostdStep* st, ostStepRec* r, const ostAdjointLayout* A,
                            const ostAdjointLane* al, int j, const ostAdjointSettings* as) {
  ostu_recordAt(r, A, al, j);
  ostdStep s = {NULL, r->qpos_prev, r->qvel_prev, r->qvel, r->ctrl, NULL, NULL, r->rows,
                r->lambda, *r->nrow, as->truncate, *r->h, as->lookahead, as->reg, as->creep,
                as->fb_eps, A->nparam, as->param_adr, as->pair_fric_geom,
                as->pair_fric_weight, r->act_prev};
  *st = s;
}


// g += the cotangents of world i's state after step t - 1 (time index t)
OST_HD void osti_adjointInject(const ostAdjointLayout* A, const ostAdjointLane* al, int i,
                               int nworld, int t, const double* gq, const double* gu) {
  int nv = A->s.nv;
  size_t at = ((size_t)t * nworld + i) * nv;
  for (int j = 0; j < nv; j++) {
    al->g[j] += gq ? gq[at + j] : 0;
    al->g[nv + j] += gu ? gu[at + j] : 0;
  }
}


// q <- q (x) exp(v) for a unit quaternion q and a rotation vector v in q's local frame
// (mju_quatIntegrate with scale 1). Below a rotation of 1e-6 rad the exponential is its series
// 1 - |v|^2/8, (v/2)(1 - |v|^2/24): the value agrees to 1e-24 and the first derivative at v = 0
// stays finite (|v| is not differentiable there), which the dual numbers need.
OST_HD void osti_quatIntegrate(ostNum q[4], const ostNum v[3]) {
  ostNum t2 = v[0] * v[0] + v[1] * v[1] + v[2] * v[2];
  ostNum dq[4];
  if (t2 > 1e-12) {
    ostNum t = sqrt(t2);
    ostNum s = ostu_sin(0.5 * t) / t;
    dq[0] = ostu_cos(0.5 * t);
    dq[1] = s * v[0];
    dq[2] = s * v[1];
    dq[3] = s * v[2];
  } else {
    ostNum s = 0.5 * (1 - t2 / 24);
    dq[0] = 1 - t2 / 8;
    dq[1] = s * v[0];
    dq[2] = s * v[1];
    dq[3] = s * v[2];
  }
  osti_kinQuatMul(q, q, dq);
  osti_kinNormalize4(q);
}


// qpos <- qpos (+) h qvel (mj_integratePos): slide and hinge add, ball and free rotations
// integrate the local angular velocity by the exponential map, free positions add h v
OST_HD void osti_integratePos(const ostModel* m, ostNum* qpos, const ostNum* qvel, ostNum h) {
  for (int j = 0; j < m->s.njnt; j++) {
    ostNum* q = qpos + m->jnt_qposadr[j];
    const ostNum* v = qvel + m->jnt_dofadr[j];
    int type = m->jnt_type[j];
    if (type == OST_JNT_FREE) {
      for (int i = 0; i < 3; i++) {
        q[i] += h * v[i];
      }
      q += 3;
      v += 3;
    }
    if (type == OST_JNT_FREE || type == OST_JNT_BALL) {
      ostNum w[3] = {h * v[0], h * v[1], h * v[2]};
      osti_quatIntegrate(q, w);
    } else {
      q[0] += h * v[0];
    }
  }
}


// the tangent vector dq (nv) with qpos = qref (+) dq to first order, for qpos near qref: slide,
// hinge and free positions subtract; rotations give 2 vec(conj(qref) qpos) (the local rotation
// vector for small angles). Exact in its first derivative at qpos = qref, which is where the
// dual numbers evaluate it (mj_differentiatePos there has a 0/0 in its axis).
OST_HD void osti_tangentLinear(const ostModel* m, ostNum* dq, const ostNum* qpos,
                               const ostNum* qref) {
  for (int j = 0; j < m->s.njnt; j++) {
    int a = m->jnt_qposadr[j], v = m->jnt_dofadr[j], type = m->jnt_type[j];
    if (type == OST_JNT_FREE) {
      for (int i = 0; i < 3; i++) {
        dq[v + i] = qpos[a + i] - qref[a + i];
      }
      a += 3;
      v += 3;
    }
    if (type == OST_JNT_FREE || type == OST_JNT_BALL) {
      ostNum conj[4] = {qref[a], -qref[a + 1], -qref[a + 2], -qref[a + 3]}, d[4];
      osti_kinQuatMul(d, conj, qpos + a);
      dq[v] = 2 * d[1];
      dq[v + 1] = 2 * d[2];
      dq[v + 2] = 2 * d[3];
    } else {
      dq[v] = qpos[a] - qref[a];
    }
  }
}


// The residual R (nv + nrow) of the step at (u, lambda), see the file comment, in three parts,
// so that the adjoint's passes that vary (u, lambda) alone reuse the factor and the diagonal.
// The world holds the step's start (w->qfrc_explicit = f, w->qvel_prev = u-, w->h) and the rows
// and J at q+ = q- (+) h u.

// the dynamics rows R (nv): Mt (u - u-) - h (f + J' lambda), Mt unfactored (nv x nv, dense);
// uses w->tmp
OST_HD void osti_residualDynamics(ostWorld* w, const ostNum* Mt, const ostNum* u,
                                  const ostNum* lambda, ostNum* R) {
  int nv = w->nv;
  ostNum* t = w->tmp;
  for (int j = 0; j < nv; j++) {
    t[j] = u[j] - w->qvel_prev[j];
  }
  ostu_mulMatVec(R, Mt, t, nv, nv);
  ostu_mulMatTVec(t, w->J, lambda, w->nrow, nv);
  for (int j = 0; j < nv; j++) {
    R[j] -= w->h * (w->qfrc_explicit[j] + t[j]);
  }
}


// the Jacobi diagonal J_i Mt^-1 J_i' (the effective-mass scales of the rows) into w->diag,
// factoring w->M (Mt) in place
OST_HD void osti_residualPrepare(ostWorld* w) {
  osti_factorMass(w);
  for (int i = 0; i < w->nrow; i++) {
    osti_rowDiag(w, i);
  }
}


// the constraint rows r (nrow) after osti_residualPrepare; fills w->Ju = J u first unless ju is
// 0 (w->Ju already holds J u for this u)
OST_HD void osti_residualRowsJu(ostWorld* w, const ostNum* u, const ostNum* lambda, ostNum reg,
                                ostNum creep, ostNum fb_eps, ostNum* r, int ju) {
  int nv = w->nv, nrow = w->nrow;
  ostNum h = w->h;
  for (int i = 0; ju && i < nrow; i++) {
    w->Ju[i] = ostu_dot(w->J + (size_t)i * nv, u, nv);
  }
  for (int i = 0; i < nrow; i++) {
    const ostRow* row = w->rows + i;
    ostNum lam = lambda[i];
    switch (row->type) {
    case OST_ROW_EQUALITY:
      r[i] = (row->pos + (row->alpha + reg * h * h * osti_equalityScale(w, i)) * lam) / h;
      break;
    case OST_ROW_LIMIT:
    case OST_ROW_CONTACT: {
      int nf = osti_frictionCount(w->rows, nrow, i);
      ostNum df = osti_frictionDiagMax(w, i, nf), fa, fb;
      if (row->type == OST_ROW_CONTACT && osti_contactImmobile(w, i, df)) {
        for (int q = 0; q <= nf; q++) r[i + q] = h * df * lambda[i + q];  // held at zero force
        break;
      }
      ostNum k = h * h * osti_contactScale(w, i, df);
      r[i] = osti_fb(row->pos + reg * k * lam, k * lam, fb_eps, &fa, &fb) / h;
      break;
    }
    case OST_ROW_FRICTION: {
      // all friction rows at the first of the contact (Alart-Curnier, as osti_frictionRows):
      // G = lambda_f - proj(z), scaled by k_f to a velocity
      if (i == 0 || w->rows[i - 1].type != OST_ROW_CONTACT) {
        break;
      }
      int n = i - 1, nf = osti_frictionCount(w->rows, nrow, n);
      if (osti_contactImmobile(w, n, osti_frictionDiagMax(w, n, nf))) {
        break;  // filled with its contact row
      }
      ostNum kf = 0;
      for (int k = 0; k < nf; k++) {
        kf += w->diag[i + k];
      }
      kf = h * kf / nf;
      ostNum cs = reg * kf + creep;
      ostNum bound = w->rows[n].mu * (lambda[n] > 0 ? lambda[n] : 0);
      ostNum z[OST_MAXFRIC], zn2 = 0;
      for (int k = 0; k < nf; k++) {
        z[k] = lambda[i + k] - (w->Ju[i + k] + cs * lambda[i + k]) / kf;
        zn2 += z[k] * z[k];
      }
      ostNum scl = 1;
      if (zn2 > bound * bound) {
        scl = bound / sqrt(zn2);
      }
      for (int k = 0; k < nf; k++) {
        r[i + k] = kf * (lambda[i + k] - scl * z[k]);
      }
      break;
    }
    case OST_ROW_DRY: {
      // k_f (lambda - clamp(z, -mu, mu)), z = lambda - (J u + c_s lambda) / k_f (osti_dryRow)
      ostNum kf = h * w->diag[i], cs = reg * kf;
      ostNum z = lam - (w->Ju[i] + cs * lam) / kf;
      z = z < -row->mu ? -row->mu : (z > row->mu ? row->mu : z);
      r[i] = kf * (lam - z);
      break;
    }
    case OST_ROW_SERVO: {
      ostNum F = row->pos + row->mu * w->Ju[i];
      F = F < row->lo ? row->lo : (F > row->hi ? row->hi : F);
      r[i] = row->alpha * (lam - F);
      break;
    }
    default:
      r[i] = lam;
      break;
    }
  }
}


// osti_residualRowsJu with J u made
OST_HD void osti_residualRows(ostWorld* w, const ostNum* u, const ostNum* lambda, ostNum reg,
                              ostNum creep, ostNum fb_eps, ostNum* r) {
  osti_residualRowsJu(w, u, lambda, reg, creep, fb_eps, r, 1);
}


// the whole residual R (nv + nrow) at (u, lambda); factors w->M in place
OST_HD void osti_stepResidual(ostWorld* w, const ostNum* u, const ostNum* lambda, ostNum reg,
                              ostNum creep, ostNum fb_eps, ostNum* R) {
  osti_residualDynamics(w, w->M, u, lambda, R);
  osti_residualPrepare(w);
  osti_residualRows(w, u, lambda, reg, creep, fb_eps, R + w->nv);
}


// complete the split passes' G (core/ost_adjoint_jacobian.h, ostx_jacColumnsSplit; layout of
// ostx_stepJacobian, ncol columns, ny rows R): the chain rule through q+ for the u and dq-
// columns, G[0:ny, c] += Rq T_c (Rq = dR/dq+, ny x nv; T = d(dq+)/d(u, dq-), nv x 2 nv), and
// the outputs' rows: dq+ = T (u, dq-), u+ = u, act+ zero outside the act- and ctrl columns (which
// the passes wrote). Plain doubles whatever ostNum is.
OST_HD void osti_jacAssemble(double* G, int ncol, int ny, int nv, int na, int nu, const double* Rq,
                             const double* T) {
  for (int c = 0; c < 2 * nv; c++) {
    int col = c < nv ? c : ny + c - nv;
    // T is block diagonal by joint (the exponential maps): a column's few non-zero entries,
    // summed in the order of the dense product (the zero terms it would add are exact)
    int j0 = nv, j1 = -1;
    for (int j = 0; j < nv; j++) {
      if (T[(size_t)j * 2 * nv + c] != 0) {
        j0 = j < j0 ? j : j0;
        j1 = j;
      }
    }
    for (int i = 0; i < ny && j1 >= 0; i++) {
      double s = 0;
      for (int j = j0; j <= j1; j++) s += Rq[(size_t)i * nv + j] * T[(size_t)j * 2 * nv + c];
      G[(size_t)i * ncol + col] += s;
    }
  }
  int ac0 = ny + 2 * nv, ac1 = ny + 2 * nv + na + nu;  // the act- and ctrl columns
  for (int r = 0; r < 2 * nv + na; r++) {
    double* g = G + (size_t)(ny + r) * ncol;
    for (int col = 0; col < ncol; col++) {
      if (r < nv) {          // dq+
        const double* Tr = T + (size_t)r * 2 * nv;
        g[col] = col < nv ? Tr[col] : (col >= ny && col < ny + nv ? Tr[nv + col - ny] : 0);
      } else if (r < 2 * nv) {  // u+
        g[col] = col == r - nv ? 1 : 0;
      } else if (col < ac0 || col >= ac1) {  // act+ (explicit in act- and ctrl only)
        g[col] = 0;
      }
    }
  }
}


// contact geometry held fixed within the step (the truncated pull-back): the rows of contacts
// keep J and frames but lose their derivatives, and each gap moves only to first order,
// gap + J_n dq+ with dq+ the tangent of q+ (nv). For the dual instantiation; a no-op on values.
OST_HD void osti_truncateContacts(ostWorld* w, const ostNum* dq) {
  int nv = w->nv;
  for (int i = 0; i < w->nrow; i++) {
    ostRow* row = w->rows + i;
    if (row->type != OST_ROW_CONTACT && row->type != OST_ROW_FRICTION) {
      continue;
    }
    ostNum* J = w->J + (size_t)i * nv;
    for (int j = 0; j < nv; j++) {
      J[j] = (double)J[j];
    }
    if (row->type == OST_ROW_CONTACT) {
      ostNum gap = (double)row->pos;
      for (int j = 0; j < nv; j++) {
        gap += J[j] * dq[j];
      }
      row->pos = gap;
    }
  }
}

#ifdef __cplusplus
}
#endif

#endif  // OSTRICH_CORE_OST_ADJOINT_H_
