// test_ost_cli_synth.c: the loss of `ostrich synth` (plugin/cli/ost_cli_synth.c) against central
// differences (eps 1e-6, normwise relative error below 1e-6), on robot_box.xml:
//   heading  dpsi/ddelta along the local rotation tangent (synth_heading) at 50 random attitudes,
//            the differences taken through mj_integratePos
//   state    the cotangents of synth_stateLoss (every sample's qpos tangent and qvel) on a random
//            path
//   knots    W^T of a random control gradient (synth_pullback) plus the regularizers
//            (synth_regLoss), against differences of sum_k gctrl_k . (W kappa)_k + regularizers
// These were `ostrich synth --selftest` (the same draws: one stream, seed 1, in this order).
// The file under test is included whole, so that its static functions can be called.
#include "ost_cli_synth.c"

#include "fixture.h"


// Normwise relative error of a against b over n entries.
static double relErr(const double* a, const double* b, int n) {
  double diff = 0, scale = 1e-12;
  for (int i = 0; i < n; i++) {
    diff = fmax(diff, fabs(a[i] - b[i]));
    scale = fmax(scale, fabs(b[i]));
  }
  return diff / scale;
}


// A random unit quaternion: yaw up to +-pi, then a tilt of up to 0.5 rad about a random axis.
static void randomQuat(cliRng* rng, mjtNum q[4]) {
  mjtNum yaw[4], tilt[4], axis[3];
  mjtNum zaxis[3] = {0, 0, 1};
  mju_axisAngle2Quat(yaw, zaxis, cli_uniform(rng, -mjPI, mjPI));
  for (int i = 0; i < 3; i++) {
    axis[i] = cli_uniform(rng, -1, 1);
  }
  mju_normalize3(axis);
  mju_axisAngle2Quat(tilt, axis, cli_uniform(rng, -0.5, 0.5));
  mju_mulQuat(q, yaw, tilt);
}


START_TEST(test_lossDerivatives) {
  ost_fixtureSetup();
  synthArgs a = {.trials = 10, .iters = 50, .seed = 1, .lr = 0.3, .engine = "mujoco",
                 .model = OST_MODEL_DIR "/robot_box.xml", .fd = "forward", .eps = 0.1,
                 .grad = "complete"};
  synthEngine e;
  ck_assert_msg(!synth_engineSetup(&e, "mujoco", &a), "cannot set up the engine on %s",
                a.model);
  const mjModel* m = e.m;
  int nq = m->nq, nv = m->nv, S = e.nsample, ns = S + 1, bad = 0;
  double eps = 1e-6, err[3];
  cliRng rng;
  cli_rngSeed(&rng, (unsigned long long)a.seed);
  mjtNum* q = (mjtNum*)synth_alloc((size_t)nq, sizeof(mjtNum), &bad);
  mjtNum* qp = (mjtNum*)synth_alloc((size_t)nq, sizeof(mjtNum), &bad);
  mjtNum* qm = (mjtNum*)synth_alloc((size_t)nq, sizeof(mjtNum), &bad);
  mjtNum* dq = (mjtNum*)synth_alloc((size_t)nv, sizeof(mjtNum), &bad);
  double* fd = (double*)synth_alloc((size_t)(2 * ns * nv + e.nvar), sizeof(double), &bad);
  double* an = (double*)synth_alloc((size_t)(2 * ns * nv + e.nvar), sizeof(double), &bad);
  double* gctrl = (double*)synth_alloc((size_t)(e.nstep * e.nu), sizeof(double), &bad);
  double* knots = (double*)synth_alloc((size_t)e.nvar, sizeof(double), &bad);
  ck_assert_msg(!bad, "out of memory");

  // 1. heading along the local rotation tangent, at 50 random attitudes (mj_integratePos)
  for (int trial = 0; trial < 50; trial++) {
    mjtNum dpsi[3];
    mju_zero(q, nq);
    randomQuat(&rng, q + 3);
    synth_heading(q + 3, dpsi);
    for (int i = 0; i < 3; i++) {
      mju_zero(dq, nv);
      dq[3 + i] = 1;
      mju_copy(qp, q, nq);
      mju_copy(qm, q, nq);
      mj_integratePos(m, qp, dq, eps);
      mj_integratePos(m, qm, dq, -eps);
      an[3 * trial + i] = dpsi[i];
      fd[3 * trial + i] = synth_wrap(synth_heading(qp + 3, NULL) - synth_heading(qm + 3, NULL)) /
                          (2 * eps);
    }
  }
  err[0] = relErr(an, fd, 150);

  // 2. state cotangents of a random path (every sample's qpos tangent and qvel)
  synthTask task = {{0.1, -0.1, 0.15}, {3, 0.2, -0.25}};
  for (int s = 0; s < ns; s++) {
    mjtNum* qs = e.qs + s * nq;
    for (int i = 0; i < nq; i++) {
      qs[i] = cli_uniform(&rng, -1, 1);
    }
    qs[0] = cli_uniform(&rng, -0.5, 4);
    randomQuat(&rng, qs + 3);
    for (int i = 0; i < nv; i++) {
      e.vs[s * nv + i] = cli_uniform(&rng, -1, 1);
    }
  }
  synthEval ev;
  synth_stateLoss(&e, &task, e.qs, e.vs, e.gqs, e.gus, &ev);
  mju_copy(an, e.gqs, ns * nv);
  mju_copy(an + ns * nv, e.gus, ns * nv);
  for (int s = 0; s < ns; s++) {
    for (int i = 0; i < 2 * nv; i++) {
      double l[2];
      for (int side = 0; side < 2; side++) {
        double h = side ? -eps : eps;
        mju_copy(q, e.qs + s * nq, nq);
        mjtNum v = e.vs[s * nv + i % nv];
        if (i < nv) {
          mju_zero(dq, nv);
          dq[i] = 1;
          mj_integratePos(m, e.qs + s * nq, dq, h);
        } else {
          e.vs[s * nv + i - nv] += h;
        }
        l[side] = synth_stateLoss(&e, &task, e.qs, e.vs, NULL, NULL, &ev);
        mju_copy(e.qs + s * nq, q, nq);
        e.vs[s * nv + i % nv] = v;
      }
      fd[(i < nv ? 0 : ns * nv) + s * nv + i % nv] = (l[0] - l[1]) / (2 * eps);
    }
  }
  err[1] = relErr(an, fd, 2 * ns * nv);

  // 3. knots: W^T of a random control gradient plus the regularizers, against differences of
  //    sum_k gctrl_k . (W kappa)_k + regularizers
  for (int c = 0; c < e.nvar; c++) {
    knots[c] = cli_uniform(&rng, -3, 3);
  }
  for (int k = 0; k < e.nstep * e.nu; k++) {
    gctrl[k] = cli_uniform(&rng, -1, 1);
  }
  mju_zero(an, e.nvar);
  synth_pullback(&e, gctrl, an);
  synth_regLoss(&e, knots, an);
  // capacity of the local control array below (u[64])
  ck_assert_int_le(e.nu, 64);
  for (int c = 0; c < e.nvar; c++) {
    double l[2];
    for (int side = 0; side < 2; side++) {
      double saved = knots[c];
      mjtNum u[64];
      knots[c] += side ? -eps : eps;
      l[side] = synth_regLoss(&e, knots, NULL);
      for (int k = 0; k < e.nstep; k++) {
        synth_ctrl(&e, knots, k, u);
        l[side] += mju_dot(gctrl + k * e.nu, u, e.nu);
      }
      knots[c] = saved;
    }
    fd[c] = (l[0] - l[1]) / (2 * eps);
  }
  err[2] = relErr(an, fd, e.nvar);

  free(q);
  free(qp);
  free(qm);
  free(dq);
  free(fd);
  free(an);
  free(gctrl);
  free(knots);
  synth_engineFree(&e);
  ck_assert_msg(err[0] < 1e-6, "heading: relative error %g", err[0]);
  ck_assert_msg(err[1] < 1e-6, "state cotangents: relative error %g", err[1]);
  ck_assert_msg(err[2] < 1e-6, "knot gradient: relative error %g", err[2]);
}
END_TEST


static Suite* suite(void) {
  Suite* s = suite_create("ost_cli_synth");
  TCase* tc = tcase_create("loss");
  tcase_add_test(tc, test_lossDerivatives);
  suite_add_tcase(s, tc);
  return s;
}


int main(void) {
  return ost_fixtureRun(suite());
}
