// test_ost_collision_ellipsoid.c: the ellipsoid's contacts (core/ost_collision_ellipsoid.h): a
// sphere and a capsule against closed forms (a round ellipsoid) and against GJK and EPA with
// first-order rates (test_ellball); the box (the rest) against
// (a) closed forms: a round ellipsoid (a ball) at any place around and inside a box, where the
//     signed distance is |c - clamp(c)| - r outside and -(min_i (e_i - |c_i|) + r) inside, and
//     an ellipsoid resting 5e-8 m deep on a face (the Allegro hand's object on its palm);
// (b) the independent convex distances on random pairs: GJK (core/ost_collision_gjk.h) where
//     they are apart, EPA (core/ost_collision_epa.h, certified depths only) where they overlap;
// (c) continuity: under a translation the signed distance is 1-Lipschitz, so along sweeps
//     across faces, edges and corners no step may change it by more than the step;
// (d) the property a Newton iteration on the gap needs, by central differences: under a rigid
//     motion of either geom the distance changes by n.(dx_box - dx_ellipsoid) at the witnesses.
#define _GNU_SOURCE  // drand48
#include "ost_collision_ball.h"
#include "ost_collision_ellipsoid.h"

#include <check.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <mujoco/mujoco.h>

#include "fixture_geom.h"

#include "ost_collision_epa.h"

#define BIG_MARGIN 1e3  // report the contact at any distance


//---------------------------------- helpers -------------------------------------------------------


// the contact of ellipsoid e : box b at any distance (exactly one)
static ostContact contact(const ostGeom* e, const ostGeom* b) {
  ostContact con;
  ck_assert_int_eq(osti_collideEllipsoidBox(&con, e, b, BIG_MARGIN, 1e-6, 50), 1);
  return con;
}


//---------------------------------- (a) closed forms ----------------------------------------------

START_TEST(test_ellbox_ball) {
  // a ball of radius r as an ellipsoid against a rotated box: every place around the box and
  // inside it (face, edge and corner regions, apart and overlapping)
  srand48(3);
  double worst_d = 0, worst_n = 0;
  for (int rep = 0; rep < 4000; rep++) {
    ostGeom e, b;
    double r = ost_fixtureUniform(0.01, 0.1);
    ost_fixtureGeom(&e, OST_GEOM_ELLIPSOID, r, r, r);
    ost_fixtureGeom(&b, OST_GEOM_BOX, ost_fixtureUniform(0.02, 0.2), ost_fixtureUniform(0.02, 0.2),
                    ost_fixtureUniform(0.02, 0.2));
    ost_fixtureRandMat(b.mat);
    ost_fixtureRandMat(e.mat);
    for (int k = 0; k < 3; k++) b.pos[k] = ost_fixtureUniform(-1, 1);
    double cl[3], q[3], dif[3];  // the centre in the box frame, and its closest box point
    int inside = 1;
    for (int k = 0; k < 3; k++) {
      cl[k] = ost_fixtureUniform(-1.5, 1.5) * b.size[k] +
              (rep % 4 == 0 ? 0 : ost_fixtureUniform(-0.5, 0.5) * r);
      q[k] = fmin(fmax(cl[k], -b.size[k]), b.size[k]);
      inside &= q[k] == cl[k];
    }
    double expect, nloc[3];  // signed distance, normal from the ball to the box (box frame)
    if (inside) {
      int f = 0;
      for (int k = 1; k < 3; k++) {
        if (b.size[k] - fabs(cl[k]) < b.size[f] - fabs(cl[f])) f = k;
      }
      expect = -(b.size[f] - fabs(cl[f]) + r);
      nloc[0] = nloc[1] = nloc[2] = 0;
      nloc[f] = cl[f] < 0 ? 1 : -1;
    } else {
      for (int k = 0; k < 3; k++) dif[k] = q[k] - cl[k];
      double len = mju_norm3(dif);
      expect = len - r;
      for (int k = 0; k < 3; k++) nloc[k] = dif[k] / len;
    }
    double world[3], nw[3];
    mju_mulMatVec(world, b.mat, cl, 3, 3);
    mju_mulMatVec(nw, b.mat, nloc, 3, 3);
    for (int k = 0; k < 3; k++) e.pos[k] = b.pos[k] + world[k];
    ostContact con = contact(&e, &b);
    worst_d = fmax(worst_d, fabs(con.dist - expect));
    ck_assert_msg(fabs(con.dist - expect) < 1e-12, "rep %d: dist %.15g, closed form %.15g "
                  "(inside %d)", rep, con.dist, expect, inside);
    // a centre inside at equal depth under two faces has two normals: skip the normal there
    double en = 0;
    for (int k = 0; k < 3; k++) en = fmax(en, fabs(con.frame[k] - nw[k]));
    if (!inside || en < 1) {
      worst_n = fmax(worst_n, en);
      ck_assert_msg(en < 1e-9, "rep %d: normal off by %g (inside %d)", rep, en, inside);
    }
    // the point lies midway between the ball's surface and the box's along the normal
    double mid[3];
    for (int k = 0; k < 3; k++) {
      mid[k] = e.pos[k] + con.frame[k] * (r + 0.5 * con.dist);
    }
    for (int k = 0; k < 3; k++) ck_assert_double_eq_tol(con.pos[k], mid[k], 1e-12);
  }
  printf("ellipsoid-box, a ball anywhere about a box: |dist - closed form| at most %.3g m, "
         "normal at most %.3g\n", worst_d, worst_n);
}
END_TEST


START_TEST(test_ellbox_resting) {
  // the Allegro hand's object: an ellipsoid (0.03, 0.04, 0.02) turned by 20 and 10 degrees,
  // sunk 5e-8 m into the face of a box tilted by 5 degrees (MuJoCo's MPR: millimetres off)
  ostGeom e, b;
  ost_fixtureGeom(&e, OST_GEOM_ELLIPSOID, 0.03, 0.04, 0.02);
  ost_fixtureGeom(&b, OST_GEOM_BOX, 0.05, 0.05, 0.01);
  double qb[4], qx[4], qy[4], qe[4], ax[3] = {1, 0, 0}, ay[3] = {0, 1, 0};
  mju_axisAngle2Quat(qb, ay, 5 * M_PI / 180);
  mju_axisAngle2Quat(qx, ax, 20 * M_PI / 180);
  mju_axisAngle2Quat(qy, ay, 10 * M_PI / 180);
  mju_mulQuat(qe, qx, qy);
  mju_quat2Mat(b.mat, qb);
  mju_quat2Mat(e.mat, qe);
  double up[3] = {b.mat[2], b.mat[5], b.mat[8]}, down[3] = {-up[0], -up[1], -up[2]}, s[3];
  osti_support(s, &e, down, 0);  // the ellipsoid's lowest point along the face normal
  for (int k = 0; k < 3; k++) {
    e.pos[k] = b.pos[k] + up[k] * (b.size[2] - 5e-8) - (s[k] - e.pos[k]);
  }
  ostContact con = contact(&e, &b), mpr;
  ck_assert_double_eq_tol(con.dist, -5e-8, 1e-15);
  for (int k = 0; k < 3; k++) ck_assert_double_eq_tol(con.frame[k], down[k], 1e-15);
  int nm = osti_collideConvex(&mpr, &e, &b, 0.01, 1e-6, 50);  // shapes inflated by 1 cm
  double ang = nm ? acos(fmin(1, mju_dot3(mpr.frame, down))) : NAN;
  printf("ellipsoid resting 5e-8 m deep on a box face: dist %.3g m, normal exact; MPR with a 1 cm "
         "look-ahead: %s%.3g "
         "m, normal %.3g deg off\n", con.dist, nm ? "" : "no contact ", nm ? mpr.dist : 0,
         ang * 180 / M_PI);
}
END_TEST


// a random ellipsoid (semi-axes 1-10 cm) about a random box (half sizes 1-20 cm), its centre
// within 10 cm of the box's extent along each box axis, both turned at random
static void randomPair(ostGeom* e, ostGeom* b) {
  ost_fixtureGeom(e, OST_GEOM_ELLIPSOID, ost_fixtureUniform(0.01, 0.1),
                  ost_fixtureUniform(0.01, 0.1), ost_fixtureUniform(0.01, 0.1));
  ost_fixtureGeom(b, OST_GEOM_BOX, ost_fixtureUniform(0.01, 0.2), ost_fixtureUniform(0.01, 0.2),
                  ost_fixtureUniform(0.01, 0.2));
  ost_fixtureRandMat(e->mat);
  ost_fixtureRandMat(b->mat);
  for (int k = 0; k < 3; k++) e->pos[k] = ost_fixtureUniform(-1, 1) * (b->size[k] + 0.1);
}


//---------------------------------- (b) against GJK and EPA ---------------------------------------

// the penetration of ellipsoid e into box b along n (from e to b), by support values:
// max over e of n.x - min over b of n.y (minus the separation along n)
static double penetration(const ostGeom* e, const ostGeom* b, const double n[3]) {
  double se[3], sb[3], mn[3] = {-n[0], -n[1], -n[2]};
  osti_support(se, e, n, 0);
  osti_support(sb, b, mn, 0);
  return mju_dot3(n, se) - mju_dot3(n, sb);
}


START_TEST(test_ellbox_gjk_epa) {
  srand48(5);
  double worst_gjk = 0, worst_epa = 0, worst_ngjk = 0, worst_nepa = 0;
  int napart = 0, nover = 0, nskip = 0;
  for (int rep = 0; rep < 6000; rep++) {
    ostGeom e, b;
    randomPair(&e, &b);
    double size = fmax(fmax(e.size[0], e.size[1]), e.size[2]);
    double dist, pa[3], pb[3], n[3];
    ostContact con = contact(&e, &b);
    if (osti_gjkDistance(&e, &b, &dist, pa, pb) && dist > 1e-6) {
      // apart: GJK's distance (its own tolerance 1e-10 of the size) and its normal (b - a)/d
      double en = 0;
      for (int k = 0; k < 3; k++) en = fmax(en, fabs(con.frame[k] - (pb[k] - pa[k]) / dist));
      worst_gjk = fmax(worst_gjk, fabs(con.dist - dist) / size);
      worst_ngjk = fmax(worst_ngjk, en);
      ck_assert_msg(fabs(con.dist - dist) < 1e-9 * size, "rep %d: dist %.15g, GJK %.15g", rep,
                    con.dist, dist);
      ck_assert_msg(en < 1e-5, "rep %d: normal off GJK's by %g (dist %g)", rep, en, dist);
      ck_assert_msg(fabs(penetration(&e, &b, con.frame) + con.dist) < 1e-12 * size,
                    "rep %d: separation along our normal is not our distance", rep);
      napart++;
    } else if (osti_epaPenetration(&e, &b, &dist, n, pa, pb, NULL) == 1 && dist > 1e-6
               && dist < 0.5 * fmin(fmin(e.size[0], e.size[1]), e.size[2])) {
      // overlapping (less than half the ellipsoid's thinnest semi-axis): EPA's certified depth
      double en = 0;
      for (int k = 0; k < 3; k++) en = fmax(en, fabs(con.frame[k] - n[k]));
      worst_epa = fmax(worst_epa, fabs(con.dist + dist) / size);
      worst_nepa = fmax(worst_nepa, en);
      ck_assert_msg(fabs(con.dist + dist) < 1e-8 * size, "rep %d: dist %.15g, EPA -%.15g", rep,
                    con.dist, dist);
      // the depth is stationary in the normal, so a depth good to 1e-12 pins the normal only
      // to about its square root over the curvature: EPA's normal is compared through values.
      // The penetration along our normal (support values) is our depth, and no larger than
      // EPA's: the depth is the least penetration over all directions
      double pen = penetration(&e, &b, con.frame);
      ck_assert_msg(fabs(pen + con.dist) < 1e-12 * size && pen < dist + 1e-10 * size,
                    "rep %d: penetration along our normal %.15g, depth %.15g, EPA's %.15g", rep,
                    pen, -con.dist, dist);
      nover++;
    } else {
      nskip++;  // touching, deep, or not certified by EPA
    }
  }
  ck_assert_int_ge(napart, 1000);
  ck_assert_int_ge(nover, 300);
  printf("ellipsoid-box against GJK (%d apart): dist %.3g of the size, normal %.3g; against "
         "EPA (%d overlapping): depth %.3g, normal %.3g; %d deep or touching not compared\n",
         napart, worst_gjk, worst_ngjk, nover, worst_epa, worst_nepa, nskip);
}
END_TEST


//---------------------------------- (c) continuity ------------------------------------------------

START_TEST(test_ellbox_lipschitz) {
  // sweeps of the ellipsoid's centre over a box's top, across its edges and past its corners,
  // from 2 cm above to a few mm deep: a translation by dx changes the signed distance by at
  // most |dx|, and the normal of a shallow contact turns by at most |dx| / (the smallest
  // radius of curvature) (a deep one may jump between faces at equal depth)
  srand48(7);
  const double step = 2e-5;
  double worst = 0;
  for (int rep = 0; rep < 60; rep++) {
    ostGeom e, b;
    ost_fixtureGeom(&e, OST_GEOM_ELLIPSOID, ost_fixtureUniform(0.02, 0.05),
                    ost_fixtureUniform(0.02, 0.05), ost_fixtureUniform(0.02, 0.05));
    ost_fixtureGeom(&b, OST_GEOM_BOX, ost_fixtureUniform(0.03, 0.1), ost_fixtureUniform(0.03, 0.1),
                    ost_fixtureUniform(0.01, 0.05));
    ost_fixtureRandMat(e.mat);
    double down[3] = {0, 0, -1}, s[3], lift = ost_fixtureUniform(-0.002, 0.02);
    osti_support(s, &e, down, 0);
    double z0 = e.pos[2] - s[2] + b.size[2] + lift;  // lowest point `lift` above the top
    double from[3] = {ost_fixtureUniform(-0.5, 0.5) * b.size[0],
                      ost_fixtureUniform(-0.5, 0.5) * b.size[1], z0};
    double dir[3] = {ost_fixtureUniform(-1, 1), ost_fixtureUniform(-1, 1),
                     ost_fixtureUniform(-0.02, 0.02)};
    mju_normalize3(dir);
    double rmin = fmin(fmin(e.size[0], e.size[1]), e.size[2]);
    double rho = rmin * rmin / fmax(fmax(e.size[0], e.size[1]), e.size[2]);
    ostContact last;
    for (int i = 0; i < 8000; i++) {
      for (int k = 0; k < 3; k++) e.pos[k] = from[k] + i * step * dir[k];
      ostContact con = contact(&e, &b);
      if (i > 0) {
        double dd = fabs(con.dist - last.dist), dn = 0;
        for (int k = 0; k < 3; k++) dn = fmax(dn, fabs(con.frame[k] - last.frame[k]));
        worst = fmax(worst, dd / step);
        ck_assert_msg(dd <= step * (1 + 1e-6), "sweep %d step %d: dist %.12g -> %.12g", rep, i,
                      last.dist, con.dist);
        ck_assert_msg(con.dist < -0.25 * rmin || dn <= 2 * step / rho,
                      "sweep %d step %d: normal turned by %g (dist %g)",
                      rep, i, dn, con.dist);
      }
      last = con;
    }
  }
  printf("ellipsoid-box sweeps: |d dist| / |dx| at most %.9f\n", worst);
}
END_TEST


//---------------------------------- (d) first order -----------------------------------------------

START_TEST(test_ellbox_first_order) {
  srand48(9);
  const double eps = 1e-6;
  double emax = 0;
  int ncase = 0;
  for (int rep = 0; rep < 3000; rep++) {
    ostGeom e, b, gp, gm;
    randomPair(&e, &b);
    ostContact con = contact(&e, &b);
    double rmin = fmin(fmin(e.size[0], e.size[1]), e.size[2]);
    if (con.dist < -0.5 * rmin) {
      continue;  // deep
    }
    double v[3] = {ost_fixtureUniform(-1, 1), ost_fixtureUniform(-1, 1), ost_fixtureUniform(-1, 1)};
    double w[3] = {ost_fixtureUniform(-3, 3), ost_fixtureUniform(-3, 3), ost_fixtureUniform(-3, 3)};
    int which = rep % 2;  // move the box (1) or the ellipsoid (0)
    const ostGeom* g = which ? &b : &e;
    ost_fixtureMoveGeom(&gp, g, v, w, eps);
    ost_fixtureMoveGeom(&gm, g, v, w, -eps);
    ostContact cp = which ? contact(&e, &gp) : contact(&gp, &b);
    ostContact cm = which ? contact(&e, &gm) : contact(&gm, &b);
    // the witnesses: the contact point +- dist/2 along the normal (ellipsoid's, box's)
    double p[3];
    for (int k = 0; k < 3; k++) {
      p[k] = con.pos[k] + (which ? 0.5 : -0.5) * con.dist * con.frame[k];
    }
    double scale,
        pred = (which ? 1 : -1) * ost_fixturePointRate(con.frame, p, g->pos, v, w, &scale);
    double rate = (cp.dist - cm.dist) / (2 * eps);
    // where the nearest features are not unique the distance has a kink; skip those
    double right = (cp.dist - con.dist) / eps, left = (con.dist - cm.dist) / eps;
    if (fabs(right - left) > 1e-4 * scale) {
      continue;
    }
    double err = fabs(rate - pred) / scale;
    emax = fmax(emax, err);
    // a relative error e of the rate is a Newton iteration's linear rate on the gap; an exact
    // distance leaves only the differences' round-off (1e-16 / eps) and curvature (eps / radius)
    ck_assert_msg(err <= 1e-6, "rep %d: d(dist)/dt %.12g, n.(dx_box - dx_ell) %.12g (dist %g)",
                  rep, rate, pred, con.dist);
    ncase++;
  }
  ck_assert_int_ge(ncase, 1500);
  printf("ellipsoid-box first order: %d motions, |d(dist)/dt - n.(dx_b - dx_e)| / |dx| at most "
         "%.3g\n", ncase, emax);
}
END_TEST


//---------------------------------- sphere and capsule --------------------------------------------

// the contact of a sphere or capsule g1 with ellipsoid e (exactly one)
static ostContact ballContact(const ostGeom* g1, const ostGeom* e) {
  ostContact con;
  int n = osti_collideBall(&con, g1, e, BIG_MARGIN, 1e-6, 50);
  ck_assert_int_eq(n, 1);
  return con;
}


// spheres and capsules about an ellipsoid: (a) about a round one (a ball of radius R), the
// closed form |core point - centre| - r - R; (b) about random ones, GJK's distance where apart,
// EPA's certified depth where they overlap (its core route: exact); (c) under rigid motions of
// either, the distance's rate n.(dx_ellipsoid - dx_ball) at the witnesses
START_TEST(test_ellball) {
  srand48(13);
  double worst_cf = 0, worst_gjk = 0, worst_epa = 0, worst_rate = 0;
  int napart = 0, nover = 0, nrate = 0;
  for (int rep = 0; rep < 6000; rep++) {
    ostGeom g, e, gp, gm;
    int capsule = rep % 2, round = rep % 3 == 0;
    ost_fixtureGeom(&g, capsule ? OST_GEOM_CAPSULE : OST_GEOM_SPHERE,
                    ost_fixtureUniform(0.005, 0.03), ost_fixtureUniform(0.01, 0.05), 0);
    double R = ost_fixtureUniform(0.02, 0.08);
    ost_fixtureGeom(&e, OST_GEOM_ELLIPSOID, R, round ? R : ost_fixtureUniform(0.02, 0.08),
                    round ? R : ost_fixtureUniform(0.02, 0.08));
    ost_fixtureRandMat(g.mat);
    ost_fixtureRandMat(e.mat);
    for (int k = 0; k < 3; k++) g.pos[k] = ost_fixtureUniform(-0.12, 0.12);
    double size = fmax(fmax(e.size[0], e.size[1]), e.size[2]);
    ostContact con = ballContact(&g, &e);
    if (round) {
      // the core point nearest the centre: the centre's projection onto the segment, clamped
      double ax[3] = {g.mat[2], g.mat[5], g.mat[8]}, dc[3], t = 0;
      for (int k = 0; k < 3; k++) dc[k] = e.pos[k] - g.pos[k];
      if (capsule) t = fmin(fmax(mju_dot3(dc, ax), -g.size[1]), g.size[1]);
      for (int k = 0; k < 3; k++) dc[k] -= t * ax[k];
      double expect = mju_norm3(dc) - g.size[0] - R;
      worst_cf = fmax(worst_cf, fabs(con.dist - expect));
      ck_assert_msg(fabs(con.dist - expect) < 1e-12, "rep %d: dist %.15g, closed form %.15g",
                    rep, con.dist, expect);
      continue;
    }
    double d, pa[3], pb[3], n[3];
    if (osti_gjkDistance(&g, &e, &d, pa, pb) && d > 1e-6) {
      worst_gjk = fmax(worst_gjk, fabs(con.dist - d) / size);
      ck_assert_msg(fabs(con.dist - d) < 1e-9 * size, "rep %d: dist %.15g, GJK %.15g", rep,
                    con.dist, d);
      napart++;
    } else if (osti_epaPenetration(&g, &e, &d, n, pa, pb, NULL) == 1 && d > 1e-6
               && d < g.size[0]) {
      worst_epa = fmax(worst_epa, fabs(con.dist + d) / size);
      ck_assert_msg(fabs(con.dist + d) < 1e-9 * size, "rep %d: dist %.15g, EPA -%.15g", rep,
                    con.dist, d);
      nover++;
    } else {
      continue;
    }
    // first order: move the ball (which = 0) or the ellipsoid (1) along a random twist
    const double eps = 1e-6;
    double v[3] = {ost_fixtureUniform(-1, 1), ost_fixtureUniform(-1, 1), ost_fixtureUniform(-1, 1)};
    double w[3] = {ost_fixtureUniform(-3, 3), ost_fixtureUniform(-3, 3), ost_fixtureUniform(-3, 3)};
    int which = rep % 4 < 2;
    const ostGeom* mv = which ? &e : &g;
    ost_fixtureMoveGeom(&gp, mv, v, w, eps);
    ost_fixtureMoveGeom(&gm, mv, v, w, -eps);
    ostContact cp = which ? ballContact(&g, &gp) : ballContact(&gp, &e);
    ostContact cm = which ? ballContact(&g, &gm) : ballContact(&gm, &e);
    double p[3];  // the witness on the moved geom: pos -+ dist/2 along the normal (ball -> ell.)
    for (int k = 0; k < 3; k++) p[k] = con.pos[k] + (which ? 0.5 : -0.5) * con.dist * con.frame[k];
    double scale,
        pred = (which ? 1 : -1) * ost_fixturePointRate(con.frame, p, mv->pos, v, w, &scale);
    double rate = (cp.dist - cm.dist) / (2 * eps);
    double err = fabs(rate - pred) / scale;
    worst_rate = fmax(worst_rate, err);
    ck_assert_msg(err < 1e-6, "rep %d: d(dist)/dt %.12g, n.(dx_e - dx_b) %.12g", rep, rate, pred);
    nrate++;
  }
  ck_assert_int_ge(napart, 1000);
  ck_assert_int_ge(nover, 200);
  printf("sphere and capsule about an ellipsoid: closed form %.3g m; against GJK (%d apart) %.3g "
         "and EPA (%d overlapping) %.3g of the size; first-order rate %.3g (%d motions)\n",
         worst_cf, napart, worst_gjk, nover, worst_epa, worst_rate, nrate);
}
END_TEST


// every contact is finite with a unit normal whatever the shapes: sizes from 0.1 mm to 100 m,
// semi-axes 1e-3 to 1e3 times each other, centres that coincide (where a point has no unique
// nearest point on the ellipsoid and MPR takes over)
START_TEST(test_ellipsoid_extremes) {
  srand48(77);
  const double sizes[4] = {1e-4, 1e-2, 1, 100};
  int ncon = 0;
  for (int rep = 0; rep < 60000; rep++) {
    ostGeom a, e;
    double s0 = sizes[rep % 4];
    ost_fixtureGeom(&e, OST_GEOM_ELLIPSOID, s0, s0 * pow(10, ost_fixtureUniform(-3, 3)),
                    s0 * pow(10, ost_fixtureUniform(-3, 3)));
    int type = rep % 3;
    ost_fixtureGeom(&a, type == 0 ? OST_GEOM_SPHERE : type == 1 ? OST_GEOM_CAPSULE : OST_GEOM_BOX,
                    s0 * ost_fixtureUniform(0, 2), s0 * ost_fixtureUniform(0, 3),
                    s0 * ost_fixtureUniform(0, 2));
    ost_fixtureRandMat(a.mat);
    ost_fixtureRandMat(e.mat);
    double reach = rep % 7 == 0 ? 0 : ost_fixtureUniform(0, 3) * s0;
    for (int k = 0; k < 3; k++) a.pos[k] = reach * ost_fixtureUniform(-1, 1);
    ostContact con[OST_MAXCONPAIR];
    int n = type < 2 ? osti_collideBall(con, &a, &e, 1e3 * s0, 1e-6, 50)
                     : osti_collideEllipsoidBox(con, &e, &a, 1e3 * s0, 1e-6, 50);
    for (int i = 0; i < n; i++) {
      ck_assert_msg(ost_fixtureContactValid(con + i), "rep %d (type %d): dist %g", rep, type,
                    con[i].dist);
    }
    ncon += n;
  }
  ck_assert_int_ge(ncon, 30000);
}
END_TEST


int main(void) {
  Suite* s = suite_create("ost_collision_ellipsoid");
  TCase* tc = tcase_create("ellipsoid");
  tcase_set_timeout(tc, 120);
  tcase_add_test(tc, test_ellbox_ball);
  tcase_add_test(tc, test_ellbox_resting);
  tcase_add_test(tc, test_ellbox_gjk_epa);
  tcase_add_test(tc, test_ellbox_lipschitz);
  tcase_add_test(tc, test_ellbox_first_order);
  tcase_add_test(tc, test_ellball);
  tcase_add_test(tc, test_ellipsoid_extremes);
  suite_add_tcase(s, tc);
  SRunner* sr = srunner_create(s);
  srunner_run_all(sr, CK_NORMAL);
  int nfailed = srunner_ntests_failed(sr);
  srunner_free(sr);
  return nfailed ? EXIT_FAILURE : EXIT_SUCCESS;
}
