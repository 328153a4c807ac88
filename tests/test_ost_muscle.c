// test_ost_muscle.c: MuJoCo's muscle actuators (core/ost_muscle.h, core/README.md eq. 8c).
// Oracles: MuJoCo 2.2.2's own mju_muscleGain, mju_muscleBias and mju_muscleDynamics at random
// states; a bisection of the backward-Euler equation written with mju_muscleDynamics; the static
// balance of a muscle and a spring under MuJoCo's curves; mj_step on MuJoCo's arm26 sample (the
// `mujoco` provider, tendons); central differences of ost_step for ost_transition (the native
// provider, joint transmissions).
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "fixture.h"
#include "ost_activation.h"
#include "ost_muscle.h"
#include "ostrich.h"

#define ARM26 "/usr/share/mujoco/model/tendon_arm/arm26.xml"


// uniform in [lo, hi) from a fixed-seed generator (reproducible)
static double uniform(unsigned* s, double lo, double hi) {
  *s = *s * 1664525u + 1013904223u;
  return lo + (hi - lo) * (*s >> 8) / 16777216.0;
}


// random muscle parameters around MuJoCo's defaults (range, force, scale, lmin, lmax, vmax,
// fpmax, fvmax), force < 0 (scale / acc0) in half the draws, and a length range
static void randomMuscle(unsigned* s, double prm[10], double lr[2], double* acc0) {
  prm[0] = uniform(s, 0.5, 0.9);
  prm[1] = uniform(s, 1.0, 1.3);
  prm[2] = uniform(s, 0, 1) < 0.5 ? -1 : uniform(s, 1, 500);
  prm[3] = uniform(s, 50, 400);
  prm[4] = uniform(s, 0.3, 0.7);
  prm[5] = uniform(s, 1.3, 1.9);
  prm[6] = uniform(s, 0.5, 3);
  prm[7] = uniform(s, 0.8, 2);
  prm[8] = uniform(s, 1.05, 1.8);
  prm[9] = 0;
  lr[0] = uniform(s, -1, 0.5);
  lr[1] = lr[0] + uniform(s, 0.05, 2);
  *acc0 = uniform(s, 0.1, 100);
}


// the curves (gain, bias) against mju_muscleGain and mju_muscleBias at 20,000 random states: the
// normalized length over [lmin - 0.3, lmax + 0.3] (every piece of FL, FP, and 2.2.2's negative FL
// below lmin), the normalized velocity over [-1.5, fvmax] (every piece of FV)
START_TEST(test_curvesOracle) {
  ost_fixtureSetup();
  unsigned s = 12345;
  double worst_gain = 0, worst_bias = 0;
  int pieces[4] = {0};
  for (int n = 0; n < 20000; n++) {
    double prm[10], lr[2], acc0;
    randomMuscle(&s, prm, lr, &acc0);
    double L0 = (lr[1] - lr[0]) / (prm[1] - prm[0]);
    double L = uniform(&s, prm[4] - 0.3, prm[5] + 0.3), V = uniform(&s, -1.5, prm[8]);
    double len = lr[0] + (L - prm[0]) * L0, vel = V * L0 * prm[6];
    double F = prm[2] < 0 ? prm[3] / acc0 : prm[2];
    double g = osti_muscleGain(len, vel, lr, acc0, prm);
    double b = osti_muscleBias(len, lr, acc0, prm);
    double gm = mju_muscleGain(len, vel, lr, acc0, prm);
    double bm = mju_muscleBias(len, lr, acc0, prm);
    worst_gain = fmax(worst_gain, fabs(g - gm) / F);
    worst_bias = fmax(worst_bias, fabs(b - bm) / F);
    pieces[L < prm[4] ? 0 : L <= 1 ? 1 : L <= prm[5] ? 2 : 3]++;
  }
  printf("muscle curves vs MuJoCo: max |gain - mju| / F %.2g, max |bias - mju| / F %.2g "
         "(L < lmin %d, <= 1 %d, <= lmax %d, beyond %d)\n",
         worst_gain, worst_bias, pieces[0], pieces[1], pieces[2], pieces[3]);
  for (int k = 0; k < 4; k++) {
    ck_assert_int_gt(pieces[k], 1000);  // every piece of the curves drawn
  }
  // the same formulas on doubles: rounding of a few operations on O(1) normalized values
  // (FL, FV <= fvmax < 2; FP grows linearly to ~ 2), so 1e-12 of the peak force F
  ck_assert_double_le(worst_gain, 1e-12);
  ck_assert_double_le(worst_bias, 1e-12);
}
END_TEST


// the activation step against mju_muscleDynamics at 20,000 random (act-, ctrl, h, tau_act,
// tau_deact), act- and ctrl also outside [0, 1] (MuJoCo clamps ctrl, and act inside tau): act+
// satisfies act+ = act- + h mju_muscleDynamics(ctrl, act+) and lies between act- and clamped ctrl
START_TEST(test_dynamicsOracle) {
  ost_fixtureSetup();
  unsigned s = 777;
  double worst = 0;
  int outside = 0;
  for (int n = 0; n < 20000; n++) {
    double prm[2] = {uniform(&s, 1e-3, 0.05), uniform(&s, 1e-3, 0.2)};
    double act = uniform(&s, -0.2, 1.2), ctrl = uniform(&s, -0.3, 1.3);
    double h = exp(uniform(&s, log(1e-5), log(0.2)));  // h / tau from 2e-4 to 200
    double c = fmin(1, fmax(0, ctrl));
    double a = osti_muscleActNext(prm, act, ctrl, h);
    double r = a - act - h * mju_muscleDynamics(ctrl, a, prm);
    worst = fmax(worst, fabs(r));
    outside += act < 0 || act > 1;
    // monotone, no overshoot: between act- and c (rounding of an O(1) value: 1e-15)
    ck_assert_double_ge(a, fmin(act, c) - 1e-15);
    ck_assert_double_le(a, fmax(act, c) + 1e-15);
  }
  printf("muscle activation vs mju_muscleDynamics: max |act+ - act- - h act_dot(act+)| %.2g "
         "(%d of 20000 with act- outside [0, 1])\n", worst, outside);
  // the closed-form root of a quadratic with O(1) coefficients once divided by its leading term
  // (act, ctrl in [0, 1]; h / tau up to 200 enters as a ratio): rounding, 1e-12 absolute
  ck_assert_double_le(worst, 1e-12);
  ck_assert_int_gt(outside, 1000);  // the clamped pieces drawn
}
END_TEST


// a muscle on a hinge with a spring, no gravity (stiffness 100 N m/rad about springref 0,
// damping 5 N m s/rad, inertia 0.1 kg m^2; peak force scale / acc0 = 200 * 0.1 = 20 N m)
static mjModel* hinge(const char* extra) {
  char xml[2048];
  snprintf(xml, sizeof(xml),
           "<mujoco><option gravity='0 0 0'/><worldbody><body name='link'>"
           "<joint name='j' type='hinge' axis='0 0 1' stiffness='100' damping='5'/>"
           "<inertial pos='0 0 0' mass='1' diaginertia='0.1 0.1 0.1'/>"
           "</body></worldbody><actuator><muscle name='mus' joint='j' lengthrange='-1 1' %s/>"
           "</actuator></mujoco>", extra);
  return ost_fixtureLoadString(xml);
}


// act+ of the backward-Euler equation by bisection on mju_muscleDynamics (an oracle independent
// of the closed form): the root of a - act - h act_dot(ctrl, a) between act and clamped ctrl
static double bisectAct(const double prm[2], double act, double ctrl, double h) {
  double c = fmin(1, fmax(0, ctrl)), lo = fmin(act, c), hi = fmax(act, c);
  for (int k = 0; k < 200 && hi - lo > 0; k++) {
    double mid = 0.5 * (lo + hi);
    if (mid <= lo || mid >= hi) {
      break;
    }
    double r = mid - act - h * mju_muscleDynamics(ctrl, mid, prm);
    if (r > 0) {
      hi = mid;
    } else {
      lo = mid;
    }
  }
  return 0.5 * (lo + hi);
}


// the hinge muscle at full activation settles where the spring balances MuJoCo's muscle force:
// k q = gain(L, 0) act + bias(L) (mju_muscleGain, mju_muscleBias at the reached q), with both
// geometry providers; meanwhile act follows the bisected backward-Euler recurrence, on (ctrl 1
// for 1 s) then off (ctrl 0 for 1 s, the deactivation branch) then on again
START_TEST(test_hingeSteadyState) {
  ost_fixtureSetup();
  mjModel* m = hinge("");
  ck_assert_int_eq(m->na, 1);
  const double h = 0.01;
  for (int geometry = 0; geometry < 2; geometry++) {
    mjData* d = mj_makeData(m);
    ost_fixtureSetProvider(m, d, h, geometry);
    double a = 0, worst_act = 0;
    for (int k = 0; k < 400; k++) {
      d->ctrl[0] = k < 100 || k >= 200 ? 1 : 0;
      ck_assert_int_eq(ost_step(m, d), OST_OK);
      a = bisectAct(m->actuator_dynprm, a, d->ctrl[0], h);
      worst_act = fmax(worst_act, fabs(d->act[0] - a));
    }
    mj_forward(m, d);
    double len = d->actuator_length[0], vel = d->actuator_velocity[0];
    double F = mju_muscleGain(len, vel, m->actuator_lengthrange, m->actuator_acc0[0],
                              m->actuator_gainprm) * d->act[0]
               + mju_muscleBias(len, m->actuator_lengthrange, m->actuator_acc0[0],
                                m->actuator_biasprm);
    double spring = -100 * d->qpos[0];
    printf("hinge muscle (geometry %d): q = %.9f, |qvel| %.2g, act %.15f, muscle %.9f N m, "
           "spring %.9f N m, |act - BE| %.2g\n", geometry, d->qpos[0], fabs(d->qvel[0]),
           d->act[0], F, spring, worst_act);
    // the closed form and the bisection solve the same equation to rounding (1e-15 of act ~ 1)
    ck_assert_double_le(worst_act, 1e-14);
    // settled: the slowest mode decays by exp(-zeta w t) ~ exp(-8) per second over the last 2 s
    // (zeta w = c / 2I = 25 /s less the muscle's own damping), left below 1e-6 rad/s
    ck_assert_double_le(fabs(d->qvel[0]), 1e-6);
    ck_assert_double_lt(d->qpos[0], -0.05);  // the muscle pulls against the spring
    // static balance: inertia and damping at |qvel| < 1e-6 leave < 1e-5 N m; 1e-6 of F = 20
    ck_assert_double_le(fabs(F + spring), 1e-5 * 20);
    ost_deleteData(d);
  }
  mj_deleteModel(m);
}
END_TEST


// wall time of a loop of n steps, s per step
static double seconds(void) {
  struct timespec t;
  clock_gettime(CLOCK_MONOTONIC, &t);
  return t.tv_sec + 1e-9 * t.tv_nsec;
}


// MuJoCo's arm26 sample (six muscles on spatial tendons wrapping cylinders; joint limits) with
// the `mujoco` provider at its own h = 5 ms and at 5 h, 2 s of smooth controls sweeping [0, 1]:
// every step converged, no NaN, act in [0, 1], and the path close to mj_step's at h; the wall
// time per step against mj_step's. The native provider refuses tendons, so gradients are refused.
START_TEST(test_arm26) {
  ost_fixtureSetup();
  char err[1000] = "";
  mjModel* m = mj_loadXML(ARM26, NULL, err, sizeof(err));
  ck_assert_msg(m != NULL, "%s", err);
  ck_assert_int_eq(ost_checkModel(m, err, sizeof(err)), OST_OK);
  ck_assert_int_eq(m->na, 6);
  const double T = 2.0, h0 = m->opt.timestep;
  int nq = m->nq;
  // the reference: mj_step at h
  mjData* ref = mj_makeData(m);
  int n0 = (int)lround(T / h0);
  double* qref = (double*)malloc((size_t)(n0 + 1) * nq * sizeof(double));
  double t0 = seconds(), pen = 0;
  for (int k = 0; k < n0; k++) {
    for (int i = 0; i < m->nu; i++) ref->ctrl[i] = 0.5 + 0.5 * sin(3 * ref->time + i);
    mj_step(m, ref);
    for (int i = 0; i < nq; i++) {
      const double* r = m->jnt_range + 2 * i;  // one hinge per joint: qpos i is joint i
      pen = fmax(pen, fmax(r[0] - ref->qpos[i], ref->qpos[i] - r[1]));
    }
    memcpy(qref + (size_t)(k + 1) * nq, ref->qpos, nq * sizeof(double));
  }
  double mj_per_step = (seconds() - t0) / n0;
  printf("arm26 mj_step: deepest joint-limit violation %.3g rad\n", pen);
  for (int mult = 1; mult <= 5; mult += 4) {
    double h = mult * h0;
    int n = (int)lround(T / h);
    mjData* d = mj_makeData(m);
    ost_fixtureSetProvider(m, d, h, OST_GEOMETRY_MUJOCO);
    double worst = 0;
    t0 = seconds();
    for (int k = 0; k < n; k++) {
      for (int i = 0; i < m->nu; i++) d->ctrl[i] = 0.5 + 0.5 * sin(3 * d->time + i);
      ck_assert_int_eq(ost_step(m, d), OST_OK);
      for (int i = 0; i < nq; i++) {
        ck_assert(isfinite(d->qpos[i]) && isfinite(d->qvel[i]));
        worst = fmax(worst, fabs(d->qpos[i] - qref[(size_t)(k + 1) * mult * nq + i]));
      }
      for (int i = 0; i < m->na; i++) {
        ck_assert(isfinite(d->act[i]) && d->act[i] >= 0 && d->act[i] <= 1);
      }
    }
    double per_step = (seconds() - t0) / n;
    printf("arm26 h = %g ms: %d steps converged, max |q - mj_step| %.3g rad, %.1f us per step "
           "(mj_step at 5 ms: %.1f us)\n", 1e3 * h, n, worst, 1e6 * per_step, 1e6 * mj_per_step);
    // the same controlled motion by two integrators: the controls drive the arm into its joint
    // limits, which MuJoCo's soft rows let it pass by ~ 0.04 rad and Ostrich's hard rows do not,
    // plus first-order differences O(h) in act and u (muscle time constants 10-40 ms); measured
    // 0.07 rad at both h, so 0.2 rad (a tenth of the 2.1 rad range) flags a wrong muscle force
    ck_assert_double_le(worst, 0.2);
    ost_deleteData(d);
  }
  // gradients need the native provider, which refuses tendons
  mjData* d = mj_makeData(m);
  double* A = (double*)malloc((size_t)(2 * m->nv + m->na) * (2 * m->nv + m->na) * sizeof(double));
  int status = ost_transition(m, d, A, NULL);
  printf("arm26 gradients: status %d\n", status);
  ck_assert_int_ne(status, OST_OK);
  free(A);
  free(qref);
  ost_deleteData(d);
  mj_deleteData(ref);
  mj_deleteModel(m);
}
END_TEST


// a double pendulum under gravity with two muscles on the joints (joint transmissions, native
// provider), one a `general` with muscle gain and bias but no dynamics (ctrl drives it directly)
static mjModel* muscleArm(void) {
  return ost_fixtureLoadString(
      "<mujoco><option gravity='0 0 -9.81'/><worldbody><body name='upper'>"
      "<joint name='shoulder' type='hinge' axis='0 1 0'/>"
      "<geom type='capsule' fromto='0 0 0 0.4 0 0' size='0.03' mass='1' contype='0' "
      "conaffinity='0'/><body name='lower' pos='0.4 0 0'>"
      "<joint name='elbow' type='hinge' axis='0 1 0'/>"
      "<geom type='capsule' fromto='0 0 0 0.4 0 0' size='0.03' mass='1' contype='0' "
      "conaffinity='0'/></body></body></worldbody><actuator>"
      "<general name='direct' joint='elbow' gaintype='muscle' biastype='muscle' "
      "gainprm='0.75 1.05 30 200 0.5 1.6 1.5 1.3 1.2' biasprm='0.75 1.05 30 200 0.5 1.6 1.5 1.3 "
      "1.2' lengthrange='-1.2 1.2'/>"
      "<muscle name='sh' joint='shoulder' lengthrange='-1.5 1.5'/>"
      "<muscle name='el' joint='elbow' gear='-1' lengthrange='-1.5 1.5' timeconst='0.02 0.05'/>"
      "</actuator></mujoco>");
}


// ost_transition's A and B against central differences of ost_step (native provider): one
// muscle activating (ctrl > act), one deactivating (ctrl < act), at lengths and velocities inside
// the curves' smooth pieces (the pieces' knots and ctrl = act are kinks)
START_TEST(test_transitionGradients) {
  ost_fixtureSetup();
  mjModel* m = muscleArm();
  int nv = m->nv, na = m->na, nu = m->nu, nx = 2 * nv + na;
  ck_assert_int_eq(na, 2);
  mjData* d = mj_makeData(m);
  ost_fixtureSetProvider(m, d, 0.01, OST_GEOMETRY_NATIVE);
  double q0[2] = {0.3, -0.4}, v0[2] = {0.2, -0.3}, a0[2] = {0.2, 0.7}, u0[3] = {0.6, 0.8, 0.3};
  double A[36], B[18], worst_a, worst_b, scale;
  ck_assert(nx * nx <= 36 && nx * nu <= 18);
  ost_fixtureSetState(m, d, q0, v0, a0, u0);
  ost_fixtureTransitionCheck(m, d, "muscle transition", A, B, &worst_a, &worst_b, &scale);
  // central differences: truncation eps^2 |x'''| ~ 1e-12 and rounding 1e-16 / eps ~ 1e-10 (no
  // contact: Newton solves the step to rounding); 1e-7 of the largest entry
  ck_assert_double_le(worst_a, 1e-7 * fmax(1, scale));
  ck_assert_double_le(worst_b, 1e-7 * fmax(1, scale));
  ost_deleteData(d);
  mj_deleteModel(m);
}
END_TEST


// the parameter gradients of a rollout with a muscle beside fixed-gain actuators
// (tests/models/activation_pusher.xml): a muscle's gainprm[0] and biasprm[1], [2] shape its
// curves, which the adjoint does not differentiate, so they come back NaN (its gainprm[0] moves
// the loss: MuJoCo reads it as the lower end of the operating range), on a tape and in a batch;
// the motor's unread biasprm has gradient 0; the fixed gains and the servo's affine bias are
// finite
START_TEST(test_muscleParamsUnknown) {
  ost_fixtureSetup();
  mjModel* m = ost_fixtureLoadModel("../tests/models/activation_pusher.xml");
  int nv = m->nv, nu = m->nu, np = ost_nparam(m), T = 20;
  int gain = ost_paramAddress(m, OST_PARAM_GAIN), bpos = ost_paramAddress(m, OST_PARAM_BIASPOS);
  int bvel = ost_paramAddress(m, OST_PARAM_BIASVEL), mus = 3, motor = 0, servo = 1;
  ck_assert_int_eq(m->actuator_gaintype[mus], mjGAIN_MUSCLE);
  mjtNum *gq = calloc((T + 1) * nv, 8), *gt = calloc(np, 8), *gc = calloc(T * nu, 8);
  mjtNum* ctrl = calloc(T * nu, 8);
  for (int t = 0; t < T; t++) {
    for (int a = 0; a < nu; a++) ctrl[t * nu + a] = 0.5;
  }
  for (int i = 0; i < (T + 1) * nv; i++) gq[i] = sin(0.7 * i);
  ostGradOptions go;
  ost_defaultGradOptions(&go);
  go.params = 1;
  go.forward_only = 1;
  mjData* d = mj_makeData(m);
  ostTape* tape = ost_tapeCreate(m, 0);
  for (int t = 0; t < T; t++) {
    memcpy(d->ctrl, ctrl + t * nu, nu * sizeof(mjtNum));
    ck_assert_int_eq(ost_tapeStep(tape, m, d), OST_OK);
  }
  ck_assert_int_eq(ost_tapeBackward(tape, m, &go, gq, NULL, gc, NULL, NULL, gt), OST_OK);
  char err[1000];
  ostBatch* b = ost_batchCreate(m, 1, "cpu:1", err, sizeof(err));
  ck_assert_msg(b != NULL, "%s", err);
  mjtNum* gb = calloc(np, 8);
  ck_assert_int_eq(ost_batchSetState(b, NULL, NULL), OST_OK);
  ck_assert_int_eq(ost_batchRollout(b, T, ctrl, NULL, NULL), OST_OK);
  ck_assert_int_eq(ost_batchBackwardParams(b, &go, 0, gq, NULL, NULL, NULL, NULL, gb), OST_OK);
  for (int k = 0; k < 2; k++) {
    const mjtNum* g = k ? gb : gt;
    printf("%s: muscle gain %g, bias %g %g; motor gain %g, bias %g; servo bias %g\n",
           k ? "batch" : "tape", g[gain + mus], g[bpos + mus], g[bvel + mus], g[gain + motor],
           g[bpos + motor], g[bpos + servo]);
    ck_assert(isnan(g[gain + mus]) && isnan(g[bpos + mus]) && isnan(g[bvel + mus]));
    ck_assert(isfinite(g[gain + motor]) && g[gain + motor] != 0);
    ck_assert(isfinite(g[bpos + servo]) && g[bpos + servo] != 0);
    ck_assert_double_eq(g[bpos + motor], 0);
    for (int i = 0; i < gain; i++) ck_assert(isfinite(g[i]));  // friction, mass, damping
  }
  ost_batchDelete(b);
  ost_tapeDelete(tape);
  ost_deleteData(d);
  free(gq); free(gt); free(gc); free(ctrl); free(gb);
  mj_deleteModel(m);
}
END_TEST


static Suite* suite(void) {
  Suite* s = suite_create("ost_muscle");
  TCase* tc = tcase_create("muscle");
  tcase_set_timeout(tc, 300);
  tcase_add_test(tc, test_curvesOracle);
  tcase_add_test(tc, test_dynamicsOracle);
  tcase_add_test(tc, test_hingeSteadyState);
  tcase_add_test(tc, test_arm26);
  tcase_add_test(tc, test_transitionGradients);
  tcase_add_test(tc, test_muscleParamsUnknown);
  suite_add_tcase(s, tc);
  return s;
}


int main(void) {
  return ost_fixtureRun(suite());
}
