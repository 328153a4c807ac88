// test_ost_row_cache.c: the rows' half-solve cache (ostWorld.yrow, core/ost_solver.h).
// osti_rowDiag keeps each row's L^-T J_i' and the islands' direct Schur solves read it back
// instead of solving again; the cache must change no bit. MuJoCo's humanoid falls, lands and
// lies in contact (islands solved directly, sliding and sticking friction, joint limits),
// 22 humanoids (22 islands) and a loaded tendon string (the geometric term's nested solves, run
// while the geometry is moved and put back) step with and without it: every state equal
// bitwise, with the same Newton iterates per step.
#include <stdio.h>
#include <string.h>

#include "fixture.h"
#include "ost_internal.h"

static void compare(const char* path, int n) {
  char err[500];
  mjModel* m = mj_loadXML(path, NULL, err, sizeof(err));
  ck_assert_msg(m != NULL, "%s", err);
  mjData* d1 = mj_makeData(m);
  mjData* d2 = mj_makeData(m);
  ost_context(m, d2)->no_row_cache = 1;
  long iterates = 0;
  for (int k = 0; k < n; k++) {
    int s1 = ost_step(m, d1), s2 = ost_step(m, d2);
    ck_assert_int_eq(s1, s2);
    ck_assert_int_eq(ost_stats(d1)->newton_iter, ost_stats(d2)->newton_iter);
    ck_assert_msg(!memcmp(d1->qpos, d2->qpos, m->nq * sizeof(mjtNum))
                  && !memcmp(d1->qvel, d2->qvel, m->nv * sizeof(mjtNum)),
                  "%s step %d: the cached and the recomputed half-solves give different states",
                  path, k);
    iterates += ost_stats(d1)->newton_iter;
  }
  printf("%s: %d steps, %.2f Newton iterates per step, states equal bitwise\n", path, n,
         (double)iterates / n);
  mj_deleteData(d1);
  mj_deleteData(d2);
  mj_deleteModel(m);
}


START_TEST(test_humanoid) {
  ost_fixtureSetup();
  compare("/usr/share/mujoco/model/humanoid/humanoid.xml", 400);
}
END_TEST


START_TEST(test_22_humanoids) {
  ost_fixtureSetup();
  compare("/usr/share/mujoco/model/humanoid/22_humanoids.xml", 60);
}
END_TEST


START_TEST(test_tendon_string) {
  ost_fixtureSetup();
  char path[1024];
  snprintf(path, sizeof(path), "%s/../tests/models/tendon_string.xml", OST_MODEL_DIR);
  compare(path, 40);
}
END_TEST


int main(void) {
  Suite* s = suite_create("ost_row_cache");
  TCase* tc = tcase_create("row_cache");
  tcase_set_timeout(tc, 120);
  tcase_add_test(tc, test_humanoid);
  tcase_add_test(tc, test_22_humanoids);
  tcase_add_test(tc, test_tendon_string);
  suite_add_tcase(s, tc);
  return ost_fixtureRun(s);
}
