// test_ost_activation.c: actuator activation dynamics (dyntype integrator and filter) taken
// implicitly with the step (core/ost_activation.h, core/README.md eq. 8b), against closed forms:
// a first-order filter follows its backward-Euler recurrence exactly and the continuous response
// 1 - exp(-t / tau) as h -> 0 at first order; an integrator integrates ctrl and stops at its
// actrange; a filter-driven position servo with tau = 1 ms reaches its target at h = 0.1 s. The
// gradients (ost_transition's (2nv + na) layout, a tape's control gradient) agree with central
// differences of ost_step.
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "fixture.h"
#include "ostrich.h"

// a 1 kg slider without gravity, driven by one actuator of the given dynamics: a motor of gain 1
// (kp = 0) or a position servo (force = kp (act - q) - kv v, a row of eq. 8)
static mjModel* slider(const char* dyn, double tau, double kp, double kv, const char* extra) {
  char xml[2048], bias[128] = "";
  if (kp > 0) {
    snprintf(bias, sizeof(bias), "biastype='affine' biasprm='0 %.17g %.17g'", -kp, -kv);
  }
  snprintf(xml, sizeof(xml),
           "<mujoco><option gravity='0 0 0'/><worldbody><body name='cart'>"
           "<joint name='slide' type='slide' axis='1 0 0'/>"
           "<geom type='box' size='0.1 0.1 0.1' mass='1' contype='0' conaffinity='0'/>"
           "</body></worldbody><actuator><general name='a' joint='slide' dyntype='%s' "
           "dynprm='%.17g' gainprm='%.17g' %s %s/></actuator></mujoco>",
           dyn, tau, kp > 0 ? kp : 1.0, bias, extra);
  return ost_fixtureLoadString(xml);
}


// a filter of tau = 0.1 s driven by ctrl = 1 from act = 0: after every step act equals the
// backward-Euler recurrence a+ = (tau a- + h) / (tau + h), and the motor's force is act+ (the
// slider's acceleration (u+ - u-) / h = act+ / 1 kg), with both geometry providers
START_TEST(test_filterRecurrence) {
  ost_fixtureSetup();
  const double tau = 0.1, h = 0.01;
  mjModel* m = slider("filter", tau, 0, 0, "");
  ck_assert_int_eq(m->na, 1);
  for (int geometry = 0; geometry < 2; geometry++) {
    mjData* d = mj_makeData(m);
    ost_fixtureSetProvider(m, d, h, geometry);
    d->ctrl[0] = 1;
    double a = 0, worst_act = 0, worst_acc = 0;
    for (int k = 0; k < 50; k++) {
      double u0 = d->qvel[0];
      ck_assert_int_eq(ost_step(m, d), OST_OK);
      a = (tau * a + h) / (tau + h);
      worst_act = fmax(worst_act, fabs(d->act[0] - a));
      worst_acc = fmax(worst_acc, fabs((d->qvel[0] - u0) / h - a));
    }
    printf("filter recurrence (geometry %d): |act - BE| %.2g, |qacc - act+| %.2g\n", geometry,
           worst_act, worst_acc);
    // the same arithmetic as the recurrence: equal to the last bits (1e-15 of act ~ 1)
    ck_assert_double_le(worst_act, 1e-15);
    // (u+ - u-) / h of a linear step solved to tol = 1e-10 m/s: error tol / h = 1e-8 m/s^2
    ck_assert_double_le(worst_acc, 1e-8);
    ost_deleteData(d);
  }
  mj_deleteModel(m);
}
END_TEST


// the continuous response act(t) = 1 - exp(-t / tau) as h -> 0: backward Euler's error at
// t = tau is exp(-1) t h / (2 tau^2) to first order ((1 + h/tau)^-n = exp(-t/tau + t h / (2
// tau^2) + ..)), so it halves with h
START_TEST(test_filterContinuous) {
  ost_fixtureSetup();
  const double tau = 0.05;
  mjModel* m = slider("filter", tau, 0, 0, "");
  double err[3];
  for (int r = 0; r < 3; r++) {
    double h = tau / (100 << r);
    mjData* d = mj_makeData(m);
    ost_fixtureSetProvider(m, d, h, 0);
    d->ctrl[0] = 1;
    int n = 100 << r;
    for (int k = 0; k < n; k++) {
      ck_assert_int_eq(ost_step(m, d), OST_OK);
    }
    err[r] = fabs(d->act[0] - (1 - exp(-1.0)));
    double predicted = exp(-1.0) * h / (2 * tau);
    printf("filter h = tau/%d: |act - (1 - e^-1)| = %.4g (first-order prediction %.4g)\n",
           100 << r, err[r], predicted);
    // the leading term of the error, to within its next order (h / tau <= 1 %)
    ck_assert_double_eq_tol(err[r], predicted, 0.02 * predicted);
    ost_deleteData(d);
  }
  // first order: halving h halves the error (to the 1 % of the next term)
  ck_assert_double_eq_tol(err[0] / err[1], 2, 0.02);
  ck_assert_double_eq_tol(err[1] / err[2], 2, 0.02);
  mj_deleteModel(m);
}
END_TEST


// an integrator with ctrlrange [-1, 1] and actrange [0, 0.5]: act+ = act- + h clamp(ctrl), then
// clamped to actrange, as mj_advance; at h = 0.1 s and ctrl = 5 act rises by 0.1 per step and
// stops at 0.5 exactly, and ctrl = -1 brings it down to 0 and holds it there
START_TEST(test_integratorClamps) {
  ost_fixtureSetup();
  mjModel* m = slider("integrator", 0, 0, 0, "ctrllimited='true' ctrlrange='-1 1' "
                      "actlimited='true' actrange='0 0.5'");
  mjData* d = mj_makeData(m);
  ost_fixtureSetProvider(m, d, 0.1, 0);
  d->ctrl[0] = 5;
  for (int k = 1; k <= 8; k++) {
    ck_assert_int_eq(ost_step(m, d), OST_OK);
    // sums of 0.1: rounding of k additions (1e-15)
    ck_assert_double_eq_tol(d->act[0], fmin(0.1 * k, 0.5), 1e-15);
  }
  ck_assert(d->act[0] == 0.5);  // the clamp is exact
  d->ctrl[0] = -1;
  for (int k = 0; k < 8; k++) {
    ck_assert_int_eq(ost_step(m, d), OST_OK);
  }
  ck_assert(d->act[0] == 0);
  // stock MuJoCo's explicit Euler clamps the same way (act_dot = ctrl is constant)
  mjData* dm = mj_makeData(m);
  m->opt.timestep = 0.1;
  dm->ctrl[0] = 5;
  for (int k = 0; k < 8; k++) {
    mj_step(m, dm);
  }
  ck_assert(dm->act[0] == 0.5);
  mj_deleteData(dm);
  ost_deleteData(d);
  mj_deleteModel(m);
}
END_TEST


// a position servo (kp = 100, kv = 20: critically damped for 1 kg) behind a filter of tau = 1 ms,
// at h = 0.1 s = 100 tau: explicit Euler on act would multiply its error by 1 - h/tau = -99 per
// step; backward Euler is stable, and the slider reaches its target 0.5 m and stays, with both
// geometry providers
START_TEST(test_filterServoLargeStep) {
  ost_fixtureSetup();
  mjModel* m = slider("filter", 1e-3, 100, 20, "");
  for (int geometry = 0; geometry < 2; geometry++) {
    mjData* d = mj_makeData(m);
    ost_fixtureSetProvider(m, d, 0.1, geometry);
    d->ctrl[0] = 0.5;
    double peak = 0;
    for (int k = 0; k < 50; k++) {
      ck_assert_int_eq(ost_step(m, d), OST_OK);
      peak = fmax(peak, fabs(d->qpos[0]));
    }
    printf("filter servo h = 0.1 s, tau = 1 ms (geometry %d): q = %.12f, act = %.12f, peak %.4f\n",
           geometry, d->qpos[0], d->act[0], peak);
    // after 5 s = 25 time constants 1/omega = 0.1 s of the critically damped servo the error
    // e^-25 (25+1) ~ 4e-10 m; backward Euler damps more, so 1e-6 m is loose
    ck_assert_double_eq_tol(d->qpos[0], 0.5, 1e-6);
    ck_assert_double_eq_tol(d->act[0], 0.5, 1e-12);  // the filter's fixed point is ctrl
    // critical damping, and backward Euler adds damping: no overshoot beyond rounding
    ck_assert_double_le(peak, 0.5 + 1e-9);
    ost_deleteData(d);
  }
  mj_deleteModel(m);
}
END_TEST


// a model with user activation dynamics is refused with a message naming the actuator and the
// callback (muscles are taken: tests/test_ost_muscle.c)
START_TEST(test_userDynamicsRefused) {
  ost_fixtureSetup();
  mjModel* m = ost_fixtureLoadString(
      "<mujoco><worldbody><body><joint name='j' type='slide' axis='1 0 0'/>"
      "<geom type='box' size='0.1 0.1 0.1' mass='1'/></body></worldbody>"
      "<actuator><general name='usr' joint='j' dyntype='user'/></actuator></mujoco>");
  char err[512] = "";
  ck_assert_int_eq(ost_checkModel(m, err, sizeof(err)), OST_ERR_MODEL);
  printf("user dynamics: %s\n", err);
  ck_assert_ptr_nonnull(strstr(err, "'usr'"));
  ck_assert_ptr_nonnull(strstr(err, "mjcb_act_dyn"));
  mj_deleteModel(m);
}
END_TEST


// a double pendulum under gravity (nonlinear in q) with three actuators: a motor without
// dynamics on the shoulder, a position servo behind a filter (tau = 50 ms) on the elbow and an
// integrator motor on the shoulder with actrange [-1, 1]; na = 2, the activations inside their
// range (the clamp is a kink)
static mjModel* pendulum(void) {
  return ost_fixtureLoadString(
      "<mujoco><option gravity='0 0 -9.81'/><worldbody><body name='upper'>"
      "<joint name='shoulder' type='hinge' axis='0 1 0'/>"
      "<geom type='capsule' fromto='0 0 0 0.4 0 0' size='0.03' mass='1' contype='0' "
      "conaffinity='0'/><body name='lower' pos='0.4 0 0'>"
      "<joint name='elbow' type='hinge' axis='0 1 0'/>"
      "<geom type='capsule' fromto='0 0 0 0.4 0 0' size='0.03' mass='1' contype='0' "
      "conaffinity='0'/></body></body></worldbody><actuator>"
      "<motor name='m' joint='shoulder' gear='1'/>"
      "<general name='servo' joint='elbow' dyntype='filter' dynprm='0.05' gainprm='20' "
      "biastype='affine' biasprm='0 -20 -2'/>"
      "<general name='int' joint='shoulder' dyntype='integrator' gainprm='3' actlimited='true' "
      "actrange='-1 1'/></actuator></mujoco>");
}


// ost_transition's A (nx x nx, nx = 2 nv + na) and B (nx x nu) against central differences of
// ost_step, each column perturbed by +-eps (qpos along the tangent, mjd_transitionFD's layout)
START_TEST(test_transitionGradients) {
  ost_fixtureSetup();
  mjModel* m = pendulum();
  int nv = m->nv, na = m->na, nu = m->nu, nx = 2 * nv + na;
  ck_assert_int_eq(na, 2);
  mjData* d = mj_makeData(m);
  ost_fixtureSetProvider(m, d, 0.01, 1);
  double q0[2] = {0.4, -0.7}, v0[2] = {0.3, -0.5}, a0[2] = {0.2, -0.3}, u0[3] = {0.5, 0.8, 0.4};
  double A[64], B[64], worst_a, worst_b, scale;
  ost_fixtureSetState(m, d, q0, v0, a0, u0);
  ck_assert(nx * nx <= 64 && nx * nu <= 64);
  double A1[64], B1[64];  // ost_transition leaves the state as it was (checked before FD steps)
  ck_assert_int_eq(ost_transition(m, d, A1, B1), OST_OK);
  ck_assert(d->act[0] == a0[0] && d->act[1] == a0[1]);
  ck_assert(d->qpos[0] == q0[0] && d->qvel[1] == v0[1]);
  ost_fixtureTransitionCheck(m, d, "transition", A, B, &worst_a, &worst_b, &scale);
  // the activation rows are exact: d act+ / d act- = tau / (tau + h) for the filter, 1 for the
  // integrator; d act+ / d ctrl = h / (tau + h) and h (rounding of one division: 1e-15)
  ck_assert_double_eq_tol(A[(2 * nv) * nx + 2 * nv], 0.05 / 0.06, 1e-15);
  ck_assert_double_eq_tol(A[(2 * nv + 1) * nx + 2 * nv + 1], 1, 1e-15);
  ck_assert_double_eq_tol(B[(2 * nv) * nu + 1], 0.01 / 0.06, 1e-15);
  ck_assert_double_eq_tol(B[(2 * nv + 1) * nu + 2], 0.01, 1e-15);
  // central differences: truncation eps^2 |x'''| ~ 1e-12 and rounding 1e-16 / eps ~ 1e-10 (the
  // pendulum has no contact: Newton solves its step to rounding); 1e-7 of the largest entry
  ck_assert_double_le(worst_a, 1e-7 * fmax(1, scale));
  ck_assert_double_le(worst_b, 1e-7 * fmax(1, scale));
  ost_deleteData(d);
  mj_deleteModel(m);
}
END_TEST


// L = sum over the rollout's T states of qpos[1] + 0.1 qvel[0], from start (q, v, act)
static double rolloutLoss(const mjModel* m, mjData* d, const double* start, const double* ctrl,
                          int T, ostTape* tape) {
  ost_fixtureSetState(m, d, start, start + m->nv, start + 2 * m->nv, ctrl);
  if (tape) {
    ost_tapeClear(tape);
  }
  double L = 0;
  for (int k = 0; k < T; k++) {
    for (int a = 0; a < m->nu; a++) d->ctrl[a] = ctrl[k * m->nu + a];
    ck_assert_int_eq(tape ? ost_tapeStep(tape, m, d) : ost_step(m, d), OST_OK);
    L += d->qpos[1] + 0.1 * d->qvel[0];
  }
  return L;
}


// a tape's control gradient of a 20-step rollout (loss on qpos and qvel; the activations carry
// each control to the later steps) against central differences of the whole rollout, without
// and with checkpoints (a segment recomputed from a checkpoint must restore act)
START_TEST(test_tapeControlGradient) {
  ost_fixtureSetup();
  mjModel* m = pendulum();
  int nv = m->nv, nu = m->nu, T = 20;
  mjData* d = mj_makeData(m);
  ost_fixtureSetProvider(m, d, 0.01, 1);
  double start[6] = {0.4, -0.7, 0.3, -0.5, 0.2, -0.3};
  double ctrl[60], gctrl[60], gq[42] = {0}, gu[42] = {0};
  for (int k = 0; k < T; k++) {
    for (int a = 0; a < nu; a++) ctrl[k * nu + a] = 0.3 * sin(0.7 * k + a);
  }
  for (int k = 1; k <= T; k++) {
    gq[k * nv + 1] = 1;    // dL/dqpos[1] at every step's end
    gu[k * nv + 0] = 0.1;  // dL/dqvel[0]
  }
  for (int S = 0; S <= 5; S += 5) {
    ostTape* tape = ost_tapeCreate(m, S);
    rolloutLoss(m, d, start, ctrl, T, tape);
    for (int i = 0; i < T * nu; i++) gctrl[i] = NAN;
    ck_assert_int_eq(ost_tapeBackward(tape, m, NULL, gq, gu, gctrl, NULL, NULL, NULL), OST_OK);
    double worst = 0, scale = 0;
    for (int i = 0; i < T * nu; i++) {
      const double eps = 1e-6;
      double c0 = ctrl[i];
      ctrl[i] = c0 + eps;
      double lp = rolloutLoss(m, d, start, ctrl, T, NULL);
      ctrl[i] = c0 - eps;
      double lm = rolloutLoss(m, d, start, ctrl, T, NULL);
      ctrl[i] = c0;
      double fd = (lp - lm) / (2 * eps);
      worst = fmax(worst, fabs(gctrl[i] - fd));
      scale = fmax(scale, fabs(fd));
    }
    printf("tape (checkpoint %d): max |dL/dctrl - FD| %.2g (relative %.2g), max %.3g\n", S,
           worst, worst / scale, scale);
    // central differences of a smooth 20-step rollout: the per-step errors above, summed over
    // 20 steps and 20 terms of L: 1e-6 of the largest entry
    ck_assert_double_le(worst, 1e-6 * scale);
    ost_tapeDelete(tape);
  }
  ost_deleteData(d);
  mj_deleteModel(m);
}
END_TEST


static Suite* suite(void) {
  Suite* s = suite_create("ost_activation");
  TCase* tc = tcase_create("activation");
  tcase_set_timeout(tc, 120);
  tcase_add_test(tc, test_filterRecurrence);
  tcase_add_test(tc, test_filterContinuous);
  tcase_add_test(tc, test_integratorClamps);
  tcase_add_test(tc, test_filterServoLargeStep);
  tcase_add_test(tc, test_userDynamicsRefused);
  tcase_add_test(tc, test_transitionGradients);
  tcase_add_test(tc, test_tapeControlGradient);
  suite_add_tcase(s, tc);
  return s;
}


int main(void) {
  return ost_fixtureRun(suite());
}
