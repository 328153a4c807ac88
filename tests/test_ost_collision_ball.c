// test_ost_collision_ball.c: spheres and capsules against cylinders (closed forms) and convex
// meshes (GJK on their cores) (core/ost_collision_ball.h), against (a) closed forms: a sphere
// about a cube mesh (|c - clamp(c)| - r) and about or inside a turned cylinder (the
// point-cylinder distance by feature minus r, and its normal); (b) GJK on the whole capsule
// where apart from a mesh, an independent minimization along the axis for a cylinder; (c) a
// capsule lying along a face: held at both ends; (d) the first-order property a Newton
// iteration on the gap needs: under rigid motions of either geom the distance changes by
// n.(dx_2 - dx_1) at the witnesses.
#define _GNU_SOURCE  // drand48
#include "ost_collision_ball.h"

#include <check.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <mujoco/mujoco.h>

#include "fixture_geom.h"

#define BIG_MARGIN 1e3  // report contacts at any distance


// a cube mesh of half size e (its 8 corners) into vert, as geom g
static void cube(ostGeom* g, double e, double vert[24]) {
  ost_fixtureGeom(g, OST_GEOM_MESH, e, e, e);
  for (int v = 0; v < 8; v++) {
    for (int k = 0; k < 3; k++) vert[3 * v + k] = (v >> k & 1 ? 1 : -1) * e;
  }
  g->nvert = 8;
  g->vert = vert;
}


// the deepest (least dist) contact of ball g1 : g2; *n gets the count
static ostContact deepest(const ostGeom* g1, const ostGeom* g2, int* n) {
  ostContact con[OST_MAXCONPAIR];
  *n = osti_collideBall(con, g1, g2, BIG_MARGIN, 1e-6, 50);
  ck_assert_int_ge(*n, 1);
  int best = 0;
  for (int i = 1; i < *n; i++) best = con[i].dist < con[best].dist ? i : best;
  return con[best];
}


// the signed distance of capsule g's axis point at t to cylinder c (osti_cylPoint)
static double cylAxisDistance(const ostGeom* g, const ostGeom* c, double t) {
  double p[3], sd, n[3], x[3];
  for (int k = 0; k < 3; k++) p[k] = g->pos[k] + t * g->mat[3 * k + 2];
  ck_assert_int_eq(osti_cylPoint(c, p, &sd, n, x), 1);
  return sd;
}


START_TEST(test_ball_closed_forms) {
  srand48(21);
  double worst_mesh = 0, worst_cyl = 0, worst_gjk = 0, worst_capcyl = 0;
  int ncase = 0;
  for (int rep = 0; rep < 6000; rep++) {
    double vert[24];
    ostGeom s, m, c;
    double r = ost_fixtureUniform(0.005, 0.03), e = ost_fixtureUniform(0.02, 0.08);
    ost_fixtureGeom(&s, OST_GEOM_SPHERE, r, 0, 0);
    cube(&m, e, vert);
    for (int k = 0; k < 3; k++) s.pos[k] = ost_fixtureUniform(-2, 2) * e;
    double cl[3], dif[3];
    for (int k = 0; k < 3; k++) {
      cl[k] = fmin(fmax(s.pos[k], -e), e);
      dif[k] = s.pos[k] - cl[k];
    }
    double D = mju_norm3(dif);
    if (D > 1e-2 * r) {  // the centre outside the cube: the core's route
      int n;
      ostContact con = deepest(&s, &m, &n);
      worst_mesh = fmax(worst_mesh, fabs(con.dist - (D - r)));
      ck_assert_msg(fabs(con.dist - (D - r)) < 1e-12, "sphere-cube rep %d: %.15g vs %.15g", rep,
                    con.dist, D - r);
      ncase++;
    }
    // a sphere about (or inside) a turned cylinder (radius R, half length hl): the distance by
    // feature (side, cap, rim) in the cylinder's frame, and its normal, to round-off (GJK's
    // witness on the curved side or rim converges linearly: its normal was off by ~1e-7 rad)
    double R = ost_fixtureUniform(0.01, 0.05), hl = ost_fixtureUniform(0.01, 0.05), loc[3];
    ost_fixtureGeom(&c, OST_GEOM_CYLINDER, R, hl, 0);
    ost_fixtureRandMat(c.mat);
    for (int k = 0; k < 3; k++) {
      c.pos[k] = ost_fixtureUniform(-0.1, 0.1);
      loc[k] = ost_fixtureUniform(-2.5, 2.5) * (k < 2 ? R : hl);
    }
    double rho = hypot(loc[0], loc[1]), z = fabs(loc[2]), sz = loc[2] < 0 ? -1 : 1, Dc;
    double nl[3] = {loc[0] / rho, loc[1] / rho, 0};  // the side's
    if (rho > R && z > hl) {
      Dc = hypot(rho - R, z - hl);
      for (int k = 0; k < 2; k++) nl[k] *= (rho - R) / Dc;
      nl[2] = sz * (z - hl) / Dc;
    } else if (rho > R || (z <= hl && rho - R > z - hl)) {
      Dc = rho - R;
    } else {
      Dc = z - hl;
      nl[0] = nl[1] = 0;
      nl[2] = sz;
    }
    mju_mulMatVec(s.pos, c.mat, loc, 3, 3);
    for (int k = 0; k < 3; k++) s.pos[k] += c.pos[k];
    {
      int n;
      ostContact con = deepest(&s, &c, &n);
      double nw[3], err = fabs(con.dist - (Dc - r));
      mju_mulMatVec(nw, c.mat, nl, 3, 3);
      for (int k = 0; k < 3; k++) err = fmax(err, fabs(con.frame[k] + nw[k]) * R);
      worst_cyl = fmax(worst_cyl, err);
      ck_assert_msg(err < 1e-15, "sphere-cylinder rep %d: %.17g vs %.17g, normal %g %g %g",
                    rep, con.dist, Dc - r, con.frame[0], con.frame[1], con.frame[2]);
    }
    // a capsule about the cylinder: the least distance of its axis points, against an
    // independent minimization (a ternary search of the point distance along the axis; the
    // distance is convex along a line)
    ostGeom cc;
    ost_fixtureGeom(&cc, OST_GEOM_CAPSULE, r, ost_fixtureUniform(0.005, 0.06), 0);
    ost_fixtureRandMat(cc.mat);
    for (int k = 0; k < 3; k++) cc.pos[k] = c.pos[k] + ost_fixtureUniform(-2, 2) * (R + hl);
    double lo = -cc.size[1], hi = cc.size[1];
    for (int it = 0; it < 200; it++) {
      double t1 = lo + (hi - lo) / 3, t2 = hi - (hi - lo) / 3;
      if (cylAxisDistance(&cc, &c, t1) <= cylAxisDistance(&cc, &c, t2)) {
        hi = t2;
      } else {
        lo = t1;
      }
    }
    double oracle = cylAxisDistance(&cc, &c, 0.5 * (lo + hi)) - r;
    if (oracle > -0.9 * fmin(R, hl)) {  // (deeper, the point distance's undefined axis)
      int n;
      ostContact con = deepest(&cc, &c, &n);
      worst_capcyl = fmax(worst_capcyl, fabs(con.dist - oracle));
      ck_assert_msg(fabs(con.dist - oracle) < 1e-14, "capsule-cylinder rep %d: %.17g vs %.17g",
                    rep, con.dist, oracle);
    }
    // a capsule about a turned cube mesh, apart: GJK on the whole capsule
    ostGeom cap;
    ost_fixtureGeom(&cap, OST_GEOM_CAPSULE, r, ost_fixtureUniform(0.01, 0.05), 0);
    ost_fixtureRandMat(cap.mat);
    ost_fixtureRandMat(m.mat);
    for (int k = 0; k < 3; k++) cap.pos[k] = ost_fixtureUniform(-0.15, 0.15);
    double d, pa[3], pb[3];
    if (osti_gjkDistance(&cap, &m, &d, pa, pb) && d > 1e-6) {
      int n;
      ostContact con = deepest(&cap, &m, &n);
      worst_gjk = fmax(worst_gjk, fabs(con.dist - d));
      ck_assert_msg(fabs(con.dist - d) < 1e-10, "capsule-cube rep %d: %.15g vs GJK %.15g", rep,
                    con.dist, d);
    }
  }
  ck_assert_int_ge(ncase, 3000);
  printf("sphere about a cube mesh: %.3g m; about a cylinder (distance and normal x R): %.3g m; "
         "capsule about a cube, against GJK: %.3g m; about a cylinder: %.3g m\n", worst_mesh,
         worst_cyl, worst_gjk, worst_capcyl);
}
END_TEST


// a capsule lying 1 mm above a cube mesh's top face, tilted by under OST_BALL_PARALLEL: its two
// end balls are contacts, each at its own height (a single witness would slide along the face)
START_TEST(test_ball_capsule_lying) {
  double vert[24];
  ostGeom cap, m;
  cube(&m, 0.1, vert);
  ost_fixtureGeom(&cap, OST_GEOM_CAPSULE, 0.01, 0.04, 0);
  double ax[3] = {1, 0, 0.02}, q[4];
  mju_normalize3(ax);
  // the capsule's z axis along ax
  double zz[3] = {0, 0, 1}, c[3];
  mju_cross(c, zz, ax);
  double ang = acos(mju_dot3(zz, ax));
  mju_normalize3(c);
  mju_axisAngle2Quat(q, c, ang);
  mju_quat2Mat(cap.mat, q);
  cap.pos[0] = 0.01;
  cap.pos[2] = 0.1 + 0.01 + 1e-3;
  ostContact con[OST_MAXCONPAIR];
  int n = osti_collideBall(con, &cap, &m, 0.01, 1e-6, 50);
  ck_assert_int_ge(n, 2);
  for (int e = -1; e <= 1; e += 2) {
    double end = cap.pos[2] + e * 0.04 * ax[2] - 0.01 - 0.1, found = 0;
    for (int i = 0; i < n; i++) found += fabs(con[i].dist - end) < 1e-12;
    ck_assert_msg(found >= 1, "no contact at the end %+d's height %g", e, end);
  }
  for (int i = 0; i < n; i++) ck_assert_double_eq_tol(con[i].frame[2], -1, 1e-12);
}
END_TEST


START_TEST(test_ball_first_order) {
  srand48(23);
  const double eps = 1e-6;
  double worst = 0;
  int ncase = 0;
  for (int rep = 0; rep < 4000; rep++) {
    double vert[24];
    ostGeom b, g, gp, gm;
    ost_fixtureGeom(&b, rep % 2 ? OST_GEOM_CAPSULE : OST_GEOM_SPHERE,
                    ost_fixtureUniform(0.005, 0.03), ost_fixtureUniform(0.01, 0.05), 0);
    if (rep % 4 < 2) {
      cube(&g, ost_fixtureUniform(0.02, 0.08), vert);
    } else {
      ost_fixtureGeom(&g, OST_GEOM_CYLINDER, ost_fixtureUniform(0.01, 0.05),
                      ost_fixtureUniform(0.01, 0.05), 0);
    }
    ost_fixtureRandMat(b.mat);
    ost_fixtureRandMat(g.mat);
    for (int k = 0; k < 3; k++) b.pos[k] = ost_fixtureUniform(-0.12, 0.12);
    int n;
    ostContact con = deepest(&b, &g, &n);
    if (n != 1 || con.dist < -0.5 * b.size[0]) {
      continue;  // several contacts (lying along a face) or deep
    }
    double v[3] = {ost_fixtureUniform(-1, 1), ost_fixtureUniform(-1, 1), ost_fixtureUniform(-1, 1)};
    double w[3] = {ost_fixtureUniform(-3, 3), ost_fixtureUniform(-3, 3), ost_fixtureUniform(-3, 3)};
    int which = rep % 8 < 4;
    const ostGeom* mv = which ? &g : &b;
    ost_fixtureMoveGeom(&gp, mv, v, w, eps);
    ost_fixtureMoveGeom(&gm, mv, v, w, -eps);
    int np, nm;
    ostContact cp = which ? deepest(&b, &gp, &np) : deepest(&gp, &g, &np);
    ostContact cm = which ? deepest(&b, &gm, &nm) : deepest(&gm, &g, &nm);
    double p[3];
    for (int k = 0; k < 3; k++) p[k] = con.pos[k] + (which ? 0.5 : -0.5) * con.dist * con.frame[k];
    double scale,
        pred = (which ? 1 : -1) * ost_fixturePointRate(con.frame, p, mv->pos, v, w, &scale);
    double right = (cp.dist - con.dist) / eps, left = (con.dist - cm.dist) / eps;
    if (fabs(right - left) > 1e-4 * scale) {
      continue;  // a kink: the nearest features change within eps
    }
    double err = fabs((cp.dist - cm.dist) / (2 * eps) - pred) / scale;
    worst = fmax(worst, err);
    // both shapes' distances are exact to round-off (closed forms; GJK ends exactly on a
    // polytope): the central difference's truncation, eps^2 over the curvatures' radii
    // (>= 1e-3 m here), and round-off over eps (1e-16 / 1e-6) bound it far below 1e-6
    ck_assert_msg(err < 1e-6, "rep %d: rate %.12g, n.(dx_2 - dx_1) %.12g", rep,
                  (cp.dist - cm.dist) / (2 * eps), pred);
    ncase++;
  }
  ck_assert_int_ge(ncase, 1500);
  printf("ball pairs first order: %d motions, relative rate error at most %.3g\n", ncase, worst);
}
END_TEST


// every contact is finite with a unit normal whatever the shapes: sizes from 0.1 mm to 100 m,
// random hexahedral meshes and cylinders, capsules from points to long rods, axes that pass
// through the other shape's centre (where the core touches a mesh, or sits on a cylinder's
// axis deep inside it, and MPR takes over)
START_TEST(test_ball_extremes) {
  srand48(78);
  const double sizes[4] = {1e-4, 1e-2, 1, 100};
  int ncon = 0;
  for (int rep = 0; rep < 60000; rep++) {
    double vert[24], s0 = sizes[rep % 4];
    ostGeom b, g;
    if (rep % 2) {
      ost_fixtureGeom(&g, OST_GEOM_MESH, s0, s0, s0);
      for (int v = 0; v < 8; v++) {
        for (int k = 0; k < 3; k++) {
          vert[3 * v + k] = (v >> k & 1 ? 1 : -1) * s0 * ost_fixtureUniform(0.01, 1);
        }
      }
      g.nvert = 8;
      g.vert = vert;
    } else {
      ost_fixtureGeom(&g, OST_GEOM_CYLINDER, s0 * ost_fixtureUniform(0.01, 1),
                      s0 * ost_fixtureUniform(0.01, 1), 0);
    }
    ost_fixtureGeom(&b, rep % 4 < 2 ? OST_GEOM_CAPSULE : OST_GEOM_SPHERE,
                    s0 * ost_fixtureUniform(0, 2), s0 * ost_fixtureUniform(0, 3), 0);
    ost_fixtureRandMat(b.mat);
    ost_fixtureRandMat(g.mat);
    double reach = rep % 7 == 0 ? 0 : ost_fixtureUniform(0, 3) * s0;
    for (int k = 0; k < 3; k++) b.pos[k] = reach * ost_fixtureUniform(-1, 1);
    ostContact con[OST_MAXCONPAIR];
    int n = osti_collideBall(con, &b, &g, 1e3 * s0, 1e-6, 50);
    for (int i = 0; i < n; i++) {
      ck_assert_msg(ost_fixtureContactValid(con + i), "rep %d: dist %g", rep, con[i].dist);
    }
    ncon += n;
  }
  ck_assert_int_ge(ncon, 30000);
}
END_TEST


int main(void) {
  Suite* s = suite_create("ost_collision_ball");
  TCase* tc = tcase_create("ball");
  tcase_set_timeout(tc, 120);
  tcase_add_test(tc, test_ball_closed_forms);
  tcase_add_test(tc, test_ball_capsule_lying);
  tcase_add_test(tc, test_ball_first_order);
  tcase_add_test(tc, test_ball_extremes);
  suite_add_tcase(s, tc);
  SRunner* sr = srunner_create(s);
  srunner_run_all(sr, CK_NORMAL);
  int nfailed = srunner_ntests_failed(sr);
  srunner_free(sr);
  return nfailed ? EXIT_FAILURE : EXIT_SUCCESS;
}
