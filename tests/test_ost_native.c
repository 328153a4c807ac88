// test_ost_native.c: the `native` geometry provider (core/ost_rows_native.h, plugin/ost_pack.c,
// plugin/ost_native_check.c) against the `mujoco` provider and MuJoCo itself:
// - kinematics, mass matrix, bias forces, Jacobians and contacts equal MuJoCo's on every model
//   in mjcf_models/ and on Debian's humanoid (ost_compareNative, the oracle of `ostrich check`);
// - a full Ostrich step with `native` equals the step with `mujoco` to 1e-8 over 100 steps of
//   the wheeled robot, the pallet scene and the terrain scenes (a mesh terrain against the
//   height field with the same triangles);
// - what native cannot do is refused with a message naming it.
#include <dirent.h>
#include <math.h>
#include <stdio.h>
#include <string.h>

#include "fixture.h"
#include "ostrich.h"

// ost_compareNative on one model; prints the report and asserts every tolerance
static void compareModel(const mjModel* m, const char* label, int nstate) {
  char err[512] = "";
  ostNativeReport r;
  int status = ost_compareNative(m, nstate, 7, &r, err, sizeof(err));
  ck_assert_msg(status == OST_OK, "%s: %s", label, err);
  printf("%-28s states %3d contacts %5d | pos %.1e rot %.1e M %.1e bias %.1e passive %.1e "
         "act %.1e jac %.1e | unmatched %d | analytic %.1e %.1e %.1e | mpr %.1e %.1e %.1e\n",
         label, r.nstate, r.ncontact, r.body_pos, r.body_rot, r.mass_matrix, r.bias, r.passive,
         r.actuator, r.jacobian, r.contact_count, r.contact_analytic[0], r.contact_analytic[1],
         r.contact_analytic[2], r.contact_mpr[0], r.contact_mpr[1], r.contact_mpr[2]);
  ck_assert_msg(r.ok, "%s: native geometry differs from MuJoCo beyond tolerance", label);
}


// every model of mjcf_models/ that native can represent, and the humanoid
START_TEST(test_nativeMatchesMujoco) {
  ost_fixtureSetup();
  DIR* dir = opendir(OST_MODEL_DIR);
  ck_assert_ptr_nonnull(dir);
  struct dirent* e;
  int checked = 0;
  while ((e = readdir(dir))) {
    size_t n = strlen(e->d_name);
    if (n < 5 || strcmp(e->d_name + n - 4, ".xml") || !strcmp(e->d_name, "wheeled_robot_body.xml")) {
      continue;
    }
    mjModel* m = ost_fixtureLoadModel(e->d_name);
    char err[512];
    if (ost_checkNative(m, err, sizeof(err)) == OST_OK) {
      compareModel(m, e->d_name, 30);
      checked++;
    } else {
      printf("%-28s refused: %s\n", e->d_name, err);
    }
    mj_deleteModel(m);
  }
  closedir(dir);
  ck_assert_int_ge(checked, 8);
  char err[512] = "";
  mjModel* h = mj_loadXML("/usr/share/mujoco/model/humanoid/humanoid.xml", NULL, err, 512);
  ck_assert_msg(h != NULL, "%s", err);
  compareModel(h, "humanoid.xml", 30);
  mj_deleteModel(h);
}
END_TEST


// step two copies of a scene for n steps, one per provider (model b may differ from a, e.g. a
// mesh terrain against a height field), with a Newton budget of 100 so that solves converge
// where they can. Returns the largest state difference over the steps before the first whose
// solve did not converge in either run (best residual > 1e-9 m/s: round-off in the inputs then
// moves the result), *prefix = that step count; *total = the difference over all n steps.
static double stepBoth(const mjModel* ma, const mjModel* mb, double h, double margin,
                       const double* ctrl, int n, int* prefix, double* total) {
  mjData* da = mj_makeData(ma);
  mjData* db = mj_makeData(mb);
  ostOptions oa, ob;
  ck_assert_int_eq(ost_readOptions(ma, &oa, NULL, 0), OST_OK);
  ck_assert_int_eq(ost_readOptions(mb, &ob, NULL, 0), OST_OK);
  oa.timestep = ob.timestep = h;
  oa.newton_iter = ob.newton_iter = 100;
  oa.margin = ob.margin = margin;
  oa.geometry = OST_GEOMETRY_MUJOCO;
  ob.geometry = OST_GEOMETRY_NATIVE;
  // the geometric terms are the mujoco provider's only (core/ost_geometric.h): off, so that a
  // loop that fails is retried and split the same way by both providers
  oa.geometric_newton = 0;
  ck_assert_int_eq(ost_setOptions(ma, da, &oa), OST_OK);
  ck_assert_int_eq(ost_setOptions(mb, db, &ob), OST_OK);
  double worst = 0;
  *prefix = -1;
  *total = 0;
  for (int k = 0; k < n; k++) {
    for (int i = 0; i < ma->nu; i++) {
      da->ctrl[i] = db->ctrl[i] = ctrl[i];
    }
    int sa = ost_step(ma, da), sb = ost_step(mb, db);
    ck_assert_msg(sa == OST_OK, "mujoco provider step %d: %s", k, ost_lastError(da));
    ck_assert_msg(sb == OST_OK, "native provider step %d: %s", k, ost_lastError(db));
    if (*prefix < 0 && (ost_stats(da)->residual > 1e-9 || ost_stats(db)->residual > 1e-9)) {
      *prefix = k;
    }
    double diff = 0;
    for (int j = 0; j < ma->nq; j++) diff = fmax(diff, fabs(da->qpos[j] - db->qpos[j]));
    for (int j = 0; j < ma->nv; j++) diff = fmax(diff, fabs(da->qvel[j] - db->qvel[j]));
    if (*prefix < 0) {
      worst = fmax(worst, diff);
    }
    *total = fmax(*total, diff);
  }
  if (*prefix < 0) {
    *prefix = n;
  }
  ost_deleteData(da);
  ost_deleteData(db);
  return worst;
}


// a full Ostrich step with native equals the step with mujoco to 1e-8 over 100 steps, every
// Newton solve converging: the robot on flat ground, climbing the pallet (both providers collide
// cylinder-box pairs with core/ost_collision_cylbox.h) and on the sum-of-sinusoids height field
// (wheels by core/ost_collision_cylsurf.h, every other height-field pair by
// core/ost_collision_terrain.h, in both providers), with and without the look-ahead. The mesh terrain (native only) is
// held against the height field with the same triangles: MuJoCo stores mesh vertices as floats,
// so that pair agrees to 1e-6 (measured 1.9e-7), not 1e-8.
START_TEST(test_nativeStepEqualsMujoco) {
  ost_fixtureSetup();
  const struct { const char* a; const char* b; double h, margin, tol; } cases[] = {
    {"wheeled_robot.xml", "wheeled_robot.xml", 0.01, 0.01, 1e-8},
    {"robot_pallet.xml", "robot_pallet.xml", 0.05, 0.01, 1e-8},
    {"terrain_hfield.xml", "terrain_hfield.xml", 0.05, 0, 1e-8},
    {"terrain_hfield.xml", "terrain_hfield.xml", 0.05, 0.01, 1e-8},
    {"terrain_hfield.xml", "terrain_mesh.xml", 0.05, 0, 1e-6},
  };
  for (int c = 0; c < 5; c++) {
    mjModel* ma = ost_fixtureLoadModel(cases[c].a);
    mjModel* mb = ost_fixtureLoadModel(cases[c].b);
    double ctrl[8], total;
    for (int i = 0; i < ma->nu; i++) ctrl[i] = 3;
    int prefix;
    double diff = stepBoth(ma, mb, cases[c].h, cases[c].margin, ctrl, 100, &prefix, &total);
    printf("native vs mujoco, %s / %s, h=%g: %d converged steps, max |state difference| "
           "%.2e there, %.2e over 100 steps\n", cases[c].a, cases[c].b, cases[c].h, prefix,
           diff, total);
    ck_assert_int_eq(prefix, 100);
    ck_assert_double_lt(total, cases[c].tol);
    mj_deleteModel(ma);
    mj_deleteModel(mb);
  }
}
END_TEST


// three spheres and an ellipsoid dropped on the sum-of-sinusoids height field at the default
// look-ahead: both providers collide every height-field pair with core's functions (MuJoCo
// 2.2.2 reports height-field distances without the margin), so their steps agree to 1e-8 over
// 100 steps, every step converged. (Flat-sided geoms converge less well on a height field with
// either provider, and with MuJoCo's collider at margin 0: their prism contacts switch between
// iterates; a box converged in 23 of 30 steps, a capsule in 99 of 100.)
START_TEST(test_hfieldPrimitivesBothProviders) {
  ost_fixtureSetup();
  char xml[2048];
  snprintf(xml, sizeof(xml),
           "<mujoco><asset><hfield name='t' file='%s/terrain_sinusoid.bin' "
           "size='12 12 0.28148 0.5'/></asset><worldbody>"
           "<geom type='hfield' hfield='t' pos='0 0 -0.139822'/>"
           "<body pos='0.3 0.2 0.3'><freejoint/><geom type='sphere' size='0.1'/></body>"
           "<body pos='-0.4 0.1 0.3'><freejoint/><geom type='sphere' size='0.08'/></body>"
           "<body pos='0.1 -0.5 0.3' euler='0 0.2 0.5'><freejoint/>"
           "<geom type='sphere' size='0.05'/></body>"
           "<body pos='-0.3 -0.4 0.3'><freejoint/><geom type='ellipsoid' size='0.1 0.07 0.05'/>"
           "</body></worldbody></mujoco>", OST_MODEL_DIR);
  mjModel* m = ost_fixtureLoadString(xml);
  int prefix;
  double total, diff = stepBoth(m, m, 0.02, 0.01, NULL, 100, &prefix, &total);
  printf("native vs mujoco, primitives on a height field, margin 0.01: %d converged steps, "
         "max |state difference| %.2e\n", prefix, total);
  ck_assert_int_eq(prefix, 100);
  ck_assert_double_lt(diff, 1e-8);
  mj_deleteModel(m);
}
END_TEST


// one step from the same state with each provider, at 100 states along a native run: equal to
// 1e-8. Budget of 2 Newton iterates, no splitting, no warm start, so both providers take the
// same iterates (two unconverged iterates amplify round-off: on the height field one state of
// 100 differs by 6.7e-8, measured). Terrain at ostrich/margin 0 (the mujoco provider's
// condition for height fields); the mesh terrain is compared against the height field with
// the same triangles: MuJoCo stores mesh vertices as floats, so the two surfaces differ by about
// 1e-7 m and the steps by up to 9.2e-4 (measured), bounded at 1e-3. The terrain rows' bounds
// and counts are regression baselines (measured values beside them), kept to catch drift.
START_TEST(test_nativeStepFromSameState) {
  ost_fixtureSetup();
  const struct { const char* a; const char* b; double margin, tol; int min_equal; } cases[] = {
    {"wheeled_robot.xml", "wheeled_robot.xml", 0.01, 1e-8, 100},
    {"robot_pallet.xml", "robot_pallet.xml", 0.01, 1e-8, 100},
    {"terrain_hfield.xml", "terrain_hfield.xml", 0, 1e-7, 95},  // measured 99, 6.7e-8
    {"terrain_hfield.xml", "terrain_mesh.xml", 0, 1e-3, 5},     // measured 26 of 100, 9.2e-4
  };
  for (int c = 0; c < 4; c++) {
    mjModel* ma = ost_fixtureLoadModel(cases[c].a);
    mjModel* mb = ost_fixtureLoadModel(cases[c].b);
    mjData* run = mj_makeData(mb);
    mjData* da = mj_makeData(ma);
    mjData* db = mj_makeData(mb);
    ostOptions o, oa, ob;
    ck_assert_int_eq(ost_readOptions(mb, &o, NULL, 0), OST_OK);
    o.timestep = 0.05;
    o.geometry = OST_GEOMETRY_NATIVE;
    ck_assert_int_eq(ost_setOptions(mb, run, &o), OST_OK);
    oa = ob = o;
    oa.newton_iter = ob.newton_iter = 2;
    oa.split_depth = ob.split_depth = 0;
    oa.warmstart = ob.warmstart = 0;
    oa.margin = ob.margin = cases[c].margin;
    oa.geometry = OST_GEOMETRY_MUJOCO;
    oa.geometric_newton = 0;  // the mujoco provider's only: its retry would differ (stepBoth)
    ck_assert_int_eq(ost_setOptions(ma, da, &oa), OST_OK);
    ck_assert_int_eq(ost_setOptions(mb, db, &ob), OST_OK);
    double worst = 0;
    int ncontact = 0, nequal = 0;
    for (int k = 0; k < 100; k++) {
      for (int i = 0; i < mb->nu; i++) run->ctrl[i] = 3;
      ost_fixtureCopyState(mb, da, run);
      ost_fixtureCopyState(mb, db, run);
      // two Newton iterates need not reach tol: both providers take the step and agree on
      // whether it converged
      int sa = ost_step(ma, da), sb = ost_step(mb, db);
      ck_assert_msg(sa == OST_OK || OST_IS_WARNING(sa), "mujoco provider: %s", ost_lastError(da));
      ck_assert_msg(sb == OST_OK || OST_IS_WARNING(sb), "native provider: %s", ost_lastError(db));
      ncontact += ost_stats(db)->ncon;
      double diff = 0;
      for (int j = 0; j < mb->nq; j++) diff = fmax(diff, fabs(da->qpos[j] - db->qpos[j]));
      for (int j = 0; j < mb->nv; j++) diff = fmax(diff, fabs(da->qvel[j] - db->qvel[j]));
      worst = fmax(worst, diff);
      nequal += diff < 1e-8;
      ck_assert_msg(ost_step(mb, run) == OST_OK, "native run: %s", ost_lastError(run));
    }
    printf("one step from the same state, %s (mujoco) / %s (native), 100 states, %d contacts: "
           "%d steps equal to 1e-8, max |difference| %.2e\n", cases[c].a, cases[c].b, ncontact,
           nequal, worst);
    fflush(stdout);
    ck_assert_int_gt(ncontact, 100);
    ck_assert_double_lt(worst, cases[c].tol);
    ck_assert_int_ge(nequal, cases[c].min_equal);
    ost_deleteData(run);
    ost_deleteData(da);
    ost_deleteData(db);
    mj_deleteModel(ma);
    mj_deleteModel(mb);
  }
}
END_TEST


// the pallet run with native reaches the top of the pallet and crosses it (physics, not just
// agreement): chassis higher than 0.48 m at some point and beyond x = 3 m after 6 s
START_TEST(test_nativePalletClimb) {
  ost_fixtureSetup();
  mjModel* m = ost_fixtureLoadModel("robot_pallet.xml");
  mjData* d = mj_makeData(m);
  ostOptions o;
  ck_assert_int_eq(ost_readOptions(m, &o, NULL, 0), OST_OK);
  o.geometry = OST_GEOMETRY_NATIVE;
  o.timestep = 0.1;
  ck_assert_int_eq(ost_setOptions(m, d, &o), OST_OK);
  double zmax = 0;
  for (int k = 0; k < 60; k++) {
    for (int i = 0; i < m->nu; i++) d->ctrl[i] = 3;
    ck_assert_msg(ost_step(m, d) == OST_OK, "%s", ost_lastError(d));
    zmax = fmax(zmax, d->qpos[2]);
  }
  printf("native pallet h=0.1: final x %.3f y %.3f, max z %.3f\n", d->qpos[0], d->qpos[1], zmax);
  // on the pallet: ride height 0.35 m + pallet 0.144 m = 0.494 m (measured 0.494); the pallet's
  // far edge is at x = 2.2 m, so x > 3 m means it drove off (measured final x 6.203 m)
  ck_assert_double_gt(zmax, 0.48);
  ck_assert_double_gt(d->qpos[0], 3);
  ck_assert_double_lt(fabs(d->qpos[1]), 0.5);
  ost_deleteData(d);
  mj_deleteModel(m);
}
END_TEST


// the packed model follows the user's mjModel: an edit between steps (gravity reversed, then a
// body mass changed) takes effect at the next native step, as with the mujoco provider
START_TEST(test_nativeFollowsModelEdits) {
  ost_fixtureSetup();
  mjModel* m = ost_fixtureLoadModel("box_plane.xml");
  mjData* d = mj_makeData(m);
  ostOptions o;
  ck_assert_int_eq(ost_readOptions(m, &o, NULL, 0), OST_OK);
  o.geometry = OST_GEOMETRY_NATIVE;
  o.timestep = 0.01;
  ck_assert_int_eq(ost_setOptions(m, d, &o), OST_OK);
  for (int k = 0; k < 5; k++) ck_assert_int_eq(ost_step(m, d), OST_OK);
  ck_assert_double_lt(fabs(d->qvel[2]), 1e-6);  // resting on the plane
  m->opt.gravity[2] = 9.81;                     // gravity now pulls up
  ck_assert_int_eq(ost_step(m, d), OST_OK);
  printf("native after reversing gravity: vz %.6f (expected 0.0981)\n", d->qvel[2]);
  ck_assert_double_eq_tol(d->qvel[2], 9.81 * 0.01, 1e-6);
  ost_deleteData(d);
  mj_deleteModel(m);
}
END_TEST


// features native cannot do are refused by name, by ost_checkNative and by the step
START_TEST(test_nativeRefusals) {
  ost_fixtureSetup();
  mjModel* m = ost_fixtureLoadString(
      "<mujoco><worldbody><body><joint name='j1' type='hinge'/><geom size='.1'/></body>"
      "<body><joint name='j2' type='hinge'/><geom size='.1'/></body></worldbody>"
      "<equality><joint name='couple' joint1='j1' joint2='j2'/></equality>"
      "<custom><numeric name='ostrich/geometry' data='1'/></custom></mujoco>");
  char err[512] = "";
  ck_assert_int_eq(ost_checkNative(m, err, sizeof(err)), OST_ERR_MODEL);
  ck_assert_ptr_nonnull(strstr(err, "couple"));
  mjData* d = mj_makeData(m);
  ck_assert_int_eq(ost_step(m, d), OST_ERR_MODEL);
  ck_assert_ptr_nonnull(strstr(ost_lastError(d), "equality"));
  ck_assert_double_eq(d->time, 0);
  ost_deleteData(d);
  mj_deleteModel(m);

  m = ost_fixtureLoadString(
      "<mujoco><custom><numeric name='ostrich/geometry' data='2'/></custom></mujoco>");
  d = mj_makeData(m);
  ck_assert_int_eq(ost_step(m, d), OST_ERR_MODEL);
  ck_assert_ptr_nonnull(strstr(ost_lastError(d), "geometry"));
  ost_deleteData(d);
  mj_deleteModel(m);
}
END_TEST


int main(void) {
  Suite* s = suite_create("ost_native");
  TCase* tc = tcase_create("native");
  tcase_set_timeout(tc, 600);
  tcase_add_test(tc, test_nativeRefusals);
  tcase_add_test(tc, test_nativeFollowsModelEdits);
  tcase_add_test(tc, test_nativeMatchesMujoco);
  tcase_add_test(tc, test_nativeStepEqualsMujoco);
  tcase_add_test(tc, test_nativeStepFromSameState);
  tcase_add_test(tc, test_nativePalletClimb);
  tcase_add_test(tc, test_hfieldPrimitivesBothProviders);
  suite_add_tcase(s, tc);
  return ost_fixtureRun(s);
}
