// test_ost_published.c: the publication of a step (plugin/ost_published.c). MuJoCo's position
// stage at q+ is copied from the iterates' mjData instead of being run again on the user's:
// every array of mjData (MuJoCo's own list, mjxmacro.h) must hold the same bits as when the
// publication runs mj_fwdPosition, step after step, on models that exercise each copied group:
// free bodies in contact (MuJoCo's humanoid: quaternions, contacts, fixed tendons, motors),
// spatial tendons wrapping cylinders with muscles (MuJoCo's arm26: wrap points, actuator
// moments), and a mocap body.
#include <math.h>
#include <stddef.h>
#include <stdio.h>
#include <string.h>

#include <mujoco/mjxmacro.h>

#include "fixture.h"
#include "ost_internal.h"

#define HUMANOID "/usr/share/mujoco/model/humanoid/humanoid.xml"
#define ARM26 "/usr/share/mujoco/model/tendon_arm/arm26.xml"

// a box pushed around by a mocap body through a weld, next to a resting sphere
static const char* mocap_scene =
  "<mujoco><option timestep='0.005'/><worldbody><geom type='plane' size='5 5 0.1'/>"
  "<body name='hand' mocap='true' pos='0 0 0.3'><geom type='sphere' size='0.02' "
  "contype='0' conaffinity='0'/></body>"
  "<body name='box' pos='0 0 0.3'><freejoint/><geom type='box' size='.1 .1 .1'/></body>"
  "<body pos='0.5 0 0.1'><freejoint/><geom type='sphere' size='0.1'/></body></worldbody>"
  "<equality><weld body1='hand' body2='box' solref='0.02 1'/></equality></mujoco>";


// the first mjData array (MJDATA_POINTERS order) in which a and b differ, or NULL
static const char* firstDifference(const mjModel* m, const mjData* a, const mjData* b) {
  MJDATA_POINTERS_PREAMBLE(m)
  if (a->ncon != b->ncon || a->nefc != b->nefc) return "ncon or nefc";
  // contacts past ncon are scratch: mj_collision's on one side, earlier steps' on the other
  for (int i = 0; i < a->ncon; i++) {
    const mjContact *p = a->contact + i, *q = b->contact + i;
    // every field but H, the solver's cone Hessian, which only MuJoCo's solver sets
    // (mj_collision leaves whatever its stack held)
    size_t h0 = offsetof(mjContact, H), h1 = h0 + sizeof(p->H);
    size_t end = offsetof(mjContact, efc_address) + sizeof(int);
    if (memcmp(p, q, h0) || memcmp((const char*)p + h1, (const char*)q + h1, end - h1)) {
      printf("contact %d: dist %.17g %.17g pos %g %g geom %d %d / %d %d dim %d %d efc %d %d "
             "excl %d %d mu %g %g frame %g %g\n", i, p->dist, q->dist, p->pos[0], q->pos[0],
             p->geom1, p->geom2, q->geom1, q->geom2, p->dim, q->dim, p->efc_address,
             q->efc_address, p->exclude, q->exclude, p->mu, q->mu, p->frame[0], q->frame[0]);
      fflush(stdout);
      return "contact";
    }
  }
#define X(type, name, nr, nc)                                                              \
  if (strcmp(#name, "contact")                                                             \
      && memcmp(a->name, b->name, (size_t)m->nr * (nc) * sizeof(type))) return #name;
  MJDATA_POINTERS
#undef X
  return NULL;
}


// step two copies of the same model n times, one publishing by copy, the other by
// mj_fwdPosition; every array equal after every step, and the copy taken in most steps
static void compare(mjModel* m, int n, int mocap) {
  mjData* d1 = mj_makeData(m);
  mjData* d2 = mj_makeData(m);
  ost_context(m, d2)->publish_full = 1;
  for (int k = 0; k < n; k++) {
    for (int i = 0; i < m->nu; i++) d1->ctrl[i] = d2->ctrl[i] = 0.5 * sin(0.05 * k + i);
    if (mocap) {
      d1->mocap_pos[0] = d2->mocap_pos[0] = 0.3 * sin(0.02 * k);
    }
    int s1 = ost_step(m, d1), s2 = ost_step(m, d2);
    ck_assert_int_eq(s1, s2);
    ck_assert_msg(s1 == OST_OK || OST_IS_WARNING(s1), "step %d: %d %s", k, s1, ost_lastError(d1));
    const char* diff = firstDifference(m, d1, d2);
    ck_assert_msg(!diff, "step %d: %s differs between the copied and the recomputed stage", k,
                  diff ? diff : "");
  }
  long copies = ost_context(m, d1)->publish_copies;
  printf("%d steps, %ld published by copy: every mjData array equal\n", n, copies);
  // the copy is taken whenever the last evaluated iterate is the committed one: at least in
  // most steps (a step whose best iterate was not its last evaluates it again, and is copied)
  ck_assert_int_ge(copies, n * 9 / 10);
  ck_assert_int_eq(ost_context(m, d2)->publish_copies, 0);
  mj_deleteData(d1);
  mj_deleteData(d2);
}


START_TEST(test_humanoid) {
  ost_fixtureSetup();
  char err[500];
  mjModel* m = mj_loadXML(HUMANOID, NULL, err, sizeof(err));
  ck_assert_msg(m != NULL, "%s", err);
  compare(m, 400, 0);  // falls, lands and lies in contact
  mj_deleteModel(m);
}
END_TEST


START_TEST(test_arm26) {
  ost_fixtureSetup();
  char err[500];
  mjModel* m = mj_loadXML(ARM26, NULL, err, sizeof(err));
  ck_assert_msg(m != NULL, "%s", err);
  compare(m, 200, 0);
  mj_deleteModel(m);
}
END_TEST


START_TEST(test_mocap) {
  ost_fixtureSetup();
  mjModel* m = ost_fixtureLoadString(mocap_scene);
  compare(m, 200, 1);
  mj_deleteModel(m);
}
END_TEST


int main(void) {
  Suite* s = suite_create("ost_published");
  TCase* tc = tcase_create("published");
  tcase_set_timeout(tc, 120);
  tcase_add_test(tc, test_humanoid);
  tcase_add_test(tc, test_arm26);
  tcase_add_test(tc, test_mocap);
  suite_add_tcase(s, tc);
  return ost_fixtureRun(s);
}
