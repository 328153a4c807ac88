// test_ost_adhesion.c: adhesion actuators (body transmissions) with the mujoco geometry provider.
// MuJoCo 2.2.2 pulls the body toward every contact it has within the model's margins, along the
// contacts' normals, with force gain x ctrl; Ostrich applies that force at (q-, u-) like any
// explicit actuator force. A ball under a ceiling is held where the adhesion exceeds its weight,
// at h and 10 h; below its weight it falls as backward Euler under the net force gives, in step
// with MuJoCo, until it leaves the 1 cm margin layer. Gradients and the native provider, which
// have no contacts at q-, refuse the actuator by name.
#include <math.h>
#include <stdio.h>
#include <string.h>

#include "fixture.h"
#include "ostrich.h"

static const double kGain = 20;    // adhesion gain (N per unit ctrl)
static const double kMass = 1;     // the ball's mass (kg)
static const double kZ0 = 0.9;     // its centre at the start: its top touches the ceiling (z = 1)

// a 1 kg ball of radius 0.1 touching a fixed ceiling from below; geoms with margin and gap 1 cm
// (MuJoCo's adhesion idiom: inactive contacts within 1 cm for the actuator to pull on)
static mjModel* ceilingModel(void) {
  return ost_fixtureLoadString(
      "<mujoco><option timestep='0.002'/><worldbody>"
      "<geom name='ceiling' type='box' pos='0 0 1.05' size='1 1 0.05'/>"
      "<body name='ball' pos='0 0 0.9'><freejoint/>"
      "<geom type='sphere' size='0.1' mass='1' margin='0.01' gap='0.01'/></body>"
      "</worldbody><actuator><adhesion name='glue' body='ball' ctrlrange='0 1' gain='20'/>"
      "</actuator></mujoco>");
}


// adhesion above the ball's weight (20 N against 9.81 N) holds it at the ceiling for 1 s at h
// and 10 h: every step converged, the ball within the solver's tolerance of its start (a hard
// contact: no sinking into the ceiling, no drift away from it)
START_TEST(test_adhesionHolds) {
  mjModel* m = ceilingModel();
  mjData* d = mj_makeData(m);
  const double hs[2] = {0.002, 0.02};
  for (int k = 0; k < 2; k++) {
    ost_fixtureSetProvider(m, d, hs[k], OST_GEOMETRY_MUJOCO);
    mj_resetData(m, d);
    d->ctrl[0] = 1;
    int n = (int)lround(1.0 / hs[k]);
    double worst = 0;
    for (int t = 0; t < n; t++) {
      int status = ost_step(m, d);
      ck_assert_msg(status == OST_OK, "h %g step %d: %d %s", hs[k], t, status, ost_lastError(d));
      worst = fmax(worst, fabs(d->qpos[2] - kZ0));
    }
    printf("adhesion 20 N on a 1 kg ball, h %g s: |z - z0| at most %.3g m over 1 s\n", hs[k],
           worst);
    ck_assert_double_lt(worst, 1e-6);
    ck_assert_double_lt(fabs(d->qvel[2]), 1e-6);
  }
  mj_deleteData(d);
  mj_deleteModel(m);
}
END_TEST


// adhesion below the weight (6 N): while the ball is within the 1 cm layer it accelerates
// downward at a = g - 6 / m, and backward Euler under that constant net force gives
// z_n = z0 - a h^2 n (n + 1) / 2 exactly; stock MuJoCo's Euler step computes the same recurrence,
// so the two engines agree to rounding over 0.2 s, through the ball's exit from the layer
// (t ~ 0.072 s) and its free fall after it
START_TEST(test_adhesionReleasesAsMuJoCo) {
  mjModel* m = ceilingModel();
  mjData* d = mj_makeData(m);
  mjData* dm = mj_makeData(m);
  double h = m->opt.timestep;
  ost_fixtureSetProvider(m, d, h, OST_GEOMETRY_MUJOCO);
  d->ctrl[0] = dm->ctrl[0] = 0.3;
  double a = -m->opt.gravity[2] - 0.3 * kGain / kMass, worst_layer = 0, worst_mujoco = 0;
  for (int n = 1; n <= 100; n++) {
    ck_assert_int_eq(ost_step(m, d), OST_OK);
    mj_step(m, dm);
    if (n <= 30) {  // 0.06 s: inside the layer (1 cm at a = 3.81 m/s^2 takes 0.072 s)
      worst_layer = fmax(worst_layer, fabs(d->qpos[2] - (kZ0 - a * h * h * n * (n + 1) / 2)));
    }
    worst_mujoco = fmax(worst_mujoco, fabs(d->qpos[2] - dm->qpos[2]));
  }
  printf("adhesion 6 N: |z - backward Euler| %.3g m in the layer, |z - MuJoCo| %.3g m over "
         "0.2 s (z %.6f m, MuJoCo %.6f)\n", worst_layer, worst_mujoco, d->qpos[2], dm->qpos[2]);
  ck_assert_double_lt(worst_layer, 1e-9);
  // the same recurrence in both engines (MuJoCo's contact at 0 m is inactive: its gap is the
  // margin), so only rounding separates them
  ck_assert_double_lt(worst_mujoco, 1e-9);
  ck_assert_double_lt(d->qpos[2], kZ0 - 0.1);  // it did fall
  mj_deleteData(dm);
  mj_deleteData(d);
  mj_deleteModel(m);
}
END_TEST


// what has no contacts at q- refuses the actuator, naming it: the native geometry provider and
// the gradients (which evaluate the step through core's native model)
START_TEST(test_adhesionRefusedWithoutContactsAtStart) {
  mjModel* m = ceilingModel();
  mjData* d = mj_makeData(m);
  ost_fixtureSetProvider(m, d, m->opt.timestep, OST_GEOMETRY_NATIVE);
  int status = ost_step(m, d);
  printf("native provider: status %d: %s\n", status, ost_lastError(d));
  ck_assert_int_ne(status, OST_OK);
  ck_assert_ptr_nonnull(strstr(ost_lastError(d), "glue"));
  ost_fixtureSetProvider(m, d, m->opt.timestep, OST_GEOMETRY_MUJOCO);
  mj_resetData(m, d);
  d->ctrl[0] = 1;
  double A[12 * 12], B[12];
  status = ost_transition(m, d, A, B);
  printf("ost_transition: status %d: %s\n", status, ost_lastError(d));
  ck_assert_int_ne(status, OST_OK);
  ck_assert_ptr_nonnull(strstr(ost_lastError(d), "glue"));
  mj_deleteData(d);
  mj_deleteModel(m);
}
END_TEST


int main(void) {
  Suite* s = suite_create("ost_adhesion");
  TCase* tc = tcase_create("adhesion");
  tcase_add_test(tc, test_adhesionHolds);
  tcase_add_test(tc, test_adhesionReleasesAsMuJoCo);
  tcase_add_test(tc, test_adhesionRefusedWithoutContactsAtStart);
  suite_add_tcase(s, tc);
  return ost_fixtureRun(s);
}
