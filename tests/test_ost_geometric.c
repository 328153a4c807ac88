// test_ost_geometric.c: the geometric terms of the Newton model (core/ost_geometric.h, options
// geometric_newton and geometric_retry). A nearly taut string of beads on inextensible tendons
// converges at a large step only with T; a bead pendulum on two tendons keeps its analytic
// period with the term on every iterate; a chain of capsules piling onto a floor converges
// within a small budget with T and R over every row, or with the retry; and the terms change
// how Newton reaches a step's solution, not the solution.
#include "ost_geometric.h"  // compiles alone

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "fixture.h"
#include "ostrich.h"

static mjModel* loadTest(const char* file) {
  char path[1024], err[1000];
  snprintf(path, sizeof(path), "%s/../tests/models/%s", OST_MODEL_DIR, file);
  mjModel* m = mj_loadXML(path, NULL, err, sizeof(err));
  ck_assert_msg(m != NULL, "%s", err);
  return m;
}


static void setMode(const mjModel* m, mjData* d, double h, int mode) {
  ostOptions o;
  ck_assert_int_eq(ost_readOptions(m, &o, NULL, 0), OST_OK);
  o.timestep = h;
  o.geometric_newton = mode;
  ck_assert_int_eq(ost_setOptions(m, d, &o), OST_OK);
}


// n steps of d from its state with ost_step: the steps that did not converge and that were
// split, the Newton iterates, the worst residual (m/s) and the largest change of any tendon's
// length from the start (m)
typedef struct { int unconverged, split, iterates; double worst, stretch; } tendonRun;

static tendonRun runTendons(const mjModel* m, mjData* d, int n) {
  tendonRun r = {0, 0, 0, 0, 0};
  mj_fwdPosition(m, d);
  double* L0 = malloc(sizeof(double) * m->ntendon);
  memcpy(L0, d->ten_length, sizeof(double) * m->ntendon);
  for (int k = 0; k < n; k++) {
    int status = ost_step(m, d);
    ck_assert_msg(status == OST_OK || OST_IS_WARNING(status), "step %d: %d %s", k, status,
                  ost_lastError(d));
    r.unconverged += status != OST_OK;
    r.split += ost_stats(d)->substeps > 1;
    r.iterates += ost_stats(d)->newton_iter;
    r.worst = fmax(r.worst, ost_stats(d)->residual);
    mj_fwdPosition(m, d);
    for (int t = 0; t < m->ntendon; t++) r.stretch = fmax(r.stretch, fabs(d->ten_length[t] - L0[t]));
  }
  free(L0);
  return r;
}


// the string at h = 0.05 s for 2 s. With the term: every step converged without splitting, in
// at most 10 Newton iterates on average (the system is smooth, no contacts: Newton on its
// complete Jacobian converges quadratically from the warm start). Without it the same run splits
// at least half of its steps (measured: every step, 232 iterates per step): the model exercises
// the term. Both keep the tendons at their length: hard rows, stretched only by the relative
// compliance reg h^2 J Mt^-1 J' lambda, below 1e-6 m here.
START_TEST(test_stringConverges) {
  ost_fixtureSetup();
  mjModel* m = loadTest("tendon_string.xml");
  mjData* d = mj_makeData(m);
  double h = 0.05;
  for (int mode = 1; mode >= 0; mode--) {
    mj_resetData(m, d);
    setMode(m, d, h, mode);
    int n = 40;
    tendonRun r = runTendons(m, d, n);
    int split = r.split, iterates = r.iterates, unconverged = r.unconverged;
    double stretch = r.stretch;
    printf("tendon string, h = %g, geometric_newton %d: %d unconverged, %d split, %.1f Newton "
           "iterates per step, max stretch %.2e m\n", h, mode, unconverged, split,
           (double)iterates / n, stretch);
    ck_assert_int_eq(unconverged, 0);
    ck_assert_double_lt(stretch, 1e-6);
    if (mode == 1) {
      ck_assert_int_eq(split, 0);
      ck_assert_double_le((double)iterates / n, 10);
    } else {
      ck_assert_int_ge(split, n / 2);
    }
  }
  mj_deleteData(d);
  mj_deleteModel(m);
}
END_TEST


// the grid of beads (tests/models/tendon_grid.xml) at h = 50 ms for 1 s. The system is smooth
// (no contacts): with the term, Newton converges superlinearly from the warm start, so every step
// reaches tol = 1e-10 m/s within its budget, unsplit, in at most 20 iterates on average
// (measured 14.2), and the tendons keep their 5 cm length to 0.1 % (hard rows, stretched only by
// their relative compliance `regularization`: measured 3.0e-5 m, 6.4e-6 at 1e-7, 1.4e-6 at 1e-8). The
// term's last product along the final direction du must move q by its difference step whatever
// |du|: when it moved q by dq |du| (1e-12 m at |du| = 1e-8 m/s) its rounding stalled the merit at
// 1e-8 to 1e-10 m/s (measured: 12 of 20 steps unconverged, 755 iterates per step with splits).
START_TEST(test_gridConverges) {
  ost_fixtureSetup();
  mjModel* m = loadTest("tendon_grid.xml");
  mjData* d = mj_makeData(m);
  ck_assert_int_gt(m->neq, 50);
  mj_resetData(m, d);
  setMode(m, d, 0.05, 1);
  int n = 20;
  tendonRun r = runTendons(m, d, n);
  int split = r.split, iterates = r.iterates, unconverged = r.unconverged;
  double stretch = r.stretch, worst = r.worst, drop = 0;
  for (int j = 0; j < m->nq; j++) drop = fmin(drop, d->qpos[j]);
  printf("tendon grid, h = 0.05: %d unconverged, %d split, %.1f Newton iterates per step, worst "
         "residual %.2e m/s, max stretch %.2e m, lowest slide %.3f m\n", unconverged, split,
         (double)iterates / n, worst, stretch, drop);
  ck_assert_int_eq(unconverged, 0);
  ck_assert_int_eq(split, 0);
  ck_assert_double_le((double)iterates / n, 20);
  ck_assert_double_lt(stretch, 5e-5);
  ck_assert_double_lt(drop, -0.05);  // the sheet did fall and swing: the steps were not trivial
  mj_deleteData(d);
  mj_deleteModel(m);
}
END_TEST


// start the pendulum at angle th about the anchors' line (the x axis at z = 1), at rest
static void pendulumStart(const mjModel* m, mjData* d, double th) {
  mj_resetData(m, d);
  d->qpos[1] = 0.3 * sin(th);
  d->qpos[2] = 0.3 - 0.3 * cos(th);
}


// the bead pendulum from 0.1 rad with the term on every iterate (mode 2), h = 2 ms: the time
// between two downward zero crossings of y equals the pendulum's period 2 pi sqrt(l/g)
// (1 + th^2/16) = 1.09950 s to 0.1 % (backward Euler lengthens it by (w h)^2/3 = 4e-5, the
// crossings are interpolated linearly)
START_TEST(test_pendulumPeriod) {
  ost_fixtureSetup();
  mjModel* m = loadTest("tendon_pendulum.xml");
  mjData* d = mj_makeData(m);
  double h = 0.002, th = 0.1, l = 0.3, g = 9.81;
  double T = 2 * M_PI * sqrt(l / g) * (1 + th * th / 16);
  pendulumStart(m, d, th);
  setMode(m, d, h, 2);
  double cross[2];
  int nc = 0;
  for (int k = 0; k < 2000 && nc < 2; k++) {
    double y0 = d->qpos[1], t0 = d->time;
    ck_assert_int_eq(ost_step(m, d), OST_OK);
    double y1 = d->qpos[1];
    if (y0 > 0 && y1 <= 0) {
      cross[nc++] = t0 + h * y0 / (y0 - y1);
    }
  }
  ck_assert_int_eq(nc, 2);
  double period = cross[1] - cross[0];
  printf("tendon pendulum, geometric_newton 2, h = %g: period %.5f s, analytic %.5f s (%.1e)\n",
         h, period, T, period / T - 1);
  ck_assert_double_lt(fabs(period / T - 1), 1e-3);
  mj_deleteData(d);
  mj_deleteModel(m);
}
END_TEST


// the pendulum from 0.5 rad at h = 10 ms, 100 steps with the term on every iterate and without
// it: both solve the same step equations to tol = 1e-10 m/s, so the states agree to 1e-8
// (tol h per step, over 100 steps, through a stable oscillation)
START_TEST(test_sameSolution) {
  ost_fixtureSetup();
  mjModel* m = loadTest("tendon_pendulum.xml");
  mjData* a = mj_makeData(m);
  mjData* b = mj_makeData(m);
  pendulumStart(m, a, 0.5);
  pendulumStart(m, b, 0.5);
  setMode(m, a, 0.01, 2);
  setMode(m, b, 0.01, 0);
  double diff = 0;
  for (int k = 0; k < 100; k++) {
    ck_assert_int_eq(ost_step(m, a), OST_OK);
    ck_assert_int_eq(ost_step(m, b), OST_OK);
    for (int j = 0; j < m->nq; j++) diff = fmax(diff, fabs(a->qpos[j] - b->qpos[j]));
  }
  printf("tendon pendulum, geometric_newton 2 vs 0, 100 steps: max |qpos difference| %.2e\n",
         diff);
  ck_assert_double_lt(diff, 1e-8);
  mj_deleteData(a);
  mj_deleteData(b);
  mj_deleteModel(m);
}
END_TEST


// the capsule chain (tests/models/capsule_chain.xml) for 0.6 s at step h with a Newton budget of
// 10 iterates, geometric_newton `mode` and geometric_retry `retry`: its unconverged steps, mean
// Newton iterates per step and the loops redone with the geometric terms
static void chainRun(double h, int mode, int retry, int* unconverged, double* iterates,
                     long* geo_retries) {
  mjModel* m = loadTest("capsule_chain.xml");
  mjData* d = mj_makeData(m);
  ostOptions o;
  ck_assert_int_eq(ost_readOptions(m, &o, NULL, 0), OST_OK);
  o.timestep = h;
  o.newton_iter = 10;
  o.geometric_newton = mode;
  o.geometric_retry = retry;
  ck_assert_int_eq(ost_setOptions(m, d, &o), OST_OK);
  int n = (int)lround(0.6 / h), it = 0;
  *unconverged = 0;
  for (int k = 0; k < n; k++) {
    int status = ost_step(m, d);
    ck_assert_msg(status == OST_OK || OST_IS_WARNING(status), "step %d: %s", k, ost_lastError(d));
    *unconverged += status != OST_OK;
    it += ost_stats(d)->newton_iter;
  }
  *iterates = (double)it / n;
  *geo_retries = ost_totals(d)->geo_retries;
  ost_deleteData(d);
  mj_deleteModel(m);
}


// The chain falls and piles onto its floor: a contact force on it turns with q as its capsules
// roll and its hinges' axes turn (T), and so does the slip its friction reads (R); with the
// fixed-J model (geometric_newton 1: no equality rows here, so no term) Newton converges
// linearly there, at rates up to 0.75 per iterate in MuJoCo's rope, and a budget of 10 iterates
// leaves steps unconverged (measured: 2 at h = 2 ms, 8 at 10 ms). With both terms over every
// row (mode 3) Newton has the complete Jacobian of the step and converges superlinearly: every
// step within the 10 iterates, in fewer iterates on average (measured 3.0 and 4.5 against 5.2
// and 16.2).
START_TEST(test_chainAllRows) {
  ost_fixtureSetup();
  const double hs[2] = {0.002, 0.01};
  for (int c = 0; c < 2; c++) {
    int u1, u3;
    double i1, i3;
    long g1, g3;
    chainRun(hs[c], 1, 0, &u1, &i1, &g1);
    chainRun(hs[c], 3, 0, &u3, &i3, &g3);
    printf("capsule chain, h = %g, budget 10: geometric_newton 1: %d unconverged, %.2f iterates "
           "per step; 3: %d unconverged, %.2f iterates\n", hs[c], u1, i1, u3, i3);
    ck_assert_int_ge(u1, 1);
    ck_assert_int_eq(u3, 0);
    ck_assert_double_lt(i3, i1);
    ck_assert_int_eq(g1 + g3, 0);  // geometric_retry off
  }
}
END_TEST


// geometric_retry on the same runs (geometric_newton 1): a loop that ran out of its 10 iterates
// while still improving is redone cold with both terms over every row, which converges where
// the fixed-J loop did not: fewer unconverged steps than without the retry (measured: 0 and 1
// against 2 and 8), and the retries counted (ostTotals.geo_retries)
START_TEST(test_geometricRetry) {
  ost_fixtureSetup();
  const double hs[2] = {0.002, 0.01};
  for (int c = 0; c < 2; c++) {
    int u0, u1;
    double i0, i1;
    long g0, g1;
    chainRun(hs[c], 1, 0, &u0, &i0, &g0);
    chainRun(hs[c], 1, 1, &u1, &i1, &g1);
    printf("capsule chain, h = %g, budget 10: geometric_retry 0: %d unconverged; 1: %d "
           "unconverged, %ld geometric retries\n", hs[c], u0, u1, g1);
    ck_assert_int_eq(g0, 0);
    ck_assert_int_ge(g1, 1);
    ck_assert_int_lt(u1, u0);
  }
}
END_TEST


// the terms change how Newton reaches a step's solution, not the solution: one step from each
// of 30 states of the falling chain (h = 10 ms, default budget, warm start off so that both
// start alike) with geometric_newton 3 and with 1, both converged to tol = 1e-10 m/s, agree
// in u+ to 1e-8 m/s (two solutions of the same equations to tol, through the contact system's
// conditioning: 1e2 tol)
START_TEST(test_chainSameSolution) {
  ost_fixtureSetup();
  mjModel* m = loadTest("capsule_chain.xml");
  mjData* run = mj_makeData(m);
  mjData* a = mj_makeData(m);
  mjData* b = mj_makeData(m);
  ostOptions o;
  ck_assert_int_eq(ost_readOptions(m, &o, NULL, 0), OST_OK);
  o.timestep = 0.01;
  ck_assert_int_eq(ost_setOptions(m, run, &o), OST_OK);
  o.warmstart = 0;
  o.geometric_newton = 3;
  ck_assert_int_eq(ost_setOptions(m, a, &o), OST_OK);
  o.geometric_newton = 1;
  ck_assert_int_eq(ost_setOptions(m, b, &o), OST_OK);
  double worst = 0;
  int compared = 0;
  for (int k = 0; k < 30; k++) {
    ost_fixtureCopyState(m, a, run);
    ost_fixtureCopyState(m, b, run);
    if (ost_step(m, a) == OST_OK && ost_step(m, b) == OST_OK) {
      for (int j = 0; j < m->nv; j++) worst = fmax(worst, fabs(a->qvel[j] - b->qvel[j]));
      compared++;
    }
    int status = ost_step(m, run);
    ck_assert_msg(status == OST_OK || OST_IS_WARNING(status), "%s", ost_lastError(run));
  }
  printf("capsule chain, one step from 30 states, geometric_newton 3 vs 1: %d both converged, "
         "max |u+ difference| %.2e m/s\n", compared, worst);
  ck_assert_int_ge(compared, 25);
  ck_assert_double_lt(worst, 1e-8);
  ost_deleteData(run);
  ost_deleteData(a);
  ost_deleteData(b);
  mj_deleteModel(m);
}
END_TEST


static Suite* suite(void) {
  Suite* s = suite_create("ost_geometric");
  TCase* tc = tcase_create("geometric");
  tcase_add_test(tc, test_stringConverges);
  tcase_add_test(tc, test_gridConverges);
  tcase_add_test(tc, test_pendulumPeriod);
  tcase_add_test(tc, test_sameSolution);
  tcase_add_test(tc, test_chainAllRows);
  tcase_add_test(tc, test_geometricRetry);
  tcase_add_test(tc, test_chainSameSolution);
  suite_add_tcase(s, tc);
  return s;
}


int main(void) {
  return ost_fixtureRun(suite());
}
