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


static void setProvider(const mjModel* m, mjData* d, double h, int geometry) {
  ostOptions opt;
  ck_assert_int_eq(ost_readOptions(m, &opt, NULL, 0), OST_OK);
  opt.timestep = h;
  opt.geometry = geometry;
  ck_assert_int_eq(ost_setOptions(m, d, &opt), OST_OK);
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
    setProvider(m, d, h, geometry);
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
    setProvider(m, d, h, 0);
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
  setProvider(m, d, 0.1, 0);
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
    setProvider(m, d, 0.1, geometry);
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


// a model with a muscle is refused with a message naming the actuator and the dynamics
START_TEST(test_muscleRefused) {
  ost_fixtureSetup();
  mjModel* m = ost_fixtureLoadString(
      "<mujoco><worldbody><body><joint name='j' type='slide' axis='1 0 0'/>"
      "<geom type='box' size='0.1 0.1 0.1' mass='1'/></body></worldbody>"
      "<actuator><muscle name='mus' joint='j' lengthrange='-1 1'/></actuator></mujoco>");
  char err[512] = "";
  ck_assert_int_eq(ost_checkModel(m, err, sizeof(err)), OST_ERR_MODEL);
  printf("muscle: %s\n", err);
  ck_assert_ptr_nonnull(strstr(err, "'mus'"));
  ck_assert_ptr_nonnull(strstr(err, "dyntype muscle"));
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
  tcase_add_test(tc, test_muscleRefused);
  suite_add_tcase(s, tc);
  return s;
}


int main(void) {
  return ost_fixtureRun(suite());
}
