// test_ost_published.c: the publication of a step (plugin/ost_published.c). MuJoCo's position
// stage at q+ is copied from the iterates' mjData instead of being run again on the user's:
// every array of mjData (MuJoCo's own list, mjxmacro.h) must hold the same bits as when the
// publication runs mj_fwdPosition, step after step, on models that exercise each copied group:
// free bodies in contact (MuJoCo's humanoid: quaternions, contacts, fixed tendons, motors),
// spatial tendons wrapping cylinders with muscles (MuJoCo's arm26: wrap points, actuator
// moments), and a mocap body. Contacts of the pairs core collides itself (box-box here) are
// published as core's, with MuJoCo's contact parameters, in place of MuJoCo 2.2.2's own, and,
// with the option convex_distance, the contacts of MuJoCo's general convex collision with their
// true distances.
#include <math.h>
#include <stddef.h>
#include <stdio.h>
#include <string.h>

#include <mujoco/mjxmacro.h>

#include "fixture.h"
#include "ost_collision_mpr.h"
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


// boxes that core collides (ost_corePair): A rests on the floor, B on A (condim 4, its own
// friction, solref, solimp and solmix), D on B through an explicit <pair> only (D collides with
// nothing else); C, fixed and of priority 1, points a corner at the centre of A's face from
// 5.5 mm away (MuJoCo 2.2.2's box-box reports half that distance for a corner)
static const char* box_scene =
  "<mujoco><option timestep='0.005'/><worldbody><geom type='plane' size='5 5 0.1'/>"
  "<geom name='C' type='box' size='.1 .1 .1' pos='0.239731 -0.094713 0.045122' "
  "quat='0.963780 -0.211796 -0.009600 0.161797' priority='1' friction='0.5 0.02 0.002' "
  "solimp='0.7 0.95 0.001 0.5 2'/>"
  "<body pos='0 0 0.1'><freejoint/><geom name='A' type='box' size='.1 .1 .1' friction='0.7' "
  "solmix='2' solref='0.03 1.2' solimp='0.8 0.9 0.002 0.5 2'/></body>"
  "<body pos='0 0 0.3'><freejoint/><geom name='B' type='box' size='.08 .08 .1' mass='2' "
  "condim='4' friction='0.9 0.01 0.001' solmix='0.5' solref='0.01 0.8'/></body>"
  "<body pos='0 0 0.46'><freejoint/><geom name='D' type='box' size='.05 .05 .06' mass='0.7' "
  "contype='0' conaffinity='0'/></body></worldbody>"
  "<contact><pair geom1='B' geom2='D' condim='3' friction='0.4 0.4 0.005 0.0001 0.0001' "
  "solref='0.04 1' solimp='0.85 0.9 0.001 0.5 2'/></contact></mujoco>";


// the published contacts of the box scene after it settled: core's, not MuJoCo's. Each box
// pair's contacts carry the parameters MuJoCo's own contact of that pair carries at the same
// state (its collision of the private, look-ahead model), and their distances are core's: A
// and C stay 5.5 mm apart (MuJoCo 2.2.2's box-box reports centimetres of penetration there),
// resting contacts are not penetrated. Hard contact at rest: the published normal forces that
// carry B and D (2 + 0.7 kg) and D (0.7 kg) sum to their weights.
START_TEST(test_coreContacts) {
  ost_fixtureSetup();
  mjModel* m = ost_fixtureLoadString(box_scene);
  compare(m, 100, 0);
  mjData* d = mj_makeData(m);
  for (int k = 0; k < 100; k++) {
    ck_assert_int_eq(ost_step(m, d), OST_OK);
  }
  const mjModel* mo = ost_context(m, d)->mo;
  mjData* ref = mj_makeData(mo);
  memcpy(ref->qpos, d->qpos, m->nq * sizeof(mjtNum));
  mj_fwdPosition(mo, ref);
  int A = mj_name2id(m, mjOBJ_GEOM, "A"), B = mj_name2id(m, mjOBJ_GEOM, "B");
  int C = mj_name2id(m, mjOBJ_GEOM, "C"), D = mj_name2id(m, mjOBJ_GEOM, "D");
  int pairs[3][2] = {{A, B}, {A, C}, {B, D}}, count[3] = {0, 0, 0};
  double load[3] = {0, 0, 0}, mujoco_gap_AC = HUGE_VAL;
  for (int i = 0; i < ref->ncon; i++) {
    const mjContact* r = ref->contact + i;
    if ((r->geom1 == A && r->geom2 == C) || (r->geom1 == C && r->geom2 == A)) {
      mujoco_gap_AC = fmin(mujoco_gap_AC, r->dist);
    }
  }
  for (int i = 0; i < d->ncon; i++) {
    const mjContact* con = d->contact + i;
    for (int p = 0; p < 3; p++) {
      int a = pairs[p][0], b = pairs[p][1];
      if (!((con->geom1 == a && con->geom2 == b) || (con->geom1 == b && con->geom2 == a))) {
        continue;
      }
      count[p]++;
      const mjContact* r = NULL;
      for (int j = 0; j < ref->ncon && !r; j++) {
        int g1 = ref->contact[j].geom1, g2 = ref->contact[j].geom2;
        if ((g1 == a && g2 == b) || (g1 == b && g2 == a)) r = ref->contact + j;
      }
      ck_assert_msg(r != NULL, "MuJoCo reports no contact of pair %d", p);
      ck_assert_int_eq(con->dim, r->dim);
      ck_assert_double_eq(con->includemargin, r->includemargin);
      ck_assert_double_eq(con->mu, r->mu);
      for (int k = 0; k < 5; k++) ck_assert_double_eq(con->friction[k], r->friction[k]);
      for (int k = 0; k < mjNREF; k++) ck_assert_double_eq(con->solref[k], r->solref[k]);
      for (int k = 0; k < mjNIMP; k++) ck_assert_double_eq(con->solimp[k], r->solimp[k]);
      if (p == 1) {
        ck_assert_msg(fabs(con->dist - 0.0055) < 1e-4, "A-C distance %g, not 5.5 mm", con->dist);
      } else {
        ck_assert_msg(con->dist > -1e-6, "pair %d penetrated by %g m", p, -con->dist);
      }
      mjtNum f[6];
      mj_contactForce(m, d, i, f);
      load[p] += f[0];
    }
  }
  printf("box-box contacts: %d A-B, %d A-C, %d B-D; MuJoCo's own A-C distance %.4g m; "
         "loads %.6g N (B's and D's weight %.6g), %.6g N (D's %.6g), A-C %.3g N\n", count[0],
         count[1], count[2], mujoco_gap_AC, load[0], 2.7 * 9.81, load[2], 0.7 * 9.81, load[1]);
  ck_assert_int_ge(count[0], 4);
  ck_assert_int_ge(count[1], 1);
  ck_assert_int_ge(count[2], 4);
  // the case this fixes: MuJoCo's own distance is off by more than a millimetre
  ck_assert_double_gt(fabs(mujoco_gap_AC - 0.0055), 1e-3);
  ck_assert_double_lt(fabs(load[0] - 2.7 * 9.81), 1e-6 * 2.7 * 9.81);
  ck_assert_double_lt(fabs(load[2] - 0.7 * 9.81), 1e-6 * 0.7 * 9.81);
  // A and C stay apart: only the smoothing's force fb_eps^2 / (2 gap k) acts (1e-11 N)
  ck_assert_double_lt(fabs(load[1]), 1e-6);
  mj_deleteData(ref);
  mj_deleteData(d);
  mj_deleteModel(m);
}
END_TEST


// two convex meshes 0.195 mm apart (a bar fixed in the world, a free wedge; no gravity): inside
// Ostrich's 1 cm look-ahead MuJoCo 2.2.2's convex collision (MPR on both shapes inflated by half
// the margin) reports them 2.2 mm deep. Ostrich's rows and published contact carry their true
// distance with the option convex_distance (ost_refineConvexContacts), so the step removes no
// phantom penetration and the wedge, on which no force acts, stays at rest; without it (the
// default) the step pushes the wedge out of a penetration that is not there.
static const char* convex_scene =
  "<mujoco><option gravity='0 0 0' timestep='0.01'/><asset>"
  "<mesh name='bar' vertex='-.06 -.01 -.01 .06 -.01 -.01 -.06 .01 -.01 .06 .01 -.01 -.06 -.01 .01"
  " .06 -.01 .01 -.06 .01 .01 .06 .01 .01'/>"
  "<mesh name='wedge' vertex='0 0 0 .08 0 0 0 .08 0 0 0 .05 .02 .02 .06'/></asset><worldbody>"
  "<geom name='bar' type='mesh' mesh='bar'/>"
  "<body pos='0.1327 -0.0075 -0.0291' quat='0.19493 0.00526 -0.70943 0.67726'><freejoint/>"
  "<geom name='wedge' type='mesh' mesh='wedge'/></body></worldbody></mujoco>";

// distance of segments p1q1 and p2q2 (Ericson 5.1.9)
static double segmentDistance(const double p1[3], const double q1[3], const double p2[3],
                              const double q2[3]) {
  double d1[3], d2[3], r[3], c1[3], c2[3], s, t;
  mju_sub3(d1, q1, p1);
  mju_sub3(d2, q2, p2);
  mju_sub3(r, p1, p2);
  double a = mju_dot3(d1, d1), e = mju_dot3(d2, d2), f = mju_dot3(d2, r);
  double c = mju_dot3(d1, r), b = mju_dot3(d1, d2), den = a * e - b * b;
  s = den > 0 ? mju_clip((b * f - c * e) / den, 0, 1) : 0;
  t = (b * s + f) / e;
  if (t < 0) {
    t = 0;
    s = mju_clip(-c / a, 0, 1);
  } else if (t > 1) {
    t = 1;
    s = mju_clip((b - c) / a, 0, 1);
  }
  mju_addScl3(c1, p1, d1, s);
  mju_addScl3(c2, p2, d2, t);
  return mju_dist3(c1, c2);
}

// the world vertices of mesh geom g (at most 16)
static int meshVertices(const mjModel* m, const mjData* d, int g, double v[16][3]) {
  int id = m->geom_dataid[g], n = m->mesh_vertnum[id];
  for (int i = 0; i < n && i < 16; i++) {
    double local[3];
    for (int k = 0; k < 3; k++) local[k] = m->mesh_vert[3 * (m->mesh_vertadr[id] + i) + k];
    mju_rotVecMat(v[i], local, d->geom_xmat + 9 * g);
    mju_addTo3(v[i], d->geom_xpos + 3 * g);
  }
  return n;
}

// distance of two separated convex mesh geoms by brute force over their hulls' features:
// vertex-triangle both ways and edge-edge (exact for convex polytopes)
static double polytopeDistance(const mjModel* m, const mjData* d, int g1, int g2) {
  double v[2][16][3], best = HUGE_VAL;
  int gs[2] = {g1, g2};
  for (int s = 0; s < 2; s++) meshVertices(m, d, gs[s], v[s]);
  for (int s = 0; s < 2; s++) {
    int id = m->geom_dataid[gs[s]], o = 1 - s, io = m->geom_dataid[gs[o]];
    for (int f = 0; f < m->mesh_facenum[id]; f++) {
      const int* tri = m->mesh_face + 3 * (m->mesh_faceadr[id] + f);
      for (int i = 0; i < m->mesh_vertnum[io]; i++) {
        // core's point-triangle distance (libccd's, as MPR uses it) from the vertex as origin
        double x[3][3], w[3];
        for (int k = 0; k < 3; k++) mju_sub3(x[k], v[s][tri[k]], v[o][i]);
        best = fmin(best, sqrt(osti_mprTriDist2(x[0], x[1], x[2], w)));
      }
      for (int f2 = 0; s == 0 && f2 < m->mesh_facenum[io]; f2++) {
        const int* tri2 = m->mesh_face + 3 * (m->mesh_faceadr[io] + f2);
        for (int e = 0; e < 3; e++) {
          for (int e2 = 0; e2 < 3; e2++) {
            best = fmin(best, segmentDistance(v[0][tri[e]], v[0][tri[(e + 1) % 3]],
                                              v[1][tri2[e2]], v[1][tri2[(e2 + 1) % 3]]));
          }
        }
      }
    }
  }
  return best;
}

START_TEST(test_convexContacts) {
  ost_fixtureSetup();
  mjModel* m = ost_fixtureLoadString(convex_scene);
  mjData* d = mj_makeData(m);
  int bar = mj_name2id(m, mjOBJ_GEOM, "bar"), wedge = mj_name2id(m, mjOBJ_GEOM, "wedge");
  for (int on = 0; on < 2; on++) {
    mj_resetData(m, d);
    mj_forward(m, d);
    double truth = polytopeDistance(m, d, bar, wedge);
    // the case this fixes: MuJoCo's convex collision at the look-ahead margin is 2 mm off
    mjContact raw;
    ck_assert_int_eq(mjCOLLISIONFUNC[mjGEOM_MESH][mjGEOM_MESH](m, d, &raw, bar, wedge, 0.01), 1);
    ck_assert_double_gt(fabs(raw.dist - truth), 1e-3);
    ostOptions opt;
    ck_assert_int_eq(ost_readOptions(m, &opt, NULL, 0), OST_OK);
    ck_assert_int_eq(opt.convex_distance, 0);  // the default
    opt.convex_distance = on;
    ck_assert_int_eq(ost_setOptions(m, d, &opt), OST_OK);
    ck_assert_int_eq(ost_step(m, d), OST_OK);
    const ostStats* st = ost_stats(d);
    double speed = 0;
    for (int j = 0; j < m->nv; j++) speed = fmax(speed, fabs(d->qvel[j]));
    int found = 0;
    double dist = HUGE_VAL;
    for (int i = 0; i < d->ncon; i++) {
      const mjContact* con = d->contact + i;
      if ((con->geom1 == bar && con->geom2 == wedge)
          || (con->geom1 == wedge && con->geom2 == bar)) {
        found++;
        dist = con->dist;
      }
    }
    printf("convex meshes, convex_distance %d: true distance %.6g m, MuJoCo's MPR at the "
           "look-ahead %.6g m, published %.6g m; initial violation %.3g m, wedge speed after a "
           "step %.3g\n", on, truth, raw.dist, dist, st->initial_violation, speed);
    ck_assert_int_eq(found, 1);
    if (on) {
      ck_assert_msg(fabs(dist - truth) < 1e-7, "published distance %g, true %g", dist, truth);
      ck_assert_int_eq(st->status & OST_DEPENETRATED, 0);
      ck_assert_double_eq(st->initial_violation, 0);
      // nothing touches and nothing acts: only the FB smoothing's force (~1e-12 N) remains
      ck_assert_double_lt(speed, 1e-9);
    } else {
      // MuJoCo's distance: a phantom penetration of 2.2 mm, removed within the step (it is
      // below h depenetration_speed / 2), which throws the wedge off at over 1 m/s
      ck_assert_double_lt(dist, 1e-6);
      ck_assert_double_gt(speed, 0.1);
    }
  }
  mj_deleteData(d);
  mj_deleteModel(m);
}
END_TEST


// ost_contactFrame makes the tangents MuJoCo's mj_collision makes from a contact's normal: over
// random poses of the convex scene's wedge (normals in every direction), bit for bit
START_TEST(test_contactFrame) {
  ost_fixtureSetup();
  mjModel* m = ost_fixtureLoadString(convex_scene);
  mjData* d = mj_makeData(m);
  for (int g = 0; g < m->ngeom; g++) m->geom_margin[g] = 0.05;
  srand48(5);
  int ncon = 0, ny = 0;
  for (int rep = 0; rep < 300; rep++) {
    for (int k = 0; k < 3; k++) d->qpos[k] = 0.16 * (drand48() - 0.5);
    double q[4];
    for (int k = 0; k < 4; k++) q[k] = drand48() - 0.5;
    mju_normalize4(q);
    mju_copy4(d->qpos + 3, q);
    mj_kinematics(m, d);
    mj_comPos(m, d);
    mj_collision(m, d);
    for (int i = 0; i < d->ncon; i++) {
      mjtNum f[9] = {0};
      mju_copy3(f, d->contact[i].frame);
      ost_contactFrame(f);
      for (int k = 0; k < 9; k++) {
        ck_assert_msg(f[k] == d->contact[i].frame[k], "pose %d contact %d entry %d: %.17g, "
                      "MuJoCo %.17g", rep, i, k, f[k], d->contact[i].frame[k]);
      }
      ncon++;
      ny += fabs(f[1]) >= 0.5;
    }
  }
  printf("contact frames: %d of MuJoCo's (%d with the normal within 60 degrees of y) made alike\n",
         ncon, ny);
  ck_assert_int_gt(ny, 10);
  ck_assert_int_gt(ncon - ny, 10);
  mj_deleteData(d);
  mj_deleteModel(m);
}
END_TEST


// Coulomb friction on refined convex contacts: a mesh block (translating only: MuJoCo collides
// two meshes at one point) resting on a mesh slab tilted by 20 degrees (mu = 1 > tan 20 deg =
// 0.36) stays put with convex_distance 0 and 1. Its contact is found apart (by GJK) in some
// iterates and overlapping (MuJoCo's) in others; a contact without its tangent rows would let
// the block slide down at g sin 20 deg = 3.4 m/s^2 (0.3 m/s after 0.1 s).
static const char* slope_scene =
  "<mujoco><option timestep='0.01'/><asset>"
  "<mesh name='slab' vertex='-.5 -.5 -.05 .5 -.5 -.05 -.5 .5 -.05 .5 .5 -.05 -.5 -.5 0 .5 -.5 0"
  " -.5 .5 0 .5 .5 0'/>"
  "<mesh name='block' vertex='-.05 -.05 -.05 .05 -.05 -.05 -.05 .05 -.05 .05 .05 -.05 -.05 -.05"
  " .05 .05 -.05 .05 -.05 .05 .05 .05 .05 .05'/></asset><worldbody>"
  "<geom type='mesh' mesh='slab' euler='0 20 0' friction='1'/>"
  "<body pos='0.0171010 0 0.0469846' euler='0 20 0'><joint type='slide' axis='1 0 0'/>"
  "<joint type='slide' axis='0 1 0'/><joint type='slide' axis='0 0 1'/>"
  "<geom type='mesh' mesh='block' friction='1'/></body>"
  "</worldbody></mujoco>";

START_TEST(test_convexFriction) {
  ost_fixtureSetup();
  mjModel* m = ost_fixtureLoadString(slope_scene);
  mjData* d = mj_makeData(m);
  for (int on = 0; on < 2; on++) {
    mj_resetData(m, d);
    ostOptions opt;
    ck_assert_int_eq(ost_readOptions(m, &opt, NULL, 0), OST_OK);
    opt.convex_distance = on;
    ck_assert_int_eq(ost_setOptions(m, d, &opt), OST_OK);
    for (int k = 0; k < 10; k++) {
      int status = ost_step(m, d);
      ck_assert_msg(status == OST_OK, "convex_distance %d step %d: status %d, residual %g", on, k,
                    status, ost_stats(d)->residual);
    }
    double speed = mju_norm3(d->qvel);
    printf("block on a 20 degree slope, convex_distance %d: %.3g m/s after 0.1 s, %d contacts\n",
           on, speed, d->ncon);
    ck_assert_int_ge(d->ncon, 1);
    for (int i = 0; i < d->ncon; i++) {
      const mjtNum* f = d->contact[i].frame;  // an orthonormal frame around the normal
      ck_assert_double_eq_tol(mju_dot3(f + 3, f + 3), 1, 1e-12);
      ck_assert_double_eq_tol(mju_dot3(f, f + 3), 0, 1e-12);
    }
    ck_assert_double_lt(speed, 1e-3);
  }
  mj_deleteData(d);
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
  tcase_add_test(tc, test_coreContacts);
  tcase_add_test(tc, test_convexContacts);
  tcase_add_test(tc, test_contactFrame);
  tcase_add_test(tc, test_convexFriction);
  suite_add_tcase(s, tc);
  return ost_fixtureRun(s);
}
