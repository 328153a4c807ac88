// test_ost_frictionloss.c: dry friction (joint and tendon frictionloss) and tendon limits as hard
// rows of Ostrich's step, against their closed forms: a hinge under a torque below its
// frictionloss does not move at any h, above it accelerates at (tau - frictionloss) / I exactly;
// a tendon's frictionloss holds coef times its bound; a tendon at its limit holds with the
// constraint force the load needs. The one-step Jacobians (ost_transition) agree with finite
// differences of ost_step in both the sticking and the sliding regime.
#include <math.h>
#include <stdio.h>
#include <stdlib.h>

#include "fixture.h"
#include "ostrich.h"

static const double kLoss = 1.0;  // frictionloss of the hinge or tendon (N m)

// a rotor about the vertical axis (gravity exerts no torque on it) with a motor of gear 1;
// joint_loss on the hinge, or a fixed tendon of coefficient coef with tendon_loss and, when
// limited, range (lo, hi)
static mjModel* rotor(double joint_loss, double coef, double tendon_loss, int limited, double lo,
                      double hi) {
  char xml[2048], tendon[512] = "";
  if (coef != 0) {
    snprintf(tendon, sizeof(tendon),
             "<tendon><fixed name='t' frictionloss='%.17g' limited='%s' range='%.17g %.17g'>"
             "<joint joint='hinge' coef='%.17g'/></fixed></tendon>",
             tendon_loss, limited ? "true" : "false", lo, hi, coef);
  }
  snprintf(xml, sizeof(xml),
           "<mujoco><worldbody><body name='rotor'>"
           "<joint name='hinge' type='hinge' axis='0 0 1' frictionloss='%.17g'/>"
           "<geom type='box' size='0.5 0.1 0.1' mass='2' contype='0' conaffinity='0'/>"
           "</body></worldbody>%s<actuator><motor joint='hinge' gear='1'/></actuator></mujoco>",
           joint_loss, tendon);
  return ost_fixtureLoadString(xml);
}


// moment of inertia about the hinge, from MuJoCo's mass matrix
static double inertia(const mjModel* m, mjData* d) {
  mj_forward(m, d);
  return d->qM[0];
}


// step 1 s at h under torque tau from rest; every step converged
static void run(const mjModel* m, mjData* d, double h, double tau) {
  mj_resetData(m, d);
  d->ctrl[0] = tau;
  int n = (int)lround(1.0 / h);
  for (int k = 0; k < n; k++) {
    int status = ost_step(m, d);
    ck_assert_msg(status == OST_OK, "h=%g step %d: status %d %s", h, k, status,
                  ost_lastError(d));
  }
}


// a hinge under half and one and a half times its frictionloss, at h = 1, 10, 100 ms, with both
// geometry providers: sticking, it stays put; sliding, the backward Euler recurrence under the
// constant net torque tau - loss gives u_n = n h (tau - loss) / I exactly
START_TEST(test_jointStickAndSlide) {
  ost_fixtureSetup();
  mjModel* m = rotor(kLoss, 0, 0, 0, 0, 0);
  mjData* d = mj_makeData(m);
  double I = inertia(m, d);
  for (int geometry = 0; geometry < 2; geometry++) {
    for (double h = 1e-3; h < 0.2; h *= 10) {
      ost_fixtureSetProvider(m, d, h, geometry);
      run(m, d, h, 0.5 * kLoss);
      // the sticking compliance reg k_f (reg = 1e-6, k_f = h / I) lets it creep at
      // reg h tau / I <= 3e-7 rad/s here; 1e-6 rad over 1 s would be a slip of the dry friction
      printf("frictionloss stick geometry %d h=%g: q = %.3g rad\n", geometry, h, d->qpos[0]);
      ck_assert_double_lt(fabs(d->qpos[0]), 1e-6);
      for (int sign = -1; sign <= 1; sign += 2) {
        run(m, d, h, sign * 1.5 * kLoss);
        double u = sign * 0.5 * kLoss / I * 1.0;  // t = 1 s
        printf("frictionloss slide geometry %d h=%g: u = %.12g (closed form %.12g)\n",
               geometry, h, d->qvel[0], u);
        // rounding and the solver's tol (1e-10 m/s) over at most 1,000 steps
        ck_assert_double_eq_tol(d->qvel[0], u, 1e-7 * fabs(u));
      }
    }
  }
  ost_deleteData(d);
  mj_deleteModel(m);
}
END_TEST


// a tendon of coefficient 2 with frictionloss 1 holds joint torques up to 2 N m (its force 1 N
// times its moment arm 2) and lets a larger one through at (tau - 2) / I
START_TEST(test_tendonFrictionloss) {
  ost_fixtureSetup();
  mjModel* m = rotor(0, 2, kLoss, 0, 0, 0);
  mjData* d = mj_makeData(m);
  double I = inertia(m, d), h = 0.01;
  ost_fixtureSetProvider(m, d, h, OST_GEOMETRY_MUJOCO);
  run(m, d, h, 1.9 * kLoss);
  // the same creep bound as a joint's (the tendon's k_f is 4 h / I, its force 0.95 N)
  ck_assert_double_lt(fabs(d->qpos[0]), 1e-6);
  run(m, d, h, 3 * kLoss);
  ck_assert_double_eq_tol(d->qvel[0], 1.0 / I, 1e-7 / I);
  ost_deleteData(d);
  mj_deleteModel(m);
}
END_TEST


// a tendon limited to L <= 0.3 rad pulled by 2 N m: it comes to rest at its limit within the
// hard-contact allowance (the FB smoothing leaves a gap of order fb_eps) and the constraint
// force it publishes balances the load (qfrc_constraint = -tau at rest); also with coef -1,
// where the joint's upper motion is the tendon's lower limit
START_TEST(test_tendonLimitHolds) {
  ost_fixtureSetup();
  for (int flip = 0; flip < 2; flip++) {
    double coef = flip ? -1 : 1;
    mjModel* m = rotor(0, coef, 0, 1, flip ? -0.3 : -1, flip ? 1 : 0.3);
    mjData* d = mj_makeData(m);
    double h = 0.02;
    ost_fixtureSetProvider(m, d, h, OST_GEOMETRY_MUJOCO);
    run(m, d, h, 2.0);
    double L = coef * d->qpos[0];
    printf("tendon limit coef %g: L = %.9f, u = %.3g, qfrc_constraint = %.9f\n", coef, L,
           d->qvel[0], d->qfrc_constraint[0]);
    ck_assert_double_eq_tol(fabs(L), 0.3, 1e-6);
    ck_assert_double_lt(fabs(d->qvel[0]), 1e-6);
    ck_assert_double_eq_tol(d->qfrc_constraint[0], -2.0, 1e-6);
    ost_deleteData(d);
    mj_deleteModel(m);
  }
}
END_TEST


// ost_transition's B = d(q+, u+)/d ctrl and A's velocity block against central differences of
// ost_step, sticking (tau = 0.5, u = 0: every derivative zero, the friction absorbs any small
// change) and sliding (tau = 1.5, u = 0.3: du+/dctrl = h / I, du+/du- = 1)
START_TEST(test_frictionlossGradients) {
  ost_fixtureSetup();
  mjModel* m = rotor(kLoss, 0, 0, 0, 0, 0);
  mjData* d = mj_makeData(m);
  double I = inertia(m, d), h = 0.01, eps = 1e-6;
  for (int slide = 0; slide < 2; slide++) {
    ost_fixtureSetProvider(m, d, h, OST_GEOMETRY_MUJOCO);
    mj_resetData(m, d);
    double tau = slide ? 1.5 : 0.5, u0 = slide ? 0.3 : 0;
    d->ctrl[0] = tau;
    d->qvel[0] = u0;
    double A[4], B[2];
    ck_assert_int_eq(ost_transition(m, d, A, B), OST_OK);
    double fd[2][2];  // [perturbed input: ctrl, qvel][output: q, u]
    for (int in = 0; in < 2; in++) {
      double out[2][2];
      for (int s = 0; s < 2; s++) {
        mj_resetData(m, d);
        d->ctrl[0] = tau + (in == 0 ? (s ? eps : -eps) : 0);
        d->qvel[0] = u0 + (in == 1 ? (s ? eps : -eps) : 0);
        ck_assert_int_eq(ost_step(m, d), OST_OK);
        out[s][0] = d->qpos[0];
        out[s][1] = d->qvel[0];
      }
      fd[in][0] = (out[1][0] - out[0][0]) / (2 * eps);
      fd[in][1] = (out[1][1] - out[0][1]) / (2 * eps);
    }
    double want_b = slide ? h / I : 0, want_a = slide ? 1 : 0;
    printf("frictionloss gradients slide=%d: B = (%.9g, %.9g), fd (%.9g, %.9g); du+/du- = %.9g, "
           "fd %.9g\n", slide, B[0], B[1], fd[0][0], fd[0][1], A[3], fd[1][1]);
    // A, B: exact up to the solver's tol, except that sticking lets through the share of the
    // sticking compliance, reg k_f = reg h / I (1e-6 of the free response); the differences:
    // rounding / eps ~ 1e-10 / 1e-6
    double allow = 2e-6 * h / I;
    ck_assert_double_eq_tol(B[1], want_b, allow);
    ck_assert_double_eq_tol(B[0], h * want_b, h * allow);
    ck_assert_double_eq_tol(A[3], want_a, 2e-6);
    ck_assert_double_eq_tol(fd[0][1], want_b, 1e-4);
    ck_assert_double_eq_tol(fd[1][1], want_a, 1e-4);
  }
  ost_deleteData(d);
  mj_deleteModel(m);
}
END_TEST


static Suite* suite(void) {
  Suite* s = suite_create("ost_frictionloss");
  TCase* tc = tcase_create("frictionloss");
  tcase_set_timeout(tc, 120);
  tcase_add_test(tc, test_jointStickAndSlide);
  tcase_add_test(tc, test_tendonFrictionloss);
  tcase_add_test(tc, test_tendonLimitHolds);
  tcase_add_test(tc, test_frictionlossGradients);
  suite_add_tcase(s, tc);
  return s;
}


int main(void) {
  return ost_fixtureRun(suite());
}
