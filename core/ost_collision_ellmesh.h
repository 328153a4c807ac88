// ost_collision_ellmesh.h: Ostrich's own contact of an ellipsoid with a convex mesh (its hull's
// vertices and triangles; both geometry providers use it). MuJoCo 2.2.2 collides the pair by
// MPR, whose depth along the ray between the centres follows no contact Jacobian: a Shadow
// Hand's object (an ellipsoid) 6e-5 m from a fingertip mesh kept a step's Newton loop at a
// residual of 0.07 m/s. GJK would give the gap, but its normal only to about 1e-7 rad (the
// witness of a curved support converges linearly).
// As for the box (ost_collision_ellipsoid.h), the signed distance of the two convex shapes is
//   d = max over unit n of sep(n),   sep(n) = min_ellipsoid(n.x) - max_hull(n.x)
// (n from the hull to the ellipsoid), either sign, and its maximizer lies in the normal cone of
// one hull feature, which gives a closed form or a one-dimensional root:
//   face (outward normal n_f)  sep = n_f.p - n_f.v0 with p the ellipsoid's support point along
//                              -n_f; a lower bound of d for every face of the hull, and d
//                              itself where p lies over the triangle (the face holds) apart
//   edge                       the signed distance in the plane across the edge between its
//                              point and the ellipsoid's shadow (osti_ellShadowNormal)
//   vertex                     the point's signed distance to the ellipsoid (osti_ellFramePoint)
// An edge or vertex value is d where it holds: its witness lies on the feature and no hull
// vertex reaches further along its normal (a scan of the hull, as max_hull(n.x)). Every face
// is tried (the best face that holds apart is taken at once); where the best face does not
// hold the maximizer is an edge or vertex. Apart (the best face's value > 0), d is the
// least value of the edges and vertices (each a distance between points of the two shapes):
// those of the faces around the best one (sharing a vertex with it), checked to hold, else
// all. In contact, the largest of the best face's value and the edges' and vertices' that hold,
// over the faces around the best one and then over all, skipping features that a bound from
// the ellipsoid's inscribed ball shows cannot do better or that lie too far from it to carry
// the witness. Values meet at the borders between features, so the contact is continuous. A
// point inside an ellipsoid deeper than its least radius of curvature (smin^2 / smax) can have
// several normals to its surface, of which an edge's or vertex's value takes the nearest: in
// such deep penetrations the value is a lower bound of d (the separation along a supporting
// direction), not always d. Where no feature holds (a degenerate hull) the pair falls back to
// MPR as MuJoCo collides it (osti_collideConvex).
// Invariant: at most one contact per pair, dist < margin, normal from geom1 (the ellipsoid) to
// geom2 (the mesh), frame completed as MuJoCo's driver does (osti_makeFrame, no tangent hint);
// loops have fixed bounds (host and device, double and dual builds). The hull's triangles are
// those of MuJoCo's convex-hull graph (mesh_graph), face ids into the geom's vert.
#ifndef OSTRICH_CORE_OST_COLLISION_ELLMESH_H_
#define OSTRICH_CORE_OST_COLLISION_ELLMESH_H_

#include <math.h>
#include <stddef.h>

#include "ost_collision_convex.h"
#include "ost_collision_ellipsoid.h"
#include "ost_collision_primitive.h"
#include "ost_geom.h"
#include "ost_hd.h"

#ifdef __cplusplus
extern "C" {
#endif

#define OST_ELLMESH_SLACK 1e-9  // a feature holds within this share of the hull's size
                                // (round-off at the borders between features)
#define OST_ELLMESH_TIES 8      // faces within slack of the best value whose holding is tested


// a hull vertex (mesh frame, ostNum)
OST_HD const ostNum* osti_hullVert(const ostGeom* g, int v) {
  return g->vert + 3 * (size_t)v;
}


// face f's outward unit normal nf and offset (nf.v0): 0 if the triangle is degenerate. The mesh
// frame's origin is the mesh's centre of mass (MuJoCo centres meshes there), inside the hull:
// the normal is turned away from it
OST_HD int osti_hullFace(const ostGeom* g, int f, ostNum nf[3], ostNum* off) {
  const int* t = g->face + 3 * (size_t)f;
  const ostNum *a = osti_hullVert(g, t[0]), *b = osti_hullVert(g, t[1]),
               *c = osti_hullVert(g, t[2]);
  ostNum u[3] = {b[0] - a[0], b[1] - a[1], b[2] - a[2]};
  ostNum w[3] = {c[0] - a[0], c[1] - a[1], c[2] - a[2]};
  nf[0] = u[1] * w[2] - u[2] * w[1];
  nf[1] = u[2] * w[0] - u[0] * w[2];
  nf[2] = u[0] * w[1] - u[1] * w[0];
  ostNum len = sqrt(nf[0] * nf[0] + nf[1] * nf[1] + nf[2] * nf[2]);
  if (!(len > 0)) {
    return 0;
  }
  ostNum sg = nf[0] * a[0] + nf[1] * a[1] + nf[2] * a[2] < 0 ? -1 : 1;
  for (int l = 0; l < 3; l++) nf[l] *= sg / len;
  *off = nf[0] * a[0] + nf[1] * a[1] + nf[2] * a[2];
  return 1;
}


// 1 if p (in face f's plane) lies within its triangle, to slack tol (a length)
OST_HD int osti_hullFaceHolds(const ostGeom* g, int f, const ostNum nf[3], const ostNum p[3],
                              ostNum tol) {
  const int* t = g->face + 3 * (size_t)f;
  for (int e = 0; e < 3; e++) {
    const ostNum *a = osti_hullVert(g, t[e]), *b = osti_hullVert(g, t[(e + 1) % 3]);
    ostNum u[3] = {b[0] - a[0], b[1] - a[1], b[2] - a[2]};
    // the in-plane outward normal of the edge: u x nf
    ostNum o[3] = {u[1] * nf[2] - u[2] * nf[1], u[2] * nf[0] - u[0] * nf[2],
                   u[0] * nf[1] - u[1] * nf[0]};
    ostNum lo = sqrt(o[0] * o[0] + o[1] * o[1] + o[2] * o[2]);
    ostNum side = (p[0] - a[0]) * o[0] + (p[1] - a[1]) * o[1] + (p[2] - a[2]) * o[2];
    // the winding may be either way: the third vertex tells the inside
    const ostNum* c = osti_hullVert(g, t[(e + 2) % 3]);
    ostNum in = (c[0] - a[0]) * o[0] + (c[1] - a[1]) * o[1] + (c[2] - a[2]) * o[2];
    if ((in < 0 ? -side : side) < -tol * lo) {
      return 0;
    }
  }
  return 1;
}


// 1 if no hull vertex lies further than b along -n (n from the ellipsoid to the hull, so -n
// faces the ellipsoid) beyond tol: the feature at b is the hull's support along -n
OST_HD int osti_hullSupports(const ostGeom* g, const ostNum n[3], const ostNum b[3], ostNum tol) {
  ostNum nb = n[0] * b[0] + n[1] * b[1] + n[2] * b[2] - tol;
  for (int v = 0; v < g->nvert; v++) {
    const ostNum* p = osti_hullVert(g, v);
    if (n[0] * p[0] + n[1] * p[1] + n[2] * p[2] < nb) {
      return 0;
    }
  }
  return 1;
}


// edge (p0, p1) of the hull: 1 with its value, normal n (ellipsoid to hull) and witnesses x
// (ellipsoid) and b (edge), mesh frame, where x's foot on the edge's line lies within the edge
// (to tol); whether it holds is osti_hullSupports'. c, Rr, s: the ellipsoid's centre, axes and
// semi-axes in the mesh frame
OST_HD int osti_ellmeshEdge(const ostNum c[3], const ostNum Rr[9], const ostNum s[3],
                            const ostNum p0[3], const ostNum p1[3], ostNum tol, ostNum* dist,
                            ostNum n[3], ostNum x[3], ostNum b[3]) {
  ostNum d[3] = {p1[0] - p0[0], p1[1] - p0[1], p1[2] - p0[2]};
  ostNum len = sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]);
  if (!(len > 0)) {
    return 0;
  }
  for (int l = 0; l < 3; l++) d[l] /= len;
  // a frame (e1, e2) across the edge: e1 orthogonal to d from its smallest component's axis
  int a = fabs(d[0]) <= fabs(d[1]) && fabs(d[0]) <= fabs(d[2]) ? 0
          : fabs(d[1]) <= fabs(d[2])                          ? 1
                                                              : 2;
  ostNum e1[3] = {0, 0, 0}, e2[3];
  e1[a] = 1;
  for (int l = 0; l < 3; l++) e1[l] -= d[a] * d[l];
  ostNum l1 = sqrt(e1[0] * e1[0] + e1[1] * e1[1] + e1[2] * e1[2]);
  for (int l = 0; l < 3; l++) e1[l] /= l1;
  e2[0] = d[1] * e1[2] - d[2] * e1[1];
  e2[1] = d[2] * e1[0] - d[0] * e1[2];
  e2[2] = d[0] * e1[1] - d[1] * e1[0];
  // the shadow's shape matrix E' Q E (Q = Rr diag(s^2) Rr') and the edge's point about its
  // centre
  ostNum r1[3], r2[3], A = 0, B = 0, C = 0;
  osti_boxMulMatTVec(r1, Rr, e1);
  osti_boxMulMatTVec(r2, Rr, e2);
  for (int l = 0; l < 3; l++) {
    ostNum s2 = s[l] * s[l];
    A += r1[l] * r1[l] * s2;
    B += r1[l] * r2[l] * s2;
    C += r2[l] * r2[l] * s2;
  }
  ostNum q[3] = {p0[0] - c[0], p0[1] - c[1], p0[2] - c[2]};
  ostNum w[2] = {q[0] * e1[0] + q[1] * e1[1] + q[2] * e1[2],
                 q[0] * e2[0] + q[1] * e2[1] + q[2] * e2[2]}, m[2];
  if (!osti_ellShadowNormal(A, B, C, w, m)) {
    return 0;
  }
  for (int l = 0; l < 3; l++) n[l] = m[0] * e1[l] + m[1] * e2[l];
  osti_ellboxSupport(x, c, Rr, s, n);
  ostNum t = (x[0] - p0[0]) * d[0] + (x[1] - p0[1]) * d[1] + (x[2] - p0[2]) * d[2];
  if (t < -tol || t > len + tol) {
    return 0;
  }
  for (int l = 0; l < 3; l++) b[l] = p0[l] + t * d[l];
  *dist = (b[0] - x[0]) * n[0] + (b[1] - x[1]) * n[1] + (b[2] - x[2]) * n[2];
  return 1;
}


// the distance from c to point p0 (p1 NULL), or to the segment p0 p1 (line 1: its line)
OST_HD ostNum osti_ellmeshReach(const ostNum c[3], const ostNum p0[3], const ostNum* p1,
                                int line) {
  ostNum q[3] = {c[0] - p0[0], c[1] - p0[1], c[2] - p0[2]}, t = 0;
  if (p1) {
    ostNum d[3] = {p1[0] - p0[0], p1[1] - p0[1], p1[2] - p0[2]};
    ostNum dd = d[0] * d[0] + d[1] * d[1] + d[2] * d[2];
    t = dd > 0 ? (q[0] * d[0] + q[1] * d[1] + q[2] * d[2]) / dd : 0;
    t = line ? t : t < 0 ? 0 : t > 1 ? 1 : t;
    for (int l = 0; l < 3; l++) q[l] -= t * d[l];
  }
  return sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2]);
}


#define OST_ELLMESH_SEEN 32  // vertices of the faces around the best one tried only once


// one candidate of osti_ellmeshFeatures, edge (p0, p1) or vertex p0 (p1 NULL): its value, if it
// can do better than the one found and holds, replaces it (see there). Returns found
OST_HD int osti_ellmeshTry(const ostGeom* g, const ostNum c[3], const ostNum Rr[9],
                           const ostNum s[3], const ostNum* p0, const ostNum* p1, int sep,
                           ostNum tol, ostNum near_max, ostNum smin, ostNum smax, int found,
                           ostNum* dist, ostNum n[3], ostNum x[3], ostNum b[3]) {
  ostNum reach = osti_ellmeshReach(c, p0, p1, 0);
  if (found && (sep ? !(reach - smax < *dist)
                    : !(osti_ellmeshReach(c, p0, p1, 1) - smin > *dist))) {
    return found;
  }
  if (!sep && !(reach <= near_max)) {
    return found;  // in contact the witness lies within near_max of c
  }
  ostNum dd, nn[3], xx[3], bb[3] = {p0[0], p0[1], p0[2]};
  int ok = p1 ? osti_ellmeshEdge(c, Rr, s, p0, p1, tol, &dd, nn, xx, bb)
              : osti_ellFramePoint(c, Rr, s, p0, &dd, nn, xx);
  // apart, a value is a distance between points of the shapes only where positive (an edge's
  // line may pierce the ellipsoid beside the edge)
  if (!ok || (sep && !(dd > 0)) || (found && (sep ? !(dd < *dist) : !(dd > *dist)))) {
    return found;
  }
  if (!sep && !osti_hullSupports(g, nn, bb, tol)) {
    return found;
  }
  *dist = dd;
  for (int l = 0; l < 3; l++) {
    n[l] = nn[l];
    x[l] = xx[l];
    b[l] = bb[l];
  }
  return 1;
}


// the best edge or vertex of the faces around face `best` (sharing a vertex with it; all
// faces if all) into (dist, n, x, b), found set: apart (sep: the shapes are apart) each value
// is a distance between points of the two shapes, at least d, and d the least of them; in
// contact the largest value that holds (osti_hullSupports) against the one found. Features
// that cannot do better are skipped by bounds from the ellipsoid's centre c and its least and
// largest semi-axes: a value is at most (the feature's line's or point's distance from c) -
// smin (the inscribed ball) and, apart, at least (the segment's or point's distance) - smax;
// in contact only features within near_max of c can hold the maximizer's witness. Each vertex
// is tried once; over all faces each edge once, from the face where it runs from its lower
// vertex id (MuJoCo's hull triangles are wound consistently: each edge runs one way in each of
// its two faces). Returns found
OST_HD int osti_ellmeshFeatures(const ostGeom* g, const ostNum c[3], const ostNum Rr[9],
                                const ostNum s[3], int best, int all, int sep, ostNum tol,
                                ostNum near_max, int found, ostNum* dist, ostNum n[3],
                                ostNum x[3], ostNum b[3]) {
  const int* tb = g->face + 3 * (size_t)best;
  ostNum smin = s[0] < s[1] ? s[0] : s[1], smax = s[0] > s[1] ? s[0] : s[1];
  smin = s[2] < smin ? s[2] : smin;
  smax = s[2] > smax ? s[2] : smax;
  int seen[OST_ELLMESH_SEEN], nseen = 0;
  for (int v = 0; all && v < g->nvert; v++) {
    found = osti_ellmeshTry(g, c, Rr, s, osti_hullVert(g, v), NULL, sep, tol, near_max, smin,
                            smax, found, dist, n, x, b);
  }
  for (int f = 0; f < g->nface; f++) {
    const int* t = g->face + 3 * (size_t)f;
    int near = all;
    for (int i = 0; i < 3; i++) {
      near |= t[i] == tb[0] || t[i] == tb[1] || t[i] == tb[2];
    }
    if (!near) {
      continue;
    }
    for (int i = 0; i < 3; i++) {
      int v0 = t[i], v1 = t[(i + 1) % 3];
      if (!all || v0 < v1) {
        found = osti_ellmeshTry(g, c, Rr, s, osti_hullVert(g, v0), osti_hullVert(g, v1), sep,
                                tol, near_max, smin, smax, found, dist, n, x, b);
      }
      int again = all;
      for (int k = 0; k < nseen; k++) again |= seen[k] == v0;
      if (again) {
        continue;
      }
      if (nseen < OST_ELLMESH_SEEN) {
        seen[nseen++] = v0;
      }
      found = osti_ellmeshTry(g, c, Rr, s, osti_hullVert(g, v0), NULL, sep, tol, near_max, smin,
                              smax, found, dist, n, x, b);
    }
  }
  return found;
}


// ellipsoid g1 : convex mesh g2 with its hull's triangles (g2->nface > 0); tol and maxiter are
// MPR's (the fallback)
OST_HD int osti_collideEllipsoidMesh(ostContact* con, const ostGeom* g1, const ostGeom* g2,
                                     ostNum margin, ostNum tol, int maxiter) {
  const ostNum* s = g1->size;
  ostNum c[3], Rr[9];  // the ellipsoid in the mesh frame
  osti_ellInFrame(g1, g2, c, Rr);
  ostNum slack = OST_ELLMESH_SLACK * g2->rbound;

  // faces: the best lower bound top, and the faces whose value comes within slack of it (up to
  // OST_ELLMESH_TIES: a face and its coplanar neighbours), whose holding is tested after. A
  // face's value n_f.c - off - |diag(s) Rr' n_f| is at most n_f.c - off - smin: a face that
  // cannot come near top is skipped before its support point
  ostNum smin = s[0] < s[1] ? s[0] : s[1];
  smin = s[2] < smin ? s[2] : smin;
  int best = -1, held = -1, tie[OST_ELLMESH_TIES], ntie = 0;
  ostNum top = 0, dist = 0, n[3] = {0, 0, 0}, x[3] = {0, 0, 0}, b[3] = {0, 0, 0};
  ostNum tn[3] = {0, 0, 0}, tx[3] = {0, 0, 0}, tb[3] = {0, 0, 0};  // the best face's
  ostNum tieh[OST_ELLMESH_TIES];
  for (int f = 0; f < g2->nface; f++) {
    ostNum nf[3], off, u[3], p[3];
    if (!osti_hullFace(g2, f, nf, &off)) {
      continue;
    }
    ostNum above = nf[0] * c[0] + nf[1] * c[1] + nf[2] * c[2] - off;
    if (best >= 0 && !(above - smin >= top - slack)) {
      continue;
    }
    for (int l = 0; l < 3; l++) u[l] = -nf[l];  // the ellipsoid's normal toward the face
    osti_ellboxSupport(p, c, Rr, s, u);
    ostNum h = nf[0] * p[0] + nf[1] * p[1] + nf[2] * p[2] - off;
    if (best < 0 || h > top) {
      best = f;
      top = h;
      for (int l = 0; l < 3; l++) {
        tn[l] = u[l];
        tx[l] = p[l];
        tb[l] = p[l] - h * nf[l];
      }
      // the ties left behind by more than slack go
      int keep = 0;
      for (int k = 0; k < ntie; k++) {
        if (tieh[k] >= top - slack) {
          tie[keep] = tie[k];
          tieh[keep++] = tieh[k];
        }
      }
      ntie = keep;
    }
    if (h >= top - slack && ntie < OST_ELLMESH_TIES) {
      tie[ntie] = f;
      tieh[ntie++] = h;
    }
  }
  // the best face that holds among the ties
  for (int k = 0; k < ntie; k++) {
    ostNum nf[3], off, u[3], p[3], foot[3];
    if (!(tieh[k] >= top - slack) || (held >= 0 && !(tieh[k] > dist))
        || !osti_hullFace(g2, tie[k], nf, &off)) {
      continue;
    }
    for (int l = 0; l < 3; l++) u[l] = -nf[l];
    osti_ellboxSupport(p, c, Rr, s, u);
    for (int l = 0; l < 3; l++) foot[l] = p[l] - tieh[k] * nf[l];
    if (osti_hullFaceHolds(g2, tie[k], nf, foot, slack)) {
      held = tie[k];
      dist = tieh[k];
      for (int l = 0; l < 3; l++) {
        n[l] = u[l];
        x[l] = p[l];
        b[l] = foot[l];
      }
    }
  }
  if (best < 0) {
    return osti_collideConvex(con, g1, g2, margin, tol, maxiter);
  }

  // a face that holds with the best value, apart, is d (a distance between points of the
  // shapes, and a lower bound of d). Else, apart, the maximizer is an edge or vertex (where a
  // coplanar neighbour of the best face holds, it has its value to round-off); in contact the
  // best face's value stands against the edges' and vertices' that hold (the prism under a
  // face can reach outside the hull: holding decides nothing there)
  if (held < 0 || dist < top - slack || !(dist > 0)) {
    int sep = top > 0;  // d >= top > 0: the shapes are apart
    int found = !sep;
    if (!sep) {
      // in contact the best face's value is sep(n_f) exactly (a hull's face supports it along
      // its normal), held or not: the value to beat, with the face plane's foot as witness
      dist = top;
      for (int l = 0; l < 3; l++) {
        n[l] = tn[l];
        x[l] = tx[l];
        b[l] = tb[l];
      }
    }
    // in contact the maximizer's witness on the hull lies within max(d, 0) of the ellipsoid,
    // so within smax + max(d, 0) of its centre, and max(d, 0) <= |v - c| - smin for every hull
    // vertex v (apart d is at most v's distance, which the inscribed ball bounds)
    ostNum smax = s[0] > s[1] ? s[0] : s[1], up = 0;
    smax = s[2] > smax ? s[2] : smax;
    if (!sep) {
      for (int v = 0; v < g2->nvert; v++) {
        ostNum r = osti_ellmeshReach(c, osti_hullVert(g2, v), NULL, 0) - smin;
        up = v == 0 || r < up ? r : up;
      }
      up = up > 0 ? up : 0;
    }
    // the faces around the best one, then (in contact always, apart where the least value
    // found does not hold) every face's, skipping features that cannot do better
    for (int all = 0; all < 2; all++) {
      found = osti_ellmeshFeatures(g2, c, Rr, s, best, all, sep, slack, smax + up + slack, found,
                                   &dist, n, x, b);
      if (sep && found && !osti_hullSupports(g2, n, b, slack)) {
        found = 0;  // a coarse hull: the least value lies beyond the faces around the best
      } else if (sep) {
        break;
      }
    }
    if (!found) {
      return osti_collideConvex(con, g1, g2, margin, tol, maxiter);
    }
  }
  if (!(dist < margin)) {
    return 0;
  }
  osti_ellFrameContact(con, g2, dist, n, x, b);
  return 1;
}

#ifdef __cplusplus
}
#endif

#endif  // OSTRICH_CORE_OST_COLLISION_ELLMESH_H_
