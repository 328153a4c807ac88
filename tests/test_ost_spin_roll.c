// test_ost_spin_roll.c: torsional (condim 4) and rolling (condim 6) friction as rows of the
// contact's friction cone (MuJoCo's elliptic cone, normalized rows, core/ost_constraint.h),
// against closed forms: a sphere spinning on a plane stops at the rate its torsional coefficient
// gives and then stays put; a ball rolling on a plane decelerates at its rolling coefficient's
// rate. Both geometry providers, several h; one-step Jacobians against finite differences.
#include <math.h>
#include <stdio.h>
#include <stdlib.h>

#include "fixture.h"
#include "ostrich.h"

static const double kG = 9.81, kR = 0.1, kMass = 1;

// a solid sphere of radius kR and mass kMass resting on a plane, with condim and friction
// (sliding, torsional, rolling) on both geoms
static mjModel* ball(int condim, double slide, double torsion, double roll) {
  char xml[1024];
  snprintf(xml, sizeof(xml),
           "<mujoco><option gravity='0 0 %.17g'/><default><geom condim='%d' "
           "friction='%.17g %.17g %.17g'/></default><worldbody>"
           "<geom type='plane' size='20 20 1'/>"
           "<body pos='0 0 %.17g'><freejoint/><geom type='sphere' size='%.17g' mass='%.17g'/>"
           "</body></worldbody></mujoco>",
           -kG, condim, slide, torsion, roll, kR, kR, kMass);
  return ost_fixtureLoadString(xml);
}


static void setup(const mjModel* m, mjData* d, double h, int geometry) {
  ost_fixtureSetProvider(m, d, h, geometry);
  mj_resetData(m, d);
}


static void stepTo(const mjModel* m, mjData* d, double h, double t) {
  int n = (int)lround(t / h);
  for (int k = 0; k < n; k++) {
    int status = ost_step(m, d);
    ck_assert_msg(status == OST_OK, "h=%g step %d: status %d %s", h, k, status,
                  ost_lastError(d));
  }
}


// spin about the normal at w0 = 10 rad/s with torsional coefficient 0.01 m: the torsional
// friction torque is mu_t m g (the cone saturated along its torsional axis alone, no slip), so
// with I = 2/5 m r^2 the spin falls linearly, dw/dt = -mu_t g / (0.4 r^2) = -24.5 rad/s^2, and
// stops at t = 0.41 s; the backward Euler recurrence of a constant torque is exact
START_TEST(test_spinStops) {
  ost_fixtureSetup();
  double mu_t = 0.01, w0 = 10, rate = mu_t * kG / (0.4 * kR * kR);
  mjModel* m = ball(4, 1, mu_t, 0);
  mjData* d = mj_makeData(m);
  for (int geometry = 0; geometry < 2; geometry++) {
    for (double h = 1e-3; h < 0.06; h *= 5) {
      setup(m, d, h, geometry);
      d->qvel[5] = w0;
      stepTo(m, d, h, 0.2);
      double want = w0 - rate * 0.2;
      printf("spin geometry %d h=%g: w(0.2 s) = %.9f (closed form %.9f)\n", geometry, h,
             d->qvel[5], want);
      // the normal force equals m g to the FB smoothing and the regularization (1e-6 relative)
      ck_assert_double_eq_tol(d->qvel[5], want, 1e-5 * w0);
      stepTo(m, d, h, 0.8);
      // stopped: the torsional friction holds it (creep of the regularization only)
      ck_assert_double_lt(fabs(d->qvel[5]), 1e-6);
      ck_assert_double_lt(hypot(d->qvel[0], d->qvel[1]), 1e-9);  // no sliding arises
    }
  }
  ost_deleteData(d);
  mj_deleteModel(m);
}
END_TEST


// roll at v0 = 2 m/s (w = v0 / r, no slip) with rolling coefficient 0.002 m and sliding
// coefficient 1: the rolling torque mu_r m g opposes the spin, the ground's tangential force F
// keeps it from slipping: m a = F, I a / r = -F r - mu_r m g, so a = -mu_r g r / (r^2 + I / m)
// = -5 mu_r g / (7 r) = -0.140 m/s^2. In the elliptic cone the tangential force takes the share
// (F / (mu m g))^2 ~ (2 mu_r / (7 r))^2 ~ 3e-5 of the cone, so the rolling torque is mu_r m g to
// that relative order.
START_TEST(test_rollDecelerates) {
  ost_fixtureSetup();
  double mu_r = 0.002, v0 = 2, a = 5 * mu_r * kG / (7 * kR);
  mjModel* m = ball(6, 1, 0.005, mu_r);
  mjData* d = mj_makeData(m);
  for (int geometry = 0; geometry < 2; geometry++) {
    for (double h = 1e-3; h < 0.06; h *= 5) {
      setup(m, d, h, geometry);
      d->qvel[0] = v0;
      d->qvel[4] = v0 / kR;
      stepTo(m, d, h, 0.5);
      double v_half = d->qvel[0];
      stepTo(m, d, h, 0.5);
      double v = d->qvel[0], rate = (v_half - v) / 0.5;
      printf("roll geometry %d h=%g: deceleration %.9f (closed form %.9f), slip %.3g m/s\n",
             geometry, h, rate, a, v - kR * d->qvel[4]);
      // measured once the slip below has built up (over the first steps, where v loses
      // slip I / (I + m r^2) ~ 7e-5 m/s less); 2e-4 is above the cone share 3e-5
      ck_assert_double_eq_tol(rate, a, 2e-4 * a);
      // it rolls, but not perfectly: in the elliptic cone the tangential force F needs a slip
      // along the slip direction in the cone's share, slip / (mu_r w) = F / (mu m g), so
      // slip ~ (mu_r / mu) w x 0.014 = 0.036 m/s x 0.014 = 5e-4 m/s; 1e-3 m/s would be a ball
      // that skids
      ck_assert_double_lt(fabs(v - kR * d->qvel[4]), 1e-3);
    }
  }
  ost_deleteData(d);
  mj_deleteModel(m);
}
END_TEST


// ost_transition's velocity block for a rolling, spinning ball (condim 6, sliding of the cone
// along its rolling and torsional axes) against central differences of ost_step
START_TEST(test_spinRollGradients) {
  ost_fixtureSetup();
  mjModel* m = ball(6, 1, 0.01, 0.002);
  mjData* d = mj_makeData(m);
  int nv = m->nv;
  double h = 0.01, eps = 1e-6;
  double u0[6] = {0.5, 0.2, 0, 0.3, 0.5 / kR, 4};
  double* A = calloc(4 * nv * nv, sizeof(double));
  setup(m, d, h, OST_GEOMETRY_NATIVE);
  stepTo(m, d, h, 0.05);  // settle into contact
  double q0[7];
  for (int i = 0; i < 7; i++) q0[i] = d->qpos[i];
  for (int i = 0; i < 6; i++) d->qvel[i] = u0[i];
  ck_assert_int_eq(ost_transition(m, d, A, NULL), OST_OK);
  double worst = 0, scale = 0;
  for (int j = 0; j < nv; j++) {
    double out[2][6];
    for (int s = 0; s < 2; s++) {
      for (int i = 0; i < 7; i++) d->qpos[i] = q0[i];
      for (int i = 0; i < 6; i++) d->qvel[i] = u0[i] + (i == j ? (s ? eps : -eps) : 0);
      d->time = 0;
      ck_assert_int_eq(ost_step(m, d), OST_OK);
      for (int i = 0; i < 6; i++) out[s][i] = d->qvel[i];
    }
    for (int i = 0; i < nv; i++) {
      double fd = (out[1][i] - out[0][i]) / (2 * eps);
      double an = A[(nv + i) * 2 * nv + nv + j];  // d u+_i / d u-_j
      worst = fmax(worst, fabs(an - fd));
      scale = fmax(scale, fabs(fd));
    }
  }
  printf("spin/roll gradients: max |adjoint - fd| = %.3g of max |fd| = %.3g\n", worst, scale);
  // differences of steps solved to tol 1e-10: rounding / eps ~ 1e-4 of an O(1) Jacobian
  ck_assert_double_lt(worst, 1e-4 * scale);
  free(A);
  ost_deleteData(d);
  mj_deleteModel(m);
}
END_TEST


static Suite* suite(void) {
  Suite* s = suite_create("ost_spin_roll");
  TCase* tc = tcase_create("spin_roll");
  tcase_set_timeout(tc, 120);
  tcase_add_test(tc, test_spinStops);
  tcase_add_test(tc, test_rollDecelerates);
  tcase_add_test(tc, test_spinRollGradients);
  suite_add_tcase(s, tc);
  return s;
}


int main(void) {
  return ost_fixtureRun(suite());
}
