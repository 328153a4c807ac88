// ost_python_mujoco.c: stock MuJoCo's rollouts for the finite-difference baselines of
// ostrich.suite, stepped in C without a Python call per step: plain rollouts (whole-rollout
// differences restart one at each perturbed step), and rollouts linearized by MuJoCo's own
// finite-difference step Jacobians (mjd_transitionFD) with the backward chain of those
// Jacobians (what iLQR-style planners on MuJoCo use). Part of libostrich_python.so.
//
// Invariant: a state's tangent is MuJoCo's (mjd_transitionFD): x = (dq, qvel, act), n = 2 nv + na,
// dq in mj_integratePos's tangent (the local frame for ball and free rotations).
#include <stdlib.h>

#include "ost_python.h"

//---------------------------------- Stock MuJoCo rollouts -----------------------------------------

// Step stock MuJoCo (mj_step) from p's state through nctrl control steps of nsub steps each, with
// controls ctrl (nctrl x nu) held over each control step: the finite-difference baselines' inner
// loop without a Python call per step. qpos (nctrl x nq) and qvel (nctrl x nv) receive the state
// at the end of each control step; snap (nctrl x (nq + 2 nv + na), may be NULL) the state at the
// start of each, as qpos, qvel, qacc_warmstart, act, so that a later rollout can restart there.
// Returns OST_OK, or OST_ERR_NUMERIC with MuJoCo's error (the steps stop at the failed one).
OSTPY_API int ostpy_mujocoRollout(ostpyPhysics* p, int nctrl, int nsub, const mjtNum* ctrl,
                                  mjtNum* qpos, mjtNum* qvel, mjtNum* snap) {
  const mjModel* m = p->m;
  mjData* d = p->d;
  int nq = m->nq, nv = m->nv, na = m->na, nu = m->nu;
  int nsnap = nq + 2 * nv + na;
  p->err[0] = 0;
  if (nctrl < 0 || nsub < 1) {
    return ostpy_fail(p->err, OST_ERR_INPUT, "need nctrl >= 0 control steps of nsub >= 1 steps");
  }
  char* err = ostpy_mujocoError();
  err[0] = 0;
  for (int k = 0; k < nctrl; k++) {
    if (snap) {
      mjtNum* s = snap + (size_t)k * nsnap;
      mju_copy(s, d->qpos, nq);
      mju_copy(s + nq, d->qvel, nv);
      mju_copy(s + nq + nv, d->qacc_warmstart, nv);
      mju_copy(s + nq + 2 * nv, d->act, na);
    }
    mju_copy(d->ctrl, ctrl + (size_t)k * nu, nu);
    for (int i = 0; i < nsub; i++) {
      mj_step(m, d);
      if (err[0]) {
        return ostpy_fail(p->err, OST_ERR_NUMERIC, err);
      }
    }
    mju_copy(qpos + (size_t)k * nq, d->qpos, nq);
    mju_copy(qvel + (size_t)k * nv, d->qvel, nv);
  }
  return OST_OK;
}


// The Jacobians A (n x n) and B (n x nu) of mj_step at d's state by forward differences of size
// eps, each column from a step of a perturbed copy of the state (qpos along mj_integratePos's
// tangent, qvel, act, ctrl), the next states compared by mj_differentiatePos; d is restored. For
// the integrators whose derivatives mjd_transitionFD of MuJoCo 2.2.2 gets wrong (RK4: checked
// against these columns on dm_control's cart-pole, whose velocity columns it gives as -5.5
// instead of 1). s: scratch of 3 nq + 4 nv + 3 na + nu.
static void stepJacobianFD(const mjModel* m, mjData* d, mjtNum eps, mjtNum* A, mjtNum* B,
                           mjtNum* s) {
  int nq = m->nq, nv = m->nv, na = m->na, nu = m->nu, n = 2 * nv + na;
  mjtNum* q0 = s;                 // the start: qpos, qvel, act, warm start, ctrl
  mjtNum* v0 = q0 + nq;
  mjtNum* a0 = v0 + nv;
  mjtNum* w0 = a0 + na;
  mjtNum* u0 = w0 + nv;
  mjtNum* q1 = u0 + nu;           // the nominal next state: qpos, qvel, act
  mjtNum* v1 = q1 + nq;
  mjtNum* a1 = v1 + nv;
  mjtNum* dq = a1 + na;           // a tangent (nv), then a perturbed start's qpos (nq)
  mjtNum* qp = dq + nv;
  mju_copy(q0, d->qpos, nq);
  mju_copy(v0, d->qvel, nv);
  mju_copy(a0, d->act, na);
  mju_copy(w0, d->qacc_warmstart, nv);
  mju_copy(u0, d->ctrl, nu);
  mjtNum time = d->time;
  mj_step(m, d);
  mju_copy(q1, d->qpos, nq);
  mju_copy(v1, d->qvel, nv);
  mju_copy(a1, d->act, na);
  for (int c = 0;; c++) {
    // the start again: with column c's component moved by eps, or at the end as it was
    mju_copy(d->qpos, q0, nq);
    mju_copy(d->qvel, v0, nv);
    mju_copy(d->act, a0, na);
    mju_copy(d->qacc_warmstart, w0, nv);
    mju_copy(d->ctrl, u0, nu);
    d->time = time;
    if (c == n + nu) {
      break;
    }
    if (c < nv) {
      mju_zero(dq, nv);
      dq[c] = 1;
      mju_copy(qp, q0, nq);
      mj_integratePos(m, qp, dq, eps);
      mju_copy(d->qpos, qp, nq);
    } else if (c < 2 * nv) {
      d->qvel[c - nv] += eps;
    } else if (c < n) {
      d->act[c - 2 * nv] += eps;
    } else {
      d->ctrl[c - n] += eps;
    }
    mj_step(m, d);
    // column c of [A B]: (x1(c) - x1) / eps, qpos by its tangent difference
    mj_differentiatePos(m, dq, 1, q1, d->qpos);
    for (int i = 0; i < n; i++) {
      mjtNum di = i < nv ? dq[i] : i < 2 * nv ? d->qvel[i - nv] - v1[i - nv]
                                             : d->act[i - 2 * nv] - a1[i - 2 * nv];
      if (c < n) {
        A[(size_t)i * n + c] = di / eps;
      } else {
        B[(size_t)i * nu + c - n] = di / eps;
      }
    }
  }
}


// ostpy_mujocoRollout, and for each control step k the Jacobians of its end state by its start
// state and by its controls, A (nctrl x n x n) and B (nctrl x n x nu), by forward differences
// of size eps at each of its nsub steps (mjd_transitionFD for the Euler integrator,
// stepJacobianFD for the others), chained: A_k = A_nsub ... A_1 and
// B_k = sum_j A_nsub ... A_j+1 B_j (the controls are held over the control step). A step costs
// 1 + n + nu MuJoCo steps whatever the horizon. Returns OST_OK, OST_ERR_INPUT, OST_ERR_MEMORY, or OST_ERR_NUMERIC with MuJoCo's error.
OSTPY_API int ostpy_mujocoLinearRollout(ostpyPhysics* p, int nctrl, int nsub, const mjtNum* ctrl,
                                        mjtNum eps, mjtNum* qpos, mjtNum* qvel,
                                        mjtNum* A, mjtNum* B) {
  const mjModel* m = p->m;
  mjData* d = p->d;
  int nq = m->nq, nv = m->nv, nu = m->nu, n = 2 * m->nv + m->na;
  p->err[0] = 0;
  if (nctrl < 0 || nsub < 1 || !(eps > 0)) {
    return ostpy_fail(p->err, OST_ERR_INPUT,
                      "need nctrl >= 0 control steps of nsub >= 1 steps and eps > 0");
  }
  // one step's Jacobians, and a product's scratch
  size_t nscratch = 2 * (size_t)n * n + 2 * (size_t)n * nu + 3 * (size_t)nq + 4 * (size_t)nv
                    + 3 * (size_t)m->na + nu + 1;
  mjtNum* Ai = (mjtNum*)malloc(sizeof(mjtNum) * nscratch);
  if (!Ai) {
    return ostpy_fail(p->err, OST_ERR_MEMORY, "out of memory for the step Jacobians");
  }
  mjtNum* Bi = Ai + (size_t)n * n;
  mjtNum* tA = Bi + (size_t)n * nu;
  mjtNum* tB = tA + (size_t)n * n;
  mjtNum* fd = tB + (size_t)n * nu;  // stepJacobianFD's scratch
  int own = m->opt.integrator != mjINT_EULER;
  char* err = ostpy_mujocoError();
  err[0] = 0;
  int status = OST_OK;
  for (int k = 0; k < nctrl && status == OST_OK; k++) {
    mjtNum* Ak = A + (size_t)k * n * n;
    mjtNum* Bk = B + (size_t)k * n * nu;
    mju_copy(d->ctrl, ctrl + (size_t)k * nu, nu);
    for (int i = 0; i < nsub; i++) {
      // the Jacobians of this step at d's state (both restore d), then the step
      if (own) {
        stepJacobianFD(m, d, eps, i ? Ai : Ak, i ? Bi : Bk, fd);
      } else {
        mjd_transitionFD(m, d, eps, 0, i ? Ai : Ak, i ? Bi : Bk,
                         NULL, NULL);
      }
      if (i) {  // A_k = A_i A_k, B_k = A_i B_k + B_i
        mju_mulMatMat(tA, Ai, Ak, n, n, n);
        mju_copy(Ak, tA, n * n);
        mju_mulMatMat(tB, Ai, Bk, n, n, nu);
        mju_add(Bk, tB, Bi, n * nu);
      }
      mj_step(m, d);
      if (err[0]) {
        status = ostpy_fail(p->err, OST_ERR_NUMERIC, err);
        break;
      }
    }
    mju_copy(qpos + (size_t)k * nq, d->qpos, nq);
    mju_copy(qvel + (size_t)k * nv, d->qvel, nv);
  }
  free(Ai);
  return status;
}


// The vector-Jacobian product of such a linearized rollout: for cotangents g (nctrl x n) of its
// end states x_1 .. x_nctrl (tangent), the controls' gradient gctrl (nctrl x nu) and the start
// state's g0 (n; may be NULL) by the chain rule backward:
//   lambda = 0;  for k = nctrl - 1 .. 0:  lambda += g_k,  gctrl_k = B_k' lambda,  lambda = A_k' lambda.
// Returns OST_OK, or OST_ERR_MEMORY.
OSTPY_API int ostpy_linearBackward(int nctrl, int n, int nu, const mjtNum* A, const mjtNum* B,
                                   const mjtNum* g, mjtNum* gctrl, mjtNum* g0) {
  mjtNum* lam = (mjtNum*)calloc(2 * (size_t)n + 1, sizeof(mjtNum));
  if (!lam) {
    return OST_ERR_MEMORY;
  }
  mjtNum* t = lam + n;
  for (int k = nctrl - 1; k >= 0; k--) {
    mju_addTo(lam, g + (size_t)k * n, n);
    mju_mulMatTVec(gctrl + (size_t)k * nu, B + (size_t)k * n * nu, lam, n, nu);
    mju_mulMatTVec(t, A + (size_t)k * n * n, lam, n, n);
    mju_copy(lam, t, n);
  }
  if (g0) {
    mju_copy(g0, lam, n);
  }
  free(lam);
  return OST_OK;
}
