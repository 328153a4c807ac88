// test_ost_equality.c: equality constraints in closed kinematic loops (core/ost_solver.h,
// osti_equalityScale): a one-legged robot with a spring-loaded rod loop and a planar four-bar
// (tests/models/closed_loop_springs.xml) converges at its own timestep and at 10 times it, under
// zero and varying motor torques, keeps its loops closed and stays bounded.
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "fixture.h"
#include "ostrich.h"

static mjModel* loadLoop(void) {
  char path[1024], err[1000];
  snprintf(path, sizeof(path), "%s/../tests/models/closed_loop_springs.xml", OST_MODEL_DIR);
  mjModel* m = mj_loadXML(path, NULL, err, sizeof(err));
  ck_assert_msg(m != NULL, "%s", err);
  return m;
}


// a deterministic control sequence in ctrlrange, held for 0.1 s blocks
static double control(const mjModel* m, int i, double t) {
  unsigned s = (unsigned)(t / 0.1) * 2654435761u + (unsigned)i * 40503u + 1u;
  s ^= s >> 13;
  s *= 0x5bd1e995u;
  s ^= s >> 15;
  double r = (s & 0xffff) / 65535.0;
  const double* cr = m->actuator_ctrlrange + 2 * i;
  return cr[0] + r * (cr[1] - cr[0]);
}


// 1 s at h = 0.5 ms and 5 ms, zero and varying controls: at least 99.5 % of the steps converged
// (the share Ostrich asks of its corpus), the loops closed (they open by the relative compliance
// E lambda = reg h^2 d_eq lambda only), no blow-up: the base slower than 10 m/s (a fall from 1 m
// reaches 4.4 m/s) and every |qvel| below 1e3 rad/s (the rod spins freely about its own axis,
// inertia 1e-5 kg m^2, at tens of rad/s; diverged steps reached 1e6)
START_TEST(test_closedLoopsConverge) {
  ost_fixtureSetup();
  mjModel* m = loadLoop();
  mjData* d = mj_makeData(m);
  for (int scale = 1; scale <= 10; scale += 9) {
    for (int varying = 0; varying < 2; varying++) {
      double h = scale * m->opt.timestep;
      ost_fixtureSetTimestep(m, d, h);
      mj_resetData(m, d);
      int n = (int)lround(1.0 / h), converged = 0, iterates = 0;
      double open = 0, speed = 0, base = 0, force = 0;
      for (int k = 0; k < n; k++) {
        for (int i = 0; i < m->nu; i++) {
          d->ctrl[i] = varying ? control(m, i, d->time) : 0;
        }
        int status = ost_step(m, d);
        ck_assert_msg(status == OST_OK || OST_IS_WARNING(status), "step %d: %d %s", k, status,
                      ost_lastError(d));
        converged += status == OST_OK;
        iterates += ost_stats(d)->newton_iter;
        for (int i = 0; i < d->nefc; i++) {
          if (d->efc_type[i] == mjCNSTR_EQUALITY) {
            open = fmax(open, fabs(d->efc_pos[i]));
            force = fmax(force, fabs(d->efc_force[i]));
          }
        }
        for (int j = 0; j < m->nv; j++) {
          ck_assert(isfinite(d->qvel[j]));
          speed = fmax(speed, fabs(d->qvel[j]));
        }
        base = fmax(base, sqrt(d->qvel[0] * d->qvel[0] + d->qvel[1] * d->qvel[1]
                               + d->qvel[2] * d->qvel[2]));
      }
      printf("closed loops h=%g %s: %d/%d converged, loops open %.3g m (loop force %.3g N), "
             "max |qvel| %.3g, base speed %.3g m/s, mean Newton iterates %.2f\n", h,
             varying ? "varying" : "zero", converged, n, open, force, speed, base,
             (double)iterates / n);
      ck_assert_int_ge(converged, (int)ceil(0.995 * n));
      // reg h^2 d_eq lambda <= 1e-6 x (5 ms)^2 x 40 / kg x 1e5 N = 1e-4 m at these forces
      ck_assert_double_lt(open, 1e-4);
      ck_assert_double_lt(base, 10);
      ck_assert_double_lt(speed, 1e3);
    }
  }
  ost_deleteData(d);
  mj_deleteModel(m);
}
END_TEST


static Suite* suite(void) {
  Suite* s = suite_create("ost_equality");
  TCase* tc = tcase_create("equality");
  tcase_set_timeout(tc, 300);
  tcase_add_test(tc, test_closedLoopsConverge);
  suite_add_tcase(s, tc);
  return s;
}


int main(void) {
  return ost_fixtureRun(suite());
}
