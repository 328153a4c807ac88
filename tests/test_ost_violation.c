// test_ost_violation.c: bad starting states and steps that are not to tolerance (core/ost_step.h
// osti_relaxStart, plugin/ost_step.c). A body placed into its floor, two overlapping boxes, a
// joint started beyond its limit and a violated equality are removed at the bounded
// depenetration speed, and the step says so; a fast ball never leaves a step faster than it came
// in; an unsolved step returns a warning, and every backward pass through it refuses.
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "fixture.h"
#include "ostrich.h"

// largest |qvel| over the linear (translational) dofs of free joints, and over hinge dofs
static double maxSpeed(const mjModel* m, const mjData* d) {
  double v = 0;
  for (int j = 0; j < m->njnt; j++) {
    int a = m->jnt_dofadr[j];
    int n = m->jnt_type[j] == mjJNT_FREE ? 3 : m->jnt_type[j] == mjJNT_BALL ? 0 : 1;
    for (int k = 0; k < n; k++) v = fmax(v, fabs(d->qvel[a + k]));
  }
  return v;
}


// step n times; return the largest speed seen and count OST_DEPENETRATED steps
static double stepAndWatch(const mjModel* m, mjData* d, int n, int* depen, double* initial) {
  double vmax = 0;
  *depen = 0;
  *initial = 0;
  for (int k = 0; k < n; k++) {
    int status = ost_step(m, d);
    ck_assert_msg(status == OST_OK, "step %d: status %d %s", k, status, ost_lastError(d));
    const ostStats* st = ost_stats(d);
    *depen += (st->status & OST_DEPENETRATED) != 0;
    *initial = fmax(*initial, st->initial_violation);
    vmax = fmax(vmax, maxSpeed(m, d));
  }
  return vmax;
}


static const char* sunk_box =
  "<mujoco><option timestep='0.002'/><worldbody><geom type='plane' size='5 5 0.1'/>"
  "<body pos='0 0 0.05'><freejoint/><geom type='box' size='0.1 0.1 0.1' mass='1'/></body>"
  "</worldbody></mujoco>";

// a 0.2 m box placed 5 cm into its floor at h = 2 ms. Removed at once the step would leave at
// 0.05 / 0.002 = 25 m/s; at depenetration_speed v = 1 m/s it rises at v (gravity pulls down),
// clears the floor after about 0.05 / (v h) = 25 steps, and the first step reports the true
// depth 0.05 m. It leaves the floor with at most v, so it rises at most v^2 / 2g = 5.1 cm and
// lands back at rest. With the option at 0 the old behaviour (> 20 m/s) comes back.
START_TEST(test_sunkBox) {
  ost_fixtureSetup();
  mjModel* m = ost_fixtureLoadString(sunk_box);
  mjData* d = mj_makeData(m);
  int depen;
  double initial;
  double vmax = stepAndWatch(m, d, 25, &depen, &initial), zmax = 0;
  for (int k = 0; k < 375; k++) {
    ck_assert_int_eq(ost_step(m, d), OST_OK);
    zmax = fmax(zmax, d->qpos[2]);
    vmax = fmax(vmax, maxSpeed(m, d));
    depen += (ost_stats(d)->status & OST_DEPENETRATED) != 0;
  }
  printf("sunk box: max speed %.6f m/s, %d depenetrating steps, initial depth %.6f m, top z "
         "%.5f, end z %.7f, speed %.2e\n", vmax, depen, initial, zmax, d->qpos[2],
         maxSpeed(m, d));
  ck_assert_double_le(vmax, 1 + 1e-6);
  ck_assert_double_eq_tol(initial, 0.05, 1e-9);
  ck_assert_int_ge(depen, 23);  // 0.05 m at 2 mm per step, the last two may finish it at once
  ck_assert_int_le(depen, 25);
  ck_assert_double_le(zmax, 0.1 + 1 / (2 * 9.81) + 1e-3);
  ck_assert_double_eq_tol(d->qpos[2], 0.1, 1e-6);      // resting on the floor again
  ck_assert_double_lt(maxSpeed(m, d), 1e-6);           // and at rest
  ck_assert_int_eq(ost_totals(d)->depenetrated, depen);
  ck_assert_double_eq_tol(ost_totals(d)->worst_initial_violation, 0.05, 1e-9);

  // depenetration_speed 0: at once, 25 m/s
  mj_resetData(m, d);
  ostOptions o;
  ck_assert_int_eq(ost_readOptions(m, &o, NULL, 0), OST_OK);
  o.depenetration_speed = 0;
  ck_assert_int_eq(ost_setOptions(m, d, &o), OST_OK);
  ck_assert_int_eq(ost_step(m, d), OST_OK);
  printf("sunk box, depenetration_speed 0: %.3f m/s\n", maxSpeed(m, d));
  ck_assert_double_gt(maxSpeed(m, d), 20);
  ost_deleteData(d);
  mj_deleteModel(m);
}
END_TEST


static const char* overlapping_boxes =
  "<mujoco><option timestep='0.002' gravity='0 0 0'/><worldbody>"
  "<body pos='0 0 0'><freejoint/><geom type='box' size='0.5 0.5 0.5' mass='1'/></body>"
  "<body pos='0.45 0 0'><freejoint/><geom type='box' size='0.5 0.5 0.5' mass='1'/></body>"
  "</worldbody></mujoco>";

// two 1 m boxes overlapping by 0.55 m, no gravity: the bound applies to the distance, which
// grows by h v_rel per step, so the boxes part at a relative speed of v = 1 m/s (0.5 m/s each
// by symmetry) instead of 0.55 / h = 275 m/s
START_TEST(test_overlappingBoxes) {
  ost_fixtureSetup();
  mjModel* m = ost_fixtureLoadString(overlapping_boxes);
  mjData* d = mj_makeData(m);
  int depen;
  double initial;
  double vmax = stepAndWatch(m, d, 20, &depen, &initial);
  double rel = d->qvel[6] - d->qvel[0];
  printf("overlapping boxes: max speed %.6f m/s, relative %.6f m/s, initial depth %.4f m, %d "
         "depenetrating steps\n", vmax, rel, initial, depen);
  ck_assert_double_le(vmax, 0.5 + 1e-5);
  ck_assert_double_le(rel, 1 + 1e-5);
  ck_assert_double_eq_tol(initial, 0.55, 1e-6);
  ck_assert_double_eq_tol(ost_stats(d)->max_penetration, 0.55 - 20 * 0.002, 1e-6);
  ck_assert_int_eq(depen, 20);  // 0.55 m at 2 mm per step takes 275 steps
  ost_deleteData(d);
  mj_deleteModel(m);
}
END_TEST


// a knee started at 0 deg with its range 5..150 deg (dm_control's hopper starts so): removed at
// once at h = 5 ms it would turn at 0.0873 / 0.005 = 17.45 rad/s; bounded, at 1 rad/s
START_TEST(test_jointOutsideRange) {
  ost_fixtureSetup();
  mjModel* m = ost_fixtureLoadString(
    "<mujoco><option timestep='0.005' gravity='0 0 0'/><compiler angle='degree'/><worldbody>"
    "<body><joint name='knee' type='hinge' axis='0 1 0' limited='true' range='5 150'/>"
    "<geom type='capsule' fromto='0 0 0 0.3 0 0' size='0.04' mass='1'/></body>"
    "</worldbody></mujoco>");
  mjData* d = mj_makeData(m);
  int depen;
  double initial;
  double vmax = stepAndWatch(m, d, 40, &depen, &initial);
  printf("knee outside its range: max speed %.6f rad/s, initial violation %.6f rad, %d "
         "depenetrating steps, end angle %.6f\n", vmax, initial, depen, d->qpos[0]);
  ck_assert_double_le(vmax, 1 + 1e-6);
  ck_assert_double_eq_tol(initial, 5 * M_PI / 180, 1e-9);
  ck_assert_int_ge(depen, 16);  // 0.0873 rad at 5 mrad per step
  ck_assert_double_ge(d->qpos[0], 5 * M_PI / 180 - 1e-6);  // inside the range at the end
  ost_deleteData(d);
  mj_deleteModel(m);
}
END_TEST


// a free ball whose connect to a world point is violated by 0.2 m at the start: it is pulled
// back at 1 m/s, not at 0.2 / h = 40 m/s
START_TEST(test_violatedEquality) {
  ost_fixtureSetup();
  mjModel* m = ost_fixtureLoadString(
    "<mujoco><option timestep='0.005' gravity='0 0 0'/><worldbody>"
    "<body name='ball' pos='0.2 0 0'><freejoint/><geom type='sphere' size='0.05' mass='1'/>"
    "</body></worldbody>"
    "<equality><connect body1='ball' body2='world' anchor='-0.2 0 0'/></equality></mujoco>");
  mjData* d = mj_makeData(m);
  d->qpos[0] = 0.4;  // the connect holds at qpos0 (x = 0.2); start 0.2 m from it
  int depen;
  double initial;
  double vmax = stepAndWatch(m, d, 60, &depen, &initial);
  printf("violated connect: max speed %.6f m/s, initial violation %.6f m, end x %.6f\n", vmax,
         initial, d->qpos[0]);
  ck_assert_double_le(vmax, 1 + 1e-6);
  ck_assert_double_eq_tol(initial, 0.2, 1e-9);
  ck_assert_double_lt(fabs(d->qpos[0] - 0.2), 1e-6);  // back after 0.2 / 0.005 = 40 steps
  ost_deleteData(d);
  mj_deleteModel(m);
}
END_TEST


// a resting heavy-on-light stack at h = 0.05 s is untouched by the bound: its penetration
// (1e-7 m) is far below h v = 0.05 m, so no step is OST_DEPENETRATED
START_TEST(test_restingStackUntouched) {
  ost_fixtureSetup();
  mjModel* m = ost_fixtureLoadModel("stack_heavy_light.xml");
  mjData* d = mj_makeData(m);
  ost_fixtureSetTimestep(m, d, 0.05);
  int depen;
  double initial;
  stepAndWatch(m, d, 60, &depen, &initial);
  ck_assert_int_eq(depen, 0);
  ck_assert_double_eq(initial, 0);
  ost_deleteData(d);
  mj_deleteModel(m);
}
END_TEST


// the fast ball of hard_ball_fast.xml (keyframe: 20 m/s down, 1 m above the floor) at h = 0.05
// s: hard inelastic contact, so no step may leave it faster than it fell: |v| <= 20 + g t
START_TEST(test_fastBallKeyframe) {
  ost_fixtureSetup();
  mjModel* m = ost_fixtureLoadModel("hard_ball_fast.xml");
  mjData* d = mj_makeData(m);
  mj_resetDataKeyframe(m, d, 0);
  ost_fixtureSetTimestep(m, d, 0.05);
  double vmax = 0;
  for (int k = 0; k < 20; k++) {
    int status = ost_step(m, d);
    ck_assert_msg(status == OST_OK, "step %d: status %d (%s), residual %g", k, status,
                  ost_lastError(d), ost_stats(d)->residual);
    vmax = fmax(vmax, maxSpeed(m, d));
  }
  printf("fast ball h=0.05: max speed %.4f m/s, end z %.6f\n", vmax, d->qpos[2]);
  ck_assert_double_le(vmax, 20 + 9.81 * 0.05 + 1e-9);
  ck_assert_double_eq_tol(d->qpos[2], 0.1, 1e-6);
  ost_deleteData(d);
  mj_deleteModel(m);
}
END_TEST


// an unsolved step (pallet at h = 0.1 s, 2 Newton iterates, no splitting) returns the warning,
// advances the state, is counted; ost_adjoint, ost_transition and a tape's backward pass all
// refuse it with OST_ERR_NOT_CONVERGED and name it
START_TEST(test_unconvergedRefused) {
  ost_fixtureSetup();
  mjModel* m = ost_fixtureLoadModel("robot_pallet.xml");
  mjData* d = mj_makeData(m);
  ostOptions o;
  ck_assert_int_eq(ost_readOptions(m, &o, NULL, 0), OST_OK);
  o.timestep = 0.1;
  o.newton_iter = 2;
  o.split_depth = 0;
  ck_assert_int_eq(ost_setOptions(m, d, &o), OST_OK);
  for (int i = 0; i < m->nu; i++) d->ctrl[i] = 3;
  ostTape* t = ost_tapeCreate(m, 0);
  int first_bad = -1;
  for (int k = 0; k < 10; k++) {
    double time = d->time;
    int status = ost_tapeStep(t, m, d);
    ck_assert(status == OST_OK || status == OST_WARN_NOT_CONVERGED);
    ck_assert_double_eq_tol(d->time, time + 0.1, 1e-12);  // taken either way
    if (status == OST_WARN_NOT_CONVERGED && first_bad < 0) {
      first_bad = k;
      ck_assert_double_gt(ost_stats(d)->residual, o.tol);
      mjtNum g[64] = {0}, out[64];
      ck_assert_int_eq(ost_adjoint(m, d, NULL, g, g, out, out, NULL, NULL),
                       OST_ERR_NOT_CONVERGED);
      ck_assert_ptr_nonnull(strstr(ost_lastError(d), "did not converge"));
    }
  }
  ck_assert_int_ge(first_bad, 0);
  ck_assert_int_gt(ost_totals(d)->unconverged, 0);
  mjtNum* gctrl = (mjtNum*)calloc(10 * m->nu, sizeof(mjtNum));
  ck_assert_int_eq(ost_tapeBackward(t, m, NULL, NULL, NULL, gctrl, NULL, NULL, NULL),
                   OST_ERR_NOT_CONVERGED);
  char want[32];
  snprintf(want, sizeof(want), "step %d ", first_bad);
  printf("tape refuses: %s\n", ost_tapeError(t));
  ck_assert_ptr_nonnull(strstr(ost_tapeError(t), want));
  free(gctrl);
  ost_tapeDelete(t);
  ost_deleteData(d);
  mj_deleteModel(m);
}
END_TEST


// a batch world whose rollout kept part of an initial penetration (the sunk box) gets NaN
// gradients and OST_DEPENETRATED; a resting world beside it gets finite ones
START_TEST(test_batchRefusesUnsolved) {
  ost_fixtureSetup();
  mjModel* m = ost_fixtureLoadString(sunk_box);
  char err[300];
  ostBatch* b = ost_batchCreate(m, 2, "cpu:1", err, sizeof(err));
  ck_assert_msg(b != NULL, "%s", err);
  mjtNum qpos[14] = {0, 0, 0.05, 1, 0, 0, 0, 0, 0, 0.1, 1, 0, 0, 0};
  ck_assert_int_eq(ost_batchSetState(b, qpos, NULL), OST_OK);
  int T = 5, nv = m->nv;
  ck_assert_int_eq(ost_batchRollout(b, T, NULL, NULL, NULL), OST_OK);
  int status[2], unconverged[2];
  ck_assert_int_eq(ost_batchStatus(b, status), OST_OK);
  ck_assert_int_eq(ost_batchUnconverged(b, unconverged), OST_OK);
  ck_assert(status[0] & OST_DEPENETRATED);
  ck_assert(!(status[1] & OST_DEPENETRATED));
  mjtNum* gq = (mjtNum*)calloc((T + 1) * 2 * nv, sizeof(mjtNum));
  mjtNum gq0[12], gu0[12];
  for (int i = 0; i < 2 * nv; i++) gq[T * 2 * nv + i] = 1;
  ck_assert_int_eq(ost_batchBackward(b, NULL, 0, gq, NULL, NULL, gq0, gu0), OST_OK);
  ck_assert_int_eq(ost_batchStatus(b, status), OST_OK);
  ck_assert(isnan(gq0[0]) && (status[0] & OST_DEPENETRATED));
  for (int j = 0; j < nv; j++) ck_assert(isfinite(gq0[nv + j]));
  free(gq);
  ost_batchDelete(b);
  mj_deleteModel(m);
}
END_TEST


int main(void) {
  Suite* s = suite_create("ost_violation");
  TCase* tc = tcase_create("violation");
  tcase_set_timeout(tc, 120);
  tcase_add_test(tc, test_sunkBox);
  tcase_add_test(tc, test_overlappingBoxes);
  tcase_add_test(tc, test_jointOutsideRange);
  tcase_add_test(tc, test_violatedEquality);
  tcase_add_test(tc, test_restingStackUntouched);
  tcase_add_test(tc, test_fastBallKeyframe);
  tcase_add_test(tc, test_unconvergedRefused);
  tcase_add_test(tc, test_batchRefusesUnsolved);
  suite_add_tcase(s, tc);
  return ost_fixtureRun(s);
}
