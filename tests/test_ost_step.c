// test_ost_step.c: ost_step against closed-form backward Euler updates, reproducibility of a step
// repeated from a restored state, the splitting of steps whose Newton solve fails, and the cold
// retry of a Newton loop that its warm start sent into a cycle.
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "fixture.h"
#include "ostrich.h"

static const char* free_fall =
  "<mujoco><option timestep='0.1' gravity='0 0 -9.81'/>"
  "<worldbody><body pos='0 0 10'><freejoint/><geom type='sphere' size='0.1' mass='2'"
  " contype='0' conaffinity='0'/></body></worldbody></mujoco>";

// free fall: u+ = u- + h g, z+ = z- + h u+ (backward Euler, exact for constant force)
START_TEST(test_freeFall) {
  ost_fixtureSetup();
  mjModel* m = ost_fixtureLoadString(free_fall);
  mjData* d = mj_makeData(m);
  double h = 0.1, g = 9.81, z = 10, vz = 0;
  d->qvel[0] = 1.5;
  for (int k = 0; k < 20; k++) {
    ck_assert_int_eq(ost_step(m, d), OST_OK);
    vz -= h * g;
    z += h * vz;
    ck_assert_double_eq_tol(d->qvel[2], vz, 1e-10);
    ck_assert_double_eq_tol(d->qpos[2], z, 1e-10);
    ck_assert_double_eq_tol(d->qpos[0], 1.5 * h * (k + 1), 1e-10);
  }
  ck_assert_double_eq_tol(d->time, 2.0, 1e-12);
  ost_deleteData(d);
  mj_deleteModel(m);
}
END_TEST

// a step repeated from a restored state (as finite differences do) starts cold and gives the
// same result bitwise every time, and agrees with the warm-started step to solver accuracy
START_TEST(test_repeatFromRestoredState) {
  ost_fixtureSetup();
  mjModel* m = ost_fixtureLoadModel("wheeled_robot.xml");
  mjData* d = mj_makeData(m);
  ost_fixtureSetTimestep(m, d, 0.05);
  for (int i = 0; i < m->nu; i++) d->ctrl[i] = 3;
  for (int k = 0; k < 20; k++) ck_assert_int_eq(ost_step(m, d), OST_OK);
  int nq = m->nq, nv = m->nv;
  double t0 = d->time, q0[64], v0[64], a0[64], warm[64], cold[64];
  memcpy(q0, d->qpos, nq * sizeof(double));
  memcpy(v0, d->qvel, nv * sizeof(double));
  memcpy(a0, d->qacc_warmstart, nv * sizeof(double));
  ck_assert_int_eq(ost_step(m, d), OST_OK);
  memcpy(warm, d->qvel, nv * sizeof(double));
  for (int rep = 0; rep < 2; rep++) {
    d->time = t0;
    memcpy(d->qpos, q0, nq * sizeof(double));
    memcpy(d->qvel, v0, nv * sizeof(double));
    memcpy(d->qacc_warmstart, a0, nv * sizeof(double));
    ck_assert_int_eq(ost_step(m, d), OST_OK);
    for (int j = 0; j < nv; j++) {
      if (rep == 0) {
        cold[j] = d->qvel[j];
        // solver accuracy: both solves stop at tol (1e-10 m/s) from different starts; 1e-8 is
        // 100 times that, for the merit's scaling to qvel
        ck_assert_double_eq_tol(cold[j], warm[j], 1e-8);
      } else {
        ck_assert(d->qvel[j] == cold[j]);
      }
    }
  }
  ost_deleteData(d);
  mj_deleteModel(m);
}
END_TEST


// a step whose Newton solve fails (a wheel meeting the pallet edge at h = 0.1 s with a budget
// of 3 Newton iterates) is split into substeps: the stats say so and time still advances by
// exactly h per ost_step. The split is bounded: three levels freely (2^3 substeps), then at most
// deep_splits more halvings, each adding one substep (a step failing at every level of six would
// otherwise cost 2^6 loops)
START_TEST(test_splitStep) {
  ost_fixtureSetup();
  mjModel* m = ost_fixtureLoadModel("robot_pallet.xml");
  mjData* d = mj_makeData(m);
  ostOptions opt;
  ck_assert_int_eq(ost_readOptions(m, &opt, NULL, 0), OST_OK);
  opt.timestep = 0.1;
  opt.newton_iter = 3;
  ck_assert_int_eq(ost_setOptions(m, d, &opt), OST_OK);
  for (int i = 0; i < m->nu; i++) d->ctrl[i] = 3;
  int split = 0, warned = 0, most = 0;
  for (int k = 0; k < 20; k++) {
    // a step is a warning exactly when a committed substep stayed above tol
    int status = ost_step(m, d);
    ck_assert(status == OST_OK || status == OST_WARN_NOT_CONVERGED);
    ck_assert_int_eq(status == OST_WARN_NOT_CONVERGED, ost_stats(d)->residual > opt.tol);
    ck_assert_int_eq(status == OST_WARN_NOT_CONVERGED,
                     (ost_stats(d)->status & OST_NOT_CONVERGED) != 0);
    // the warning's message names it (a caller printing ost_lastError says why), a converged
    // step leaves none
    ck_assert_int_eq(status == OST_WARN_NOT_CONVERGED,
                     strstr(ost_lastError(d), "did not converge") != NULL);
    ck_assert_int_eq(status == OST_OK, ost_lastError(d)[0] == 0);
    warned += status != OST_OK;
    split += ost_stats(d)->substeps > 1;
    ck_assert_int_le(ost_stats(d)->substeps, 8 + opt.deep_splits);
    most = ost_stats(d)->substeps > most ? ost_stats(d)->substeps : most;
    ck_assert_double_eq_tol(d->time, 0.1 * (k + 1), 1e-12);
  }
  printf("pallet h=0.1: %d of 20 steps split, %d not converged, at most %d substeps\n", split,
         warned, most);
  // with 3 Newton iterates the wheel's steps on the edge fail at every level (measured: 13 of
  // 20 unconverged): such a step takes the whole budget, and no more
  ck_assert_int_eq(most, 8 + opt.deep_splits);
  ck_assert_int_eq(ost_totals(d)->unconverged, warned);
  ck_assert_int_eq(ost_totals(d)->steps, 20);
  ck_assert_int_gt(split, 0);
  ost_deleteData(d);
  mj_deleteModel(m);
}
END_TEST

// uniform numbers in [0, 1) from xorshift64 (Marsaglia 2003), the same on every machine
static double uniform(uint64_t* x) {
  *x ^= *x << 13;
  *x ^= *x >> 7;
  *x ^= *x << 17;
  return (double)(*x >> 11) * 0x1p-53;
}


// tests/models/planar_legs.xml, loaded after the fixture's setup
static mjModel* loadPlanarLegs(void) {
  ost_fixtureSetup();
  char path[1024], err[1000] = "";
  snprintf(path, sizeof(path), "%s/../tests/models/planar_legs.xml", OST_MODEL_DIR);
  mjModel* m = mj_loadXML(path, NULL, err, sizeof(err));
  ck_assert_msg(m != NULL, "%s", err);
  return m;
}


// the planar legs' random motor controls before step k: uniform in [-1, 1], new every 3 steps
static void planarControls(const mjModel* m, mjData* d, int k, uint64_t* x) {
  for (int i = 0; i < m->nu && k % 3 == 0; i++) d->ctrl[i] = 2 * uniform(x) - 1;
}


// a planar body on two legs with capsule feet (tests/models/planar_legs.xml), driven by random
// motor controls held for 3 steps of h = 0.07 s: at the 56th step of this sequence the Newton loop
// started from the last step's forces and acceleration cycles with period 2 (merit 2.5e-2 and
// 2.6e-2 m/s) and never reaches tol, through every split. From a cold start (u-, no carried
// forces) the same step converges. With cold_retry every step of the sequence
// converges; with it off (and split_depth 3) the stall is reported as a warning. (The stall is a
// property of this trajectory's bits: should a change of the solver remove it with cold_retry off, this test
// says so and needs a new sequence.)
START_TEST(test_coldRetry) {
  mjModel* m = loadPlanarLegs();
  mjData* d = mj_makeData(m);
  for (int retry = 0; retry < 2; retry++) {
    ostOptions opt;
    ck_assert_int_eq(ost_readOptions(m, &opt, NULL, 0), OST_OK);
    ck_assert_int_eq(opt.cold_retry, 1);  // the default
    opt.timestep = 0.07;
    opt.cold_retry = retry;
    opt.split_depth = 3;  // (halving six times also gets past the stall, slowly)
    mj_resetData(m, d);
    ck_assert_int_eq(ost_setOptions(m, d, &opt), OST_OK);
    ost_resetTotals(d);
    uint64_t x = 1835 * 0x9E3779B97F4A7C15ull + 1;
    int first_unconverged = -1;
    for (int k = 0; k < 100; k++) {
      planarControls(m, d, k, &x);
      int status = ost_step(m, d);
      ck_assert(status == OST_OK || status == OST_WARN_NOT_CONVERGED);
      if (status != OST_OK && first_unconverged < 0) first_unconverged = k;
      // a retried step said so, and only a loop that failed is retried
      ck_assert(retry || ost_stats(d)->retries == 0);
    }
    const ostTotals* t = ost_totals(d);
    printf("planar legs h=0.07, cold_retry %d: %ld of 100 steps not converged (first: step %d),"
           " %ld cold retries, worst residual %.3g m/s\n", retry, t->unconverged,
           first_unconverged, t->retries, t->worst_residual);
    if (retry) {
      ck_assert_int_eq(t->unconverged, 0);
      ck_assert_int_ge(t->retries, 1);
      ck_assert_double_le(t->worst_residual, opt.tol);
    } else {
      ck_assert_msg(t->unconverged >= 1, "the warm-start stall this test guards against no longer "
                    "occurs with cold_retry 0: pick a control sequence that shows one");
      ck_assert_int_eq(t->retries, 0);
    }
  }
  ost_deleteData(d);
  mj_deleteModel(m);
}
END_TEST

// the planar legs under the controls of test_coldRetry from seed at step size h, with the default
// options otherwise: every one of 100 steps must converge to tol
static void assertPlanarConverges(double h, uint64_t seed) {
  mjModel* m = loadPlanarLegs();
  mjData* d = mj_makeData(m);
  ostOptions opt;
  ck_assert_int_eq(ost_readOptions(m, &opt, NULL, 0), OST_OK);
  opt.timestep = h;
  ck_assert_int_eq(ost_setOptions(m, d, &opt), OST_OK);
  ost_resetTotals(d);
  uint64_t x = seed * 0x9E3779B97F4A7C15ull + 1;
  for (int k = 0; k < 100; k++) {
    planarControls(m, d, k, &x);
    int status = ost_step(m, d);
    ck_assert_msg(status == OST_OK, "h %g, seed %d, step %d: status %d, residual %.3g m/s", h,
                  (int)seed, k, status, ost_stats(d)->residual);
  }
  const ostTotals* t = ost_totals(d);
  printf("planar legs h=%g, seed %d: %ld of 100 steps not converged, worst residual %.3g m/s\n",
         h, (int)seed, t->unconverged, t->worst_residual);
  ck_assert_int_eq(t->unconverged, 0);
  ck_assert_double_le(t->worst_residual, opt.tol);
  ost_deleteData(d);
  mj_deleteModel(m);
}


// the planar legs at h = 0.03 s under the controls of test_coldRetry from seed 4: at the 78th step
// one foot's friction is on its cone while its Newton model is sticking (|z| <= mu lambda_n) and
// asks for a force far outside it; before the saturated-sticking model (osti_saturateSticking)
// that step cycled with period 6 through every split and the cold retry (merit 0.22 m/s; one of
// the 12 unconverged steps of seeds 1-2000 at this h, 200,000 steps, with the default options).
// Every step must converge to tol, as every step of those seeds now does.
START_TEST(test_saturatedSticking) {
  assertPlanarConverges(0.03, 4);
}
END_TEST

// the planar legs at h = 0.1 s under the controls of test_coldRetry from seed 943: one step's
// Newton loop cycled through every split and the cold retry (one of the 3 unconverged steps of
// seeds 0-999 at this h with the default options) after directions that coupled a sliding
// foot's friction bound to its normal force while driving that force below zero. Since such a
// direction without descent returns to its base and the next lags that contact's coupling
// (osti_couplingFallback), the step converges. Every step here must converge to tol.
START_TEST(test_voidSlidingCoupling) {
  assertPlanarConverges(0.1, 943);
}
END_TEST

int main(void) {
  Suite* s = suite_create("ost_step");
  TCase* tc = tcase_create("step");
  tcase_add_test(tc, test_freeFall);
  tcase_add_test(tc, test_repeatFromRestoredState);
  tcase_add_test(tc, test_splitStep);
  tcase_add_test(tc, test_coldRetry);
  tcase_add_test(tc, test_saturatedSticking);
  tcase_add_test(tc, test_voidSlidingCoupling);
  suite_add_tcase(s, tc);
  return ost_fixtureRun(s);
}
