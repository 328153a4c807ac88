// test_ost_collision_primitive.c: the analytic pair functions of ost_collision_primitive.h and
// ost_collision_box.h, and osti_makeFrame, against MuJoCo 2.2.2's mj_forward contacts.
// Each pair gets a one-pair model (a plane in the world and/or free bodies); every case sets
// sizes, margins and poses at random (with flat, aligned and parallel special poses mixed in),
// runs mj_forward, and matches d->contact with Ostrich's contacts as sets, by position.
#include "ost_collision_box.h"
#include "ost_collision_cylbox.h"
#include "ost_collision_gjk.h"

#include <check.h>
#include <math.h>
#include <mujoco/mujoco.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#define TOL 1e-9  // the closed forms MuJoCo uses, in double: round-off grown near parallel poses

//---------------------------------- random numbers -----------------------------------------------

static unsigned long long rng_state = 88172645463325252ULL;

static double urand(void) {  // uniform in [0, 1)
  rng_state ^= rng_state << 13;
  rng_state ^= rng_state >> 7;
  rng_state ^= rng_state << 17;
  return (double)(rng_state >> 11) / 9007199254740992.0;
}

static double urange(double a, double b) {
  return a + (b - a) * urand();
}

// uniform random unit quaternion
static void randQuat(double q[4]) {
  double n = 0;
  do {
    for (int i = 0; i < 4; i++) q[i] = urange(-1, 1);
    n = sqrt(q[0]*q[0] + q[1]*q[1] + q[2]*q[2] + q[3]*q[3]);
  } while (n < 0.1 || n > 1);
  for (int i = 0; i < 4; i++) q[i] /= n;
}

// one of the 24 rotations that map axes onto axes, then a turn by ang about a random axis
static void alignedQuat(double q[4], double ang) {
  int perm[6][3] = {{0, 1, 2}, {1, 2, 0}, {2, 0, 1}, {0, 2, 1}, {2, 1, 0}, {1, 0, 2}};
  int p = (int)(urand() * 6);
  double R[9] = {0}, sgn[3];
  for (int i = 0; i < 3; i++) sgn[i] = urand() < 0.5 ? -1 : 1;
  double det = (p < 3 ? 1 : -1) * sgn[0] * sgn[1] * sgn[2];
  if (det < 0) sgn[2] = -sgn[2];
  for (int i = 0; i < 3; i++) R[3*i + perm[p][i]] = sgn[i];
  mju_mat2Quat(q, R);
  if (ang != 0) {
    double ax[3] = {urange(-1, 1), urange(-1, 1), urange(-1, 1)}, dq[4], res[4];
    mju_normalize3(ax);
    mju_axisAngle2Quat(dq, ax, ang);
    mju_mulQuat(res, q, dq);
    mju_copy4(q, res);
  }
}

// a random pose quaternion: uniform, or aligned (exactly, or nearly)
static void poseQuat(double q[4]) {
  double u = urand();
  if (u < 0.6) {
    randQuat(q);
  } else if (u < 0.8) {
    alignedQuat(q, 0);
  } else {
    alignedQuat(q, urange(-1, 1) * (urand() < 0.5 ? 1e-3 : 0.2));
  }
}

//---------------------------------- one-pair models ----------------------------------------------

static const char* typeName(int t) {
  switch (t) {
  case mjGEOM_PLANE:    return "plane";
  case mjGEOM_SPHERE:   return "sphere";
  case mjGEOM_CAPSULE:  return "capsule";
  case mjGEOM_CYLINDER: return "cylinder";
  case mjGEOM_BOX:      return "box";
  default:              return "?";
  }
}

// model with geom 0 of type t1 (a world plane, or on a free body) and geom 1 of type t2
static mjModel* pairModel(int t1, int t2) {
  char xml[2000], err[1000];
  if (t1 == mjGEOM_PLANE) {
    snprintf(xml, sizeof(xml),
             "<mujoco><option gravity='0 0 0'/><worldbody>"
             "<geom type='plane' size='0 0 1'/>"
             "<body><freejoint/><geom type='%s' size='.1 .1 .1'/></body>"
             "</worldbody></mujoco>", typeName(t2));
  } else {
    snprintf(xml, sizeof(xml),
             "<mujoco><option gravity='0 0 0'/><worldbody>"
             "<body><freejoint/><geom type='%s' size='.1 .1 .1'/></body>"
             "<body><freejoint/><geom type='%s' size='.1 .1 .1'/></body>"
             "</worldbody></mujoco>", typeName(t1), typeName(t2));
  }
  // load from a virtual file (no temporary files on disk)
  mjVFS* vfs = (mjVFS*)malloc(sizeof(mjVFS));
  ck_assert_ptr_nonnull(vfs);
  mj_defaultVFS(vfs);
  int len = (int)strlen(xml);
  ck_assert_int_eq(mj_makeEmptyFileVFS(vfs, "pair.xml", len), 0);
  int idx = mj_findFileVFS(vfs, "pair.xml");
  ck_assert_int_ge(idx, 0);
  memcpy(vfs->filedata[idx], xml, len);
  mjModel* m = mj_loadXML("pair.xml", vfs, err, sizeof(err));
  mj_deleteVFS(vfs);
  free(vfs);
  ck_assert_msg(m != NULL, "load failed: %s", err);
  return m;
}

// random size of a geom of type t
static void randSize(double size[3], int t) {
  size[0] = size[1] = size[2] = 0;
  switch (t) {
  case mjGEOM_SPHERE:
    size[0] = urange(0.05, 0.5);
    break;
  case mjGEOM_CAPSULE:
  case mjGEOM_CYLINDER:
    size[0] = urange(0.05, 0.4);
    size[1] = urange(0.05, 0.6);
    break;
  case mjGEOM_BOX:
    for (int i = 0; i < 3; i++) size[i] = urange(0.05, 0.6);
    break;
  default:
    break;
  }
}

// bounding radius of a geom of type t
static double boundRadius(const double size[3], int t) {
  switch (t) {
  case mjGEOM_SPHERE:   return size[0];
  case mjGEOM_CAPSULE:  return size[0] + size[1];
  case mjGEOM_CYLINDER: return sqrt(size[0]*size[0] + size[1]*size[1]);
  case mjGEOM_BOX:      return sqrt(size[0]*size[0] + size[1]*size[1] + size[2]*size[2]);
  default:              return 0;
  }
}

// the ostGeom of geom g after mj_forward
static ostGeom placedGeom(const mjModel* m, const mjData* d, int g) {
  ostGeom og;
  memset(&og, 0, sizeof(og));
  og.type = m->geom_type[g];
  for (int i = 0; i < 3; i++) {
    og.size[i] = m->geom_size[3*g + i];
    og.pos[i] = d->geom_xpos[3*g + i];
  }
  for (int i = 0; i < 9; i++) og.mat[i] = d->geom_xmat[9*g + i];
  og.rbound = m->geom_rbound[g];
  return og;
}

//---------------------------------- comparison ---------------------------------------------------

typedef struct {
  int ncase, nhit, ncon, badcount, badcontact;
  double err_dist, err_pos, err_frame;
} pairStats;

// set one random case in (m, d): sizes, margin, poses; kind selects special poses
static void randomCase(mjModel* m, mjData* d, int t1, int t2) {
  int plane = (t1 == mjGEOM_PLANE);
  double s1[3], s2[3], q[4];
  randSize(s1, t1);
  randSize(s2, t2);
  double rb1 = boundRadius(s1, t1), rb2 = boundRadius(s2, t2);
  for (int i = 0; i < 3; i++) {
    m->geom_size[i] = plane ? (i < 2 ? 0 : 1) : s1[i];
    m->geom_size[3 + i] = s2[i];
  }
  m->geom_rbound[0] = plane ? 0 : 50;
  m->geom_rbound[1] = 50;
  double margin = urand() < 0.5 ? 0 : urange(0, 0.1);
  m->geom_margin[0] = urand() < 0.5 ? margin : 0;
  m->geom_margin[1] = margin;
  mj_resetData(m, d);

  if (plane) {
    // plane pose: flat and at the origin, or tilted and moved
    int flat = urand() < 0.4;
    double pq[4] = {1, 0, 0, 0}, n[3];
    if (!flat) randQuat(pq);
    for (int i = 0; i < 3; i++) m->geom_pos[i] = flat ? 0 : urange(-1, 1);
    mju_copy4(m->geom_quat, pq);
    double z[3] = {0, 0, 1};
    mju_rotVecQuat(n, z, pq);

    // body: resting (about a turn of the normal), or at random
    double h = urange(-rb2, rb2 + 0.12);
    if (flat && urand() < 0.5) {
      double half = t2 == mjGEOM_SPHERE ? s2[0] : (t2 == mjGEOM_BOX ? s2[2] : s2[1]);
      if (t2 == mjGEOM_CAPSULE) half = s2[0];
      double zq[4], side[4], ax[3] = {1, 0, 0}, zax[3] = {0, 0, 1};
      mju_axisAngle2Quat(zq, zax, urange(-3.14, 3.14));
      int onside = (t2 == mjGEOM_CAPSULE) || (t2 == mjGEOM_CYLINDER && urand() < 0.5);
      if (onside) {
        mju_axisAngle2Quat(side, ax, 0.5 * mjPI);
        mju_mulQuat(q, zq, side);
        half = s2[0];
      } else {
        mju_copy4(q, zq);
      }
      double r = urand();
      h = half + (r < 0.3 ? 0 : (r < 0.6 ? -urange(0, 0.01) : urange(0, 0.1)));
    } else {
      poseQuat(q);
    }
    for (int i = 0; i < 3; i++) d->qpos[i] = m->geom_pos[i] + h * n[i] + urange(-1, 1);
    // remove the sideways shift's normal part so that h stays the center's height
    double off[3] = {d->qpos[0] - m->geom_pos[0], d->qpos[1] - m->geom_pos[1],
                     d->qpos[2] - m->geom_pos[2]};
    double hn = mju_dot3(off, n);
    for (int i = 0; i < 3; i++) d->qpos[i] += (h - hn) * n[i];
    mju_copy4(d->qpos + 3, q);
  } else {
    // body 1 anywhere, body 2 around it within reach, often parallel or aligned to body 1
    for (int i = 0; i < 3; i++) d->qpos[i] = urange(-1, 1);
    poseQuat(d->qpos + 3);
    double dir[3] = {urange(-1, 1), urange(-1, 1), urange(-1, 1)};
    mju_normalize3(dir);
    double dist = urand() < 0.02 ? 0 : urange(0, rb1 + rb2 + 0.12);  // 0: same center
    for (int i = 0; i < 3; i++) d->qpos[7 + i] = d->qpos[i] + dist * dir[i];
    double r = urand();
    if (r < 0.2) {
      mju_copy4(d->qpos + 10, d->qpos + 3);
    } else if (r < 0.4) {
      double dq[4], ax[3] = {urange(-1, 1), urange(-1, 1), urange(-1, 1)};
      mju_normalize3(ax);
      mju_axisAngle2Quat(dq, ax, urange(-1, 1) * 1e-3);
      mju_mulQuat(d->qpos + 10, d->qpos + 3, dq);
    } else {
      poseQuat(d->qpos + 10);
    }
  }
}

// run ncase random cases of the pair (t1, t2); returns the statistics
static pairStats runPair(int t1, int t2, int ncase, int verbose) {
  pairStats st;
  memset(&st, 0, sizeof(st));
  mjModel* m = pairModel(t1, t2);
  mjData* d = mj_makeData(m);
  ostContact con[OST_MAXCONPAIR];
  for (int c = 0; c < ncase; c++) {
    randomCase(m, d, t1, t2);
    mj_forward(m, d);
    st.ncase++;

    // MuJoCo's geom order (the contacts name it; else types ascending, then geom ids)
    int g1 = 0, g2 = 1;
    if (d->ncon > 0) {
      g1 = d->contact[0].geom1;
      g2 = d->contact[0].geom2;
    }
    ostGeom og1 = placedGeom(m, d, g1), og2 = placedGeom(m, d, g2);
    double margin = mju_max(m->geom_margin[g1], m->geom_margin[g2]);

    // poison, collide
    for (int i = 0; i < OST_MAXCONPAIR; i++) {
      con[i].dist = NAN;
      for (int k = 0; k < 3; k++) con[i].pos[k] = NAN;
      for (int k = 0; k < 9; k++) con[i].frame[k] = NAN;
    }
    int handled = 0;
    int n = osti_collidePrimitive(con, &og1, &og2, margin, &handled);
    ck_assert_int_eq(handled, 1);
    if (t1 == mjGEOM_BOX && t2 == mjGEOM_BOX) {
      n = osti_collideBoxBoxMujoco(con, &og1, &og2, margin);  // MuJoCo's half-height dist
    }
    if (d->ncon) st.nhit++;
    st.ncon += d->ncon;
    if (n != d->ncon) {
      if (verbose && st.badcount < 5) {
        printf("  %s-%s case %d: count %d, MuJoCo %d\n", typeName(t1), typeName(t2), c, n,
               d->ncon);
      }
      st.badcount++;
      continue;
    }

    // match as sets: each MuJoCo contact with the nearest unused Ostrich contact
    int used[OST_MAXCONPAIR] = {0};
    for (int i = 0; i < d->ncon; i++) {
      const mjContact* mc = d->contact + i;
      int best = -1;
      double bestd = 1e300;
      for (int j = 0; j < n; j++) {
        if (used[j]) continue;
        double e = mju_dist3(mc->pos, con[j].pos) + fabs(mc->dist - con[j].dist);
        if (!(e >= bestd)) {
          bestd = e;
          best = j;
        }
      }
      ck_assert_int_ge(best, 0);
      used[best] = 1;
      double ed = fabs(mc->dist - con[best].dist), ep = 0, ef = 0;
      for (int k = 0; k < 3; k++) ep = fmax(ep, fabs(mc->pos[k] - con[best].pos[k]));
      for (int k = 0; k < 9; k++) ef = fmax(ef, fabs(mc->frame[k] - con[best].frame[k]));
      if (!(ed <= TOL && ep <= TOL && ef <= TOL) && verbose && st.badcontact++ < 5) {
        printf("  %s-%s case %d contact %d: dist err %.3g pos err %.3g frame err %.3g\n",
               typeName(t1), typeName(t2), c, i, ed, ep, ef);
        for (int k = 0; k < 9; k++) printf(" %g/%g", mc->frame[k], con[best].frame[k]);
        printf("\n");
      }
      st.err_dist = fmax(st.err_dist, isnan(ed) ? 1e300 : ed);
      st.err_pos = fmax(st.err_pos, isnan(ep) ? 1e300 : ep);
      st.err_frame = fmax(st.err_frame, isnan(ef) ? 1e300 : ef);
    }
  }
  mj_deleteData(d);
  mj_deleteModel(m);
  if (verbose) {
    printf("%-8s %-8s cases %6d  with contact %6d  contacts %6d  count mismatches %d  "
           "max err: dist %.2e pos %.2e frame %.2e\n", typeName(t1), typeName(t2), st.ncase,
           st.nhit, st.ncon, st.badcount, st.err_dist, st.err_pos, st.err_frame);
  }
  return st;
}

static int verboseRun(void) {
  const char* q = getenv("OSTRICH_QUIET");
  return !(q && q[0] == '1');
}

static void checkPair(int t1, int t2, int ncase) {
  pairStats st = runPair(t1, t2, ncase, verboseRun());
  ck_assert_int_eq(st.badcount, 0);
  ck_assert_double_le(st.err_dist, TOL);
  ck_assert_double_le(st.err_pos, TOL);
  ck_assert_double_le(st.err_frame, TOL);
  ck_assert_int_gt(st.nhit, ncase / 5);  // the cases do exercise contacts
}

//---------------------------------- tests --------------------------------------------------------

#define NCASE 20000

START_TEST(test_plane_box) { checkPair(mjGEOM_PLANE, mjGEOM_BOX, NCASE); } END_TEST
START_TEST(test_plane_sphere) { checkPair(mjGEOM_PLANE, mjGEOM_SPHERE, NCASE); } END_TEST
START_TEST(test_plane_capsule) { checkPair(mjGEOM_PLANE, mjGEOM_CAPSULE, NCASE); } END_TEST
START_TEST(test_sphere_sphere) { checkPair(mjGEOM_SPHERE, mjGEOM_SPHERE, NCASE); } END_TEST
START_TEST(test_sphere_capsule) { checkPair(mjGEOM_SPHERE, mjGEOM_CAPSULE, NCASE); } END_TEST
START_TEST(test_capsule_capsule) { checkPair(mjGEOM_CAPSULE, mjGEOM_CAPSULE, NCASE); } END_TEST
START_TEST(test_sphere_box) { checkPair(mjGEOM_SPHERE, mjGEOM_BOX, NCASE); } END_TEST
START_TEST(test_box_box) { checkPair(mjGEOM_BOX, mjGEOM_BOX, NCASE); } END_TEST
START_TEST(test_capsule_box) { checkPair(mjGEOM_CAPSULE, mjGEOM_BOX, NCASE); } END_TEST


//---------------------------------- cylinder : box (Ostrich's own) -------------------------------

// a wheel (r 0.35, half length 0.05) against the pallet's box (half sizes 0.6 0.4 0.072 at the
// origin); axis 0: along world y (a wheel), 1: along z (standing on its cap); yaw about z
static int wheelBox(ostContact* con, double x, double y, double z, int standing, double yaw,
                    double margin) {
  ostGeom cyl, box;
  memset(&cyl, 0, sizeof(cyl));
  memset(&box, 0, sizeof(box));
  box.type = OST_GEOM_BOX;
  box.size[0] = 0.6; box.size[1] = 0.4; box.size[2] = 0.072;
  box.mat[0] = box.mat[4] = box.mat[8] = 1;
  cyl.type = OST_GEOM_CYLINDER;
  cyl.size[0] = 0.35; cyl.size[1] = 0.05;
  cyl.pos[0] = x; cyl.pos[1] = y; cyl.pos[2] = z;
  // columns are the geom's axes: standing: identity; wheel: x, -z, y rotated by yaw about z
  double c = cos(yaw), s = sin(yaw);
  double ax[3] = {c, s, 0}, ay[3] = {0, 0, -1}, az[3] = {-s, c, 0};
  if (standing) {
    ay[1] = 1; ay[2] = 0; az[0] = 0; az[1] = 0; az[2] = 1; ax[0] = 1; ax[1] = 0;
  }
  for (int r = 0; r < 3; r++) {
    cyl.mat[3 * r] = ax[r]; cyl.mat[3 * r + 1] = ay[r]; cyl.mat[3 * r + 2] = az[r];
  }
  return osti_collideCylinderBox(con, &cyl, &box, margin);
}


// closed-form cases: a wheel on the top face, flush with the side face, on the near edge
// (parallel), lifted above the margin, standing on its cap; and continuity of the deepest
// contact while the wheel rolls over the edge and while it yaws through 0 on the edge
START_TEST(test_cylinder_box) {
  ostContact con[OST_MAXCONPAIR];
  const double top = 0.072, r = 0.35;

  // on the top face, 3 mm deep: the two ends of the bottom line
  int n = wheelBox(con, 0.1, 0.2, top + r - 0.003, 0, 0, 0);
  ck_assert_int_eq(n, 2);
  for (int i = 0; i < n; i++) {
    ck_assert_double_eq_tol(con[i].dist, -0.003, 1e-15);
    ck_assert_double_eq_tol(con[i].frame[2], -1, 1e-15);
    ck_assert_double_eq_tol(con[i].pos[2], top - 0.0015, 1e-15);
    ck_assert_double_eq_tol(fabs(con[i].pos[1] - 0.2), 0.05, 1e-15);
  }

  // flush with the side face (outer rim at y = 0.4): still the face, rims at 0.3 and 0.4
  n = wheelBox(con, 0.1, 0.35, top + r - 0.003, 0, 0, 0);
  ck_assert_int_eq(n, 2);
  ck_assert_double_eq_tol(con[0].frame[2], -1, 1e-15);
  ck_assert_double_eq_tol(con[1].frame[2], -1, 1e-15);
  ck_assert_double_eq_tol(fmax(con[0].pos[1], con[1].pos[1]), 0.4, 1e-15);

  // on the near edge (x = -0.6, z = top), axis parallel to it: the distance from the edge to
  // the axis minus r, normal from the axis to the edge, two points 1% of hl inside the rims
  double dx = 0.2, dz = 0.25, len = sqrt(dx * dx + dz * dz);
  n = wheelBox(con, -0.6 - dx, 0.2, top + dz, 0, 0, 0);
  ck_assert_int_eq(n, 2);
  for (int i = 0; i < n; i++) {
    ck_assert_double_eq_tol(con[i].dist, len - r, 1e-14);
    ck_assert_double_eq_tol(con[i].frame[0], dx / len, 1e-14);
    ck_assert_double_eq_tol(con[i].frame[2], -dz / len, 1e-14);
    ck_assert_double_eq_tol(fabs(con[i].pos[1] - 0.2), 0.0495, 1e-14);
  }

  // 2 cm above the face: nothing within a 1 cm margin, two contacts within 3 cm
  ck_assert_int_eq(wheelBox(con, 0.1, 0.2, top + r + 0.02, 0, 0, 0.01), 0);
  n = wheelBox(con, 0.1, 0.2, top + r + 0.02, 0, 0, 0.03);
  ck_assert_int_eq(n, 2);
  ck_assert_double_eq_tol(con[0].dist, 0.02, 1e-15);

  // standing on its cap, 1 mm deep: four rim points
  n = wheelBox(con, 0.1, 0.1, top + 0.05 - 0.001, 1, 0, 0);
  ck_assert_int_eq(n, 4);
  for (int i = 0; i < n; i++) {
    ck_assert_double_eq_tol(con[i].dist, -0.001, 1e-15);
    ck_assert_double_eq_tol(con[i].frame[2], -1, 1e-15);
  }

  // rolling over the edge at the height where the wheel touches the face: the deepest
  // distance is continuous (Lipschitz 1 in x), and so is the normal's x component
  double prev_d = 0, prev_nx = 0, step = 1e-4, worst = 0;
  for (int k = 0; k <= 3500; k++) {
    double x = -0.75 + k * step;
    n = wheelBox(con, x, 0.2, top + r - 0.001, 0, 0, 0.05);
    ck_assert_int_ge(n, 1);
    double d = 1, nx = 0;
    for (int i = 0; i < n; i++) {
      if (con[i].dist < d) {
        d = con[i].dist;
        nx = con[i].frame[0];
      }
    }
    if (k > 0) {
      worst = fmax(worst, fabs(d - prev_d) / step);
      ck_assert_msg(fabs(nx - prev_nx) < 0.01, "normal jumps at x = %g", x);
    }
    prev_d = d;
    prev_nx = nx;
  }
  ck_assert_double_le(worst, 1 + 1e-6);

  // yawing through 0 on the edge: distances continuous (slope <= hl), count constant
  double prev[2] = {0, 0};
  for (int k = -100; k <= 100; k++) {
    double yaw = k * 1e-6;
    n = wheelBox(con, -0.6 - dx, 0.2, top + dz, 0, yaw, 0);
    ck_assert_int_eq(n, 2);
    if (k > -100) {
      for (int i = 0; i < 2; i++) {
        ck_assert_double_le(fabs(con[i].dist - prev[i]), 0.06 * 1e-6);
      }
    }
    prev[0] = con[0].dist;
    prev[1] = con[1].dist;
  }
}
END_TEST


//---------------------------------- plane : cylinder (Ostrich's own) -----------------------------

// a cylinder (radius r, half length hl) at height z over the plane z = 0, its axis tilted by
// tilt about the horizontal direction (cos az, sin az, 0), then turned by spin about its axis
static int cylPlane(ostContact* con, double r, double hl, double z, double tilt, double az,
                    double spin, double margin) {
  ostGeom plane, cyl;
  memset(&plane, 0, sizeof(plane));
  memset(&cyl, 0, sizeof(cyl));
  plane.type = OST_GEOM_PLANE;
  plane.mat[0] = plane.mat[4] = plane.mat[8] = 1;
  cyl.type = OST_GEOM_CYLINDER;
  cyl.size[0] = r;
  cyl.size[1] = hl;
  cyl.pos[2] = z;
  double qs[4], qt[4], q[4], z3[3] = {0, 0, 1}, h3[3] = {cos(az), sin(az), 0};
  mju_axisAngle2Quat(qs, z3, spin);
  mju_axisAngle2Quat(qt, h3, tilt);
  mju_mulQuat(q, qt, qs);
  double mat[9];
  mju_quat2Mat(mat, q);
  for (int i = 0; i < 9; i++) cyl.mat[i] = mat[i];
  return osti_collidePlaneCylinder(con, &plane, &cyl, margin);
}


// the lowest height of the solid cylinder: centre - hl |cos tilt| - r |sin tilt|
static double cylLowest(double r, double hl, double z, double tilt) {
  return z - hl * fabs(cos(tilt)) - r * fabs(sin(tilt));
}


// tilted by more than OST_CYLPLANE_TILT, the deepest contact is the solid's lowest point, for
// random sizes, heights and poses (a wheel on its side included); every contact point lies on
// the cylinder's rim, with the plane's normal, within the margin
START_TEST(test_plane_cylinder) {
  ostContact con[OST_MAXCONPAIR];
  for (int c = 0; c < 20000; c++) {
    double r = urange(0.01, 0.5), hl = urange(0.005, 0.5), margin = urange(0, 0.02);
    double tilt = urange(OST_CYLPLANE_TILT * 1.01, mjPI - OST_CYLPLANE_TILT * 1.01);
    if (c % 10 == 0) tilt = 0.5 * mjPI;  // a wheel on its side
    double az = urange(-mjPI, mjPI), spin = urange(-mjPI, mjPI);
    double low = -urange(-margin, 0.01), z = low - cylLowest(r, hl, 0, tilt);
    int n = cylPlane(con, r, hl, z, tilt, az, spin, margin);
    ck_assert_int_ge(n, low <= margin ? 1 : 0);
    ck_assert_int_le(n, 2 + 2 * OST_CYLPLANE_RIM);
    double deepest = HUGE_VAL;
    for (int i = 0; i < n; i++) {
      deepest = fmin(deepest, con[i].dist);
      ck_assert_double_le(con[i].dist, margin);
      ck_assert_double_eq_tol(con[i].frame[2], 1, 1e-15);
      // the surface point pos + dist/2 n: on a rim (axial offset hl, radial offset r)
      double p[3] = {con[i].pos[0], con[i].pos[1], con[i].pos[2] + con[i].dist * 0.5 - z};
      // the axis R e_z
      double a[3] = {sin(az) * sin(tilt), -cos(az) * sin(tilt), cos(tilt)};
      double along = p[0] * a[0] + p[1] * a[1] + p[2] * a[2];
      double rad2 = p[0] * p[0] + p[1] * p[1] + p[2] * p[2] - along * along;
      ck_assert_double_eq_tol(fabs(along), hl, 1e-12);
      ck_assert_double_eq_tol(sqrt(fmax(rad2, 0)), r, 1e-12);
    }
    if (n > 0) {
      ck_assert_double_eq_tol(deepest, low, 1e-12);
    }
  }
}
END_TEST


// a disk lying (nearly) flat: 1 mm deep it touches at the fixed rim points and its centre;
// tilted below OST_CYLPLANE_TILT the deepest contact is above the solid's lowest point by at
// most r sin(tilt) (1 - cos(pi / OST_CYLPLANE_RIM)); and tilting through flat (where the
// direction of the lowest rim point turns over) moves every contact continuously, so a Newton
// iterate near rest sees the same contact set as its neighbour
START_TEST(test_plane_cylinder_flat) {
  ostContact con[OST_MAXCONPAIR], prev[OST_MAXCONPAIR];
  const double r = 0.045, hl = 0.0026;

  // flat, 1 mm deep: the lower disk's rim points and its centre; of the upper disk (5.2 mm
  // higher) only the centre, within a 1 cm margin (its rim points are out of the band)
  int n = cylPlane(con, r, hl, hl - 0.001, 0, 0, 0.3, 0);
  ck_assert_int_eq(n, OST_CYLPLANE_RIM + 1);
  for (int i = 0; i < n; i++) ck_assert_double_eq_tol(con[i].dist, -0.001, 1e-15);
  ck_assert_int_eq(cylPlane(con, r, hl, hl - 0.001, 0, 0, 0.3, 0.01), OST_CYLPLANE_RIM + 2);

  // a wheel on its side, at any spin: the two lowest points only, as MuJoCo's
  for (int k = 0; k < 100; k++) {
    n = cylPlane(con, 0.35, 0.05, 0.35 - 0.003, 0.5 * mjPI, 0.3, k * 0.0628, 0.01);
    ck_assert_int_eq(n, 2);
    ck_assert_double_eq_tol(con[0].dist, -0.003, 1e-15);
    ck_assert_double_eq_tol(con[1].dist, -0.003, 1e-15);
  }

  // below the threshold: the deepest contact within the stated bound of the solid's lowest point
  double bound_scale = 1 - cos(mjPI / OST_CYLPLANE_RIM);
  for (int c = 0; c < 5000; c++) {
    double tilt = urange(0, OST_CYLPLANE_TILT), az = urange(-mjPI, mjPI);
    double spin = urange(-mjPI, mjPI), z = 0.02;
    n = cylPlane(con, r, hl, z, tilt, az, spin, 1);
    double deepest = HUGE_VAL;
    for (int i = 0; i < n; i++) deepest = fmin(deepest, con[i].dist);
    double low = cylLowest(r, hl, z, tilt);
    ck_assert_double_ge(deepest, low - 1e-15);
    ck_assert_double_le(deepest, low + r * sin(tilt) * bound_scale + 1e-15);
  }

  // through flat along random directions, within 1e-4 rad (where no rim point leaves the
  // band): same count, each contact moving at most (r / sin OST_CYLPLANE_TILT + r + hl) per
  // radian of tilt; over +-0.02 rad the deepest distance is Lipschitz (2 r + hl: the inward-moving point sinks at
  // up to 2 r per radian)
  for (int c = 0; c < 50; c++) {
    double az = urange(-mjPI, mjPI), spin = urange(-mjPI, mjPI), step = 1e-6;
    double lip = r / sin(OST_CYLPLANE_TILT) + r + hl;
    int np = 0;
    for (int k = -100; k <= 100; k++) {
      n = cylPlane(con, r, hl, hl - 0.001, k * step, az, spin, 0.002);
      if (k > -100) {
        ck_assert_int_eq(n, np);
        for (int i = 0; i < n; i++) {
          double dp = 0;
          for (int j = 0; j < 3; j++) dp = fmax(dp, fabs(con[i].pos[j] - prev[i].pos[j]));
          ck_assert_msg(dp <= lip * step * 1.001, "contact %d jumps by %g at tilt %g", i, dp,
                        k * step);
          ck_assert_double_le(fabs(con[i].dist - prev[i].dist), (r + hl) * step * 1.001);
        }
      }
      memcpy(prev, con, sizeof(con));
      np = n;
    }
    double prev_low = 0;
    for (int k = -2000; k <= 2000; k++) {
      n = cylPlane(con, r, hl, hl - 0.001, k * 1e-5, az, spin, 0.01);
      double low = HUGE_VAL;
      for (int i = 0; i < n; i++) low = fmin(low, con[i].dist);
      if (k > -2000) ck_assert_double_le(fabs(low - prev_low), (2 * r + hl) * 1e-5 * 1.001);
      prev_low = low;
    }
  }
}
END_TEST


//---------------------------------- box : box (Ostrich's own face points) ------------------------

// a box of half sizes s at pos with orientation quaternion q
static ostGeom boxGeom(const double s[3], const double pos[3], const double q[4]) {
  ostGeom g;
  memset(&g, 0, sizeof(g));
  g.type = OST_GEOM_BOX;
  double mat[9];
  mju_quat2Mat(mat, q);
  for (int i = 0; i < 3; i++) {
    g.size[i] = s[i];
    g.pos[i] = pos[i];
  }
  for (int i = 0; i < 9; i++) g.mat[i] = mat[i];
  g.rbound = sqrt(s[0] * s[0] + s[1] * s[1] + s[2] * s[2]);
  return g;
}


// equal cubes (half size 0.1) stacked with an offset (0.02, 0.01) and an overlap of 1e-4 m: the
// four corners of the faces' intersection, each with dist -1e-4 (MuJoCo's routine reports
// -5e-5, and a fifth point outside the lower face) and the normal +z
START_TEST(test_box_box_stacked) {
  const double s[3] = {0.1, 0.1, 0.1}, q0[4] = {1, 0, 0, 0};
  const double p1[3] = {0, 0, 0.1}, p2[3] = {0.02, 0.01, 0.3 - 1e-4};
  ostGeom a = boxGeom(s, p1, q0), b = boxGeom(s, p2, q0);
  ostContact con[OST_MAXCONPAIR];
  int n = osti_collideBoxBox(con, &a, &b, 0.01);
  ck_assert_int_eq(n, 4);
  int seen = 0;
  for (int i = 0; i < n; i++) {
    ck_assert_double_eq_tol(con[i].dist, -1e-4, 1e-15);
    ck_assert_double_eq_tol(con[i].frame[2], 1, 1e-15);
    ck_assert_double_eq_tol(con[i].pos[2], 0.2 - 0.5e-4, 1e-15);
    int cx = fabs(con[i].pos[0] - 0.1) < 1e-12 ? 1 : (fabs(con[i].pos[0] + 0.08) < 1e-12 ? 0 : -1);
    int cy = fabs(con[i].pos[1] - 0.1) < 1e-12 ? 1 : (fabs(con[i].pos[1] + 0.09) < 1e-12 ? 0 : -1);
    ck_assert_msg(cx >= 0 && cy >= 0, "contact %d at (%g, %g) is no corner", i, con[i].pos[0],
                  con[i].pos[1]);
    seen |= 1 << (2 * cx + cy);
  }
  ck_assert_int_eq(seen, 15);
  ck_assert_int_ge(osti_collideBoxBoxMujoco(con, &a, &b, 0.01), 4);
  ck_assert_double_eq_tol(con[0].dist, -0.5e-4, 1e-15);
}
END_TEST


// a small box resting on a large one at random sizes, yaws, offsets and tilts up to 0.02 rad:
// the contacts are the four corners of the small box's lower face, each with its height over
// the large box's top face as dist (MuJoCo's routine reports half of it) and the normal +z
START_TEST(test_box_box_resting) {
  for (int c = 0; c < 5000; c++) {
    double s1[3], s2[3];
    for (int i = 0; i < 3; i++) s1[i] = urange(0.1, 0.3);
    s2[0] = urange(0.2, 0.45) * fmin(s1[0], s1[1]);
    s2[1] = urange(0.2, 0.45) * fmin(s1[0], s1[1]);
    s2[2] = urange(0.05, 0.3);
    double ax[3] = {urange(-1, 1), urange(-1, 1), 0}, z3[3] = {0, 0, 1}, qt[4], qy[4], q2[4];
    double q1[4] = {1, 0, 0, 0};
    mju_normalize3(ax);
    mju_axisAngle2Quat(qt, ax, urange(0, 0.02));
    mju_axisAngle2Quat(qy, z3, urange(-mjPI, mjPI));
    mju_mulQuat(q2, qt, qy);
    // within the large face whatever the yaw and tilt: offset + the small face's half diagonal
    // + the shift of its lower face by the tilt < s1
    double reach = hypot(s2[0], s2[1]) + 0.02 * s2[2] + 0.001;
    double rx = fmax(s1[0] - reach, 0), ry = fmax(s1[1] - reach, 0);
    double p1[3] = {0, 0, 0}, p2[3] = {urange(-rx, rx), urange(-ry, ry), 0};
    ostGeom a = boxGeom(s1, p1, q1), b = boxGeom(s2, p2, q2);
    // the lower face's corners (box 2's axis 2 points up, so -s2[2]); lowest 1e-4 deep
    double corner[4][3], low = HUGE_VAL;
    for (int v = 0; v < 4; v++) {
      double lv[3] = {(v & 1 ? 1 : -1) * s2[0], (v & 2 ? 1 : -1) * s2[1], -s2[2]};
      mju_mulMatVec(corner[v], b.mat, lv, 3, 3);
      low = fmin(low, corner[v][2]);
    }
    b.pos[2] = s1[2] - low - 1e-4;
    ostContact con[OST_MAXCONPAIR];
    int n = osti_collideBoxBox(con, &a, &b, 0.01);
    ck_assert_int_eq(n, 4);
    for (int i = 0; i < n; i++) {
      ck_assert_double_eq_tol(con[i].frame[2], 1, 1e-12);
      // the corner this contact is (pos is midway: the corner minus dist/2 along +z)
      int hit = 0;
      for (int v = 0; v < 4; v++) {
        double x = b.pos[0] + corner[v][0], y = b.pos[1] + corner[v][1];
        double z = b.pos[2] + corner[v][2];
        if (fabs(con[i].pos[0] - x) < 1e-12 && fabs(con[i].pos[1] - y) < 1e-12) {
          ck_assert_double_eq_tol(con[i].dist, z - s1[2], 1e-12);
          ck_assert_double_eq_tol(con[i].pos[2], z - 0.5 * con[i].dist, 1e-12);
          hit = 1;
        }
      }
      ck_assert_msg(hit, "case %d: contact %d is no corner of the small box", c, i);
    }
  }
}
END_TEST


// pairs of small boxes crossed at random angles, up to 6 cm apart with a 1 cm margin (fingers of
// a hand): boxes that are apart (GJK's distance > 0) must get no penetrating contact, and no
// contact's distance may fall below their true distance by more than the separating-axis bound's
// error. MuJoCo's edge routine measures an edge contact's points on a face of box 1, which put
// points of boxes 6.8 mm apart 22 mm deep (1,185 of 37,932 separated pairs penetrating, 11.6 cm
// at worst): Ostrich's points lie no deeper than the axis's overlap allows
START_TEST(test_box_box_crossed) {
  int napart = 0, nfar = 0;
  double worst = 0;
  for (int c = 0; c < 60000; c++) {
    double s1[3], s2[3], p1[3] = {0, 0, 0}, p2[3], q1[4], q2[4];
    for (int i = 0; i < 3; i++) {
      s1[i] = urange(0.005, 0.03);
      s2[i] = urange(0.005, 0.03);
      p2[i] = urange(-0.06, 0.06);
    }
    randQuat(q1);
    randQuat(q2);
    ostGeom a = boxGeom(s1, p1, q1), b = boxGeom(s2, p2, q2);
    ostContact con[OST_MAXCONPAIR];
    int n = osti_collideBoxBox(con, &a, &b, 0.01);
    double d, pa[3], pb[3];
    if (!n || !osti_gjkDistance(&a, &b, &d, pa, pb) || !(d > 1e-9)) {
      continue;
    }
    napart++;
    for (int i = 0; i < n; i++) {
      ck_assert_msg(con[i].dist >= 0, "case %d: boxes %.3g m apart, contact %d at %.3g m", c, d,
                    i, con[i].dist);
      worst = fmax(worst, d - con[i].dist);
      nfar += d - con[i].dist > 1e-3;
    }
  }
  ck_assert_int_ge(napart, 10000);
  // the separating axes' bound (the largest separation over 15 axes) is below the distance
  // where the nearest features are a corner and an edge: regression baseline (measured at most
  // 2.5 mm, 69 contacts over 1 mm, at the time of writing)
  ck_assert_double_lt(worst, 4e-3);
  printf("box-box crossed: %d pairs apart within the margin, none penetrating; a contact below "
         "the true distance by at most %.3g m (%d by over 1 mm)\n", napart, worst, nfar);
}
END_TEST


// osti_makeFrame against the frames of mj_forward for tilted planes under a sphere (no hint)
// and under a capsule (the axis as hint), including normals near the y axis
START_TEST(test_make_frame) {
  int types[2] = {mjGEOM_SPHERE, mjGEOM_CAPSULE};
  for (int t = 0; t < 2; t++) {
    mjModel* m = pairModel(mjGEOM_PLANE, types[t]);
    mjData* d = mj_makeData(m);
    m->geom_rbound[1] = 50;
    double maxerr = 0;
    int nframe = 0;
    for (int c = 0; c < 2000; c++) {
      double q[4];
      if (c % 4 == 0) {
        // normals within a few degrees of |n_y| = 0.5, where the rule switches axes
        double ang = asin(0.5) + urange(-0.05, 0.05), ax[3] = {1, 0, 0};
        if (urand() < 0.5) ang = -ang;
        mju_axisAngle2Quat(q, ax, -(0.5 * mjPI - ang));
      } else {
        randQuat(q);
      }
      mju_copy4(m->geom_quat, q);
      mj_resetData(m, d);
      randQuat(d->qpos + 3);
      mj_forward(m, d);
      for (int i = 0; i < d->ncon; i++) {
        double f[9];
        mju_copy(f, d->contact[i].frame, 3);
        mju_zero(f + 3, 6);
        if (types[t] == mjGEOM_CAPSULE) {
          int g = d->contact[i].geom2;
          for (int k = 0; k < 3; k++) f[3 + k] = d->geom_xmat[9*g + 3*k + 2];
        }
        osti_makeFrame(f);
        for (int k = 0; k < 9; k++) maxerr = fmax(maxerr, fabs(f[k] - d->contact[i].frame[k]));
        nframe++;
      }
    }
    ck_assert_int_gt(nframe, 1000);
    ck_assert_double_le(maxerr, 1e-12);
    mj_deleteData(d);
    mj_deleteModel(m);
  }
}
END_TEST


// the dispatcher leaves the pairs that MuJoCo 2.2.2 sends to MPR (or to the height field)
START_TEST(test_dispatch) {
  int mpr[][2] = {{mjGEOM_PLANE, mjGEOM_ELLIPSOID}, {mjGEOM_PLANE, mjGEOM_MESH},
                  {mjGEOM_SPHERE, mjGEOM_CYLINDER}, {mjGEOM_SPHERE, mjGEOM_ELLIPSOID},
                  {mjGEOM_CAPSULE, mjGEOM_CYLINDER}, {mjGEOM_CYLINDER, mjGEOM_CYLINDER},
                  {mjGEOM_CYLINDER, mjGEOM_BOX}, {mjGEOM_HFIELD, mjGEOM_BOX}};
  ostContact con[OST_MAXCONPAIR];
  for (int i = 0; i < (int)(sizeof(mpr) / sizeof(mpr[0])); i++) {
    ostGeom a, b;
    memset(&a, 0, sizeof(a));
    memset(&b, 0, sizeof(b));
    a.type = mpr[i][0];
    b.type = mpr[i][1];
    a.mat[0] = a.mat[4] = a.mat[8] = b.mat[0] = b.mat[4] = b.mat[8] = 1;
    int handled = 1;
    ck_assert_int_eq(osti_collidePrimitive(con, &a, &b, 0, &handled), 0);
    ck_assert_int_eq(handled, 0);
    // MuJoCo's table uses its general convex function for these pairs
    // (the one of sphere-ellipsoid, or of plane-ellipsoid for planes), or the height field's
    int ref = mpr[i][0] == mjGEOM_PLANE ? mjGEOM_PLANE : mjGEOM_SPHERE;
    if (mpr[i][0] != mjGEOM_HFIELD) {
      ck_assert_ptr_eq(mjCOLLISIONFUNC[mpr[i][0]][mpr[i][1]],
                       mjCOLLISIONFUNC[ref][mjGEOM_ELLIPSOID]);
    }
  }
}
END_TEST


int main(void) {
  Suite* s = suite_create("ost_collision_primitive");
  TCase* tc = tcase_create("primitive");
  tcase_set_timeout(tc, 60);
  tcase_add_test(tc, test_make_frame);
  tcase_add_test(tc, test_dispatch);
  tcase_add_test(tc, test_plane_cylinder);
  tcase_add_test(tc, test_plane_cylinder_flat);
  tcase_add_test(tc, test_plane_box);
  tcase_add_test(tc, test_plane_sphere);
  tcase_add_test(tc, test_plane_capsule);
  tcase_add_test(tc, test_sphere_sphere);
  tcase_add_test(tc, test_sphere_capsule);
  tcase_add_test(tc, test_capsule_capsule);
  tcase_add_test(tc, test_sphere_box);
  tcase_add_test(tc, test_box_box);
  tcase_add_test(tc, test_box_box_stacked);
  tcase_add_test(tc, test_box_box_resting);
  tcase_add_test(tc, test_box_box_crossed);
  tcase_add_test(tc, test_capsule_box);
  tcase_add_test(tc, test_cylinder_box);
  suite_add_tcase(s, tc);
  SRunner* sr = srunner_create(s);
  srunner_run_all(sr, CK_NORMAL);
  int nfail = srunner_ntests_failed(sr);
  srunner_free(sr);
  return nfail == 0 ? 0 : 1;
}
