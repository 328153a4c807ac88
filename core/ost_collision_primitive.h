// ost_collision_primitive.h: analytic collisions of planes, spheres, capsules, cylinders and boxes
// with planes, and of spheres and capsules with each other.
// Mirrors engine_collision_primitive.c of MuJoCo 2.2.2 (mjc_PlaneSphere, mjc_PlaneCapsule,
// mjc_PlaneBox, mjc_SphereSphere, mjc_SphereCapsule, mjc_CapsuleCapsule), with
// the contact frame completed as MuJoCo's driver completes it (osti_makeFrame); plane : cylinder
// and plane : convex hull are Ostrich's own, with contact sets that move continuously.
// Invariant: each function writes n <= OST_MAXCONPAIR contacts in con[0..n), every one with
// dist <= margin, its normal from g1 to g2, its pos midway between the surfaces, and returns n;
// g1 has the lower geom type (plane first), as in MuJoCo's collision table.
#ifndef OSTRICH_CORE_OST_COLLISION_PRIMITIVE_H_
#define OSTRICH_CORE_OST_COLLISION_PRIMITIVE_H_

#include <math.h>

#include "ost_geom.h"
#include "ost_hd.h"
#include "ost_math.h"

#ifdef __cplusplus
extern "C" {
#endif

//---------------------------------- small vector helpers -----------------------------------------

// a . b
OST_HD ostNum osti_primDot(const ostNum a[3], const ostNum b[3]) {
  return a[0]*b[0] + a[1]*b[1] + a[2]*b[2];
}


// res = a + s b (res may alias a or b)
OST_HD void osti_primAxpy(ostNum res[3], const ostNum a[3], ostNum s, const ostNum b[3]) {
  ostNum r0 = a[0] + s*b[0], r1 = a[1] + s*b[1], r2 = a[2] + s*b[2];
  res[0] = r0; res[1] = r1; res[2] = r2;
}


// res = a x b (res must not alias)
OST_HD void osti_primCross(ostNum res[3], const ostNum a[3], const ostNum b[3]) {
  res[0] = a[1]*b[2] - a[2]*b[1];
  res[1] = a[2]*b[0] - a[0]*b[2];
  res[2] = a[0]*b[1] - a[1]*b[0];
}


// v /= |v| and return |v|; a vector shorter than OST_MINVAL becomes (1,0,0)
OST_HD ostNum osti_primNormalize(ostNum v[3]) {
  ostNum len = sqrt(osti_primDot(v, v));
  if (len < OST_MINVAL) {
    v[0] = 1; v[1] = 0; v[2] = 0;
  } else {
    ostNum inv = 1 / len;
    v[0] *= inv; v[1] *= inv; v[2] *= inv;
  }
  return len;
}


// column c of a row-major rotation (the geom's axis c in the world)
OST_HD void osti_primAxis(ostNum res[3], const ostNum mat[9], int c) {
  res[0] = mat[c]; res[1] = mat[3+c]; res[2] = mat[6+c];
}


// clamp x to [-1, 1]
OST_HD ostNum osti_primClip1(ostNum x) {
  return x > 1 ? 1 : (x < -1 ? -1 : x);
}


// write one contact: normal n, tangent hint t (NULL: none), then complete the frame
OST_HD void osti_primSetContact(ostContact* con, ostNum dist, const ostNum pos[3],
                                const ostNum n[3], const ostNum* t) {
  con->dist = dist;
  for (int i = 0; i < 3; i++) {
    con->pos[i] = pos[i];
    con->frame[i] = n[i];
    con->frame[3+i] = t ? t[i] : 0;
    con->frame[6+i] = 0;
  }
  osti_makeFrame(con->frame);
}


//---------------------------------- shared point tests -------------------------------------------

// plane (pos1, normal n) : ball (center c, radius r); the tangent hint t may be NULL
//   d = (c - pos1).n,   dist = d - r,   pos = c - n (r + dist/2)
OST_HD int osti_primPlaneBall(ostContact* con, ostNum margin, const ostNum pos1[3],
                              const ostNum n[3], const ostNum c[3], ostNum r, const ostNum* t) {
  ostNum dif[3] = {c[0] - pos1[0], c[1] - pos1[1], c[2] - pos1[2]};
  ostNum d = osti_primDot(dif, n);
  if (d > margin + r) {
    return 0;
  }
  ostNum dist = d - r, pos[3];
  osti_primAxpy(pos, c, -(dist/2 + r), n);
  osti_primSetContact(con, dist, pos, n, t);
  return 1;
}


// ball (c1, r1) : ball (c2, r2); z1, z2 are the geoms' z axes, whose cross product is the
// normal when the centers coincide
//   dist = |c2 - c1| - r1 - r2,   n = (c2 - c1)/|c2 - c1|,   pos = c1 + n (r1 + dist/2)
OST_HD int osti_primBallBall(ostContact* con, ostNum margin, const ostNum c1[3], ostNum r1,
                             const ostNum z1[3], const ostNum c2[3], ostNum r2,
                             const ostNum z2[3]) {
  ostNum n[3] = {c2[0] - c1[0], c2[1] - c1[1], c2[2] - c1[2]};
  ostNum len = sqrt(osti_primDot(n, n));
  if (len > margin + r1 + r2) {
    return 0;
  }
  ostNum dist = len - r1 - r2;

  // coincident centers: normal = z1 x z2, or (1,0,0) when the axes are parallel
  if (osti_primNormalize(n) < OST_MINVAL) {
    osti_primCross(n, z1, z2);
    osti_primNormalize(n);
  }
  ostNum pos[3];
  osti_primAxpy(pos, c1, r1 + dist/2, n);
  osti_primSetContact(con, dist, pos, n, 0);
  return 1;
}


//---------------------------------- plane collisions ---------------------------------------------

// plane : sphere
OST_HD int osti_collidePlaneSphere(ostContact* con, const ostGeom* g1, const ostGeom* g2,
                                   ostNum margin) {
  ostNum n[3];
  osti_primAxis(n, g1->mat, 2);
  return osti_primPlaneBall(con, margin, g1->pos, n, g2->pos, g2->size[0], 0);
}


// plane : capsule; the two end balls, upper end first, each with the capsule axis as tangent
OST_HD int osti_collidePlaneCapsule(ostContact* con, const ostGeom* g1, const ostGeom* g2,
                                    ostNum margin) {
  ostNum n[3], axis[3], end[3];
  osti_primAxis(n, g1->mat, 2);
  osti_primAxis(axis, g2->mat, 2);
  int cnt = 0;
  for (int s = 1; s >= -1; s -= 2) {
    osti_primAxpy(end, g2->pos, s * g2->size[1], axis);
    cnt += osti_primPlaneBall(con + cnt, margin, g1->pos, n, end, g2->size[0], axis);
  }
  return cnt;
}


// plane : cylinder, Ostrich's own (MuJoCo 2.2.2's mjc_PlaneCylinder takes its points along the
// tilt direction, which turns at random when the disk lies flat: a disk resting off-centre loaded
// changed its contact points between Newton iterates and never converged). Every point here
// moves continuously with the pose, and points appear only where they carry no force, so the
// Newton model holds between iterates. Candidates:
// - on each disk (centre p2 +- hl a), its lowest rim point p2 +- hl a + r v with
//   v = w / max(|w|, sin OST_CYLPLANE_TILT), w = (n.a) a - n (the plane's downward direction
//   without its axial part, |w| = sin tilt): the exact lowest rim point once the disk is tilted
//   by more than OST_CYLPLANE_TILT, moving into the disk's centre as it lies flat;
// - OST_CYLPLANE_RIM rim points of each disk at fixed angles in the geom's frame, which hold a
//   disk lying (nearly) flat; a tilt below OST_CYLPLANE_TILT leaves the lowest rim point at most
//   r sin(tilt) (1 - cos(pi / OST_CYLPLANE_RIM)) below them. A fixed point counts only while it
//   is less than OST_CYLPLANE_BAND r |n.a| above the lowest candidate: all of them on a flat
//   disk, none on a wheel rolling on its side (whose lowest points are exact), and one leaves
//   at a positive gap, where it carries no force.
// Every candidate within the margin (and the band) is a contact.
#define OST_CYLPLANE_TILT 0.01  // tilt (rad) below which the lowest-point contact moves inwards
#define OST_CYLPLANE_SINTILT 0.009999833334166664  // sin(OST_CYLPLANE_TILT)
#define OST_CYLPLANE_RIM 6      // fixed rim points per disk
#define OST_CYLPLANE_BAND 1e-3  // fixed rim points within this fraction of r of the lowest
OST_HD int osti_collidePlaneCylinder(ostContact* con, const ostGeom* g1, const ostGeom* g2,
                                     ostNum margin) {
  ostNum n[3], a[3], x[3], y[3];
  ostNum radius = g2->size[0], half = g2->size[1];
  osti_primAxis(n, g1->mat, 2);
  osti_primAxis(x, g2->mat, 0);
  osti_primAxis(y, g2->mat, 1);
  osti_primAxis(a, g2->mat, 2);
  ostNum dif[3] = {g2->pos[0] - g1->pos[0], g2->pos[1] - g1->pos[1], g2->pos[2] - g1->pos[2]};
  ostNum d0 = osti_primDot(dif, n);  // height of the centre over the plane
  ostNum s = osti_primDot(n, a);     // cos tilt

  // v: the lowest rim direction, shortened below the tilt threshold (|v| <= 1)
  ostNum v[3];
  osti_primAxpy(v, n, -s, a);
  ostNum sint = sqrt(osti_primDot(v, v));
  ostNum scl = -1 / (sint > OST_CYLPLANE_SINTILT ? sint : OST_CYLPLANE_SINTILT);
  v[0] *= scl; v[1] *= scl; v[2] *= scl;

  // candidates: disk +1 then -1; on each the lowest point (k = -1), then the fixed angles
  ostNum cand[2 * (OST_CYLPLANE_RIM + 1)][4];  // rim point relative to p2, and its distance
  ostNum lowest = HUGE_VAL;
  int nc = 0;
  for (int side = 1; side >= -1; side -= 2) {
    for (int k = -1; k < OST_CYLPLANE_RIM; k++, nc++) {
      ostNum* r = cand[nc];
      if (k < 0) {
        for (int i = 0; i < 3; i++) r[i] = radius * v[i];
      } else {
        // cos and sin of k 60 degrees as constants: the same bits on the CPU and the GPU
        const ostNum rim[OST_CYLPLANE_RIM][2] = {
          {1, 0}, {0.5, 0.8660254037844386}, {-0.5, 0.8660254037844386},
          {-1, 0}, {-0.5, -0.8660254037844386}, {0.5, -0.8660254037844386}};
        ostNum cs = radius * rim[k][0], sn = radius * rim[k][1];
        for (int i = 0; i < 3; i++) r[i] = cs * x[i] + sn * y[i];
      }
      osti_primAxpy(r, r, side * half, a);
      r[3] = d0 + osti_primDot(r, n);
      lowest = r[3] < lowest ? r[3] : lowest;
    }
  }
  ostNum band = OST_CYLPLANE_BAND * radius * fabs(s);
  int cnt = 0;
  for (int i = 0; i < nc; i++) {
    ostNum dist = cand[i][3];
    int fixed = i % (OST_CYLPLANE_RIM + 1) != 0;
    if (dist > margin || (fixed && !(dist < lowest + band))) {
      continue;
    }
    ostNum pos[3];
    osti_primAxpy(pos, g2->pos, 1, cand[i]);
    osti_primAxpy(pos, pos, -dist * 0.5, n);
    osti_primSetContact(con + cnt, dist, pos, n, 0);
    cnt++;
  }
  return cnt;
}


// plane : box; the corners below the center's height (n.corner <= 0) within the margin, in
// corner order (bit k set: +size[k]), at most 4
OST_HD int osti_collidePlaneBox(ostContact* con, const ostGeom* g1, const ostGeom* g2,
                                ostNum margin) {
  ostNum n[3], pos[3];
  osti_primAxis(n, g1->mat, 2);
  ostNum dif[3] = {g2->pos[0] - g1->pos[0], g2->pos[1] - g1->pos[1], g2->pos[2] - g1->pos[2]};
  ostNum d0 = osti_primDot(dif, n);
  const ostNum* R = g2->mat;
  int cnt = 0;
  for (int i = 0; i < 8; i++) {
    // corner relative to the box center, in world axes: c = R v
    ostNum v[3] = {(i & 1) ? g2->size[0] : -g2->size[0],
                   (i & 2) ? g2->size[1] : -g2->size[1],
                   (i & 4) ? g2->size[2] : -g2->size[2]};
    ostNum c[3] = {R[0]*v[0] + R[1]*v[1] + R[2]*v[2],
                   R[3]*v[0] + R[4]*v[1] + R[5]*v[2],
                   R[6]*v[0] + R[7]*v[1] + R[8]*v[2]};
    ostNum h = osti_primDot(n, c);
    if (d0 + h > margin || h > 0) {
      continue;
    }

    // pos = center + c - n dist/2
    ostNum dist = d0 + h;
    osti_primAxpy(pos, g2->pos, 1, c);
    osti_primAxpy(pos, pos, -dist/2, n);
    osti_primSetContact(con + cnt, dist, pos, n, 0);
    if (++cnt >= 4) {
      break;
    }
  }
  return cnt;
}


// plane : convex mesh, for the mujoco provider; every vertex of the mesh's convex hull below its
// center's height
// (n.(R v) <= 0) within the margin is a contact, so the contact set moves continuously with the
// pose (MuJoCo 2.2.2's plane-mesh, mirrored by osti_collidePlaneMesh, gives the deepest vertex and
// at most 2 neighbours: a mesh resting on a face switches between them from one Newton iterate to
// the next). vert: the mesh's
// vertices in the geom frame (float, as mjModel.mesh_vert); ids: the hull's vertex indices (NULL:
// all nid vertices). More than OST_MAXCONPAIR candidates keep the deepest.
OST_HD int osti_collidePlaneHull(ostContact* con, const ostGeom* g1, const ostGeom* g2,
                                 const float* vert, const int* ids, int nid, ostNum margin) {
  ostNum n[3], pos[3];
  osti_primAxis(n, g1->mat, 2);
  ostNum dif[3] = {g2->pos[0] - g1->pos[0], g2->pos[1] - g1->pos[1], g2->pos[2] - g1->pos[2]};
  ostNum d0 = osti_primDot(dif, n);
  const ostNum* R = g2->mat;
  int cnt = 0;
  for (int k = 0; k < nid; k++) {
    const float* vf = vert + 3 * (ids ? ids[k] : k);
    ostNum v[3] = {vf[0], vf[1], vf[2]};
    ostNum c[3] = {R[0]*v[0] + R[1]*v[1] + R[2]*v[2],
                   R[3]*v[0] + R[4]*v[1] + R[5]*v[2],
                   R[6]*v[0] + R[7]*v[1] + R[8]*v[2]};
    ostNum h = osti_primDot(n, c), dist = d0 + h;
    if (dist > margin || h > 0) {
      continue;
    }
    int slot = cnt;
    if (cnt == OST_MAXCONPAIR) {  // full: replace the shallowest if this one is deeper
      slot = 0;
      for (int j = 1; j < cnt; j++) {
        slot = con[j].dist > con[slot].dist ? j : slot;
      }
      if (!(dist < con[slot].dist)) {
        continue;
      }
    } else {
      cnt++;
    }
    // pos = center + c - n dist/2
    osti_primAxpy(pos, g2->pos, 1, c);
    osti_primAxpy(pos, pos, -dist/2, n);
    osti_primSetContact(con + slot, dist, pos, n, 0);
  }
  return cnt;
}


//---------------------------------- sphere and capsule collisions --------------------------------

// sphere : sphere
OST_HD int osti_collideSphereSphere(ostContact* con, const ostGeom* g1, const ostGeom* g2,
                                    ostNum margin) {
  ostNum z1[3], z2[3];
  osti_primAxis(z1, g1->mat, 2);
  osti_primAxis(z2, g2->mat, 2);
  return osti_primBallBall(con, margin, g1->pos, g1->size[0], z1, g2->pos, g2->size[0], z2);
}


// sphere : capsule; the ball at the segment point nearest to the sphere center
//   x = clip(a.(p1 - p2) / a.a, -1, 1),   a = half axis
OST_HD int osti_collideSphereCapsule(ostContact* con, const ostGeom* g1, const ostGeom* g2,
                                     ostNum margin) {
  ostNum z1[3], z2[3], a[3], near[3];
  osti_primAxis(z1, g1->mat, 2);
  osti_primAxis(z2, g2->mat, 2);
  a[0] = z2[0] * g2->size[1]; a[1] = z2[1] * g2->size[1]; a[2] = z2[2] * g2->size[1];
  ostNum dif[3] = {g1->pos[0] - g2->pos[0], g1->pos[1] - g2->pos[1], g1->pos[2] - g2->pos[2]};
  ostNum x = osti_primClip1(osti_primDot(a, dif) / osti_primDot(a, a));
  osti_primAxpy(near, g2->pos, x, a);
  return osti_primBallBall(con, margin, g1->pos, g1->size[0], z1, near, g2->size[0], z2);
}


// capsule : capsule; nearest points of the segments p1 + x1 a1, p2 + x2 a2 (|x| <= 1), from
//   [ a1.a1  -a1.a2 ] [x1]   [ -a1.(p1-p2) ]
//   [-a1.a2   a2.a2 ] [x2] = [  a2.(p1-p2) ]
// clipped one coordinate after the other; parallel axes test up to 4 end-point pairs, keeping 2
OST_HD int osti_collideCapsuleCapsule(ostContact* con, const ostGeom* g1, const ostGeom* g2,
                                      ostNum margin) {
  ostNum z1[3], z2[3], a1[3], a2[3], q1[3], q2[3];
  ostNum r1 = g1->size[0], r2 = g2->size[0];
  osti_primAxis(z1, g1->mat, 2);
  osti_primAxis(z2, g2->mat, 2);
  for (int i = 0; i < 3; i++) {
    a1[i] = z1[i] * g1->size[1];
    a2[i] = z2[i] * g2->size[1];
  }
  ostNum dif[3] = {g1->pos[0] - g2->pos[0], g1->pos[1] - g2->pos[1], g1->pos[2] - g2->pos[2]};
  ostNum ma = osti_primDot(a1, a1), mb = -osti_primDot(a1, a2), mc = osti_primDot(a2, a2);
  ostNum u = -osti_primDot(a1, dif), v = osti_primDot(a2, dif);
  ostNum det = ma*mc - mb*mb;

  // general configuration
  if (fabs(det) >= OST_MINVAL) {
    ostNum x1 = (mc*u - mb*v) / det, x2 = (ma*v - mb*u) / det;
    if (x1 > 1) {
      x1 = 1;
      x2 = (v - mb) / mc;
    } else if (x1 < -1) {
      x1 = -1;
      x2 = (v + mb) / mc;
    }
    if (x2 > 1) {
      x2 = 1;
      x1 = osti_primClip1((u - mb) / ma);
    } else if (x2 < -1) {
      x2 = -1;
      x1 = osti_primClip1((u + mb) / ma);
    }
    osti_primAxpy(q1, g1->pos, x1, a1);
    osti_primAxpy(q2, g2->pos, x2, a2);
    return osti_primBallBall(con, margin, q1, r1, z1, q2, r2, z2);
  }

  // parallel axes: ends of capsule 1 (x1 = +1, -1) against segment 2, then, while fewer than
  // two contacts, ends of capsule 2 (x2 = +1, -1) against segment 1
  int cnt = 0;
  for (int k = 0; k < 4; k++) {
    if (k >= 2 && cnt >= 2) {
      break;
    }
    ostNum sgn = (k % 2 == 0) ? 1 : -1;
    if (k < 2) {
      osti_primAxpy(q1, g1->pos, sgn, a1);
      osti_primAxpy(q2, g2->pos, osti_primClip1((v - sgn*mb) / mc), a2);
    } else {
      osti_primAxpy(q2, g2->pos, sgn, a2);
      osti_primAxpy(q1, g1->pos, osti_primClip1((u - sgn*mb) / ma), a1);
    }
    cnt += osti_primBallBall(con + cnt, margin, q1, r1, z1, q2, r2, z2);
  }
  return cnt;
}

#ifdef __cplusplus
}
#endif

#endif  // OSTRICH_CORE_OST_COLLISION_PRIMITIVE_H_
