// test_ost_collision_ellmesh.c: an ellipsoid against a convex mesh by its hull's triangles
// (core/ost_collision_ellmesh.h), hulls from MuJoCo's own convex-hull graph (mesh_graph), against
// (a) the ellipsoid-box contact (core/ost_collision_ellipsoid.h, its own oracles) on a cube
// mesh, either side of contact; (b) on a random hull, the optimality conditions that make a
// signed distance exact: the witness x on the ellipsoid with n its outward normal there, the
// witness b on the hull with no hull vertex beyond it along -n (a separating or supporting plane
// touching both), b - x = dist n; apart, GJK's distance, and in overlap EPA's depth; (c) the
// first-order property a Newton iteration on the gap needs: under rigid motions of either geom
// the distance changes by n.(dx_2 - dx_1) at the witnesses. MPR (the fallback) would not meet
// (b)'s conditions.
#define _GNU_SOURCE  // drand48
#include "ost_collision_ellmesh.h"

#include <check.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <mujoco/mujoco.h>

#include "fixture.h"
#include "fixture_geom.h"
#include "ost_collision_epa.h"

#define BIG_MARGIN 1e3  // report contacts at any distance

typedef struct {   // a hull as the native provider packs it: the mesh's vertices, hull triangles
  double vert[3 * 200];
  int    face[3 * 400];
  int    nvert, nface;
} hull;


// the hull of npt points (mesh frame: MuJoCo moves the mesh's origin to its centre of mass and
// turns it to its principal axes) from MuJoCo's compiler, as ost_pack.c packs it
static void makeHull(const double* pt, int npt, hull* h) {
  char xml[20000], *p = xml;
  p += sprintf(p, "<mujoco><asset><mesh name='m' vertex='");
  for (int i = 0; i < 3 * npt; i++) p += sprintf(p, "%.17g ", pt[i]);
  sprintf(p, "'/></asset><worldbody><body><freejoint/><geom type='mesh' mesh='m'/></body>"
          "</worldbody></mujoco>");
  mjModel* m = ost_fixtureLoadString(xml);
  ck_assert_int_ge(m->mesh_graphadr[0], 0);
  const int* graph = m->mesh_graph + m->mesh_graphadr[0];
  h->nvert = m->mesh_vertnum[0];
  h->nface = graph[1];
  ck_assert_int_le(h->nvert, 200);
  ck_assert_int_le(h->nface, 400);
  for (int i = 0; i < 3 * h->nvert; i++) h->vert[i] = m->mesh_vert[i];
  for (int i = 0; i < 3 * h->nface; i++) h->face[i] = graph[2 + 3 * graph[0] + 3 * graph[1] + i];
  mj_deleteModel(m);
  // the triangles are wound consistently (ost_collision_ellmesh.h tries each edge once, from the
  // face where it runs from its lower vertex id): every edge runs one way in exactly one face
  for (int f = 0; f < h->nface; f++) {
    for (int i = 0; i < 3; i++) {
      int a = h->face[3 * f + i], b = h->face[3 * f + (i + 1) % 3], same = 0, reverse = 0;
      for (int g = 0; g < 3 * h->nface; g++) {
        int c = h->face[g], d = h->face[3 * (g / 3) + (g % 3 + 1) % 3];
        same += c == a && d == b;
        reverse += c == b && d == a;
      }
      ck_assert_int_eq(same, 1);
      ck_assert_int_eq(reverse, 1);
    }
  }
}


// hull h as mesh geom g
static void hullGeom(ostGeom* g, const hull* h) {
  ost_fixtureGeom(g, OST_GEOM_MESH, 0, 0, 0);
  g->nvert = h->nvert;
  g->vert = h->vert;
  g->nface = h->nface;
  g->face = h->face;
  double r = 0;
  for (int v = 0; v < h->nvert; v++) r = fmax(r, mju_norm3(h->vert + 3 * v));
  g->rbound = r;
}


// the contact of ellipsoid e : mesh g (one, at any distance)
static ostContact contact(const ostGeom* e, const ostGeom* g) {
  ostContact con[OST_MAXCONPAIR];
  int n = osti_collideEllipsoidMesh(con, e, g, BIG_MARGIN, 1e-10, 500);
  ck_assert_int_eq(n, 1);
  return con[0];
}


// a random ellipsoid about hull geom g: along a random direction u from g's origin, at the
// hull's support along u plus its own extent along u times a factor in [-0.2, 1.2) (from a
// penetration of 20 % of its extent to apart by about its size)
static void randomEllipsoid(ostGeom* e, const ostGeom* g, const hull* h) {
  ost_fixtureGeom(e, OST_GEOM_ELLIPSOID, ost_fixtureUniform(0.01, 0.04),
                  ost_fixtureUniform(0.01, 0.04), ost_fixtureUniform(0.01, 0.04));
  ost_fixtureRandMat(e->mat);
  double u[3] = {ost_fixtureUniform(-1, 1), ost_fixtureUniform(-1, 1),
                 ost_fixtureUniform(-1, 1)}, ul[3], reach = -HUGE_VAL, ext = 0;
  mju_normalize3(u);
  mju_mulMatTVec(ul, g->mat, u, 3, 3);
  for (int v = 0; v < h->nvert; v++) reach = fmax(reach, mju_dot3(ul, h->vert + 3 * v));
  mju_mulMatTVec(ul, e->mat, u, 3, 3);
  for (int k = 0; k < 3; k++) ext += (e->size[k] * ul[k]) * (e->size[k] * ul[k]);
  ext = sqrt(ext);
  double r = reach + ext * ost_fixtureUniform(-0.2, 1.2);
  for (int k = 0; k < 3; k++) e->pos[k] = g->pos[k] + r * u[k];
  e->rbound = fmax(e->size[0], fmax(e->size[1], e->size[2]));
}


// (a) a cube mesh against the ellipsoid-box contact, apart and in overlap
START_TEST(test_cube_against_box) {
  ost_fixtureSetup();
  srand48(5);
  double corner[24];
  for (int v = 0; v < 8; v++) {
    for (int k = 0; k < 3; k++) corner[3 * v + k] = (v >> k & 1 ? 1 : -1) * 0.03;
  }
  hull h;
  makeHull(corner, 8, &h);
  ostGeom g, box, e;
  hullGeom(&g, &h);
  // MuJoCo keeps the cube's corners (in float): the box of that half size
  double half = fabs(h.vert[0]);
  ck_assert_int_eq(h.nvert, 8);
  for (int i = 0; i < 24; i++) ck_assert_double_eq(fabs(h.vert[i]), half);
  ost_fixtureGeom(&box, OST_GEOM_BOX, half, half, half);
  double worst = 0;
  int n = 0;
  for (int rep = 0; rep < 4000; rep++) {
    ost_fixtureRandMat(g.mat);
    for (int k = 0; k < 3; k++) g.pos[k] = ost_fixtureUniform(-0.1, 0.1);
    memcpy(box.mat, g.mat, sizeof(g.mat));
    memcpy(box.pos, g.pos, sizeof(g.pos));
    randomEllipsoid(&e, &g, &h);
    ostContact cb[OST_MAXCONPAIR];
    ck_assert_int_eq(osti_collideEllipsoidBox(cb, &e, &box, BIG_MARGIN, 1e-10, 500), 1);
    if (cb[0].dist < -0.5 * fmin(e.size[0], fmin(e.size[1], e.size[2]))) {
      continue;  // deep: the box's own route may be MPR there
    }
    ostContact cm = contact(&e, &g);
    double err = fabs(cm.dist - cb[0].dist);
    for (int k = 0; k < 3; k++) err = fmax(err, 0.03 * fabs(cm.frame[k] - cb[0].frame[k]));
    worst = fmax(worst, err);
    ck_assert_msg(err < 1e-12, "rep %d: dist %.17g vs the box's %.17g, normal (%g %g %g) vs "
                  "(%g %g %g)", rep, cm.dist, cb[0].dist, cm.frame[0], cm.frame[1], cm.frame[2],
                  cb[0].frame[0], cb[0].frame[1], cb[0].frame[2]);
    n++;
  }
  printf("ellipsoid-cube mesh against ellipsoid-box: %d poses, worst %.2g m\n", n, worst);
  ck_assert_int_gt(n, 1500);
}
END_TEST


// a random hull of 60 points on a flattened sphere (many small faces, edges and vertices)
static void randomHull(hull* h) {
  double pt[180];
  for (int i = 0; i < 60; i++) {
    double d[3] = {ost_fixtureUniform(-1, 1), ost_fixtureUniform(-1, 1),
                   ost_fixtureUniform(-1, 1)};
    mju_normalize3(d);
    pt[3 * i] = 0.05 * d[0];
    pt[3 * i + 1] = 0.03 * d[1];
    pt[3 * i + 2] = 0.02 * d[2];
  }
  makeHull(pt, 60, h);
}


// (b) the optimality conditions on a random hull, and GJK's distance and EPA's depth (in
// penetrations up to the ellipsoid's least radius of curvature; deeper, a lower bound of the
// signed distance, ost_collision_ellmesh.h)
START_TEST(test_random_hull_exact) {
  srand48(7);
  hull h;
  randomHull(&h);
  ostGeom g, e;
  hullGeom(&g, &h);
  double worst_kkt = 0, worst_gjk = 0, worst_epa = 0;
  int napart = 0, nover = 0, ndeep = 0, nlocal = 0;
  for (int rep = 0; rep < 3000; rep++) {
    ost_fixtureRandMat(g.mat);
    for (int k = 0; k < 3; k++) g.pos[k] = ost_fixtureUniform(-0.1, 0.1);
    randomEllipsoid(&e, &g, &h);
    ostContact con = contact(&e, &g);
    const double* n = con.frame;
    // against GJK (apart; its curved witness converges linearly) and EPA (overlap)
    double dist, pa[3], pb[3], depth, a2[3], b2[3], n2[3];
    if (osti_gjkDistance(&e, &g, &dist, pa, pb)) {
      worst_gjk = fmax(worst_gjk, fabs(dist - con.dist));
      ck_assert_msg(fabs(dist - con.dist) < 1e-8, "rep %d: %.17g vs GJK's %.17g", rep, con.dist,
                    dist);
      napart++;
    } else if (osti_epaPenetration(&e, &g, &depth, n2, a2, b2, NULL)) {
      // deeper than the ellipsoid's least radius of curvature smin^2 / smax, a hull vertex or
      // edge inside it can have several normals to its surface: the value is then a lower bound
      // (the separation along a supporting direction), not always d
      double smin = fmin(e.size[0], fmin(e.size[1], e.size[2]));
      double smax = fmax(e.size[0], fmax(e.size[1], e.size[2]));
      if (depth > smin * smin / smax) {
        ck_assert_msg(con.dist <= -depth + 1e-12, "rep %d: %.17g above EPA's %.17g", rep,
                      con.dist, -depth);
        ndeep++;
        nlocal += fabs(depth + con.dist) > 1e-8;
        continue;
      }
      worst_epa = fmax(worst_epa, fabs(depth + con.dist));
      ck_assert_msg(fabs(depth + con.dist) < 1e-8, "rep %d: %.17g vs EPA's depth %.17g", rep,
                    con.dist, depth);
      nover++;
    } else {
      continue;
    }
    // the witnesses: x = pos - dist/2 n on the ellipsoid, b = pos + dist/2 n on the hull
    double x[3], b[3], q[3], dif[3], grad[3], quad = 0;
    for (int k = 0; k < 3; k++) {
      x[k] = con.pos[k] - 0.5 * con.dist * n[k];
      b[k] = con.pos[k] + 0.5 * con.dist * n[k];
      dif[k] = x[k] - e.pos[k];
    }
    mju_mulMatTVec(q, e.mat, dif, 3, 3);
    for (int k = 0; k < 3; k++) {
      quad += q[k] * q[k] / (e.size[k] * e.size[k]);
      q[k] /= e.size[k] * e.size[k];
    }
    mju_mulMatVec(grad, e.mat, q, 3, 3);
    mju_normalize3(grad);
    double kkt = fabs(sqrt(quad) - 1) * 0.04;  // x on the surface (a length)
    for (int k = 0; k < 3; k++) kkt = fmax(kkt, 0.04 * fabs(grad[k] - n[k]));
    // no hull vertex beyond b along -n, and one at it (the hull touches the plane at b)
    double nb = mju_dot3(n, b), least = HUGE_VAL;
    for (int v = 0; v < h.nvert; v++) {
      double w[3];
      mju_mulMatVec(w, g.mat, h.vert + 3 * v, 3, 3);
      mju_addTo3(w, g.pos);
      least = fmin(least, mju_dot3(n, w));
    }
    kkt = fmax(kkt, fabs(least - nb));
    worst_kkt = fmax(worst_kkt, kkt);
    ck_assert_msg(kkt < 1e-12, "rep %d: optimality conditions off by %g m (dist %g)", rep, kkt,
                  con.dist);
  }
  printf("ellipsoid-random hull (%d vertices, %d triangles): optimality %.2g m; GJK %.2g m "
         "(%d apart), EPA %.2g m (%d in overlap; %d deeper, %d of them below d)\n",
         h.nvert, h.nface, worst_kkt, worst_gjk, napart, worst_epa, nover, ndeep, nlocal);
  ck_assert_int_gt(napart, 500);
  ck_assert_int_gt(nover, 500);
}
END_TEST


// (c) under a rigid motion of size eps of either geom the distance changes by n.(dx_2 - dx_1)
// at the witnesses, to O(eps^2) (apart and in penetrations up to the least radius of
// curvature). The second-order term is about eps |dx|^2 / r for the ellipsoid's curvature 1/r
// (r >= 0.01 m, |dx| up to 2 m/s per unit eps here): below 1e-4 at eps = 1e-7
START_TEST(test_first_order) {
  srand48(11);
  hull h;
  randomHull(&h);
  ostGeom g, e;
  hullGeom(&g, &h);
  double worst = 0, eps = 1e-7;
  int n = 0;
  for (int rep = 0; rep < 2000; rep++) {
    ost_fixtureRandMat(g.mat);
    randomEllipsoid(&e, &g, &h);
    ostContact c0 = contact(&e, &g);
    double smin = fmin(e.size[0], fmin(e.size[1], e.size[2]));
    if (c0.dist < -smin * smin / fmax(e.size[0], fmax(e.size[1], e.size[2]))) {
      continue;
    }
    double v[3], w[3];
    for (int k = 0; k < 3; k++) {
      v[k] = ost_fixtureUniform(-1, 1);
      w[k] = ost_fixtureUniform(-20, 20);
    }
    int which = rep % 2;
    ostGeom moved;
    ost_fixtureMoveGeom(&moved, which ? &g : &e, v, w, eps);
    ostContact c1 = which ? contact(&e, &moved) : contact(&moved, &g);
    // the witness of the moving geom and its velocity there: v + w x (p - origin)
    double p[3], r[3], vel[3];
    for (int k = 0; k < 3; k++) {
      p[k] = c0.pos[k] + (which ? 0.5 : -0.5) * c0.dist * c0.frame[k];
      r[k] = p[k] - (which ? g.pos[k] : e.pos[k]);
    }
    mju_cross(vel, w, r);
    mju_addTo3(vel, v);
    double pred = (which ? 1 : -1) * mju_dot3(c0.frame, vel) * eps;
    double err = fabs(c1.dist - c0.dist - pred) / eps;
    worst = fmax(worst, err);
    ck_assert_msg(err < 1e-4, "rep %d (%s moves): change %.6g against n.dx %.6g (dist %g)", rep,
                  which ? "mesh" : "ellipsoid", c1.dist - c0.dist, pred, c0.dist);
    n++;
  }
  printf("ellipsoid-random hull, first order: %d poses, worst |d dist - n.dx| / eps %.2g\n", n,
         worst);
  ck_assert_int_gt(n, 1000);
}
END_TEST


Suite* ellmeshSuite(void) {
  Suite* s = suite_create("ellmesh");
  TCase* tc = tcase_create("core");
  tcase_set_timeout(tc, 120);
  tcase_add_test(tc, test_cube_against_box);
  tcase_add_test(tc, test_random_hull_exact);
  tcase_add_test(tc, test_first_order);
  suite_add_tcase(s, tc);
  return s;
}


int main(void) {
  SRunner* sr = srunner_create(ellmeshSuite());
  srunner_run_all(sr, CK_NORMAL);
  int failed = srunner_ntests_failed(sr);
  srunner_free(sr);
  return failed ? EXIT_FAILURE : EXIT_SUCCESS;
}
