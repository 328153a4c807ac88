// test_ost_collision_mujoco.c: the iterates' collision from a list of nearby geom pairs
// (plugin/ost_collision_mujoco.c) equals MuJoCo 2.2.2's mj_collision bit for bit: every contact
// field, in the same order, with the same overflow warnings, while the list is reused and after
// it is rebuilt; a model whose contacts depend on the broadphase's frame uses mj_collision.
#include <math.h>
#include <stdio.h>
#include <string.h>

#include "fixture.h"
#include "ost_internal.h"

// everything mj_collideGeoms sets, in one scene: a world plane and a static world box; free
// boxes (box-box, whose duplicate points MuJoCo drops), capsules (a plane-capsule contact carries
// its own tangent hint), spheres, an ellipsoid and a cylinder (general convex collision); a mocap
// sphere swept through the pile; geoms with priority, solmix, condim, margin and gap; an explicit
// <pair> with its own margin and friction; an <exclude>; contype/conaffinity that filter; and a
// hinged chain (parent filter)
static const char* scene =
  "<mujoco><option timestep='0.004'/><size nconmax='400' njmax='2000'/>"
  "<worldbody><geom name='floor' type='plane' size='4 4 0.1' friction='0.9 0.01 0.001'/>"
  "<geom name='wall' type='box' pos='0.6 0 0.2' size='0.05 0.6 0.2' margin='0.01'/>"
  "<body name='b1' pos='0 0 0.3'><freejoint/><geom name='box1' type='box' size='.1 .1 .1' "
  "priority='1' condim='4' solmix='2'/></body>"
  "<body name='b2' pos='0.05 0.02 0.55'><freejoint/><geom name='box2' type='box' "
  "size='.12 .08 .1' margin='0.005' gap='0.002'/></body>"
  "<body name='c1' pos='-0.3 0 0.4'><freejoint/><geom name='cap1' type='capsule' "
  "fromto='-.15 0 0 .15 0 0' size='0.05' solref='0.01 0.8' solimp='0.8 0.9 0.002'/>"
  "<geom name='sph1' type='sphere' pos='0 0.1 0' size='0.06' condim='6'/></body>"
  "<body name='c2' pos='-0.25 0.05 0.7'><freejoint/><geom name='cap2' type='capsule' "
  "fromto='0 -.15 0 0 .15 0' size='0.04' solref='-1000 -50'/></body>"
  "<body name='e1' pos='0.3 0.3 0.5'><freejoint/><geom name='ell' type='ellipsoid' "
  "size='.08 .05 .04'/></body>"
  "<body name='y1' pos='0.3 -0.3 0.5'><freejoint/><geom name='cyl' type='cylinder' "
  "size='.06 .05'/></body>"
  "<body name='hand' mocap='true' pos='0.2 0.2 0.12'><geom name='hand' type='sphere' "
  "size='0.06'/></body>"
  "<body name='ghost' pos='0 0.4 0.5'><freejoint/><geom name='ghost' type='sphere' size='0.07' "
  "contype='2' conaffinity='2'/></body>"
  "<body name='arm' pos='-0.1 -0.4 0.3'><joint type='hinge' axis='0 1 0'/>"
  "<geom name='arm1' type='capsule' fromto='0 0 0 0.2 0 0' size='0.04'/>"
  "<body pos='0.2 0 0'><joint type='hinge' axis='0 1 0'/>"
  "<geom name='arm2' type='capsule' fromto='0 0 0 0.2 0 0' size='0.04'/></body></body>"
  "</worldbody>"
  "<contact><pair geom1='box1' geom2='box2' margin='0.02' friction='0.5 0.5 0.01 0.001 0.001'/>"
  "<pair geom1='floor' geom2='sph1' condim='1'/>"
  "<exclude body1='c1' body2='c2'/></contact></mujoco>";


// 1 if the contacts of a and b are equal field by field (padding aside), with a message if not
static int sameContacts(const mjData* a, const mjData* b, char* why, int why_sz) {
  if (a->ncon != b->ncon) {
    snprintf(why, why_sz, "ncon %d against %d", a->ncon, b->ncon);
    return 0;
  }
  for (int i = 0; i < a->ncon; i++) {
    const mjContact *x = a->contact + i, *y = b->contact + i;
#define SAME(f) (!memcmp(&x->f, &y->f, sizeof(x->f)))
    if (!(SAME(dist) && SAME(pos) && SAME(frame) && SAME(includemargin) && SAME(friction)
          && SAME(solref) && SAME(solimp) && SAME(mu) && SAME(H) && SAME(dim) && SAME(geom1)
          && SAME(geom2) && SAME(exclude) && SAME(efc_address))) {
      snprintf(why, why_sz, "contact %d (geoms %d %d against %d %d) differs: dist %d pos %d "
               "frame %d margin %d friction %d solref %d solimp %d mu %d H %d dim %d exclude %d "
               "efc %d", i, x->geom1, x->geom2, y->geom1, y->geom2, SAME(dist), SAME(pos),
               SAME(frame), SAME(includemargin), SAME(friction), SAME(solref), SAME(solimp),
               SAME(mu), SAME(H), SAME(dim), SAME(exclude), SAME(efc_address));
      return 0;
    }
#undef SAME
  }
  return 1;
}


// simulate m with stock MuJoCo for n steps under random controls; at every step compare
// mj_collision with ost_collision on a copy of the state (the list carried from step to step),
// with jumps of every free body (rebuilds). Returns the contacts compared; *full counts the
// states where the contact capacity overflowed. With k->skip_core MuJoCo's contacts of core
// pairs are removed from the expected list and counted in *skipped.
static long compareSkipping(const mjModel* m, ostCollisionCache* k, int n, unsigned seed,
                            int* full, long* skipped) {
  mjData* d = mj_makeData(m);
  mjData* e = mj_makeData(m);
  long compared = 0;
  char why[200];
  for (int t = 0; t < n; t++) {
    for (int i = 0; i < m->nu; i++) {
      seed = seed * 1103515245u + 12345u;
      d->ctrl[i] = ((seed >> 8) % 2001) / 1000.0 - 1;
    }
    for (int b = 0; b < m->nmocap; b++) {
      d->mocap_pos[3 * b] = 0.2 + 0.3 * sin(0.01 * t);  // a mocap body sweeps through the pile
    }
    mj_step(m, d);
    if (t % 97 == 96) {
      // a jump: every free body moved by up to 5 cm, so that the list is rebuilt
      for (int j = 0; j < m->njnt; j++) {
        if (m->jnt_type[j] == mjJNT_FREE) {
          for (int a = 0; a < 3; a++) {
            seed = seed * 1103515245u + 12345u;
            d->qpos[m->jnt_qposadr[j] + a] += ((seed >> 8) % 1001) / 1e4 - 0.05;
          }
        }
      }
    }
    // the same qpos into both before mj_kinematics normalizes their quaternions in place
    memcpy(e->qpos, d->qpos, m->nq * sizeof(mjtNum));
    memcpy(e->mocap_pos, d->mocap_pos, 3 * m->nmocap * sizeof(mjtNum));
    memcpy(e->mocap_quat, d->mocap_quat, 4 * m->nmocap * sizeof(mjtNum));
    int warned = d->warning[mjWARN_CONTACTFULL].number;
    e->warning[mjWARN_CONTACTFULL].number = warned;
    mj_kinematics(m, d);
    mj_collision(m, d);
    if (k->skip_core) {
      // the expected list: MuJoCo's without the pairs core collides, in MuJoCo's order
      int kept = 0;
      for (int i = 0; i < d->ncon; i++) {
        if (!ost_corePair(m, d->contact[i].geom1, d->contact[i].geom2)) {
          d->contact[kept++] = d->contact[i];
        } else {
          *skipped += 1;
        }
      }
      d->ncon = kept;
    }
    mj_kinematics(m, e);
    ost_collision(k, m, e);
    ck_assert_msg(sameContacts(d, e, why, sizeof(why)), "step %d: %s", t, why);
    if (!k->skip_core) {  // with skip_core fewer contacts fill the capacity
      ck_assert_int_eq(d->warning[mjWARN_CONTACTFULL].number,
                       e->warning[mjWARN_CONTACTFULL].number);
    }
    *full += d->warning[mjWARN_CONTACTFULL].number > warned;
    compared += d->ncon;
  }
  mj_deleteData(d);
  mj_deleteData(e);
  return compared;
}


static long compareAlong(const mjModel* m, ostCollisionCache* k, int n, unsigned seed,
                         int* full) {
  long unused = 0;
  return compareSkipping(m, k, n, seed, full, &unused);
}


// the scene: 2,000 steps of a pile forming, with jumps; the list is reused for most evaluations
// and rebuilt when a geom has moved past the slack
START_TEST(test_sceneEqualsMujoco) {
  ost_fixtureSetup();
  mjModel* m = ost_fixtureLoadString(scene);
  ostCollisionCache k;
  memset(&k, 0, sizeof(k));
  int full = 0;
  long n = compareAlong(m, &k, 2000, 7, &full);
  printf("scene: %ld contacts equal over 2,000 states; lists built %ld, collisions from a list "
         "%ld\n", n, k.builds, k.uses);
  ck_assert_int_eq(k.state, 1);
  ck_assert_int_eq(k.uses, 2000);
  ck_assert(n > 2000);             // the pile is in contact (several contacts per state)
  ck_assert(k.builds > 20);         // the jumps and the fall rebuild it
  ck_assert(k.builds < k.uses / 2); // and a list serves several evaluations
  ost_collisionFree(&k);
  mj_deleteModel(m);
}
END_TEST


// a contact capacity too small for the pile: the same contacts kept and the same warnings
// counted as mj_collision (the fixture's warning handler allowed for this)
START_TEST(test_overflowEqualsMujoco) {
  ost_fixtureSetup();
  ost_fixtureAllowWarnings(1);
  mjModel* m = ost_fixtureLoadString(scene);
  m->nconmax = 5;
  ostCollisionCache k;
  memset(&k, 0, sizeof(k));
  int full = 0;
  compareAlong(m, &k, 300, 11, &full);
  ck_assert_int_eq(k.state, 1);
  ck_assert(full > 100);  // the capacity overflowed in most states
  ost_collisionFree(&k);
  mj_deleteModel(m);
}
END_TEST


// skip_core (the steps' setting): the wheeled robot on its box (cylinder-box, plane-cylinder,
// box-box pairs) and the test scene, listed and through mj_collision itself (an override):
// MuJoCo's contacts less core's pairs, the rest bit for bit in MuJoCo's order
START_TEST(test_skipCorePairs) {
  ost_fixtureSetup();
  ost_fixtureAllowWarnings(1);
  mjModel* models[2] = {ost_fixtureLoadModel("robot_box.xml"), ost_fixtureLoadString(scene)};
  for (int i = 0; i < 2; i++) {
    for (int override = 0; override < 2; override++) {
      mjModel* m = models[i];
      m->opt.enableflags = override ? m->opt.enableflags | mjENBL_OVERRIDE
                                    : m->opt.enableflags & ~mjENBL_OVERRIDE;
      ostCollisionCache k;
      memset(&k, 0, sizeof(k));
      k.skip_core = 1;
      int full = 0;
      long skipped = 0;
      long c = compareSkipping(m, &k, 300, 17, &full, &skipped);
      printf("skip_core, model %d, override %d: %ld contacts equal, %ld of core pairs left out\n",
             i, override, c, skipped);
      fflush(stdout);
      ck_assert_int_eq(k.state, override ? -1 : 1);
      // core pairs touch in most of the 300 states: the robot's wheels on the floor once it has
      // settled (265 contacts), boxes and the cylinder in the pile
      ck_assert(skipped > 150);
      ck_assert(c > 0 || i == 0);
      ost_collisionFree(&k);
    }
    mj_deleteModel(models[i]);
  }
}
END_TEST


// a margin override makes MuJoCo's contacts depend on its broadphase's frame: mj_collision is
// used (state -1), with the same result
START_TEST(test_overrideUsesMujoco) {
  ost_fixtureSetup();
  mjModel* m = ost_fixtureLoadString(scene);
  m->opt.enableflags |= mjENBL_OVERRIDE;
  m->opt.o_margin = 0.05;
  ostCollisionCache k;
  memset(&k, 0, sizeof(k));
  int full = 0;
  compareAlong(m, &k, 200, 3, &full);
  ck_assert_int_eq(k.state, -1);
  ck_assert_int_eq(k.uses, 0);
  ost_collisionFree(&k);
  mj_deleteModel(m);
}
END_TEST


// the project's scenes (a height field, a mesh terrain, wheels of cylinders, a stack) and the
// test models (legs, many contacts, a string of tendons), stepped by MuJoCo under random
// controls: each list-collided state equals mj_collision's
START_TEST(test_scenesEqualMujoco) {
  ost_fixtureSetup();
  ost_fixtureAllowWarnings(1);  // a scene may fill MuJoCo's own contact buffer; compared too
  const char* names[] = {"robot_box.xml", "robot_pallet.xml", "terrain_hfield.xml",
                         "terrain_mesh.xml", "stack_heavy_light.xml", "box_incline.xml",
                         "../tests/models/planar_legs.xml", "../tests/models/many_contacts.xml"};
  for (size_t i = 0; i < sizeof(names) / sizeof(names[0]); i++) {
    mjModel* m = ost_fixtureLoadModel(names[i]);
    ostCollisionCache k;
    memset(&k, 0, sizeof(k));
    int full = 0;
    long c = compareAlong(m, &k, 300, 13 + (unsigned)i, &full);
    printf("%s: %ld contacts equal over 300 states (list %s, built %ld)\n", names[i], c,
           k.state == 1 ? "used" : "not used: mj_collision", k.builds);
    fflush(stdout);
    ck_assert(c > 0);
    ck_assert_int_eq(k.state, 1);  // every one of them lists (the height field included)
    ost_collisionFree(&k);
    mj_deleteModel(m);
  }
}
END_TEST


// MuJoCo's humanoid sample (libmujoco-samples) falling under random controls, and two of them
static void sample(const char* path, int n) {
  char err[300];
  mjModel* m = mj_loadXML(path, NULL, err, sizeof(err));
  ck_assert_msg(m != NULL, "%s: %s (install libmujoco-samples)", path, err);
  ostCollisionCache k;
  memset(&k, 0, sizeof(k));
  int full = 0;
  long c = compareAlong(m, &k, n, 5, &full);
  printf("%s: %ld contacts equal over %d states; lists built %ld\n", path, c, n, k.builds);
  ck_assert_int_eq(k.state, 1);
  ck_assert(c > n);
  ost_collisionFree(&k);
  mj_deleteModel(m);
}

START_TEST(test_humanoidEqualsMujoco) {
  ost_fixtureSetup();
  sample("/usr/share/mujoco/model/humanoid/humanoid.xml", 1500);
  sample("/usr/share/mujoco/model/humanoid/22_humanoids.xml", 300);
}
END_TEST


int main(void) {
  Suite* s = suite_create("ost_collision_mujoco");
  TCase* tc = tcase_create("core");
  tcase_add_test(tc, test_sceneEqualsMujoco);
  tcase_add_test(tc, test_overflowEqualsMujoco);
  tcase_add_test(tc, test_skipCorePairs);
  tcase_add_test(tc, test_overrideUsesMujoco);
  tcase_add_test(tc, test_scenesEqualMujoco);
  tcase_add_test(tc, test_humanoidEqualsMujoco);
  suite_add_tcase(s, tc);
  return ost_fixtureRun(s);
}
