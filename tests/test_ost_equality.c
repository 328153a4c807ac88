// test_ost_equality.c: equality constraints in closed kinematic loops (core/ost_solver.h,
// osti_equalityScale): a one-legged robot with a spring-loaded rod loop and a planar four-bar
// (tests/models/closed_loop_springs.xml) converges at its own timestep and at 10 times it, under
// zero and varying motor torques, keeps its loops closed and stays bounded; a four-bar at its dead
// centre whose joints start beyond their limits (tests/models/fourbar_dead_centre.xml) removes
// that violation at the bounded speed, converged in every step.
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "fixture.h"
#include "ostrich.h"

static mjModel* loadTestModel(const char* name) {
  char path[1024], err[1000];
  snprintf(path, sizeof(path), "%s/../tests/models/%s", OST_MODEL_DIR, name);
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
  mjModel* m = loadTestModel("closed_loop_springs.xml");
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


// the four-bar at its dead centre with crank and output 30 degrees beyond their limits, at
// h = 0.5, 2.5 and 5 ms for 0.8 s (the violation takes 0.52 s at 1 rad/s): every step converged
// (before the relaxed steps' compliance OST_RELAX_REG, 44 of 600 steps at 0.5 ms did not: the
// shifted limits and the loop fought), the violation gone by the end and the output inside its
// range, and the loop closed to a micrometre after (the rows' relative compliance 1e-6 of the
// displacement their forces cause alone). Not asserted: the rate and speed of the removal. The
// linkage snaps through its dead centre, turning at up to 160 rad/s (500 before; stock MuJoCo,
// whose soft limits push the joints back too, peaks at 9.3), and its loop opens by 0.6 mm under
// the snap's forces (compliance 1e-4 in the relaxed steps; the 1 mm bound below is a regression
// baseline): a known limitation (core/README.md, "Depenetration")
START_TEST(test_limitsBeyondAtDeadCentre) {
  ost_fixtureSetup();
  mjModel* m = loadTestModel("fourbar_dead_centre.xml");
  mjData* d = mj_makeData(m);
  const double hs[3] = {0.0005, 0.0025, 0.005};
  for (int c = 0; c < 3; c++) {
    double h = hs[c], speed = 0, open_relax = 0, open_after = 0;
    ost_fixtureSetTimestep(m, d, h);
    mj_resetData(m, d);
    int n = (int)lround(0.8 / h), converged = 0, iterates = 0, relaxed = 0;
    for (int k = 0; k < n; k++) {
      int status = ost_step(m, d);
      ck_assert_msg(status == OST_OK || OST_IS_WARNING(status), "step %d: %d %s", k, status,
                    ost_lastError(d));
      const ostStats* st = ost_stats(d);
      converged += status == OST_OK;
      iterates += st->newton_iter;
      relaxed += (st->status & OST_DEPENETRATED) != 0;
      double open = 0;
      for (int i = 0; i < d->nefc; i++) {
        if (d->efc_type[i] == mjCNSTR_EQUALITY) open = fmax(open, fabs(d->efc_pos[i]));
      }
      if (st->status & OST_DEPENETRATED) {
        open_relax = fmax(open_relax, open);
      } else {
        open_after = fmax(open_after, open);
      }
      for (int j = 0; j < m->nv; j++) speed = fmax(speed, fabs(d->qvel[j]));
    }
    double q_out = d->qpos[m->jnt_qposadr[mj_name2id(m, mjOBJ_JOINT, "output")]];
    printf("four-bar at dead centre h=%g: %d/%d converged, %d steps removed the violation, "
           "joint speed <= %.3g rad/s, loop open %.3g m while removing, %.3g m after, output "
           "at %.4g rad, mean Newton iterates %.2f\n", h, converged, n, relaxed, speed,
           open_relax, open_after, q_out, (double)iterates / n);
    ck_assert_int_eq(converged, n);
    ck_assert_int_gt(relaxed, 0);
    ck_assert_double_eq(ost_stats(d)->initial_violation, 0);  // gone by the end
    ck_assert_double_lt(open_relax, 1e-3);  // regression baseline (measured 0.6 mm: the snap)
    ck_assert_double_lt(open_after, 1e-6);
    ck_assert_double_le(q_out, -30 * M_PI / 180 + 1e-6);  // inside its range at the end
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
  tcase_add_test(tc, test_limitsBeyondAtDeadCentre);
  suite_add_tcase(s, tc);
  return s;
}


int main(void) {
  return ost_fixtureRun(suite());
}
