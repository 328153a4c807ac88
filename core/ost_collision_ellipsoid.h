// ost_collision_ellipsoid.h: Ostrich's own contacts of an ellipsoid with a box, and the signed
// distance of a point to an ellipsoid, which ost_collision_ball.h's sphere and capsule contacts
// take (both geometry providers use them). MuJoCo 2.2.2 finds these pairs by MPR, which
// measures the depth along the ray between the two centres: an ellipsoid resting 5e-8 m deep on
// a box face came out 3.7 mm deep with its normal 10 degrees off (the Allegro hand's object on
// its palm, compare/results/convex_distance.md), a sphere pressed on an ellipsoid (the Shadow
// Hand's thumb on its object) had its gap swing by 3e-5 m between Newton iterates that moved it
// by less, and as the shapes roll such a depth moves in ways no contact Jacobian predicts, so
// Newton's iterates circle. Here each contact is the exact signed distance, continuous in both
// poses, with the ellipsoid's own outward normal at its witness (exact however small the
// distance: a difference of witnesses divided by the distance is not).
// Point-ellipse and point-ellipsoid distances by the root of Eberly's secular equation
// ("Distance from a point to an ellipse, an ellipsoid, or a hyperellipsoid", 2013):
//   closest y_i = a_i^2 p_i / (t + a_i^2),   sum_i (a_i p_i / (t + a_i^2))^2 = 1,
// one root in t > -min a_i^2 (outside: t > 0; inside: t < 0), by bisection-safeguarded Newton,
// ending with two Newton steps so that a dual build carries the root's derivatives.
// Box (half sizes e, in the box frame): the signed distance of two convex shapes is
//   d = max over unit n of sep(n),   sep(n) = min_ellipsoid(n.x) - max_box(n.x)
// (n from the box to the ellipsoid; negative d: minus the penetration depth). max_box(n.x) =
// n.v for the vertex v = sign(n) e, so the maximizing n lies in the normal cone of one box
// feature, and each feature gives a closed form or a one-dimensional root:
//   face f (normal n_f):  the ellipsoid's support point p = s(-n_f); sep_f = n_f.p - e_f; the
//                         contact holds where p lies over the face's rectangle
//   edge (axis k):        the signed distance in the plane across the edge between the edge's
//                         point and the ellipsoid's shadow (an ellipse); holds where the normal
//                         lies in the edge's quadrant and the ellipsoid's witness within the
//                         edge's length
//   vertex v:             the signed distance from v to the ellipsoid; holds where the normal
//                         lies in v's octant
// (edge and vertex by the secular equation above). Each holding feature's value is a local
// maximum of sep(n); d is the
// largest. Where the best face holds it is taken at once (a shallow contact over a face: the
// resting case); at a face's border the face and edge values meet, at an edge's end the edge
// and vertex values, so the contact is continuous across features. A configuration where no
// feature holds (only deep penetrations, beyond round-off) falls back to MPR as MuJoCo collides
// it (osti_collideConvex).
// Invariant: at most one contact per pair, dist < margin, normal from geom1 (the lower type:
// the ellipsoid to the box), frame completed as MuJoCo's
// driver does (osti_makeFrame, no tangent hint); loops have fixed bounds (host and device,
// double and dual builds).
#ifndef OSTRICH_CORE_OST_COLLISION_ELLIPSOID_H_
#define OSTRICH_CORE_OST_COLLISION_ELLIPSOID_H_

#include <math.h>
#include <stddef.h>

#include "ost_collision_boxbox.h"
#include "ost_collision_convex.h"
#include "ost_collision_primitive.h"
#include "ost_geom.h"
#include "ost_hd.h"

#ifdef __cplusplus
extern "C" {
#endif

#define OST_ELLBOX_SLACK 1e-9  // a feature holds within this share of the box's size (round-off
                               // at the borders between features, where both values agree)
#define OST_ELLBOX_ITER 100    // safeguarded Newton iterations of the secular equation (bisection
                               // alone halves a bracket of ~1 to 1e-30 in 100)


// the closest point y of the ellipse (dim 2) or ellipsoid (dim 3) sum (y_i / a_i)^2 = 1 to p
// (either side), in the shape's principal frame; returns 0 if p is at its centre (no unique
// closest point: the caller's feature does not hold)
OST_HD int osti_ellClosest(int dim, const ostNum a[3], const ostNum p[3], ostNum y[3]) {
  ostNum g0 = 0, amin2 = a[0] * a[0], amax = a[0], pp = 0;
  int imin = 0;
  for (int i = 0; i < dim; i++) {
    g0 += (p[i] / a[i]) * (p[i] / a[i]);
    pp += p[i] * p[i];
    if (a[i] * a[i] < amin2) {
      amin2 = a[i] * a[i];
      imin = i;
    }
    amax = a[i] > amax ? a[i] : amax;
  }
  if (!(pp > 0)) {
    return 0;
  }
  // inside on the medial axis (p_imin = 0): the secular function stays below 1 up to -amin2;
  // the closest points are then y_i = a_i^2 p_i / (a_i^2 - amin2), y_imin from the quadric
  if (g0 < 1 && fabs(p[imin]) < 1e-14 * a[imin]) {
    ostNum rem = 1;
    int ok = 1;
    for (int i = 0; i < dim; i++) {
      if (i != imin) {
        ostNum den = a[i] * a[i] - amin2;
        ok &= den > 1e-14 * amin2;
        y[i] = ok ? a[i] * a[i] * p[i] / den : p[i];
        rem -= (y[i] / a[i]) * (y[i] / a[i]);
      }
    }
    if (ok && rem >= 0) {
      y[imin] = a[imin] * sqrt(rem) * (p[imin] < 0 ? -1 : 1);
      return 1;
    }
  }
  // F(t) = sum (a_i p_i / (t + a_i^2))^2 - 1 falls from +inf at -amin2 to -1 at +inf
  ostNum lo = g0 >= 1 ? 0 : -amin2, hi = g0 >= 1 ? amax * sqrt(pp) : 0;
  ostNum t = g0 >= 1 ? hi : 0;
  for (int it = 0; it < OST_ELLBOX_ITER + 2; it++) {
    ostNum F = -1, dF = 0;
    for (int i = 0; i < dim; i++) {
      ostNum q = a[i] * p[i] / (t + a[i] * a[i]);
      F += q * q;
      dF -= 2 * q * q / (t + a[i] * a[i]);
    }
    if (it >= OST_ELLBOX_ITER) {
      t = t - F / dF;  // two last Newton steps: the root's derivatives in a dual build
      continue;
    }
    if (F > 0) {
      lo = t;
    } else {
      hi = t;
    }
    ostNum tn = dF < 0 ? t - F / dF : 0.5 * (lo + hi);
    if (!(tn > lo && tn < hi)) {
      tn = 0.5 * (lo + hi);
    }
    if (fabs(tn - t) <= 1e-15 * (fabs(t) + amin2)) {
      it = OST_ELLBOX_ITER - 1;  // converged: polish
    }
    t = tn;
  }
  for (int i = 0; i < dim; i++) {
    y[i] = a[i] * a[i] * p[i] / (t + a[i] * a[i]);
  }
  return 1;
}


// the ellipsoid's support point x (box frame) along unit u (box frame): x = c + Rr (s^2 w)/|s w|,
// w = Rr' u (Rr: the ellipsoid's axes in the box frame, row-major)
OST_HD void osti_ellboxSupport(ostNum x[3], const ostNum c[3], const ostNum Rr[9],
                               const ostNum s[3], const ostNum u[3]) {
  ostNum w[3], sw = 0;
  osti_boxMulMatTVec(w, Rr, u);
  for (int i = 0; i < 3; i++) sw += (s[i] * w[i]) * (s[i] * w[i]);
  sw = sqrt(sw);
  for (int i = 0; i < 3; i++) w[i] *= s[i] * s[i] / sw;
  osti_boxMulMatVec(x, Rr, w);
  for (int i = 0; i < 3; i++) x[i] += c[i];
}


// a point p (world) against ellipsoid g: 1 with its signed distance *sd, the ellipsoid's
// outward unit normal n and its witness x (world); 0 if p is at the centre
OST_HD int osti_ellPoint(const ostGeom* g, const ostNum p[3], ostNum* sd, ostNum n[3],
                         ostNum x[3]) {
  ostNum dif[3] = {p[0] - g->pos[0], p[1] - g->pos[1], p[2] - g->pos[2]}, q[3], y[3], gr[3];
  osti_boxMulMatTVec(q, g->mat, dif);  // p in the ellipsoid's frame
  if (!osti_ellClosest(3, g->size, q, y)) {
    return 0;
  }
  ostNum gn = 0;
  for (int l = 0; l < 3; l++) {
    gr[l] = y[l] / (g->size[l] * g->size[l]);
    gn += gr[l] * gr[l];
  }
  gn = sqrt(gn);
  *sd = 0;
  for (int l = 0; l < 3; l++) {
    gr[l] /= gn;
    *sd += (q[l] - y[l]) * gr[l];
  }
  osti_boxMulMatVec(n, g->mat, gr);
  osti_boxMulMatVec(x, g->mat, y);
  for (int l = 0; l < 3; l++) x[l] += g->pos[l];
  return 1;
}


// the outward unit normal m (2-d) of the ellipse of shape matrix [[A, B], [B, C]] (the points y
// of y' M^-1 y = 1 about its centre) at its point nearest w (w relative to the centre, either
// side): 1, or 0 where M is singular or w is at the centre. The ellipse is an ellipsoid's
// shadow along a line (M = E' Q E, Q = Rr diag(s^2) Rr'), so m is the normal of the distance
// between the ellipsoid and the line: an edge's contact
OST_HD int osti_ellShadowNormal(ostNum A, ostNum B, ostNum C, const ostNum w[2], ostNum m[2]) {
  // its principal axes: M = V diag(lam) V', V = [v -v_perp]
  ostNum half = 0.5 * (A - C), disc = sqrt(half * half + B * B);
  ostNum lp = 0.5 * (A + C) + disc, lm = 0.5 * (A + C) - disc, v[2];
  if (!(lm > 0)) {
    return 0;
  }
  if (fabs(B) <= 1e-15 * (A + C)) {
    v[0] = A >= C ? 1 : 0;
    v[1] = A >= C ? 0 : 1;
  } else {
    ostNum v1[2] = {lp - C, B}, v2[2] = {B, lp - A};
    ostNum n1 = v1[0] * v1[0] + v1[1] * v1[1], n2 = v2[0] * v2[0] + v2[1] * v2[1];
    ostNum nn = sqrt(n1 > n2 ? n1 : n2);
    v[0] = (n1 > n2 ? v1[0] : v2[0]) / nn;
    v[1] = (n1 > n2 ? v1[1] : v2[1]) / nn;
  }
  ostNum a[3] = {sqrt(lp), sqrt(lm), 1}, p[3] = {v[0] * w[0] + v[1] * w[1],
                                                 -v[1] * w[0] + v[0] * w[1], 0}, y[3];
  if (!osti_ellClosest(2, a, p, y)) {
    return 0;
  }
  // outward normal (grad of the quadric) back in the plane
  ostNum g0 = y[0] / lp, g1 = y[1] / lm, gn = sqrt(g0 * g0 + g1 * g1);
  m[0] = (v[0] * g0 - v[1] * g1) / gn;
  m[1] = (v[1] * g0 + v[0] * g1) / gn;
  return 1;
}


// edge along axis k at signs (si, sj) of the other two axes: 1 if it holds, with its signed
// distance *dist, the ellipsoid's outward unit normal n and its witness x, the edge's point b
// (box frame; c, Rr, s: the ellipsoid's centre, axes and semi-axes there, as above). In the
// plane across the edge the ellipsoid's shadow is an ellipse and the edge a point: their signed
// distance and normal (osti_ellShadowNormal) are the pair's where the box's normal -n lies in
// the edge's quadrant and the ellipsoid's witness (its support point along n) lies within the
// edge's length
OST_HD int osti_ellboxEdge(const ostNum c[3], const ostNum Rr[9], const ostNum s[3],
                           const ostNum e[3], int k, ostNum si, ostNum sj, ostNum* dist,
                           ostNum n[3], ostNum x[3], ostNum b[3]) {
  int i = (k + 1) % 3, j = (k + 2) % 3;
  // the shadow across the edge: shape matrix M2 = [Rr diag(s^2) Rr']_(i,j), centre (c_i, c_j)
  ostNum A = 0, B = 0, C = 0;
  for (int l = 0; l < 3; l++) {
    ostNum s2 = s[l] * s[l];
    A += Rr[3 * i + l] * Rr[3 * i + l] * s2;
    B += Rr[3 * i + l] * Rr[3 * j + l] * s2;
    C += Rr[3 * j + l] * Rr[3 * j + l] * s2;
  }
  ostNum w[2] = {si * e[i] - c[i], sj * e[j] - c[j]}, m[2];
  if (!osti_ellShadowNormal(A, B, C, w, m)) {
    return 0;
  }
  // the box's normal -n must lie in the edge's quadrant
  ostNum tol = OST_ELLBOX_SLACK;
  if (si * m[0] > tol || sj * m[1] > tol) {
    return 0;
  }
  n[i] = m[0];
  n[j] = m[1];
  n[k] = 0;
  osti_ellboxSupport(x, c, Rr, s, n);
  if (fabs(x[k]) > e[k] * (1 + tol)) {
    return 0;  // the witness lies beyond the edge's end: a vertex (or face) contact
  }
  b[i] = si * e[i];
  b[j] = sj * e[j];
  b[k] = x[k];
  *dist = (b[0] - x[0]) * n[0] + (b[1] - x[1]) * n[1] + (b[2] - x[2]) * n[2];
  return 1;
}


// ellipsoid g1's centre c and axes Rr (its columns, row-major) in the frame of geom g2
OST_HD void osti_ellInFrame(const ostGeom* g1, const ostGeom* g2, ostNum c[3], ostNum Rr[9]) {
  ostNum dif[3] = {g1->pos[0] - g2->pos[0], g1->pos[1] - g2->pos[1], g1->pos[2] - g2->pos[2]};
  osti_boxMulMatTVec(c, g2->mat, dif);
  // Rr = R2' Re
  for (int r = 0; r < 3; r++) {
    for (int q = 0; q < 3; q++) {
      Rr[3 * r + q] = g2->mat[r] * g1->mat[q] + g2->mat[3 + r] * g1->mat[3 + q]
                      + g2->mat[6 + r] * g1->mat[6 + q];
    }
  }
}


// the contact of value dist, normal n (ellipsoid -> g2) and witnesses x (ellipsoid) and b
// (g2), all in g2's frame, into con in the world frame (point midway between the witnesses)
OST_HD void osti_ellFrameContact(ostContact* con, const ostGeom* g2, ostNum dist,
                                 const ostNum n[3], const ostNum x[3], const ostNum b[3]) {
  ostNum nw[3], mid[3] = {0.5 * (x[0] + b[0]), 0.5 * (x[1] + b[1]), 0.5 * (x[2] + b[2])}, pos[3];
  osti_boxMulMatVec(nw, g2->mat, n);
  osti_boxMulMatVec(pos, g2->mat, mid);
  for (int l = 0; l < 3; l++) pos[l] += g2->pos[l];
  osti_primSetContact(con, dist, pos, nw, NULL);
}


// point p against the ellipsoid of centre c, axes Rr and semi-axes s (all in one frame): 1 with
// its signed distance, the ellipsoid's outward normal n and its witness x there (osti_ellPoint);
// 0 at the centre
OST_HD int osti_ellFramePoint(const ostNum c[3], const ostNum Rr[9], const ostNum s[3],
                              const ostNum p[3], ostNum* dist, ostNum n[3], ostNum x[3]) {
  ostGeom e;
  e.type = OST_GEOM_ELLIPSOID;
  e.nvert = e.nface = 0;
  e.vert = NULL;
  e.face = NULL;
  e.rbound = 0;
  for (int l = 0; l < 3; l++) {
    e.pos[l] = c[l];
    e.size[l] = s[l];
  }
  for (int l = 0; l < 9; l++) e.mat[l] = Rr[l];
  return osti_ellPoint(&e, p, dist, n, x);
}


// vertex v = sg e: 1 if it holds, with its signed distance, normal n, witness x (as above): the
// point-ellipsoid distance with the ellipsoid placed in the box frame
OST_HD int osti_ellboxVertex(const ostNum c[3], const ostNum Rr[9], const ostNum s[3],
                             const ostNum v[3], const ostNum sg[3], ostNum* dist, ostNum n[3],
                             ostNum x[3]) {
  if (!osti_ellFramePoint(c, Rr, s, v, dist, n, x)) {
    return 0;
  }
  for (int l = 0; l < 3; l++) {
    if (sg[l] * n[l] > OST_ELLBOX_SLACK) {
      return 0;  // -n outside v's octant
    }
  }
  return 1;
}


// ellipsoid g1 : box g2; tol and maxiter are MPR's (the fallback)
OST_HD int osti_collideEllipsoidBox(ostContact* con, const ostGeom* g1, const ostGeom* g2,
                                    ostNum margin, ostNum tol, int maxiter) {
  const ostNum* e = g2->size;
  const ostNum* s = g1->size;
  ostNum c[3], Rr[9];  // the ellipsoid in the box frame
  osti_ellInFrame(g1, g2, c, Rr);
  ostNum slack = 1 + OST_ELLBOX_SLACK;

  // faces: the best of the six lower bounds, taken if its support point lies over the face;
  // else the best face that holds (if any) stands against the edges and vertices
  int best = -1, held = -1;
  ostNum dist = 0, n[3] = {0, 0, 0}, x[3] = {0, 0, 0}, b[3] = {0, 0, 0}, top = 0;
  for (int f = 0; f < 6; f++) {
    int i = f % 3, j = (i + 1) % 3, k = (i + 2) % 3;
    ostNum sg = f < 3 ? 1 : -1, u[3] = {0, 0, 0}, p[3];
    u[i] = sg;  // the ellipsoid's outward normal at its deepest point p, -n_f
    osti_ellboxSupport(p, c, Rr, s, u);
    ostNum h = -sg * p[i] - e[i];  // the height of p over the face of outward normal -u
    int holds = fabs(p[j]) <= e[j] * slack && fabs(p[k]) <= e[k] * slack;
    if (best < 0 || h > top) {
      best = f;
      top = h;
    }
    if (holds && (held < 0 || h > dist)) {
      held = f;
      dist = h;
      for (int l = 0; l < 3; l++) {
        n[l] = u[l];
        x[l] = p[l];
        b[l] = p[l];
      }
      b[i] = -sg * e[i];
    }
  }

  // edges and vertices, where the best face does not hold: the largest value that holds
  if (held != best) {
    best = held >= 0 ? 1 : -1;
    for (int k = 0; k < 3; k++) {
      for (int q = 0; q < 4; q++) {
        ostNum dd, nn[3], xx[3], bb[3];
        if (osti_ellboxEdge(c, Rr, s, e, k, q & 1 ? -1 : 1, q & 2 ? -1 : 1, &dd, nn, xx, bb)
            && (best < 0 || dd > dist)) {
          best = 1;
          dist = dd;
          for (int l = 0; l < 3; l++) {
            n[l] = nn[l];
            x[l] = xx[l];
            b[l] = bb[l];
          }
        }
      }
    }
    for (int q = 0; q < 8; q++) {
      ostNum sg[3] = {q & 1 ? -1. : 1., q & 2 ? -1. : 1., q & 4 ? -1. : 1.};
      ostNum v[3] = {sg[0] * e[0], sg[1] * e[1], sg[2] * e[2]}, dd, nn[3], xx[3];
      if (osti_ellboxVertex(c, Rr, s, v, sg, &dd, nn, xx) && (best < 0 || dd > dist)) {
        best = 1;
        dist = dd;
        for (int l = 0; l < 3; l++) {
          n[l] = nn[l];
          x[l] = xx[l];
          b[l] = v[l];
        }
      }
    }
    if (best < 0) {
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

#endif  // OSTRICH_CORE_OST_COLLISION_ELLIPSOID_H_
