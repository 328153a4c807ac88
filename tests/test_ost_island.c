// test_ost_island.c: constraint islands (core/ost_island.h). Bodies that share no contact,
// joint or tree are solved as separate Newton systems: a stack stepped next to another, far
// away, takes exactly the steps it takes alone (same bits), however many iterates the other one
// needs (as long as it does not make the step split: splitting halves the whole step);
// the step reports one island per independent system and the worst island's residual.
#include <math.h>
#include <stdio.h>
#include <string.h>

#include "fixture.h"
#include "ostrich.h"

// a stack of three boxes; the second (when present) is heavier, spins and starts higher
static const char* stackA =
  "<body pos='0 0 0.1'><freejoint/><geom type='box' size='.1 .1 .1' mass='1'/></body>"
  "<body pos='0.02 0 0.3'><freejoint/><geom type='box' size='.1 .1 .1' mass='1'/></body>"
  "<body pos='-0.02 0.01 0.5'><freejoint/><geom type='box' size='.1 .1 .1' mass='1'/></body>";
static const char* stackB =
  "<body pos='3 0 0.3'><freejoint/><geom type='box' size='.1 .1 .1' mass='5'/></body>"
  "<body pos='3.03 0 0.6'><freejoint/><geom type='box' size='.1 .1 .1' mass='20'/></body>"
  "<body pos='3 0.05 0.9' euler='0 0 20'><freejoint/>"
  "<geom type='capsule' size='.05 .15' mass='3'/></body>";

static mjModel* stacks(int both) {
  char xml[4096];
  snprintf(xml, sizeof(xml),
           "<mujoco><option timestep='0.01'/><worldbody><geom type='plane' size='10 10 .1'/>"
           "%s%s</worldbody></mujoco>", stackA, both ? stackB : "");
  return ost_fixtureLoadString(xml);
}


// 300 steps (the stacks fall, land and settle): stack A's state is the same bits alone and
// next to stack B, and B's presence is seen in the island count
START_TEST(test_islandEqualsAlone) {
  ost_fixtureSetup();
  mjModel* m1 = stacks(0);
  mjModel* m2 = stacks(1);
  mjData* d1 = mj_makeData(m1);
  mjData* d2 = mj_makeData(m2);
  d2->qvel[m1->nv + 5] = 3;  // B's first box spins about z
  int islands = 0, it1 = 0, it2 = 0, unc1 = 0, unc2 = 0;
  for (int k = 0; k < 300; k++) {
    int s1 = ost_step(m1, d1), s2 = ost_step(m2, d2);
    // a step may warn (not converged): the comparison holds for such steps too
    ck_assert_msg((!s1 || OST_IS_WARNING(s1)) && (!s2 || OST_IS_WARNING(s2)),
                  "step %d: %d %d %s", k, s1, s2, ost_lastError(d2));
    unc1 += s1 != 0;
    unc2 += s2 != 0;
    ck_assert_msg(!memcmp(d1->qpos, d2->qpos, m1->nq * sizeof(mjtNum))
                  && !memcmp(d1->qvel, d2->qvel, m1->nv * sizeof(mjtNum)),
                  "step %d: stack A differs next to stack B (qpos[2] %.17g vs %.17g)", k,
                  d1->qpos[2], d2->qpos[2]);
    islands = ost_stats(d2)->islands > islands ? ost_stats(d2)->islands : islands;
    it1 += ost_stats(d1)->newton_iter;
    it2 += ost_stats(d2)->newton_iter;
  }
  // A's boxes stack into one island (contacts join them), so do B's: two islands, never more
  // than the six free bodies
  ck_assert_int_ge(islands, 2);
  ck_assert_int_le(islands, 6);
  ck_assert_int_ge(it2, it1);  // the joint loop runs until both islands converged
  printf("islands: up to %d; Newton iterates alone %d, with the second stack %d; unconverged "
         "steps %d, %d\n", islands, it1, it2, unc1, unc2);
  mj_deleteData(d1);
  mj_deleteData(d2);
  mj_deleteModel(m1);
  mj_deleteModel(m2);
}
END_TEST


// a body resting on another is one island with it; bodies apart are islands of their own: two
// boxes side by side on the floor, then one placed on the other
START_TEST(test_islandCount) {
  ost_fixtureSetup();
  const char* apart =
    "<mujoco><option timestep='0.01'/><worldbody><geom type='plane' size='10 10 .1'/>"
    "<body pos='0 0 0.1'><freejoint/><geom type='box' size='.1 .1 .1'/></body>"
    "<body pos='1 0 0.1'><freejoint/><geom type='box' size='.1 .1 .1'/></body>"
    "</worldbody></mujoco>";
  const char* stacked =
    "<mujoco><option timestep='0.01'/><worldbody><geom type='plane' size='10 10 .1'/>"
    "<body pos='0 0 0.1'><freejoint/><geom type='box' size='.1 .1 .1'/></body>"
    "<body pos='0 0 0.3'><freejoint/><geom type='box' size='.1 .1 .1'/></body>"
    "</worldbody></mujoco>";
  const char* xml[2] = {apart, stacked};
  int expect[2] = {2, 1};
  for (int c = 0; c < 2; c++) {
    mjModel* m = ost_fixtureLoadString(xml[c]);
    mjData* d = mj_makeData(m);
    for (int k = 0; k < 20; k++) {
      ck_assert_int_eq(ost_step(m, d), OST_OK);
    }
    ck_assert_int_eq(ost_stats(d)->islands, expect[c]);
    mj_deleteData(d);
    mj_deleteModel(m);
  }
}
END_TEST


int main(void) {
  Suite* s = suite_create("ost_island");
  TCase* tc = tcase_create("island");
  tcase_set_timeout(tc, 120);
  tcase_add_test(tc, test_islandEqualsAlone);
  tcase_add_test(tc, test_islandCount);
  suite_add_tcase(s, tc);
  return ost_fixtureRun(s);
}
