// ost_collision_mpr.h: support functions of Ostrich's convex geoms and Minkowski Portal
// Refinement penetration between two of them (the stage that ost_collision_convex.h's pair
// functions and the terrain prisms build on).
// Mirrors MuJoCo 2.2.2's engine_collision_convex.c (mjccd_support, mjccd_center, the prism
// support of its height-field path) and the libccd 2.1 routine MuJoCo calls (ccdMPRPenetration:
// Snethen's Minkowski Portal Refinement), written anew as host+device inline C.
// Invariant: every operation is done in libccd's and MuJoCo's order, so that in double
// precision the results equal libccd's (hence MuJoCo 2.2.2's) bit for bit; nothing here
// allocates, recurses, prints or touches MuJoCo, and every loop has a fixed bound.
#ifndef OSTRICH_CORE_OST_COLLISION_MPR_H_
#define OSTRICH_CORE_OST_COLLISION_MPR_H_

#include <float.h>
#include <math.h>

#include "ost_geom.h"

#ifdef __cplusplus
extern "C" {
#endif

#ifdef OST_USE_FLOAT
#define OST_CCD_EPS FLT_EPSILON      // libccd's CCD_EPS in single precision
#else
#define OST_CCD_EPS DBL_EPSILON      // libccd's CCD_EPS in double precision
#endif
#define OST_MPR_DISCOVER_MAX 1000    // cap of portal discovery/refinement (libccd: unbounded)

//---------------------------------- small vector algebra ------------------------------------------

// a.b, summed left to right (ccdVec3Dot and mju_dot3 agree on this order)
OST_HD ostNum osti_cvxDot(const ostNum a[3], const ostNum b[3]) {
  ostNum d = a[0]*b[0];
  d += a[1]*b[1];
  d += a[2]*b[2];
  return d;
}


// r = a x b
OST_HD void osti_cvxCross(ostNum r[3], const ostNum a[3], const ostNum b[3]) {
  r[0] = a[1]*b[2] - a[2]*b[1];
  r[1] = a[2]*b[0] - a[0]*b[2];
  r[2] = a[0]*b[1] - a[1]*b[0];
}


// r = a - b
OST_HD void osti_cvxSub(ostNum r[3], const ostNum a[3], const ostNum b[3]) {
  r[0] = a[0] - b[0];
  r[1] = a[1] - b[1];
  r[2] = a[2] - b[2];
}


// v *= k
OST_HD void osti_cvxScale(ostNum v[3], ostNum k) {
  v[0] *= k;
  v[1] *= k;
  v[2] *= k;
}


// libccd normalize: v *= 1/sqrt(v.v), no guard
OST_HD void osti_cvxNormalizeCcd(ostNum v[3]) {
  ostNum k = 1 / sqrt(osti_cvxDot(v, v));
  osti_cvxScale(v, k);
}


// MuJoCo normalize (mju_normalize3): v *= 1/|v|, or (1,0,0) when |v| < OST_MINVAL
OST_HD ostNum osti_cvxNormalizeMj(ostNum v[3]) {
  ostNum n = sqrt(v[0]*v[0] + v[1]*v[1] + v[2]*v[2]);
  if (n < OST_MINVAL) {
    v[0] = 1; v[1] = 0; v[2] = 0;
  } else {
    ostNum inv = 1 / n;
    osti_cvxScale(v, inv);
  }
  return n;
}


// libccd ccdIsZero: |x| < eps
OST_HD int osti_cvxIsZero(ostNum x) {
  return fabs(x) < OST_CCD_EPS;
}


// libccd ccdEq: absolute or relative equality within eps
OST_HD int osti_cvxEq(ostNum a, ostNum b) {
  ostNum ab = fabs(a - b);
  if (ab < OST_CCD_EPS) {
    return 1;
  }
  ostNum fa = fabs(a), fb = fabs(b);
  return fb > fa ? ab < OST_CCD_EPS*fb : ab < OST_CCD_EPS*fa;
}


// libccd ccdVec3Eq(v, origin): every component is zero within eps
OST_HD int osti_cvxIsOrigin(const ostNum v[3]) {
  return osti_cvxEq(v[0], 0) && osti_cvxEq(v[1], 0) && osti_cvxEq(v[2], 0);
}


// mju_sign: -1, 0 or 1
OST_HD ostNum osti_cvxSign(ostNum x) {
  return x < 0 ? -1 : (x > 0 ? 1 : 0);
}


//---------------------------------- support and center --------------------------------------------

// index of the mesh vertex of largest d.v (d in the geom frame), as mjccd_support picks it:
// graph NULL: exhaustive, the first of the largest (MuJoCo's branch for meshes without a graph);
// graph: MuJoCo's mesh_graph slice of this mesh (numvert, numface, vert_edgeadr[numvert],
// vert_globalid[numvert], edge_localid[...]) with g->vert in local-id order (vertex i of g->vert
// is mesh vertex vert_globalid[i]): hill-climbing from vertex 0 (MuJoCo's branch with a graph;
// it differs from the exhaustive one only on ties). Returns a local index, -1 if no vertex.
OST_HD int osti_meshBest(const ostGeom* g, const ostNum d[3], const int* graph) {
  const ostNum* vert = g->vert;
  if (!graph) {
    ostNum best = -1E+10;
    int ibest = -1;
    for (int i = 0; i < g->nvert; i++) {
      const ostNum* v = vert + 3*i;
      ostNum vdot = d[0]*v[0] + d[1]*v[1] + d[2]*v[2];
      if (vdot > best) {
        best = vdot;
        ibest = i;
      }
    }
    return ibest;
  }

  // hill-climb: scan the neighbours of the vertex where the scan started, move on any strict
  // improvement; each pass strictly raises best, so at most numvert passes
  int numvert = graph[0];
  const int* edgeadr = graph + 2;
  const int* edge = graph + 2 + 2*numvert;
  int ibest = 0, change = 1;
  ostNum best = d[0]*vert[0] + d[1]*vert[1] + d[2]*vert[2];
  for (int pass = 0; change && pass <= numvert; pass++) {
    change = 0;
    int locid;
    for (int i = edgeadr[ibest]; (locid = edge[i]) >= 0; i++) {
      const ostNum* v = vert + 3*locid;
      ostNum vdot = d[0]*v[0] + d[1]*v[1] + d[2]*v[2];
      if (vdot > best) {
        best = vdot;
        ibest = locid;
        change = 1;
      }
    }
  }
  return ibest;
}


// support point of geom g in world direction dir (unit), inflated by margin/2 (mjccd_support):
//   s(d) = xpos + xmat (s_local(xmat' d) + (xmat' d) margin/2)
// sphere:    s = r d                 capsule:  s = r d + sign(d_z) h e_z
// ellipsoid: s = S (S d)/|S d|       cylinder: s = r (d_x, d_y)/|d_xy| + sign(d_z) h e_z
// box:       s_i = sign(d_i) size_i  mesh:     the first vertex of largest d.v (exhaustive)
// prism (terrain): among vert[0:3] (d_z < 0) or vert[3:6], the first of largest d.v, in the
// frame of vert; no rotation, no margin (MuJoCo puts the margin into the prism's top)
OST_HD void osti_support(ostNum res[3], const ostGeom* g, const ostNum dir[3], ostNum margin) {
  const ostNum* mat = g->mat;
  const ostNum* size = g->size;
  ostNum d[3], r[3] = {0, 0, 0};

  // prism: world-frame vertices, no margin
  if (g->type == OST_GEOM_PRISM) {
    int istart = dir[2] < 0 ? 0 : 3, ibest = istart;
    ostNum best = osti_cvxDot(g->vert + 3*istart, dir);
    for (int i = istart + 1; i < istart + 3; i++) {
      ostNum tmp = osti_cvxDot(g->vert + 3*i, dir);
      if (tmp > best) {
        ibest = i;
        best = tmp;
      }
    }
    res[0] = g->vert[3*ibest];
    res[1] = g->vert[3*ibest + 1];
    res[2] = g->vert[3*ibest + 2];
    return;
  }

  // direction in the geom frame: d = xmat' dir
  d[0] = mat[0]*dir[0] + mat[3]*dir[1] + mat[6]*dir[2];
  d[1] = mat[1]*dir[0] + mat[4]*dir[1] + mat[7]*dir[2];
  d[2] = mat[2]*dir[0] + mat[5]*dir[1] + mat[8]*dir[2];

  switch (g->type) {
  case OST_GEOM_SPHERE:
    r[0] = d[0]*size[0]; r[1] = d[1]*size[0]; r[2] = d[2]*size[0];
    break;

  case OST_GEOM_CAPSULE:
    r[0] = d[0]*size[0]; r[1] = d[1]*size[0]; r[2] = d[2]*size[0];
    r[2] += osti_cvxSign(d[2]) * size[1];
    break;

  case OST_GEOM_ELLIPSOID:
    for (int i = 0; i < 3; i++) {
      r[i] = d[i] * size[i];
    }
    osti_cvxNormalizeMj(r);
    for (int i = 0; i < 3; i++) {
      r[i] *= size[i];
    }
    break;

  case OST_GEOM_CYLINDER: {
    ostNum rho = sqrt(d[0]*d[0] + d[1]*d[1]);
    if (rho > OST_MINVAL) {
      r[0] = d[0]/rho*size[0];
      r[1] = d[1]/rho*size[0];
    }
    r[2] = osti_cvxSign(d[2]) * size[1];
    break;
  }

  case OST_GEOM_BOX:
    for (int i = 0; i < 3; i++) {
      r[i] = osti_cvxSign(d[i]) * size[i];
    }
    break;

  case OST_GEOM_MESH: {
    int ibest = osti_meshBest(g, d, 0);
    if (ibest >= 0) {
      r[0] = g->vert[3*ibest]; r[1] = g->vert[3*ibest + 1]; r[2] = g->vert[3*ibest + 2];
    }
    break;
  }

  default:
    OST_ASSERT(0);
    break;
  }

  // inflate by margin/2 along d
  for (int i = 0; i < 3; i++) {
    r[i] += d[i] * margin/2;
  }

  // back to the world: res = xmat r + xpos
  res[0] = mat[0]*r[0] + mat[1]*r[1] + mat[2]*r[2];
  res[1] = mat[3]*r[0] + mat[4]*r[1] + mat[5]*r[2];
  res[2] = mat[6]*r[0] + mat[7]*r[1] + mat[8]*r[2];
  res[0] += g->pos[0];
  res[1] += g->pos[1];
  res[2] += g->pos[2];
}


// interior point of geom g: its position, or the mean of a prism's 6 vertices (mjccd_center)
OST_HD void osti_center(ostNum res[3], const ostGeom* g) {
  if (g->type == OST_GEOM_PRISM) {
    res[0] = res[1] = res[2] = 0;
    for (int i = 0; i < 6; i++) {
      res[0] += g->vert[3*i]; res[1] += g->vert[3*i + 1]; res[2] += g->vert[3*i + 2];
    }
    osti_cvxScale(res, 1.0/6.0);
    return;
  }
  res[0] = g->pos[0]; res[1] = g->pos[1]; res[2] = g->pos[2];
}


//---------------------------------- Minkowski portal refinement -----------------------------------

typedef struct ostMprPoint_ {  // a point of the Minkowski difference (ccd_support_t)
  ostNum v[3];                 // v1 - v2
  ostNum v1[3];                // support point of geom 1
  ostNum v2[3];                // support point of geom 2
} ostMprPoint;


// support of the difference g1 - g2 along dir: p.v = s1(dir) - s2(-dir)
OST_HD void osti_mprSupport(ostMprPoint* p, const ostGeom* g1, const ostGeom* g2,
                            const ostNum dir[3], ostNum margin) {
  ostNum neg[3] = {-dir[0], -dir[1], -dir[2]};
  osti_support(p->v1, g1, dir, margin);
  osti_support(p->v2, g2, neg, margin);
  osti_cvxSub(p->v, p->v1, p->v2);
}


// unit normal of the portal face p1 p2 p3, pointing away from p0: (p2-p1) x (p3-p1)
OST_HD void osti_mprPortalDir(const ostMprPoint* P, ostNum dir[3]) {
  ostNum a[3], b[3];
  osti_cvxSub(a, P[2].v, P[1].v);
  osti_cvxSub(b, P[3].v, P[1].v);
  osti_cvxCross(dir, a, b);
  osti_cvxNormalizeCcd(dir);
}


// does the new point p4 leave less than tol of growth along dir?
//   min_i (p4 - p_i).dir <= tol  over the portal face i = 1, 2, 3
OST_HD int osti_mprReachTol(const ostMprPoint* P, const ostMprPoint* p4, const ostNum dir[3],
                            ostNum tol) {
  ostNum dv1 = osti_cvxDot(P[1].v, dir), dv2 = osti_cvxDot(P[2].v, dir);
  ostNum dv3 = osti_cvxDot(P[3].v, dir), dv4 = osti_cvxDot(p4->v, dir);
  ostNum d1 = dv4 - dv1, d2 = dv4 - dv2, d3 = dv4 - dv3;
  d1 = fmin(d1, d2);
  d1 = fmin(d1, d3);
  return osti_cvxEq(d1, tol) || d1 < tol;
}


// replace one face vertex by p4 so that the new face still faces away from p0
OST_HD void osti_mprExpand(ostMprPoint* P, const ostMprPoint* p4) {
  ostNum c[3];
  osti_cvxCross(c, p4->v, P[0].v);
  if (osti_cvxDot(P[1].v, c) > 0) {
    if (osti_cvxDot(P[2].v, c) > 0) {
      P[1] = *p4;
    } else {
      P[3] = *p4;
    }
  } else {
    if (osti_cvxDot(P[3].v, c) > 0) {
      P[2] = *p4;
    } else {
      P[1] = *p4;
    }
  }
}


// squared distance from the origin to segment a b, closest point in w
OST_HD ostNum osti_mprSegDist2(const ostNum a[3], const ostNum b[3], ostNum w[3]) {
  ostNum d[3], t;
  osti_cvxSub(d, b, a);
  t = -1.0 * osti_cvxDot(a, d);
  t /= osti_cvxDot(d, d);
  if (t < 0 || osti_cvxIsZero(t)) {
    w[0] = a[0]; w[1] = a[1]; w[2] = a[2];
  } else if (t > 1 || osti_cvxEq(t, 1)) {
    w[0] = b[0]; w[1] = b[1]; w[2] = b[2];
  } else {
    w[0] = d[0]*t + a[0]; w[1] = d[1]*t + a[1]; w[2] = d[2]*t + a[2];
  }
  return osti_cvxDot(w, w);
}


// squared distance from the origin to triangle x0 b c, closest point in w:
//   T(s,t) = x0 + s d1 + t d2 minimised in closed form; edges when (s,t) leaves the triangle
OST_HD ostNum osti_mprTriDist2(const ostNum x0[3], const ostNum b[3], const ostNum c[3],
                               ostNum w[3]) {
  ostNum d1[3], d2[3], w2[3], s, t;
  osti_cvxSub(d1, b, x0);
  osti_cvxSub(d2, c, x0);
  ostNum v = osti_cvxDot(d1, d1), ww = osti_cvxDot(d2, d2);
  ostNum p = osti_cvxDot(x0, d1), q = osti_cvxDot(x0, d2), r = osti_cvxDot(d1, d2);
  ostNum det = ww * v - r * r;
  if (osti_cvxIsZero(det)) {
    s = t = -1.;
  } else {
    s = (q * r - ww * p) / det;
    t = (-s * r - q) / ww;
  }

  // inside: closest point in the face
  if ((osti_cvxIsZero(s) || s > 0) && (osti_cvxEq(s, 1) || s < 1) &&
      (osti_cvxIsZero(t) || t > 0) && (osti_cvxEq(t, 1) || t < 1) &&
      (osti_cvxEq(t + s, 1) || t + s < 1)) {
    osti_cvxScale(d1, s);
    osti_cvxScale(d2, t);
    w[0] = x0[0]; w[1] = x0[1]; w[2] = x0[2];
    w[0] += d1[0]; w[1] += d1[1]; w[2] += d1[2];
    w[0] += d2[0]; w[1] += d2[1]; w[2] += d2[2];
    return osti_cvxDot(w, w);
  }

  // outside: closest of the three edges
  ostNum dist = osti_mprSegDist2(x0, b, w), dist2 = osti_mprSegDist2(x0, c, w2);
  if (dist2 < dist) {
    dist = dist2;
    w[0] = w2[0]; w[1] = w2[1]; w[2] = w2[2];
  }
  dist2 = osti_mprSegDist2(b, c, w2);
  if (dist2 < dist) {
    dist = dist2;
    w[0] = w2[0]; w[1] = w2[1]; w[2] = w2[2];
  }
  return dist;
}


// contact point from the final portal: barycentric coordinates of the origin's projection in
// the tetrahedron p0..p3 (or, degenerate, in the face p1 p2 p3), applied to the supports of
// both geoms; pos is the midpoint of the two witnesses
OST_HD void osti_mprFindPos(const ostMprPoint* P, ostNum pos[3]) {
  ostNum dir[3], vec[3], b[4], sum, p1[3] = {0, 0, 0}, p2[3] = {0, 0, 0};
  osti_mprPortalDir(P, dir);
  osti_cvxCross(vec, P[1].v, P[2].v);
  b[0] = osti_cvxDot(vec, P[3].v);
  osti_cvxCross(vec, P[3].v, P[2].v);
  b[1] = osti_cvxDot(vec, P[0].v);
  osti_cvxCross(vec, P[0].v, P[1].v);
  b[2] = osti_cvxDot(vec, P[3].v);
  osti_cvxCross(vec, P[2].v, P[1].v);
  b[3] = osti_cvxDot(vec, P[0].v);
  sum = b[0] + b[1] + b[2] + b[3];
  if (osti_cvxIsZero(sum) || sum < 0) {
    b[0] = 0;
    osti_cvxCross(vec, P[2].v, P[3].v);
    b[1] = osti_cvxDot(vec, dir);
    osti_cvxCross(vec, P[3].v, P[1].v);
    b[2] = osti_cvxDot(vec, dir);
    osti_cvxCross(vec, P[1].v, P[2].v);
    b[3] = osti_cvxDot(vec, dir);
    sum = b[1] + b[2] + b[3];
  }
  ostNum inv = 1.0 / sum;
  for (int i = 0; i < 4; i++) {
    for (int k = 0; k < 3; k++) {
      p1[k] += P[i].v1[k] * b[i];
      p2[k] += P[i].v2[k] * b[i];
    }
  }
  for (int k = 0; k < 3; k++) {
    pos[k] = (p1[k] * inv + p2[k] * inv) * 0.5;
  }
}


// phase 1, portal discovery: a tetrahedron p0 (interior) p1 p2 p3 whose face p1 p2 p3 is hit
// by the ray from p0 through the origin; -1: origin outside, 1: origin on p1, 2: origin on the
// segment p0 p1, 0: portal built
OST_HD int osti_mprDiscover(ostMprPoint* P, const ostGeom* g1, const ostGeom* g2,
                            ostNum margin) {
  ostNum dir[3], va[3], vb[3], dot;

  // p0: interior point c1 - c2, nudged off the origin
  osti_center(P[0].v1, g1);
  osti_center(P[0].v2, g2);
  osti_cvxSub(P[0].v, P[0].v1, P[0].v2);
  if (osti_cvxIsOrigin(P[0].v)) {
    P[0].v[0] += OST_CCD_EPS * 10.0;
  }

  // p1: support towards the origin
  dir[0] = -P[0].v[0]; dir[1] = -P[0].v[1]; dir[2] = -P[0].v[2];
  osti_cvxNormalizeCcd(dir);
  osti_mprSupport(P + 1, g1, g2, dir, margin);
  dot = osti_cvxDot(P[1].v, dir);
  if (osti_cvxIsZero(dot) || dot < 0) {
    return -1;
  }

  // p2: support normal to p0, p1
  osti_cvxCross(dir, P[0].v, P[1].v);
  if (osti_cvxIsZero(osti_cvxDot(dir, dir))) {
    return osti_cvxIsOrigin(P[1].v) ? 1 : 2;
  }
  osti_cvxNormalizeCcd(dir);
  osti_mprSupport(P + 2, g1, g2, dir, margin);
  dot = osti_cvxDot(P[2].v, dir);
  if (osti_cvxIsZero(dot) || dot < 0) {
    return -1;
  }

  // p3 direction: normal of p0 p1 p2, turned away from p0
  osti_cvxSub(va, P[1].v, P[0].v);
  osti_cvxSub(vb, P[2].v, P[0].v);
  osti_cvxCross(dir, va, vb);
  osti_cvxNormalizeCcd(dir);
  if (osti_cvxDot(dir, P[0].v) > 0) {
    ostMprPoint tmp = P[1];
    P[1] = P[2];
    P[2] = tmp;
    osti_cvxScale(dir, -1.0);
  }

  // p3: rotate the portal until the origin ray passes through it
  for (int iter = 0; iter < OST_MPR_DISCOVER_MAX; iter++) {
    osti_mprSupport(P + 3, g1, g2, dir, margin);
    dot = osti_cvxDot(P[3].v, dir);
    if (osti_cvxIsZero(dot) || dot < 0) {
      return -1;
    }

    // origin outside (p1, p0, p3): p2 = p3; else outside (p3, p0, p2): p1 = p3; else done
    int cont = 0;
    osti_cvxCross(va, P[1].v, P[3].v);
    dot = osti_cvxDot(va, P[0].v);
    if (dot < 0 && !osti_cvxIsZero(dot)) {
      P[2] = P[3];
      cont = 1;
    }
    if (!cont) {
      osti_cvxCross(va, P[3].v, P[2].v);
      dot = osti_cvxDot(va, P[0].v);
      if (dot < 0 && !osti_cvxIsZero(dot)) {
        P[1] = P[3];
        cont = 1;
      }
    }
    if (!cont) {
      return 0;
    }
    osti_cvxSub(va, P[1].v, P[0].v);
    osti_cvxSub(vb, P[2].v, P[0].v);
    osti_cvxCross(dir, va, vb);
    osti_cvxNormalizeCcd(dir);
  }
  return -1;
}


// penetration of g1 and g2 (both inflated by margin/2) by MPR, as libccd's ccdMPRPenetration:
// returns 0 when they overlap, with depth, the unit direction dir along which g2 must move by
// depth to separate (zero when touching) and pos, the midpoint of the two witness points;
// returns 1 when they do not overlap. tol: mpr_tolerance, maxiter: mpr_iterations
OST_HD int osti_mprPenetration(const ostGeom* g1, const ostGeom* g2, ostNum margin,
                               ostNum tol, int maxiter, ostNum* depth, ostNum dir[3],
                               ostNum pos[3]) {
  ostMprPoint P[4], p4;
  ostNum d[3];
  int res = osti_mprDiscover(P, g1, g2, margin);

  // phase 1 outcomes
  if (res < 0) {
    return 1;
  }
  if (res == 1) {
    // touching at p1: zero depth, undefined direction
    *depth = 0;
    dir[0] = dir[1] = dir[2] = 0;
    for (int k = 0; k < 3; k++) {
      pos[k] = (P[1].v1[k] + P[1].v2[k]) * 0.5;
    }
    return 0;
  }
  if (res == 2) {
    // origin on the segment p0 p1: depth and direction from p1
    for (int k = 0; k < 3; k++) {
      pos[k] = (P[1].v1[k] + P[1].v2[k]) * 0.5;
    }
    dir[0] = P[1].v[0]; dir[1] = P[1].v[1]; dir[2] = P[1].v[2];
    *depth = sqrt(osti_cvxDot(dir, dir));
    osti_cvxNormalizeCcd(dir);
    return 0;
  }

  // phase 2, refinement: grow the portal towards the origin until it holds the origin
  int inside = 0;
  for (int iter = 0; iter < OST_MPR_DISCOVER_MAX && !inside; iter++) {
    osti_mprPortalDir(P, d);
    ostNum dot = osti_cvxDot(d, P[1].v);
    if (osti_cvxIsZero(dot) || dot > 0) {
      inside = 1;
      break;
    }
    osti_mprSupport(&p4, g1, g2, d, margin);
    dot = osti_cvxDot(p4.v, d);
    if (!(osti_cvxIsZero(dot) || dot > 0) || osti_mprReachTol(P, &p4, d, tol)) {
      return 1;
    }
    osti_mprExpand(P, &p4);
  }
  if (!inside) {
    return 1;
  }

  // phase 3, penetration: push the portal to the boundary, then the origin's nearest face point
  for (int iter = 0; ; iter++) {
    osti_mprPortalDir(P, d);
    osti_mprSupport(&p4, g1, g2, d, margin);
    if (osti_mprReachTol(P, &p4, d, tol) || iter > maxiter) {
      ostNum dist2 = osti_mprTriDist2(P[1].v, P[2].v, P[3].v, dir);
      *depth = sqrt(dist2);
      if (osti_cvxIsZero(*depth)) {
        dir[0] = dir[1] = dir[2] = 0;
      } else {
        osti_cvxNormalizeCcd(dir);
      }
      osti_mprFindPos(P, pos);
      return 0;
    }
    osti_mprExpand(P, &p4);
  }
}

#ifdef __cplusplus
}
#endif

#endif  // OSTRICH_CORE_OST_COLLISION_MPR_H_
