// ost_collision_ball.h: Ostrich's own contacts of a sphere or capsule with a cylinder or a convex
// mesh (both geometry providers use them). A sphere is a point and a capsule a segment (their
// cores) swept by a ball of radius r, so while the core stays outside the other shape
//   dist = D - r,   normal = (b - a) / D,   D = |b - a| the core's distance by GJK
// (core/ost_collision_gjk.h; a on the core, b on the other shape): the exact signed distance,
// with a normal that D of about r keeps well conditioned. MuJoCo 2.2.2 finds these pairs by MPR
// on the inflated shapes, whose depth follows no contact Jacobian: a Shadow Hand finger's capsule
// against its neighbour's fingertip mesh had its gap swing between -8e-5 and +7e-5 m while
// Newton moved it by less, and the loop circled. A capsule lying nearly parallel to the contact
// plane (|axis . normal| < OST_BALL_PARALLEL) also gets the contacts of its two end balls (GJK
// from each end point), so that a capsule lying along a face is held at both ends rather than at
// a witness that slides along it. A core that touches the other shape (a penetration of r or
// more) falls back to MPR as MuJoCo collides it.
// Invariant: at most 3 contacts, dist < margin, normal from the sphere or capsule (geom1, the
// lower type) to geom2, frames completed as MuJoCo's driver does (osti_makeFrame, no hint).
#ifndef OSTRICH_CORE_OST_COLLISION_BALL_H_
#define OSTRICH_CORE_OST_COLLISION_BALL_H_

#include <math.h>
#include <stddef.h>

#include "ost_collision_convex.h"
#include "ost_collision_gjk.h"
#include "ost_collision_primitive.h"
#include "ost_geom.h"
#include "ost_hd.h"

#ifdef __cplusplus
extern "C" {
#endif

#define OST_BALL_PARALLEL 0.05  // |axis . normal| below this: a capsule lies along the contact
#define OST_BALL_CORE 1e-3      // a core closer than this share of r counts as touching: MPR


// the contact of a ball of radius r around the core geom `core` (a point or segment) with g2,
// if the core's distance D > OST_BALL_CORE r: returns 1 (and the contact, when D - r < margin:
// *n = 1) or 0 (the core touches g2); the unit normal into nrm
OST_HD int osti_ballContact(ostContact* con, int* n, const ostGeom* core, ostNum r,
                            const ostGeom* g2, ostNum margin, ostNum nrm[3]) {
  ostNum D, a[3], b[3];
  *n = 0;
  if (!osti_gjkDistance(core, g2, &D, a, b) || !(D > OST_BALL_CORE * r)) {
    return 0;
  }
  ostNum dist = D - r, pos[3];
  for (int k = 0; k < 3; k++) {
    nrm[k] = (b[k] - a[k]) / D;
    pos[k] = a[k] + nrm[k] * (r + 0.5 * dist);  // midway between the two surfaces
  }
  if (dist < margin) {
    osti_primSetContact(con, dist, pos, nrm, NULL);
    *n = 1;
  }
  return 1;
}


// sphere or capsule g1 : cylinder or mesh g2 (g2->vert set for a mesh); tol and maxiter are
// MPR's (the fallback)
OST_HD int osti_collideBallConvex(ostContact* con, const ostGeom* g1, const ostGeom* g2,
                                  ostNum margin, ostNum tol, int maxiter) {
  ostGeom core = *g1;
  ostNum r = g1->size[0], nrm[3];
  core.size[0] = 0;
  int n;
  if (!osti_ballContact(con, &n, &core, r, g2, margin, nrm)) {
    return osti_collideConvex(con, g1, g2, margin, tol, maxiter);
  }
  if (g1->type != OST_GEOM_CAPSULE) {
    return n;
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
