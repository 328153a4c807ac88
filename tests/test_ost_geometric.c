// test_ost_geometric.c: the geometric term of the Newton model (core/ost_geometric.h, option
// geometric_newton). A nearly taut string of beads on inextensible tendons converges at a large
// step only with it; a bead pendulum on two tendons keeps its analytic period with the term on
// every iterate, and the term changes how Newton reaches a step's solution, not the solution.
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
    mj_fwdPosition(m, d);
    double L0[4];
    memcpy(L0, d->ten_length, sizeof(L0));
    int n = 40, split = 0, iterates = 0, unconverged = 0;
    double stretch = 0;
    for (int k = 0; k < n; k++) {
      int status = ost_step(m, d);
      ck_assert_msg(status == OST_OK || OST_IS_WARNING(status), "step %d: %d %s", k, status,
                    ost_lastError(d));
      unconverged += status != OST_OK;
      split += ost_stats(d)->substeps > 1;
      iterates += ost_stats(d)->newton_iter;
      mj_fwdPosition(m, d);
      for (int t = 0; t < 4; t++) stretch = fmax(stretch, fabs(d->ten_length[t] - L0[t]));
    }
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


static Suite* suite(void) {
  Suite* s = suite_create("ost_geometric");
  TCase* tc = tcase_create("geometric");
  tcase_add_test(tc, test_stringConverges);
  tcase_add_test(tc, test_pendulumPeriod);
  tcase_add_test(tc, test_sameSolution);
  suite_add_tcase(s, tc);
  return s;
}


int main(void) {
  return ost_fixtureRun(suite());
}
