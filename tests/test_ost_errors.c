// test_ost_errors.c: bad input gives a status and a message, never a crash, an exit or silently
// wrong physics: unsupported features, NaN state and controls, exhausted contact capacity,
// unknown options, malformed XML (MuJoCo's loader reports it; the library is never reached).
#include <math.h>
#include <stdio.h>
#include <string.h>

#include "fixture.h"
#include "ostrich.h"

START_TEST(test_unsupportedFeature) {
  ost_fixtureSetup();
  char path[1024];
  snprintf(path, sizeof(path), "%s/../tests/models/unsupported_user_gain.xml", OST_MODEL_DIR);
  char err[1000];
  mjModel* m = mj_loadXML(path, NULL, err, sizeof(err));
  ck_assert_ptr_nonnull(m);
  ck_assert_int_eq(ost_checkModel(m, err, sizeof(err)), OST_ERR_MODEL);
  ck_assert_ptr_nonnull(strstr(err, "gaintype user"));
  mjData* d = mj_makeData(m);
  double q0 = d->qpos[0];
  ck_assert_int_eq(ost_step(m, d), OST_ERR_MODEL);
  ck_assert_ptr_nonnull(strstr(ost_lastError(d), "gaintype user"));
  ck_assert_double_eq(d->qpos[0], q0);
  ck_assert_double_eq(d->time, 0);
  ost_deleteData(d);
  mj_deleteModel(m);
  // anisotropic rolling friction of a condim 6 pair is named too
  m = ost_fixtureLoadString("<mujoco><worldbody><geom name='floor' type='plane' size='1 1 1'/>"
                            "<body><freejoint/><geom name='ball' size='0.1'/></body></worldbody>"
                            "<contact><pair name='roll' geom1='floor' geom2='ball' condim='6'"
                            " friction='1 1 0.01 0.001 0.002'/></contact></mujoco>");
  ck_assert_int_eq(ost_checkModel(m, err, sizeof(err)), OST_ERR_MODEL);
  ck_assert_ptr_nonnull(strstr(err, "anisotropic friction"));
  ck_assert_ptr_nonnull(strstr(err, "roll"));
  mj_deleteModel(m);
}
END_TEST

// a model with three unsupported features gets all three in one refusal, grouped per feature
// (the user gain of both actuators is one entry), as a message and as ostRefusal records; a
// message that does not fit ends cleanly with "... and K more"
START_TEST(test_everyUnsupportedFeature) {
  ost_fixtureSetup();
  char path[1024], err[1000];
  snprintf(path, sizeof(path), "%s/../tests/models/unsupported_three_features.xml",
           OST_MODEL_DIR);
  mjModel* m = mj_loadXML(path, NULL, err, sizeof(err));
  ck_assert_ptr_nonnull(m);
  ck_assert_int_eq(ost_checkModel(m, err, sizeof(err)), OST_ERR_MODEL);
  const char* want[] = {"(3 features)", "contact pair 'rub': anisotropic friction",
                        "2 actuators ('shoulder_user', 'elbow_user'): a non-fixed gain",
                        "actuator 'grip': a user bias"};
  for (int i = 0; i < 4; i++) {
    ck_assert_msg(strstr(err, want[i]), "'%s' not in: %s", want[i], err);
  }

  // the records: one per feature, in the order of the message
  ostRefusal r[4];
  ck_assert_int_eq(ost_checkModelList(m, r, 4), 3);
  ck_assert_str_eq(r[0].what, "contact pair");
  ck_assert_str_eq(r[0].name[0], "rub");
  ck_assert_str_eq(r[1].what, "actuator");
  ck_assert_int_eq(r[1].count, 2);
  ck_assert_str_eq(r[1].name[0], "shoulder_user");
  ck_assert_str_eq(r[1].name[1], "elbow_user");
  ck_assert_str_eq(r[2].what, "actuator");
  ck_assert_str_eq(r[2].name[0], "grip");
  ck_assert_ptr_nonnull(strstr(r[2].feature, "user bias"));
  ck_assert_int_eq(ost_checkModelList(m, r, 1), 3);  // counted beyond nout
  ck_assert_int_eq(ost_checkModelList(NULL, r, 1), -1);

  // ost_checkStep (what ost_step checks) gives the same message with the mujoco provider, and
  // the step refuses with it
  ostOptions o;
  char step_err[1000];
  ost_defaultOptions(&o);
  ck_assert_int_eq(ost_checkStep(m, &o, step_err, sizeof(step_err)), OST_ERR_MODEL);
  ck_assert_str_eq(step_err, err);
  mjData* d = mj_makeData(m);
  ck_assert_int_eq(ost_step(m, d), OST_ERR_MODEL);
  ck_assert_str_eq(ost_lastError(d), err);
  ost_deleteData(d);

  // the native provider adds its own refusal of the tendon (native has no tendons)
  o.geometry = OST_GEOMETRY_NATIVE;
  ck_assert_int_eq(ost_checkStep(m, &o, step_err, sizeof(step_err)), OST_ERR_MODEL);
  ck_assert_msg(strstr(step_err, "(4 features)") && strstr(step_err, "tendons, which the native"),
                "%s", step_err);

  // a short buffer: whole entries, then "... and K more", never a cut entry
  char small[140];
  ck_assert_int_eq(ost_checkModel(m, small, sizeof(small)), OST_ERR_MODEL);
  ck_assert_msg(strstr(small, "anisotropic") && strstr(small, "; ... and 2 more"), "%s", small);
  ck_assert_int_lt(strlen(small), sizeof(small));
  char tiny[64];
  ck_assert_int_eq(ost_checkModel(m, tiny, sizeof(tiny)), OST_ERR_MODEL);
  ck_assert_msg(strstr(tiny, "... and 3 more"), "%s", tiny);
  mj_deleteModel(m);
}
END_TEST


START_TEST(test_nonFiniteInput) {
  ost_fixtureSetup();
  mjModel* m = ost_fixtureLoadModel("wheeled_robot.xml");
  mjData* d = mj_makeData(m);
  d->ctrl[1] = NAN;
  ck_assert_int_eq(ost_step(m, d), OST_ERR_INPUT);
  ck_assert_ptr_nonnull(strstr(ost_lastError(d), "ctrl[1]"));
  ck_assert_double_eq(d->time, 0);
  ck_assert_double_eq(d->qpos[2], m->qpos0[2]);
  d->ctrl[1] = 0;
  d->qpos[3] = INFINITY;
  ck_assert_int_eq(ost_step(m, d), OST_ERR_INPUT);
  ck_assert_ptr_nonnull(strstr(ost_lastError(d), "qpos[3]"));
  d->qpos[3] = 1;
  ck_assert_int_eq(ost_step(m, d), OST_OK);
  ost_deleteData(d);
  mj_deleteModel(m);
}
END_TEST

// the model's contacts beyond what Ostrich may grow to (81 resting spheres, nconmax 1: room for
// 64): the step fails with the reason and leaves the state as it was
START_TEST(test_contactOverflow) {
  ost_fixtureSetup();
  ost_fixtureAllowWarnings(1);  // MuJoCo warns when its contact buffer is full
  char path[1024], err[1000];
  snprintf(path, sizeof(path), "%s/../tests/models/too_many_contacts.xml", OST_MODEL_DIR);
  mjModel* m = mj_loadXML(path, NULL, err, sizeof(err));
  ck_assert_ptr_nonnull(m);
  mjData* d = mj_makeData(m);
  mjtNum z0 = d->qpos[2];
  ck_assert_int_eq(ost_step(m, d), OST_ERR_OVERFLOW);
  ck_assert_msg(strstr(ost_lastError(d), "nconmax") && strstr(ost_lastError(d), "grew"), "%s",
                ost_lastError(d));
  ck_assert_int_ne(ost_stats(d)->status & OST_OVERFLOW, 0);
  ck_assert_double_eq(d->qpos[2], z0);
  ck_assert_double_eq(d->time, 0);
  ost_deleteData(d);
  mj_deleteModel(m);
}
END_TEST


// 25 spheres with nconmax 2 (many_contacts.xml): Ostrich grows its own capacity (2, 4, ..., 32)
// and every step converges with both providers, the spheres resting at their radius (the hard
// contacts' allowance, 1e-6 m); the published contacts fill the user's buffer of 2, which the
// status says (OST_OVERFLOW) and MuJoCo warns about, as stock MuJoCo would
START_TEST(test_contactCapacityGrows) {
  ost_fixtureSetup();
  ost_fixtureAllowWarnings(1);
  mjModel* m = ost_fixtureLoadModel("../tests/models/many_contacts.xml");
  for (int geometry = 0; geometry < 2; geometry++) {
    mjData* d = mj_makeData(m);
    ost_fixtureSetProvider(m, d, m->opt.timestep, geometry);
    for (int k = 0; k < 100; k++) {
      ck_assert_msg(ost_step(m, d) == OST_OK, "step %d: %s", k, ost_lastError(d));
    }
    ck_assert_int_eq(ost_stats(d)->ncon_capacity, 32);
    ck_assert_int_ne(ost_stats(d)->status & OST_OVERFLOW, 0);
    for (int b = 2; b < m->nbody; b++) {
      ck_assert_double_eq_tol(d->xpos[3 * b + 2], 0.05, 1e-6);
    }
    ost_deleteData(d);
  }
  mj_deleteModel(m);
}
END_TEST


START_TEST(test_badOptions) {
  ost_fixtureSetup();
  char err[1000];
  ostOptions o;
  mjModel* m = ost_fixtureLoadString("<mujoco><custom><numeric name='ostrich/newtn_iter' data='4'/>"
                                     "</custom><worldbody/></mujoco>");
  ck_assert_int_eq(ost_readOptions(m, &o, err, sizeof(err)), OST_ERR_MODEL);
  ck_assert_ptr_nonnull(strstr(err, "newtn_iter"));
  mj_deleteModel(m);
  m = ost_fixtureLoadString("<mujoco><custom><numeric name='ostrich/newton_iter' data='4'/>"
                            "<numeric name='ostrich/timestep' data='0.1'/></custom>"
                            "<worldbody/></mujoco>");
  ck_assert_int_eq(ost_readOptions(m, &o, err, sizeof(err)), OST_OK);
  ck_assert_int_eq(o.newton_iter, 4);
  ck_assert_double_eq(o.timestep, 0.1);
  ck_assert_int_eq(ost_readOptions(NULL, &o, err, sizeof(err)), -1);
  mjData* d = mj_makeData(m);
  o.pcr_iter = 0;
  ck_assert_int_eq(ost_setOptions(m, d, &o), OST_ERR_MODEL);
  ost_defaultOptions(&o);
  o.split_depth = -1;
  ck_assert_int_eq(ost_setOptions(m, d, &o), OST_ERR_MODEL);
  ost_defaultOptions(&o);
  o.regularization = -1e-6;
  ck_assert_int_eq(ost_setOptions(m, d, &o), OST_ERR_MODEL);
  ost_deleteData(d);
  mj_deleteModel(m);
}
END_TEST

START_TEST(test_malformedXml) {
  ost_fixtureSetup();
  char err[1000] = "";
  mjModel* m = ost_fixtureTryLoadString("<mujoco><worldbody><body></mujoco>", err, sizeof(err));
  ck_assert_ptr_null(m);
  ck_assert_int_gt(strlen(err), 0);
  ck_assert_int_eq(ost_step(NULL, NULL), -1);
}
END_TEST

int main(void) {
  Suite* s = suite_create("ost_errors");
  TCase* tc = tcase_create("errors");
  tcase_add_test(tc, test_unsupportedFeature);
  tcase_add_test(tc, test_everyUnsupportedFeature);
  tcase_add_test(tc, test_nonFiniteInput);
  tcase_add_test(tc, test_contactOverflow);
  tcase_add_test(tc, test_contactCapacityGrows);
  tcase_add_test(tc, test_badOptions);
  tcase_add_test(tc, test_malformedXml);
  suite_add_tcase(s, tc);
  return ost_fixtureRun(s);
}
