// test_ost_sync.c: the private model follows the user's model without a copy per step
// (plugin/ost_sync.c). The model is checked and packed once over 1,000 steps; an edit of an array
// a step reads is followed at the next step, with the same bits as a model that had the edit from
// the start; a mesh edit is followed after ost_modelChanged; and the incremental path gives the
// same bits as a full copy every step. A step reuses the stages the last one published
// (plugin/ost_published.c) only while d is exactly as that step left it, with the same bits as
// recomputing them.
#include <math.h>
#include <stdio.h>
#include <string.h>

#include "fixture.h"
#include "ostrich.h"

// a motor-driven pendulum (its acceleration depends on its mass) carrying a mesh that collides
// with nothing, and a box on a plane
static const char* scene =
  "<mujoco><option timestep='0.005'/>"
  "<asset><mesh name='cube' vertex='-.1 -.1 -.1  .1 -.1 -.1  -.1 .1 -.1  .1 .1 -.1 "
  "-.1 -.1 .1  .1 -.1 .1  -.1 .1 .1  .1 .1 .1'/></asset>"
  "<worldbody><geom type='plane' size='5 5 0.1'/>"
  "<body pos='0 0 2'><joint name='hinge' type='hinge' axis='0 1 0'/>"
  "<geom type='capsule' fromto='0 0 0 0.5 0 0' size='0.05' mass='1'/>"
  "<geom type='mesh' mesh='cube' contype='0' conaffinity='0' mass='0.1'/></body>"
  "<body pos='1 0 0.2'><freejoint/><geom type='box' size='.1 .1 .1' mass='2'/></body>"
  "</worldbody><actuator><motor joint='hinge'/></actuator></mujoco>";


// step d n times with ctrl 1; every step must succeed
static void run(const mjModel* m, mjData* d, int n) {
  for (int k = 0; k < n; k++) {
    d->ctrl[0] = 1;
    int status = ost_step(m, d);
    ck_assert_msg(status == OST_OK, "step %d: status %d %s", k, status, ost_lastError(d));
  }
}


static int sameState(const mjModel* m, const mjData* a, const mjData* b) {
  return !memcmp(a->qpos, b->qpos, m->nq * sizeof(mjtNum))
         && !memcmp(a->qvel, b->qvel, m->nv * sizeof(mjtNum));
}


// 1,000 steps pack once; an edit of a compared array (body_mass) repacks at the next step, an
// edit of a mesh vertex does not until ost_modelChanged says so; new options repack, the same
// options set again do not
START_TEST(test_packedOnce) {
  ost_fixtureSetup();
  mjModel* m = ost_fixtureLoadString(scene);
  mjData* d = mj_makeData(m);
  run(m, d, 1000);
  ck_assert_int_eq(ost_totals(d)->model_packs, 1);
  m->body_mass[1] *= 2;
  run(m, d, 10);
  ck_assert_int_eq(ost_totals(d)->model_packs, 2);
  m->mesh_vert[0] *= 1.01f;
  run(m, d, 10);
  ck_assert_int_eq(ost_totals(d)->model_packs, 2);
  ost_modelChanged(m);
  run(m, d, 10);
  ck_assert_int_eq(ost_totals(d)->model_packs, 3);
  // new options are a change too (margins, checks and packing depend on them)
  ostOptions o;
  ost_defaultOptions(&o);
  o.margin = 0.02;
  ck_assert_int_eq(ost_setOptions(m, d, &o), OST_OK);
  run(m, d, 10);
  ck_assert_int_eq(ost_totals(d)->model_packs, 4);
  // the same options set again are no change (a tape sets them on its mjData at every rollout)
  ck_assert_int_eq(ost_setOptions(m, d, &o), OST_OK);
  run(m, d, 10);
  ck_assert_int_eq(ost_totals(d)->model_packs, 4);
  o.tol = 1e-11;
  ck_assert_int_eq(ost_setOptions(m, d, &o), OST_OK);
  run(m, d, 10);
  ck_assert_int_eq(ost_totals(d)->model_packs, 5);
  mj_deleteData(d);
  mj_deleteModel(m);
}
END_TEST


// an edit between steps is followed: the pendulum's mass doubled after one step (then the state
// reset) gives the same bits as a model loaded with the doubled mass, and not those of the
// unedited model (the motor's torque accelerates a heavier pendulum less)
START_TEST(test_editFollowed) {
  ost_fixtureSetup();
  mjModel* m1 = ost_fixtureLoadString(scene);
  mjModel* m2 = ost_fixtureLoadString(scene);
  mjModel* m0 = ost_fixtureLoadString(scene);
  mjData* d1 = mj_makeData(m1);
  mjData* d2 = mj_makeData(m2);
  mjData* d0 = mj_makeData(m0);
  run(m1, d1, 1);
  mj_resetData(m1, d1);
  m1->body_mass[1] *= 2;
  m2->body_mass[1] *= 2;
  run(m1, d1, 100);
  run(m2, d2, 100);
  run(m0, d0, 100);
  ck_assert_msg(sameState(m1, d1, d2), "edited model differs from one loaded with the edit");
  ck_assert_msg(fabs(d1->qpos[0] - d0->qpos[0]) > 1e-3, "the mass edit had no effect: %g %g",
                d1->qpos[0], d0->qpos[0]);
  mj_deleteData(d0);
  mj_deleteData(d1);
  mj_deleteData(d2);
  mj_deleteModel(m0);
  mj_deleteModel(m1);
  mj_deleteModel(m2);
}
END_TEST


// the incremental path (only changed arrays copied, margins refreshed) equals a full copy and
// repacking every step, through edits of a margin, a friction coefficient and opt.gravity
START_TEST(test_incrementalEqualsFull) {
  ost_fixtureSetup();
  mjModel* m1 = ost_fixtureLoadString(scene);
  mjModel* m2 = ost_fixtureLoadString(scene);
  mjData* d1 = mj_makeData(m1);
  mjData* d2 = mj_makeData(m2);
  for (int k = 0; k < 300; k++) {
    if (k == 100) {
      m1->geom_margin[2] = m2->geom_margin[2] = 0.005;
      m1->geom_friction[0] = m2->geom_friction[0] = 0.3;
    }
    if (k == 200) {
      m1->opt.gravity[0] = m2->opt.gravity[0] = 2;
    }
    ost_modelChanged(m2);
    run(m1, d1, 1);
    run(m2, d2, 1);
    ck_assert_msg(sameState(m1, d1, d2), "step %d: incremental and full copies differ", k);
  }
  ck_assert_int_eq(ost_totals(d1)->model_packs, 3);
  ck_assert_int_eq(ost_totals(d2)->model_packs, 300);
  mj_deleteData(d1);
  mj_deleteData(d2);
  mj_deleteModel(m1);
  mj_deleteModel(m2);
}
END_TEST


// a passive-force callback that adds nothing
static void zeroPassive(const mjModel* m, mjData* d) {
  (void)m;
  (void)d;
}


// ost_step1 reuses the position and velocity stages the last step published at the same state
// (every step after the first of an unbroken run), and recomputes them once a user ran MuJoCo's
// stages at another pose in between, even with the state put back: d2, whose stages are moved
// to another pose and back before every step, takes the same bits as d1, which reuses them
// (stale stages would put the mass matrix and bias forces of the other pose into its steps)
START_TEST(test_stagesReused) {
  ost_fixtureSetup();
  mjModel* m = ost_fixtureLoadString(scene);
  mjData* d1 = mj_makeData(m);
  mjData* d2 = mj_makeData(m);
  for (int k = 0; k < 200; k++) {
    run(m, d1, 1);
    if (k > 0) {
      mjtNum q = d2->qpos[0];
      d2->qpos[0] = q + 0.5;
      mj_fwdPosition(m, d2);
      mj_fwdVelocity(m, d2);
      d2->qpos[0] = q;
    }
    run(m, d2, 1);
    ck_assert_msg(sameState(m, d1, d2), "step %d: reused and recomputed stages differ", k);
  }
  ck_assert_int_eq(ost_totals(d1)->stages_reused, 199);
  ck_assert_int_eq(ost_totals(d2)->stages_reused, 0);
  // a mocap-free model's only other input, time: a step from a reset state recomputes them
  mj_resetData(m, d1);
  run(m, d1, 1);
  ck_assert_int_eq(ost_totals(d1)->stages_reused, 199);
  // a passive-force callback may read the user's own state: the stages always run again
  mjcb_passive = zeroPassive;
  run(m, d1, 10);
  mjcb_passive = NULL;
  ck_assert_int_eq(ost_totals(d1)->stages_reused, 199);
  run(m, d1, 10);
  ck_assert_int_eq(ost_totals(d1)->stages_reused, 208);
  mj_deleteData(d1);
  mj_deleteData(d2);
  mj_deleteModel(m);
}
END_TEST


int main(void) {
  Suite* s = suite_create("ost_sync");
  TCase* tc = tcase_create("sync");
  tcase_set_timeout(tc, 120);
  tcase_add_test(tc, test_packedOnce);
  tcase_add_test(tc, test_editFollowed);
  tcase_add_test(tc, test_stagesReused);
  tcase_add_test(tc, test_incrementalEqualsFull);
  suite_add_tcase(s, tc);
  return ost_fixtureRun(s);
}
