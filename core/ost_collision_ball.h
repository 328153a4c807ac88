// ost_collision_ball.h: Ostrich's own contacts of a sphere or capsule with an ellipsoid, a
// cylinder or a convex mesh (both geometry providers use them). A sphere is a point and a
// capsule a segment (their cores) swept by a ball of radius r, so while the core stays outside
// the other shape
//   dist = D - r,   normal = the direction of D,   D the core's signed distance to the shape,
// the exact signed distance, with a normal that D of about r keeps well conditioned. MuJoCo
// 2.2.2 finds these pairs by MPR on the inflated shapes, whose depth follows no contact
// Jacobian: a Shadow Hand finger's capsule against its neighbour's fingertip mesh had its gap
// swing between -8e-5 and +7e-5 m while Newton moved it by less, and the loop circled.
// D by shape:
//   ellipsoid, cylinder  the point's signed distance in closed form (the ellipsoid's secular
//                        root, ost_collision_ellipsoid.h; the cylinder by feature: side, cap or
//                        rim circle, osti_cylPoint), exact to round-off in the normal too. A
//                        capsule's core point is the axis point nearest the shape: sd is convex
//                        along the axis, so its slope n(t).a rises with t, found by bisection
//                        on the slope and one Newton step on it (the slope's derivative by a
//                        difference; not at a kink inside a cylinder), which gives t's
//                        derivatives in a dual build. GJK on a
//                        cylinder stops with its normal known to about 1e-7 rad (the witness of
//                        a curved support converges linearly); a dm_control dog leaning a leg
//                        on its target disc's rim took that as noise of 1e-7 to 1e-6 m/s in
//                        the leg's velocity, and 30 of 200 steps stalled above tolerance
//   mesh                 GJK between the core and the hull (core/ost_collision_gjk.h), exact
//                        for a polytope
// A capsule lying nearly parallel to the contact plane of a cylinder or mesh (|axis . normal|
// < OST_BALL_PARALLEL) also gets the contacts of its two end balls, so that a capsule lying
// along a flat face is held at both ends rather than at a witness that slides along it. A core
// that touches a mesh (a penetration of r or more), or whose point distance is undefined (a
// point at an ellipsoid's centre or on a cylinder's axis deep inside it), falls back to MPR as
// MuJoCo collides it.
// Invariant: at most 3 contacts, dist < margin, normal from the sphere or capsule (geom1, the
// lower type) to geom2, frames completed as MuJoCo's driver does (osti_makeFrame, no hint);
// loops have fixed bounds (host and device, double and dual builds).
#ifndef OSTRICH_CORE_OST_COLLISION_BALL_H_
#define OSTRICH_CORE_OST_COLLISION_BALL_H_

#include <math.h>
#include <stddef.h>

#include "ost_collision_convex.h"
#include "ost_collision_ellipsoid.h"
#include "ost_collision_gjk.h"
#include "ost_collision_primitive.h"
#include "ost_geom.h"
#include "ost_hd.h"

#ifdef __cplusplus
extern "C" {
#endif

#define OST_BALL_PARALLEL 0.05  // |axis . normal| below this: a capsule lies along the contact
#define OST_BALL_CORE 1e-3      // a core closer than this share of r to a mesh counts as
                                // touching it: MPR


// the signed distance sd of point p to cylinder g (radius size[0], half height size[1]), the
// outward unit normal n at its closest surface point x; by feature in the cylinder's frame
// (rho = the distance from the axis, z along it):
//   rho > R, |z| > H   the rim circle: x = (R e_rho, H sign z), n = (p - x) / |p - x|
//   rho > R            the side:  x = (R e_rho, z), n = e_rho, sd = rho - R
//   |z| > H            a cap:     x = (p_xy, H sign z), n = (0, 0, sign z), sd = |z| - H
//   inside             the nearer of side and cap, sd = max(rho - R, |z| - H) < 0
// continuous across the features. Returns 0 where n is undefined (p on the axis with the side
// nearest: deep inside a long cylinder)
OST_HD int osti_cylPoint(const ostGeom* g, const ostNum p[3], ostNum* sd, ostNum n[3],
                         ostNum x[3]) {
  const ostNum* R = g->mat;
  ostNum d[3] = {p[0] - g->pos[0], p[1] - g->pos[1], p[2] - g->pos[2]}, q[3];
  for (int i = 0; i < 3; i++) {
    q[i] = R[i] * d[0] + R[3 + i] * d[1] + R[6 + i] * d[2];  // R' (p - pos)
  }
  ostNum rad = g->size[0], hh = g->size[1], rho = sqrt(q[0] * q[0] + q[1] * q[1]);
  ostNum dr = rho - rad, sz = q[2] < 0 ? -1 : 1, dz = sz * q[2] - hh;
  int side = dr > 0 ? 1 : (dz > 0 ? 0 : dr > dz);
  if (side && !(rho > 0)) {
    return 0;
  }
  ostNum nl[3], xl[3];
  if (side) {
    ostNum ex = q[0] / rho, ey = q[1] / rho;
    xl[0] = rad * ex;
    xl[1] = rad * ey;
    if (dr > 0 && dz > 0) {  // the rim
      xl[2] = sz * hh;
      *sd = sqrt(dr * dr + dz * dz);
      nl[0] = dr * ex / *sd;
      nl[1] = dr * ey / *sd;
      nl[2] = sz * dz / *sd;
    } else {
      xl[2] = q[2];
      *sd = dr;
      nl[0] = ex;
      nl[1] = ey;
      nl[2] = 0;
    }
  } else {
    xl[0] = q[0];
    xl[1] = q[1];
    xl[2] = sz * hh;
    *sd = dz;
    nl[0] = 0;
    nl[1] = 0;
    nl[2] = sz;
  }
  for (int i = 0; i < 3; i++) {
    n[i] = R[3 * i] * nl[0] + R[3 * i + 1] * nl[1] + R[3 * i + 2] * nl[2];
    x[i] = g->pos[i] + R[3 * i] * xl[0] + R[3 * i + 1] * xl[1] + R[3 * i + 2] * xl[2];
  }
  return 1;
}


// the signed distance of point p to an ellipsoid or cylinder g2 (osti_ellPoint, osti_cylPoint)
OST_HD int osti_pointDistance(const ostGeom* g2, const ostNum p[3], ostNum* sd, ostNum n[3],
                              ostNum x[3]) {
  return g2->type == OST_GEOM_ELLIPSOID ? osti_ellPoint(g2, p, sd, n, x)
                                        : osti_cylPoint(g2, p, sd, n, x);
}


// the slope d sd(c + t a)/dt = n.a of the capsule's axis point at t (0 where undefined)
OST_HD ostNum osti_axisSlope(const ostGeom* g2, const ostNum c[3], const ostNum a[3], ostNum t) {
  ostNum p[3] = {c[0] + t * a[0], c[1] + t * a[1], c[2] + t * a[2]}, sd, n[3], x[3];
  return osti_pointDistance(g2, p, &sd, n, x) ? n[0] * a[0] + n[1] * a[1] + n[2] * a[2] : 0;
}


// the point of capsule g1's axis nearest the ellipsoid or cylinder g2 (its signed distance's
// minimum along the axis) into c
OST_HD void osti_axisNearest(const ostGeom* g1, const ostGeom* g2, ostNum c[3]) {
  ostNum a[3] = {g1->mat[2], g1->mat[5], g1->mat[8]}, hl = g1->size[1];
  ostNum t;
  if (osti_axisSlope(g2, g1->pos, a, -hl) >= 0) {
    t = -hl;  // the distance rises along the whole axis
  } else if (osti_axisSlope(g2, g1->pos, a, hl) <= 0) {
    t = hl;
  } else {
    ostNum lo = -hl, hi = hl;
    for (int it = 0; it < 60 && hi - lo > 1e-13 * hl; it++) {
      ostNum mid = 0.5 * (lo + hi);
      if (osti_axisSlope(g2, g1->pos, a, mid) < 0) {
        lo = mid;
      } else {
        hi = mid;
      }
    }
    t = 0.5 * (lo + hi);
    // one Newton step on the slope: t's value stays, its derivatives become the root's. Not at
    // a kink (inside a cylinder, where the side and a cap meet), where the slope jumps: there
    // the step would move t by about dt
    ostNum dt = 1e-6 * hl, s0 = osti_axisSlope(g2, g1->pos, a, t);
    ostNum s2 = (osti_axisSlope(g2, g1->pos, a, t + dt) - osti_axisSlope(g2, g1->pos, a, t - dt))
                / (2 * dt);
    if (s2 > 0 && fabs(s0) < 1e-9 * hl * s2) {
      t = t - s0 / s2;
    }
  }
  for (int k = 0; k < 3; k++) c[k] = g1->pos[k] + t * a[k];
}


// the contact of a ball of radius r around the core geom `core` (a sphere of radius 0 or a
// capsule of radius 0) with g2: returns 1 (and the contact, when dist < margin: *n = 1) or 0
// (the core touches a mesh, or its distance is undefined); the unit normal into nrm
OST_HD int osti_ballContact(ostContact* con, int* n, const ostGeom* core, ostNum r,
                            const ostGeom* g2, ostNum margin, ostNum nrm[3]) {
  ostNum dist, pos[3];
  *n = 0;
  if (g2->type == OST_GEOM_MESH) {
    ostNum D, a[3], b[3];
    if (!osti_gjkDistance(core, g2, &D, a, b) || !(D > OST_BALL_CORE * r)) {
      return 0;
    }
    dist = D - r;
    for (int k = 0; k < 3; k++) {
      nrm[k] = (b[k] - a[k]) / D;
      pos[k] = a[k] + nrm[k] * (r + 0.5 * dist);  // midway between the two surfaces
    }
  } else {
    ostNum c[3] = {core->pos[0], core->pos[1], core->pos[2]}, sd, out[3], x[3];
    if (core->type == OST_GEOM_CAPSULE) {
      osti_axisNearest(core, g2, c);
    }
    if (!osti_pointDistance(g2, c, &sd, out, x)) {
      return 0;
    }
    dist = sd - r;
    for (int k = 0; k < 3; k++) {
      nrm[k] = -out[k];
      pos[k] = x[k] + out[k] * (0.5 * dist);  // midway between the two surfaces
    }
  }
  if (dist < margin) {
    osti_primSetContact(con, dist, pos, nrm, NULL);
    *n = 1;
  }
  return 1;
}


// sphere or capsule g1 : ellipsoid, cylinder or mesh g2 (g2->vert set for a mesh); tol and
// maxiter are MPR's (the fallback)
OST_HD int osti_collideBall(ostContact* con, const ostGeom* g1, const ostGeom* g2, ostNum margin,
                            ostNum tol, int maxiter) {
  ostGeom core = *g1;
  ostNum r = g1->size[0], nrm[3];
  core.size[0] = 0;
  int n;
  if (!osti_ballContact(con, &n, &core, r, g2, margin, nrm)) {
    return osti_collideConvex(con, g1, g2, margin, tol, maxiter);
  }
  if (g1->type != OST_GEOM_CAPSULE || g2->type == OST_GEOM_ELLIPSOID) {
    return n;  // (an ellipsoid has no flat face: its nearest point is unique)
  }
  ostNum ax[3] = {g1->mat[2], g1->mat[5], g1->mat[8]};
  if (!(fabs(ax[0] * nrm[0] + ax[1] * nrm[1] + ax[2] * nrm[2]) < OST_BALL_PARALLEL)) {
    return n;
  }
  // lying along the contact: the end balls too (a point core: a sphere of radius 0)
  int first = n;
  for (int e = -1; e <= 1; e += 2) {
    ostGeom end = *g1;
    end.type = OST_GEOM_SPHERE;
    end.size[0] = end.size[1] = 0;
    for (int k = 0; k < 3; k++) end.pos[k] = g1->pos[k] + e * g1->size[1] * ax[k];
    int m;
    ostNum ne[3];
    if (osti_ballContact(con + n, &m, &end, r, g2, margin, ne) && m) {
      // the segment's witness at this end already: one contact
      int dup = 0;
      for (int i = 0; i < first; i++) {
        ostNum d0 = con[i].pos[0] - con[n].pos[0], d1 = con[i].pos[1] - con[n].pos[1];
        ostNum d2 = con[i].pos[2] - con[n].pos[2];
        dup |= d0 * d0 + d1 * d1 + d2 * d2 < 1e-12 * r * r;
      }
      n += !dup;
    }
  }
  return n;
}

#ifdef __cplusplus
}
#endif

#endif  // OSTRICH_CORE_OST_COLLISION_BALL_H_
