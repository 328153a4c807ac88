// test_ost_step.c: ost_step against closed-form backward Euler updates and basic contact.
#include <math.h>
#include <stdlib.h>

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

int main(void) {
  Suite* s = suite_create("ost_step");
  TCase* tc = tcase_create("step");
  tcase_add_test(tc, test_freeFall);
  suite_add_tcase(s, tc);
  return ost_fixtureRun(s);
}
