// test_ost_collision_convex.c: the convex collision path (core/ost_collision_convex.h) against
// its two oracles: (a) libccd's own ccdMPRPenetration, driven by Ostrich's support functions
// wrapped as libccd callbacks, on random pairs of every supported type; (b) MuJoCo 2.2.2's
// d->contact (count, dist, pos, the 9 frame entries) from mj_forward on one-pair models at
// random poses, penetrating and separated within the margin.
#define _GNU_SOURCE  // drand48, mkstemps, fdopen, M_PI
#include "ost_collision_convex.h"
#include "ost_collision_gjk.h"

#include <check.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include <ccd/ccd.h>
#include <ccd/vec3.h>
#include <mujoco/mujoco.h>

#define TOL_CCD 1e-12  // Ostrich MPR vs libccd (same operations: round-off or exact)
#define TOL_MJ 1e-9    // Ostrich pair functions vs MuJoCo 2.2.2


//---------------------------------- helpers -------------------------------------------------------

static void onMjError(const char* msg) {
  ck_abort_msg("MuJoCo error: %s", msg);
}


static void onMjWarning(const char* msg) {
  ck_abort_msg("MuJoCo warning: %s", msg);
}


static void setup(void) {
  mju_user_error = onMjError;
  mju_user_warning = onMjWarning;
}


static double urand(double a, double b) {
  return a + (b - a) * drand48();
}


// random unit quaternion and its rotation matrix (row-major, columns = axes)
static void randQuat(double q[4]) {
  double n = 0;
  while (n < 1e-3) {
    for (int i = 0; i < 4; i++) q[i] = urand(-1, 1);
    n = sqrt(q[0]*q[0] + q[1]*q[1] + q[2]*q[2] + q[3]*q[3]);
  }
  for (int i = 0; i < 4; i++) q[i] /= n;
}


static double maxAbsDiff(const double* a, const double* b, int n) {
  double e = 0;
  for (int i = 0; i < n; i++) {
    double d = fabs(a[i] - b[i]);
    if (!(d <= e)) e = d;  // NaN propagates as failure
  }
  return e;
}


//---------------------------------- (a) against libccd -------------------------------------------

typedef struct {
  const ostGeom* g;
  double margin;
} ccdObj;


static void ccdSupport(const void* obj, const ccd_vec3_t* dir, ccd_vec3_t* vec) {
  const ccdObj* o = (const ccdObj*)obj;
  osti_support(vec->v, o->g, dir->v, o->margin);
}


static void ccdCenter(const void* obj, ccd_vec3_t* center) {
  const ccdObj* o = (const ccdObj*)obj;
  osti_center(center->v, o->g);
}


// random geom of the given type near the origin; vert: room for 3*32 numbers
static void randGeom(ostGeom* g, int type, double* vert) {
  double q[4];
  memset(g, 0, sizeof(*g));
  g->type = type;
  for (int i = 0; i < 3; i++) {
    g->size[i] = urand(0.05, 0.5);
    g->pos[i] = urand(-0.4, 0.4);
  }
  randQuat(q);
  mju_quat2Mat(g->mat, q);
  if (type == OST_GEOM_MESH) {
    g->nvert = 20;
    for (int i = 0; i < 3*g->nvert; i++) vert[i] = urand(-0.3, 0.3);
    g->vert = vert;
  } else if (type == OST_GEOM_PRISM) {
    // bottom triangle at z = -0.5, top at heights around 0 (world frame)
    g->nvert = 6;
    for (int i = 0; i < 3; i++) {
      vert[3*i] = vert[3*(i + 3)] = g->pos[0] + urand(-0.4, 0.4);
      vert[3*i + 1] = vert[3*(i + 3) + 1] = g->pos[1] + urand(-0.4, 0.4);
      vert[3*i + 2] = -0.5;
      vert[3*(i + 3) + 2] = urand(-0.1, 0.3);
    }
    g->vert = vert;
  }
}


START_TEST(test_mpr_vs_libccd) {
  const int types[7] = {OST_GEOM_SPHERE, OST_GEOM_CAPSULE, OST_GEOM_ELLIPSOID, OST_GEOM_CYLINDER,
                        OST_GEOM_BOX, OST_GEOM_MESH, OST_GEOM_PRISM};
  double emax[3] = {0, 0, 0};
  int ncase = 0, nhit = 0;
  srand48(1);
  for (int t1 = 0; t1 < 7; t1++) {
    for (int t2 = 0; t2 < 7; t2++) {
      int hit = 0;
      for (int rep = 0; rep < 400; rep++) {
        ostGeom g1, g2;
        double v1[96], v2[96];
        randGeom(&g1, types[t1], v1);
        randGeom(&g2, types[t2], v2);
        double margin = rep % 2 ? 0 : urand(0, 0.05);
        double tol = rep % 3 ? 1e-6 : 1e-4;

        // libccd
        ccdObj o1 = {&g1, margin}, o2 = {&g2, margin};
        ccd_t ccd;
        CCD_INIT(&ccd);
        ccd.support1 = ccd.support2 = ccdSupport;
        ccd.center1 = ccd.center2 = ccdCenter;
        ccd.mpr_tolerance = tol;
        ccd.max_iterations = 50;
        ccd_real_t cdepth = NAN;
        ccd_vec3_t cdir, cpos;
        int cres = ccdMPRPenetration(&o1, &o2, &ccd, &cdepth, &cdir, &cpos);

        // Ostrich, outputs poisoned
        double depth = NAN, dir[3] = {NAN, NAN, NAN}, pos[3] = {NAN, NAN, NAN};
        int res = osti_mprPenetration(&g1, &g2, margin, tol, 50, &depth, dir, pos);
        ncase++;
        ck_assert_msg((cres == 0) == (res == 0), "types %d %d rep %d: libccd %d, Ostrich %d",
                      types[t1], types[t2], rep, cres, res);
        if (res == 0) {
          hit++;
          double e[3] = {fabs(depth - cdepth), maxAbsDiff(dir, cdir.v, 3),
                         maxAbsDiff(pos, cpos.v, 3)};
          for (int i = 0; i < 3; i++) {
            ck_assert_msg(e[i] <= TOL_CCD, "types %d %d rep %d: quantity %d differs by %g",
                          types[t1], types[t2], rep, i, e[i]);
            if (e[i] > emax[i]) emax[i] = e[i];
          }
        }
      }
      ck_assert_msg(hit >= 20, "types %d %d: only %d penetrating cases", types[t1], types[t2],
                    hit);
      nhit += hit;
    }
  }
  printf("MPR vs libccd: %d cases (%d penetrating); max |err| depth %.3g dir %.3g pos %.3g\n",
         ncase, nhit, emax[0], emax[1], emax[2]);
}
END_TEST


// GJK's distance of random separated pairs of every convex type, certified two ways:
// (1) duality: the witness points a, b lie in the shapes (convex combinations of support points),
//     so |a - b| bounds the distance from above, and the gap of the supports along n = (b - a)/d,
//     n.s2(-n) - n.s1(n), bounds it from below; the two must meet;
// (2) MPR's intersection test (ccdMPRPenetration's discovery, a different algorithm, exact up to
//     its tolerance): the shapes inflated by margin/2 each overlap when margin exceeds the
//     distance and not when it falls short of it.
START_TEST(test_gjk_distance) {
  const int types[6] = {OST_GEOM_SPHERE, OST_GEOM_CAPSULE, OST_GEOM_ELLIPSOID, OST_GEOM_CYLINDER,
                        OST_GEOM_BOX, OST_GEOM_MESH};
  double gapmax = 0;
  int nsep = 0, nover = 0;
  srand48(3);
  for (int t1 = 0; t1 < 6; t1++) {
    for (int t2 = 0; t2 < 6; t2++) {
      int sep = 0;
      for (int rep = 0; rep < 200; rep++) {
        ostGeom g1, g2;
        double v1[96], v2[96], a[3], b[3], dist = NAN, depth, dir[3], pos[3];
        randGeom(&g1, types[t1], v1);
        randGeom(&g2, types[t2], v2);
        g2.pos[0] += urand(0, 1.2);  // separated in about half of the cases
        int r = osti_gjkDistance(&g1, &g2, &dist, a, b);
        if (r == 0) {
          // touching or overlapping: MPR agrees at a margin of 0.1 um
          ck_assert_int_eq(osti_mprPenetration(&g1, &g2, 1e-7, 1e-6, 50, &depth, dir, pos), 0);
          nover++;
          continue;
        }
        sep++;
        double ab[3] = {b[0] - a[0], b[1] - a[1], b[2] - a[2]};
        ck_assert_double_eq_tol(sqrt(mju_dot3(ab, ab)), dist, 1e-12);
        double n[3] = {ab[0] / dist, ab[1] / dist, ab[2] / dist}, mn[3] = {-n[0], -n[1], -n[2]};
        double s1[3], s2[3];
        osti_support(s1, &g1, n, 0);
        osti_support(s2, &g2, mn, 0);
        double gap = mju_dot3(n, s2) - mju_dot3(n, s1);
        ck_assert_msg(gap <= dist + 1e-12 && dist - gap <= 1e-9,
                      "types %d %d rep %d: distance %.12g, lower bound %.12g", types[t1],
                      types[t2], rep, dist, gap);
        gapmax = fmax(gapmax, dist - gap);
        if (dist > 1e-4) {  // margins 10 um either side of it, 10 times MPR's tolerance
          int hi = osti_mprPenetration(&g1, &g2, dist + 1e-5, 1e-6, 50, &depth, dir, pos);
          int lo = osti_mprPenetration(&g1, &g2, dist - 1e-5, 1e-6, 50, &depth, dir, pos);
          ck_assert_msg(hi == 0 && lo == 1, "types %d %d rep %d: distance %.9g, MPR %d %d",
                        types[t1], types[t2], rep, dist, hi, lo);
        }
      }
      ck_assert_msg(sep >= 20, "types %d %d: only %d separated cases", types[t1], types[t2], sep);
      nsep += sep;
    }
  }
  printf("GJK: %d separated pairs certified (largest gap between distance and its lower bound "
         "%.3g m), %d touching or overlapping\n", nsep, gapmax, nover);
}
END_TEST


//---------------------------------- (b) against MuJoCo 2.2.2 --------------------------------------

static mjModel* loadXML(const char* xml) {
  char path[] = "/tmp/ost_convex_XXXXXX.xml", err[1000] = "";
  int fd = mkstemps(path, 4);
  ck_assert_int_ge(fd, 0);
  FILE* f = fdopen(fd, "w");
  fputs(xml, f);
  fclose(f);
  mjModel* m = mj_loadXML(path, NULL, err, sizeof(err));
  unlink(path);
  ck_assert_msg(m != NULL, "cannot load XML: %s\n%s", err, xml);
  return m;
}


// ostGeom of MuJoCo geom g; mesh hull vertices (MuJoCo's convex graph, else all) into vert
static void mjGeom(ostGeom* og, const mjModel* m, const mjData* d, int g, double* vert,
                   int nvertmax) {
  memset(og, 0, sizeof(*og));
  og->type = m->geom_type[g];
  for (int i = 0; i < 3; i++) {
    og->size[i] = m->geom_size[3*g + i];
    og->pos[i] = d->geom_xpos[3*g + i];
  }
  for (int i = 0; i < 9; i++) og->mat[i] = d->geom_xmat[9*g + i];
  og->rbound = m->geom_rbound[g];
  if (og->type == mjGEOM_MESH) {
    int id = m->geom_dataid[g], adr = m->mesh_vertadr[id], gadr = m->mesh_graphadr[id];
    const float* mv = m->mesh_vert + 3*adr;
    int n = gadr >= 0 ? m->mesh_graph[gadr] : m->mesh_vertnum[id];
    ck_assert_int_le(n, nvertmax);
    for (int i = 0; i < n; i++) {
      int gi = gadr >= 0 ? m->mesh_graph[gadr + 2 + n + i] : i;
      for (int k = 0; k < 3; k++) vert[3*i + k] = mv[3*gi + k];
    }
    og->nvert = n;
    og->vert = vert;
  }
}


typedef struct {
  double emax[3];  // dist, pos, frame
  int ncase, ncon, nmargin;
} mjStats;


// compare Ostrich with d->contact for the model's single pair; returns the contact count.
// plane: 0 convex pair, 1 plane-convex with MuJoCo's mesh graph, 2 plane-convex without it
static int compareMj(const mjModel* m, mjData* d, const char* name, int plane, mjStats* st) {
  mj_forward(m, d);
  ostContact con[OST_MAXCONPAIR];
  for (int i = 0; i < OST_MAXCONPAIR; i++) {
    con[i].dist = NAN;
  }
  double v1[3*256], v2[3*256];
  ostGeom g1, g2;
  int n;

  // geom order: MuJoCo's (lower type first), taken from the contact when there is one
  int i1 = 0, i2 = 1;
  if (m->geom_type[0] > m->geom_type[1]) {
    i1 = 1;
    i2 = 0;
  }
  mjGeom(&g1, m, d, i1, v1, 256);
  mjGeom(&g2, m, d, i2, v2, 256);
  double margin = mju_max(m->geom_margin[0], m->geom_margin[1]);
  int gadr = m->geom_type[i2] == mjGEOM_MESH ? m->mesh_graphadr[m->geom_dataid[i2]] : -1;
  if (plane == 1 && gadr >= 0) {
    n = osti_collidePlaneMesh(con, &g1, &g2, margin, m->mesh_graph + gadr);
  } else if (plane) {
    n = osti_collidePlaneConvex(con, &g1, &g2, margin);
  } else {
    n = osti_collideConvex(con, &g1, &g2, margin, m->opt.mpr_tolerance, m->opt.mpr_iterations);
  }
  st->ncase++;

  // plane == 2: the graph-less plane function; only the deepest contact is MuJoCo's
  if (plane == 2 && n >= 1 && d->ncon >= 1) {
    n = 1;
    d->ncon = 1;
  }
  ck_assert_msg(n == d->ncon, "%s case %d: Ostrich %d contacts, MuJoCo %d", name, st->ncase, n,
                d->ncon);
  for (int i = 0; i < n; i++) {
    const mjContact* c = d->contact + i;
    ck_assert_int_eq(c->geom1, i1);
    ck_assert_int_eq(c->geom2, i2);
    double e[3] = {fabs(con[i].dist - c->dist), maxAbsDiff(con[i].pos, c->pos, 3),
                   maxAbsDiff(con[i].frame, c->frame, 9)};
    for (int k = 0; k < 3; k++) {
      ck_assert_msg(e[k] <= TOL_MJ, "%s case %d contact %d: quantity %d differs by %g "
                    "(dist %g vs %g)", name, st->ncase, i, k, e[k], con[i].dist, c->dist);
      if (e[k] > st->emax[k]) st->emax[k] = e[k];
    }
    st->ncon++;
    if (c->dist > 0) st->nmargin++;
  }
  return n;
}


// a cube-ish convex mesh (inline vertices: MuJoCo keeps them and builds the hull graph)
#define MESH_ASSET \
  "<asset><mesh name='rock' vertex='-.2 -.15 -.1  .25 -.15 -.12  .22 .18 -.1  -.2 .2 -.08  " \
  "-.15 -.12 .14  .18 -.16 .12  .2 .15 .16  -.18 .2 .1  0 0 .22  .02 -.01 -.18  .05 .02 0'/>" \
  "<mesh name='gem' vertex='0 0 .2  .15 0 0  -.08 .13 0  -.08 -.13 0  0 0 -.15  .1 .1 .05'/>" \
  "</asset>"


// one free pair: geom A in body 1, geom B in body 2, margin on both
static mjModel* pairModel(const char* ga, const char* gb, double margin) {
  char xml[4096];
  snprintf(xml, sizeof(xml),
           "<mujoco><option gravity='0 0 0'/>" MESH_ASSET "<worldbody>"
           "<body><freejoint/><geom %s margin='%g'/></body>"
           "<body><freejoint/><geom %s margin='%g'/></body>"
           "</worldbody></mujoco>", ga, margin, gb, margin);
  return loadXML(xml);
}


// random poses: body 1 near the origin, body 2 along a random direction at a random distance
static void randPose(const mjModel* m, mjData* d, double rmin, double rmax) {
  double q[4], u[3];
  mj_resetData(m, d);
  for (int k = 0; k < 3; k++) d->qpos[k] = urand(-0.05, 0.05);
  randQuat(q);
  mju_copy4(d->qpos + 3, q);
  for (int k = 0; k < 3; k++) u[k] = urand(-1, 1);
  mju_normalize3(u);
  double r = urand(rmin, rmax);
  for (int k = 0; k < 3; k++) d->qpos[7 + k] = d->qpos[k] + r*u[k];
  randQuat(q);
  mju_copy4(d->qpos + 10, q);
}


static void runPair(const char* name, const char* ga, const char* gb, int ncase, int minhit) {
  mjModel* m = pairModel(ga, gb, 0.02);
  mjData* d = mj_makeData(m);
  double rb = m->geom_rbound[0] + m->geom_rbound[1];
  mjStats st;
  memset(&st, 0, sizeof(st));
  int hit = 0;
  for (int i = 0; i < ncase; i++) {
    randPose(m, d, 0.3*rb, 1.0*rb);
    hit += compareMj(m, d, name, 0, &st) > 0;
  }
  printf("%-22s %4d poses, %4d contacts (%3d within margin); max |err| dist %.2g pos %.2g "
         "frame %.2g\n", name, st.ncase, st.ncon, st.nmargin, st.emax[0], st.emax[1], st.emax[2]);
  ck_assert_msg(hit >= minhit, "%s: only %d contacts", name, hit);
  ck_assert_msg(st.nmargin > 0, "%s: no separated-within-margin case", name);
  mj_deleteData(d);
  mj_deleteModel(m);
}


START_TEST(test_cylinder_box) {
  srand48(2);
  runPair("cylinder-box", "type='cylinder' size='.3 .1'", "type='box' size='.5 .4 .1'", 600,
          100);

  // a wheel (axis horizontal) on a pallet edge: the cylinder's rim across the box's top edge
  mjModel* m = pairModel("type='cylinder' size='.3 .08'", "type='box' size='.6 .5 .07'", 0.01);
  mjData* d = mj_makeData(m);
  mjStats st;
  memset(&st, 0, sizeof(st));
  int hit = 0;
  for (int i = 0; i < 400; i++) {
    mj_resetData(m, d);
    // wheel axis along y (rotate 90 deg about x), small random tilt and yaw
    double q[4], qt[4], axis[3] = {urand(-1, 1), urand(-1, 1), urand(-1, 1)}, qa[4] = {
      cos(M_PI/4), sin(M_PI/4), 0, 0};
    mju_normalize3(axis);
    mju_axisAngle2Quat(qt, axis, urand(-0.15, 0.15));
    mju_mulQuat(q, qt, qa);
    mju_copy4(d->qpos + 3, q);
    // pallet edge at x = 0.6, top at z = 0.07; wheel center above the edge, depth -0.05..0.02
    double ang = urand(-0.7, 0.7), pen = i % 2 ? urand(-0.05, 0) : urand(0, 0.015);
    d->qpos[0] = 0.6 + (0.3 - pen)*sin(ang);
    d->qpos[1] = urand(-0.3, 0.3);
    d->qpos[2] = 0.07 + (0.3 - pen)*cos(ang);
    d->qpos[7] = 0;
    d->qpos[8] = 0;
    d->qpos[9] = 0;
    d->qpos[10] = 1;
    hit += compareMj(m, d, "wheel-on-pallet-edge", 0, &st) > 0;
  }
  printf("%-22s %4d poses, %4d contacts (%3d within margin); max |err| dist %.2g pos %.2g "
         "frame %.2g\n", "wheel-on-pallet-edge", st.ncase, st.ncon, st.nmargin, st.emax[0],
         st.emax[1], st.emax[2]);
  // a coverage floor, not an accuracy bound: most poses must touch (half are placed
  // penetrating) for the error maxima above to mean anything
  ck_assert_int_ge(hit, 250);
  mj_deleteData(d);
  mj_deleteModel(m);
}
END_TEST


START_TEST(test_convex_pairs) {
  srand48(3);
  runPair("cylinder-cylinder", "type='cylinder' size='.2 .15'", "type='cylinder' size='.25 .1'",
          500, 80);
  runPair("sphere-cylinder", "type='sphere' size='.2'", "type='cylinder' size='.25 .1'", 500, 80);
  runPair("capsule-cylinder", "type='capsule' size='.1 .2'", "type='cylinder' size='.25 .1'",
          500, 80);
  runPair("sphere-ellipsoid", "type='sphere' size='.2'", "type='ellipsoid' size='.3 .2 .1'",
          500, 80);
  runPair("capsule-ellipsoid", "type='capsule' size='.1 .2'", "type='ellipsoid' size='.3 .2 .1'",
          500, 80);
  runPair("ellipsoid-ellipsoid", "type='ellipsoid' size='.1 .25 .15'",
          "type='ellipsoid' size='.3 .2 .1'", 500, 80);
  runPair("ellipsoid-cylinder", "type='ellipsoid' size='.1 .25 .15'",
          "type='cylinder' size='.25 .1'", 500, 80);
  runPair("ellipsoid-box", "type='ellipsoid' size='.1 .25 .15'", "type='box' size='.2 .1 .3'",
          500, 80);
}
END_TEST


START_TEST(test_mesh_pairs) {
  srand48(4);
  runPair("mesh-box", "type='mesh' mesh='rock'", "type='box' size='.2 .1 .3'", 500, 80);
  runPair("mesh-mesh", "type='mesh' mesh='rock'", "type='mesh' mesh='gem'", 500, 80);
  runPair("sphere-mesh", "type='sphere' size='.2'", "type='mesh' mesh='gem'", 500, 80);
  runPair("capsule-mesh", "type='capsule' size='.1 .2'", "type='mesh' mesh='rock'", 500, 80);
  runPair("cylinder-mesh", "type='cylinder' size='.25 .1'", "type='mesh' mesh='rock'", 500, 80);
  runPair("ellipsoid-mesh", "type='ellipsoid' size='.1 .25 .15'", "type='mesh' mesh='gem'", 500,
          80);
}
END_TEST


// plane (world, random pose) against a free ellipsoid or mesh
// graph: 1 use MuJoCo's mesh graph (all contacts compared), 0 not (the deepest one compared)
static void runPlane(const char* name, const char* gb, int ncase, int graph) {
  char xml[4096];
  snprintf(xml, sizeof(xml),
           "<mujoco><option gravity='0 0 0'/>" MESH_ASSET "<worldbody>"
           "<geom type='plane' size='0 0 1' margin='0.02'/>"
           "<body><freejoint/><geom %s margin='0.02'/></body>"
           "</worldbody></mujoco>", gb);
  mjModel* m = loadXML(xml);
  if (m->geom_type[1] == mjGEOM_MESH) {
    ck_assert_int_ge(m->mesh_graphadr[0], 0);
  }
  mjData* d = mj_makeData(m);
  mjStats st;
  memset(&st, 0, sizeof(st));
  int hit = 0, multi = 0;
  for (int i = 0; i < ncase; i++) {
    double q[4];
    mj_resetData(m, d);
    for (int k = 0; k < 3; k++) m->geom_pos[k] = urand(-0.2, 0.2);
    randQuat(q);
    if (i % 2) {
      q[0] = 1;
      q[1] = q[2] = q[3] = 0;  // half the cases with a horizontal plane
    }
    mju_copy4(m->geom_quat, q);
    for (int k = 0; k < 3; k++) d->qpos[k] = m->geom_pos[k] + urand(-0.3, 0.3);
    randQuat(q);
    mju_copy4(d->qpos + 3, q);
    int n = compareMj(m, d, name, graph ? 1 : 2, &st);
    hit += n > 0;
    multi += n > 1;
  }
  printf("%-22s %4d poses, %4d contacts (%3d within margin, %d multi); max |err| dist %.2g "
         "pos %.2g frame %.2g\n", name, st.ncase, st.ncon, st.nmargin, multi, st.emax[0],
         st.emax[1], st.emax[2]);
  // a coverage floor: at least a tenth of the random poses must give a contact
  ck_assert_int_ge(hit, ncase/10);
  mj_deleteData(d);
  mj_deleteModel(m);
}


START_TEST(test_plane_convex) {
  srand48(5);
  runPlane("plane-ellipsoid", "type='ellipsoid' size='.1 .25 .15'", 1000, 1);
  runPlane("plane-mesh (graph)", "type='mesh' mesh='rock'", 1000, 1);
  runPlane("plane-mesh (no graph)", "type='mesh' mesh='rock'", 1000, 0);
}
END_TEST


int main(void) {
  Suite* s = suite_create("ost_collision_convex");
  TCase* tc = tcase_create("convex");
  tcase_add_checked_fixture(tc, setup, NULL);
  tcase_set_timeout(tc, 60);
  tcase_add_test(tc, test_mpr_vs_libccd);
  tcase_add_test(tc, test_gjk_distance);
  tcase_add_test(tc, test_cylinder_box);
  tcase_add_test(tc, test_convex_pairs);
  tcase_add_test(tc, test_mesh_pairs);
  tcase_add_test(tc, test_plane_convex);
  suite_add_tcase(s, tc);
  SRunner* sr = srunner_create(s);
  srunner_run_all(sr, CK_NORMAL);
  int nfailed = srunner_ntests_failed(sr);
  srunner_free(sr);
  return nfailed == 0 ? EXIT_SUCCESS : EXIT_FAILURE;
}
