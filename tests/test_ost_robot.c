// test_ost_robot.c: the paper's three-wheeled robot: it rests, and commanded at wheel speed w
// on flat ground it reaches forward speed w r (implicit velocity servos rolling without slip).
#include <math.h>
#include <stdio.h>

#include "fixture.h"
#include "ostrich.h"

START_TEST(test_robotRests) {
  ost_fixtureSetup();
  mjModel* m = ost_fixtureLoadModel("wheeled_robot.xml");
  ck_assert_double_eq_tol(mj_getTotalmass(m), 106, 1e-9);
  mjData* d = mj_makeData(m);
  ost_fixtureSetTimestep(m, d, 0.05);
  for (int k = 0; k < 40; k++) ck_assert_int_eq(ost_step(m, d), OST_OK);
  printf("robot at rest h=0.05: |x| %.3g, z %.6f, residual %.2g\n", fabs(d->qpos[0]), d->qpos[2],
         ost_stats(d)->residual);
  ck_assert_double_lt(fabs(d->qpos[0]), 1e-6);
  ck_assert_double_lt(fabs(d->qpos[2] - 0.35), 1e-4);
  ost_deleteData(d);
  mj_deleteModel(m);
}
END_TEST

START_TEST(test_robotSpeed) {
  ost_fixtureSetup();
  mjModel* m = ost_fixtureLoadModel("wheeled_robot.xml");
  mjData* d = mj_makeData(m);
  double h = 0.01, w = 3, r = 0.35;
  ost_fixtureSetTimestep(m, d, h);
  for (int i = 0; i < m->nu; i++) d->ctrl[i] = w;
  // average forward speed over the last second of 3 s
  double x1 = 0;
  for (int k = 0; k < 300; k++) {
    ck_assert_int_eq(ost_step(m, d), OST_OK);
    if (k == 199) x1 = d->qpos[0];
  }
  double v = d->qpos[0] - x1;
  printf("robot w=%g h=%g: speed %.4f m/s, w r = %.4f (rel err %.2g)\n", w, h, v, w * r,
         fabs(v / (w * r) - 1));
  ck_assert_double_lt(fabs(v / (w * r) - 1), 0.02);
  ost_deleteData(d);
  mj_deleteModel(m);
}
END_TEST

int main(void) {
  Suite* s = suite_create("ost_robot");
  TCase* tc = tcase_create("robot");
  tcase_set_timeout(tc, 600);
  tcase_add_test(tc, test_robotRests);
  tcase_add_test(tc, test_robotSpeed);
  suite_add_tcase(s, tc);
  return ost_fixtureRun(s);
}
