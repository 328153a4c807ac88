// ost_collision_gjk.h: the distance and closest points of two separated convex geoms by GJK
// (Gilbert, Johnson and Keerthi, IEEE J. Robotics and Automation 4(2), 1988), on the support
// functions of ost_collision_mpr.h. MPR (the penetration stage) answers whether two shapes
// overlap and how deep; it does not measure the gap between separated ones. GJK does: the
// distance d, the witness points a (on geom 1) and b (on geom 2) with |a - b| = d, and the
// normal (b - a)/d, which is the gradient of d with respect to b's position: distance and normal
// agree to first order, as a Newton model of the gap needs.
// Invariant: nothing here allocates, recurses, prints or touches MuJoCo, and every loop has a
// fixed bound (host and device).
#ifndef OSTRICH_CORE_OST_COLLISION_GJK_H_
#define OSTRICH_CORE_OST_COLLISION_GJK_H_

#include "ost_collision_mpr.h"

#ifdef __cplusplus
extern "C" {
#endif

#define OST_GJK_ITER 64     // support evaluations (polytopes finish in at most their vertex
                            // count; smooth shapes converge linearly)
#define OST_GJK_REL 1e-14   // stop when the lower bound v.w of |v|^2 is within this share of it:
                            // distance to 1e-14 of itself, the normal v/|v| to about 1e-7 rad
                            // (an absolute bound would leave the normal of touching shapes,
                            // |v| ~ 1e-9 m, undetermined)

typedef struct ostGjkPoint_ {  // a vertex of the simplex in the Minkowski difference A - B
  ostNum w[3];                 // a - b
  ostNum a[3];                 // support point of geom 1
  ostNum b[3];                 // support point of geom 2
} ostGjkPoint;


// the point of the affine hull of the k simplex vertices whose indices are set in `mask` (bit i:
// vertex i) nearest the origin, v = sum lam_i w_i with sum lam_i = 1, from the normal equations
// (E'E) mu = -E' w_0, E = [w_i - w_0]. Returns 0 if the subset is degenerate (E'E singular
// relative to its scale) or the point lies outside the subset (a barycentric below zero).
OST_HD int osti_gjkSubset(const ostGjkPoint* S, int mask, ostNum lam[4], ostNum v[3]) {
  int idx[4], k = 0;
  for (int i = 0; i < 4; i++) {
    if (mask & (1 << i)) idx[k++] = i;
  }
  const ostNum* w0 = S[idx[0]].w;
  ostNum E[3][3], G[3][3] = {{0}}, r[3] = {0, 0, 0}, mu[3] = {0, 0, 0};
  int m = k - 1;
  for (int i = 0; i < m; i++) {
    osti_cvxSub(E[i], S[idx[i + 1]].w, w0);
  }
  ostNum scale = 0;
  for (int i = 0; i < m; i++) {
    for (int j = 0; j < m; j++) G[i][j] = osti_cvxDot(E[i], E[j]);
    r[i] = -osti_cvxDot(E[i], w0);
    scale = G[i][i] > scale ? G[i][i] : scale;
  }
  // Gaussian elimination with partial pivoting on the m x m system (m <= 3)
  for (int c = 0; c < m; c++) {
    int p = c;
    for (int i = c + 1; i < m; i++) {
      if (fabs(G[i][c]) > fabs(G[p][c])) p = i;
    }
    if (!(fabs(G[p][c]) > 1e-12 * scale)) {
      return 0;  // the points are (nearly) affinely dependent
    }
    for (int j = 0; j < m; j++) {
      ostNum t = G[c][j];
      G[c][j] = G[p][j];
      G[p][j] = t;
    }
    ostNum t = r[c];
    r[c] = r[p];
    r[p] = t;
    for (int i = c + 1; i < m; i++) {
      ostNum f = G[i][c] / G[c][c];
      for (int j = c; j < m; j++) G[i][j] -= f * G[c][j];
      r[i] -= f * r[c];
    }
  }
  for (int c = m - 1; c >= 0; c--) {
    ostNum s = r[c];
    for (int j = c + 1; j < m; j++) s -= G[c][j] * mu[j];
    mu[c] = s / G[c][c];
  }
  ostNum l0 = 1;
  for (int i = 0; i < m; i++) l0 -= mu[i];
  for (int i = 0; i < 4; i++) lam[i] = 0;
  lam[idx[0]] = l0;
  for (int i = 0; i < m; i++) lam[idx[i + 1]] = mu[i];
  for (int i = 0; i < k; i++) {
    if (lam[idx[i]] < 0) return 0;
  }
  for (int c = 0; c < 3; c++) {
    v[c] = 0;
    for (int i = 0; i < k; i++) v[c] += lam[idx[i]] * S[idx[i]].w[c];
  }
  return 1;
}


// the point of the simplex S (n <= 4 vertices) nearest the origin: the nearest of the subsets'
// affine projections that lie inside their subsets (the nearest point of a convex hull is the
// projection onto the face that holds it, with positive barycentrics). S is reduced to that
// subset (n updated), lam to its barycentrics. Returns |v|^2.
OST_HD ostNum osti_gjkClosest(ostGjkPoint* S, int* n, ostNum lam[4], ostNum v[3]) {
  ostNum best = HUGE_VAL, bl[4] = {1, 0, 0, 0}, bv[3] = {S[0].w[0], S[0].w[1], S[0].w[2]};
  int bmask = 1;
  for (int mask = 1; mask < (1 << *n); mask++) {
    ostNum l[4], p[3];
    if (osti_gjkSubset(S, mask, l, p)) {
      ostNum pp = osti_cvxDot(p, p);
      if (pp < best) {
        best = pp;
        bmask = mask;
        for (int i = 0; i < 4; i++) bl[i] = l[i];
        for (int c = 0; c < 3; c++) bv[c] = p[c];
      }
    }
  }
  if (best == HUGE_VAL) {
    best = osti_cvxDot(bv, bv);  // every subset degenerate: the first vertex (not reached)
  }
  int k = 0;
  for (int i = 0; i < *n; i++) {
    if (bmask & (1 << i)) {
      S[k] = S[i];
      lam[k++] = bl[i];
    }
  }
  *n = k;
  for (int c = 0; c < 3; c++) v[c] = bv[c];
  return best;
}


// GJK on geoms g1 and g2 (margin 0): returns 1 if they are separated, with the simplex S (n
// vertices), the barycentrics lam of its point v nearest the origin and |v|^2 in *vv; 0 if they
// touch or overlap (the origin lies in the Minkowski difference; S then holds n = 4 vertices
// around it, or fewer when the origin lies on S). v approaches a - b; each support point
// w = s1(-v) - s2(v) gives the lower bound v.w / |v| of the distance, and the loop stops once
// |v|^2 - v.w <= OST_GJK_REL |v|^2 (or w repeats a vertex, or after OST_GJK_ITER support points).
OST_HD int osti_gjkSimplex(const ostGeom* g1, const ostGeom* g2, ostGjkPoint S[4], int* nS,
                           ostNum lam[4], ostNum* vvout) {
  ostNum v[3];
  int n = 0;
  lam[0] = 1;
  lam[1] = lam[2] = lam[3] = 0;
  osti_cvxSub(v, g1->pos, g2->pos);  // first direction: between the geoms' frames
  if (osti_cvxDot(v, v) < OST_MINVAL) {
    v[0] = 1;
    v[1] = v[2] = 0;
  }
  ostNum vv = osti_cvxDot(v, v);
  for (int it = 0; it < OST_GJK_ITER; it++) {
    ostNum dir[3] = {-v[0], -v[1], -v[2]}, ndir[3];
    osti_cvxScale(dir, 1 / sqrt(vv));
    ndir[0] = -dir[0];
    ndir[1] = -dir[1];
    ndir[2] = -dir[2];
    ostGjkPoint p;
    osti_support(p.a, g1, dir, 0);
    osti_support(p.b, g2, ndir, 0);
    osti_cvxSub(p.w, p.a, p.b);
    if (n > 0) {
      ostNum vw = osti_cvxDot(v, p.w);
      if (vv - vw <= OST_GJK_REL * vv) {
        break;  // no support point beyond v's plane by more than the tolerance
      }
      int repeat = 0;
      for (int i = 0; i < n; i++) {
        repeat |= p.w[0] == S[i].w[0] && p.w[1] == S[i].w[1] && p.w[2] == S[i].w[2];
      }
      if (repeat) {
        break;
      }
    }
    S[n++] = p;
    vv = osti_gjkClosest(S, &n, lam, v);
    if (n == 4 || vv < OST_MINVAL * OST_MINVAL) {
      *nS = n;
      return 0;  // the origin is inside the simplex, or on it
    }
  }
  *nS = n;
  *vvout = vv;
  return 1;
}


// distance of geoms g1 and g2 (margin 0): returns 1 and the distance with the witness points a
// (on g1) and b (on g2) if they are separated, 0 if they touch or overlap (MPR or EPA measure
// that case)
OST_HD int osti_gjkDistance(const ostGeom* g1, const ostGeom* g2, ostNum* dist, ostNum a[3],
                            ostNum b[3]) {
  ostGjkPoint S[4];
  ostNum lam[4], vv;
  int n;
  if (!osti_gjkSimplex(g1, g2, S, &n, lam, &vv)) {
    return 0;
  }
  for (int c = 0; c < 3; c++) {
    a[c] = b[c] = 0;
    for (int i = 0; i < n; i++) {
      a[c] += lam[i] * S[i].a[c];
      b[c] += lam[i] * S[i].b[c];
    }
  }
  *dist = sqrt(vv);
  return 1;
}


#ifdef __cplusplus
}
#endif

#endif  // OSTRICH_CORE_OST_COLLISION_GJK_H_
