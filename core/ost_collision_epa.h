// ost_collision_epa.h: the penetration depth, normal and witness points of two overlapping
// convex geoms by the Expanding Polytope Algorithm (van den Bergen, "Proximity queries and
// penetration depth computation on 3D game objects", GDC 2001), on the support functions of
// ost_collision_mpr.h, started from the tetrahedron GJK (ost_collision_gjk.h) ends on.
//
// Why: MPR (MuJoCo's convex collision) measures the depth along the ray from an interior point
// of the Minkowski difference through the origin, so as two shapes slide over each other its
// depth and normal move in ways no contact Jacobian predicts (a Newton iteration on such a gap
// can cycle). EPA finds the true penetration depth d = min over unit n of h(n), h the support
// function of the Minkowski difference K = A - B (the distance from the origin to K's boundary),
// with the minimizing normal and the witness points a (on A) and b (on B), a - b = d n. At the
// minimizer dd/dx = n.(dx_b - dx_a) for any rigid motion: depth and normal agree to first order,
// as they do for GJK's distance of separated shapes; the signed distance -d, normal n (from geom
// 1 to geom 2) continues GJK's across touching.
// Invariant: nothing here allocates, recurses, prints or touches MuJoCo, every loop has a fixed
// bound, and a polytope that cannot grow consistently ends the call with a failure (0), never
// with a contact the bounds do not certify (host and device).
#ifndef OSTRICH_CORE_OST_COLLISION_EPA_H_
#define OSTRICH_CORE_OST_COLLISION_EPA_H_

#include "ost_collision_gjk.h"

#ifdef __cplusplus
extern "C" {
#endif

#define OST_EPA_VERT 128     // polytope vertices (the support evaluations: 4 + iterations)
#define OST_EPA_FACE 256     // face slots (a closed polytope of V vertices has 2V - 4 faces)
#define OST_EPA_HORIZON 64   // horizon edges of one expansion
#define OST_EPA_REL 1e-12    // stop when the support point lies within this share of the shapes'
                             // size beyond the nearest face: upper minus lower bound of the depth
#define OST_EPA_ACCEPT 1e-7  // a polytope that stops early (capacity, degeneracy) is accepted
                             // when its bounds are this close (same scale)

typedef struct ostEpaFace_ {  // a triangle of the polytope, counter-clockwise seen from outside
  int    v[3];                // vertex indices
  ostNum n[3];                // outward unit normal
  ostNum d;                   // distance of its plane from the origin, n.w_v0
} ostEpaFace;


// set face f to the triangle (i, j, k) of P: its outward normal and plane distance; returns 0
// if the triangle is degenerate (area below round-off of its edges)
OST_HD int osti_epaFace(ostEpaFace* f, const ostGjkPoint* P, int i, int j, int k) {
  ostNum e1[3], e2[3];
  osti_cvxSub(e1, P[j].w, P[i].w);
  osti_cvxSub(e2, P[k].w, P[i].w);
  osti_cvxCross(f->n, e1, e2);
  ostNum nn = osti_cvxDot(f->n, f->n);
  ostNum ee = osti_cvxDot(e1, e1) * osti_cvxDot(e2, e2);
  if (!(nn > 1e-24 * ee) || !(ee > 0)) {
    return 0;
  }
  osti_cvxScale(f->n, 1 / sqrt(nn));
  f->v[0] = i;
  f->v[1] = j;
  f->v[2] = k;
  f->d = osti_cvxDot(f->n, P[i].w);
  return 1;
}


// the point v of face f's triangle nearest the origin (GJK's subset projection: for the nearest
// face that is d n, but a sliver face's normal is only as good as its shortest edge, so the
// triangle decides), with its witnesses a - b = v; returns |v|, and *inside = 1 where v lies
// inside the triangle (then the face's normal and plane distance stand for v/|v| and |v|: they
// keep their precision as the depth goes to 0, v/|v| does not)
OST_HD ostNum osti_epaWitness(const ostEpaFace* f, const ostGjkPoint* P, ostNum v[3],
                              ostNum a[3], ostNum b[3], int* inside) {
  ostGjkPoint S[4] = {P[f->v[0]], P[f->v[1]], P[f->v[2]]};
  ostNum lam[4];
  int n = 3;
  ostNum vv = osti_gjkClosest(S, &n, lam, v);
  for (int k = 0; k < 3; k++) {
    a[k] = b[k] = 0;
    for (int i = 0; i < n; i++) {
      a[k] += lam[i] * S[i].a[k];
      b[k] += lam[i] * S[i].b[k];
    }
  }
  *inside = n == 3;
  return sqrt(vv);
}


// support point of K = A - B along dir (any nonzero length; the support functions take a unit
// direction)
OST_HD void osti_epaSupport(ostGjkPoint* p, const ostGeom* g1, const ostGeom* g2,
                            const ostNum dir[3]) {
  ostNum u[3] = {dir[0], dir[1], dir[2]};
  osti_cvxScale(u, 1 / sqrt(osti_cvxDot(u, u)));
  ostNum neg[3] = {-u[0], -u[1], -u[2]};
  osti_support(p->a, g1, u, 0);
  osti_support(p->b, g2, neg, 0);
  osti_cvxSub(p->w, p->a, p->b);
}


// a tetrahedron of K's support points around the origin, from the GJK simplex: GJK stops as
// soon as the origin lies on its simplex, which for symmetric poses (coaxial spheres) is a
// segment or a triangle; those are completed by support points along directions normal to them.
// Returns 0 if the origin lies on a single support point (touching) or K looks flat.
OST_HD int osti_epaStart(ostGjkPoint P[4], int n, const ostGeom* g1, const ostGeom* g2) {
  if (n < 2) {
    return 0;
  }
  if (n == 2) {
    // directions normal to the segment: the tangents of a contact frame about it
    ostNum e[3], fr[9] = {0, 0, 0, 0, 0, 0, 0, 0, 0};
    osti_cvxSub(e, P[1].w, P[0].w);
    fr[0] = e[0];
    fr[1] = e[1];
    fr[2] = e[2];
    osti_makeFrame(fr);
    const ostNum* d1 = fr + 3;
    const ostNum* d2 = fr + 6;
    const ostNum* dirs[2] = {d1, d2};
    int found = 0;
    for (int t = 0; t < 4 && !found; t++) {
      ostNum dir[3], c[3], f[3];
      for (int q = 0; q < 3; q++) dir[q] = (t & 1 ? -1 : 1) * dirs[t >> 1][q];
      osti_epaSupport(P + 2, g1, g2, dir);
      osti_cvxSub(f, P[2].w, P[0].w);
      osti_cvxCross(c, e, f);
      found = osti_cvxDot(c, c) > 1e-24 * osti_cvxDot(e, e) * osti_cvxDot(f, f);
    }
    if (!found) {
      return 0;
    }
  }
  if (n <= 3) {
    // the triangle's normal, both ways: the farther support point completes the tetrahedron
    ostNum e1[3], e2[3], nrm[3], neg[3];
    osti_cvxSub(e1, P[1].w, P[0].w);
    osti_cvxSub(e2, P[2].w, P[0].w);
    osti_cvxCross(nrm, e1, e2);
    neg[0] = -nrm[0];
    neg[1] = -nrm[1];
    neg[2] = -nrm[2];
    ostGjkPoint up, down;
    osti_epaSupport(&up, g1, g2, nrm);
    osti_epaSupport(&down, g1, g2, neg);
    ostNum hu = osti_cvxDot(up.w, nrm) - osti_cvxDot(P[0].w, nrm);
    ostNum hd = osti_cvxDot(P[0].w, nrm) - osti_cvxDot(down.w, nrm);
    P[3] = hu >= hd ? up : down;
  }
  // a flat tetrahedron (K without interior, or round-off) cannot start the expansion
  ostNum e1[3], e2[3], e3[3], c[3];
  osti_cvxSub(e1, P[1].w, P[0].w);
  osti_cvxSub(e2, P[2].w, P[0].w);
  osti_cvxSub(e3, P[3].w, P[0].w);
  osti_cvxCross(c, e1, e2);
  ostNum vol = fabs(osti_cvxDot(c, e3));
  ostNum l1 = sqrt(osti_cvxDot(e1, e1)), l2 = sqrt(osti_cvxDot(e2, e2));
  ostNum l3 = sqrt(osti_cvxDot(e3, e3));
  return vol > 1e-12 * l1 * l2 * l3;
}


// Newton's method for the depth's normal where the polytope converges slowly (two curved
// surfaces: the polytope's gap to K shrinks by about 2 per 4 support points). The depth is the
// least of phi(n) = h(n) over unit n, and with s(n) the support point (the gradient of h):
//   gradient of phi in the tangent plane of n:  g = T's            (T = [t1 t2], orthonormal)
//   Hessian:                                    H = T'(ds/dn)T - h I
// ds/dn (the radii of curvature of K's surface) by differences of s along t1 and t2 (a step of
// OST_EPA_FD rad). At the minimizer H is positive definite (a ball of radius depth about the
// origin touches K's surface from inside). Steps n <- normalize(n - T H^-1 g), each kept only if
// h decreases. Returns 1 once the quadratic model's decrease g'H^-1 g / 2 falls below tol and
// |g| below gtol: then h(n) exceeds the depth by about that much, and the support points are the
// witnesses (a - b = h n + T g). A support that jumps (a capsule's or cylinder's side, a box)
// leaves g large at the minimum and fails the test: the polytope's bounds decide there.
#define OST_EPA_FD 1e-5      // difference step of the curvature (rad)
#define OST_EPA_NEWTON 8     // Newton steps of the polish
#define OST_EPA_GTOL 1e-9    // the polish's stationarity: |g| below this share of the size
#define OST_EPA_POLISH_AT 32 // support points after which an unconverged polytope tries it

OST_HD int osti_epaPolish(const ostGeom* g1, const ostGeom* g2, ostNum n[3], ostGjkPoint* p,
                          ostNum* h, ostNum tol, ostNum gtol) {
  osti_epaSupport(p, g1, g2, n);
  *h = osti_cvxDot(p->w, n);
  for (int it = 0; it < OST_EPA_NEWTON; it++) {
    // tangent basis T = [t1 t2]: the tangents of a contact frame about n
    ostNum fr[9] = {n[0], n[1], n[2], 0, 0, 0, 0, 0, 0};
    osti_makeFrame(fr);
    const ostNum* t[2] = {fr + 3, fr + 6};
    ostNum g[2] = {osti_cvxDot(t[0], p->w), osti_cvxDot(t[1], p->w)}, H[2][2];
    for (int j = 0; j < 2; j++) {
      ostGjkPoint q;
      ostNum m[3];
      for (int c = 0; c < 3; c++) m[c] = n[c] + OST_EPA_FD * t[j][c];
      osti_epaSupport(&q, g1, g2, m);
      for (int i = 0; i < 2; i++) {
        H[i][j] = (osti_cvxDot(t[i], q.w) - g[i]) / OST_EPA_FD;
      }
    }
    ostNum hoff = 0.5 * (H[0][1] + H[1][0]);
    H[0][0] -= *h;
    H[1][1] -= *h;
    ostNum det = H[0][0] * H[1][1] - hoff * hoff;
    if (!(H[0][0] > 0) || !(det > 0)) {
      return 0;  // not a minimum's neighbourhood (or a kinked support): no Newton step
    }
    ostNum step[2] = {(H[1][1] * g[0] - hoff * g[1]) / det, (H[0][0] * g[1] - hoff * g[0]) / det};
    ostNum decrease = 0.5 * (g[0] * step[0] + g[1] * step[1]);
    if (decrease <= tol && g[0] * g[0] + g[1] * g[1] <= gtol * gtol) {
      return 1;  // a stationary point (a kinked support, whose g stays large, never passes)
    }
    // the step, halved until h decreases
    int moved = 0;
    for (int ls = 0; ls < 4 && !moved; ls++) {
      ostNum m[3];
      ostGjkPoint q;
      for (int c = 0; c < 3; c++) m[c] = n[c] - step[0] * t[0][c] - step[1] * t[1][c];
      osti_cvxScale(m, 1 / sqrt(osti_cvxDot(m, m)));
      osti_epaSupport(&q, g1, g2, m);
      ostNum hq = osti_cvxDot(q.w, m);
      if (hq < *h) {
        *h = hq;
        *p = q;
        n[0] = m[0];
        n[1] = m[1];
        n[2] = m[2];
        moved = 1;
      }
      step[0] *= 0.5;
      step[1] *= 0.5;
    }
    if (!moved) {
      return 0;
    }
  }
  return 0;
}


// the polish from face f's normal, accepted if certified and not below f's lower bound: writes
// the depth, normal and witnesses and returns 1
OST_HD int osti_epaPolished(const ostGeom* g1, const ostGeom* g2, const ostEpaFace* f,
                            ostNum scale, ostNum* depth, ostNum n[3], ostNum a[3], ostNum b[3]) {
  ostGjkPoint q;
  ostNum m[3] = {f->n[0], f->n[1], f->n[2]}, h;
  if (!osti_epaPolish(g1, g2, m, &q, &h, OST_EPA_REL * scale, OST_EPA_GTOL * scale)
      || !(h >= f->d - OST_EPA_REL * scale)) {
    return 0;
  }
  *depth = h > 0 ? h : 0;
  for (int c = 0; c < 3; c++) {
    n[c] = m[c];
    a[c] = q.a[c];
    b[c] = q.b[c];
  }
  return 1;
}


// EPA proper on geoms g1 and g2: osti_epaPenetration's contract
OST_HD int osti_epaPolytope(const ostGeom* g1, const ostGeom* g2, ostNum* depth,
                               ostNum n[3], ostNum a[3], ostNum b[3], int* iters) {
  ostGjkPoint P[OST_EPA_VERT];
  ostEpaFace F[OST_EPA_FACE];
  ostNum lam[4], vv;
  int np, nf = 0, it = 0;
  if (iters) {
    *iters = 0;
  }
  if (osti_gjkSimplex(g1, g2, P, &np, lam, &vv) || !osti_epaStart(P, np, g1, g2)) {
    return 0;  // separated, or touching (the origin on one support point), or K flat
  }
  np = 4;

  // the tetrahedron's faces, each wound so that its normal points away from the fourth vertex
  // (the origin lies inside, so every plane distance is >= 0 up to round-off)
  const int tet[4][4] = {{0, 1, 2, 3}, {0, 3, 1, 2}, {0, 2, 3, 1}, {1, 3, 2, 0}};
  for (int t = 0; t < 4; t++) {
    int i = tet[t][0], j = tet[t][1], k = tet[t][2], o = tet[t][3];
    if (!osti_epaFace(F + nf, P, i, j, k)) {
      return 0;
    }
    ostNum side[3];
    osti_cvxSub(side, P[o].w, P[i].w);
    if (osti_cvxDot(side, F[nf].n) > 0) {
      osti_epaFace(F + nf, P, i, k, j);
    }
    nf++;
  }
  // the size that scales the tolerances: the largest vertex of the tetrahedron
  ostNum scale = 0;
  for (int i = 0; i < 4; i++) {
    ostNum r = sqrt(osti_cvxDot(P[i].w, P[i].w));
    scale = r > scale ? r : scale;
  }

  int best = 0, converged = 0;
  ostNum upper = HUGE_VAL;  // least support value h(n) seen: an upper bound of the depth
  for (;;) {
    // the face nearest the origin: its plane distance is a lower bound of the depth
    best = 0;
    for (int f = 1; f < nf; f++) {
      best = F[f].d < F[best].d ? f : best;
    }
    const ostEpaFace* fb = F + best;
    if (np == OST_EPA_VERT) {
      break;
    }

    // support point of K along the face's normal: the depth lies in [fb->d, w.n]
    ostGjkPoint* p = P + np;
    osti_epaSupport(p, g1, g2, fb->n);
    it++;
    ostNum h = osti_cvxDot(p->w, fb->n);
    upper = h < upper ? h : upper;
    if (h - fb->d <= OST_EPA_REL * scale) {
      converged = 1;
      break;  // converged: no point of K beyond the face's plane by more than the tolerance
    }
    if (it == OST_EPA_POLISH_AT && osti_epaPolished(g1, g2, fb, scale, depth, n, a, b)) {
      if (iters) {
        *iters = it;
      }
      return 1;  // two curved surfaces: Newton finishes faster than the polytope
    }

    // expand: remove the faces p sees, keep their horizon edges (an edge of a removed face
    // whose twin belongs to a kept face), and close the hole with triangles to p
    int hor[OST_EPA_HORIZON][2], nh = 0, nkeep = 0, ok = 1;
    int visible[OST_EPA_FACE];
    for (int f = 0; f < nf; f++) {
      ostNum s[3];
      osti_cvxSub(s, p->w, P[F[f].v[0]].w);
      visible[f] = f == best || osti_cvxDot(s, F[f].n) > 0;
    }
    for (int f = 0; f < nf && ok; f++) {
      if (!visible[f]) {
        continue;
      }
      for (int e = 0; e < 3; e++) {
        int i = F[f].v[e], j = F[f].v[(e + 1) % 3], twin_visible = 0;
        for (int g = 0; g < nf; g++) {
          if (g == f || !visible[g]) {
            continue;
          }
          for (int q = 0; q < 3; q++) {
            twin_visible |= F[g].v[q] == j && F[g].v[(q + 1) % 3] == i;
          }
        }
        if (!twin_visible) {
          if (nh == OST_EPA_HORIZON) {
            ok = 0;
            break;
          }
          hor[nh][0] = i;
          hor[nh][1] = j;
          nh++;
        }
      }
    }
    // the new triangles first: a degenerate one (p on a horizon edge's line, to round-off) or
    // no room ends the expansion with the polytope as it was, its bounds still valid
    ostEpaFace fresh[OST_EPA_HORIZON];
    for (int e = 0; e < nh && ok; e++) {
      ok = osti_epaFace(fresh + e, P, hor[e][0], hor[e][1], np);
    }
    for (int f = 0; f < nf; f++) {
      nkeep += !visible[f];
    }
    if (!ok || nkeep + nh > OST_EPA_FACE) {
      break;
    }
    nkeep = 0;
    for (int f = 0; f < nf; f++) {
      if (!visible[f]) {
        F[nkeep++] = F[f];
      }
    }
    for (int e = 0; e < nh; e++) {
      F[nkeep + e] = fresh[e];
    }
    np++;
    nf = nkeep + nh;
  }
  if (nf == 0 || it == 0) {
    return 0;
  }
  best = 0;
  for (int f = 1; f < nf; f++) {
    best = F[f].d < F[best].d ? f : best;
  }
  if (iters) {
    *iters = it;
  }
  if (!(F[best].d >= -OST_EPA_REL * scale)) {
    return 0;  // round-off put the origin outside the polytope
  }
  if (!converged) {
    if (osti_epaPolished(g1, g2, F + best, scale, depth, n, a, b)) {
      return 1;
    }
    if (!(upper - F[best].d <= OST_EPA_ACCEPT * scale)) {
      return 0;  // neither certified
    }
  }
  // the polytope's surface point nearest the origin: in the nearest face's plane, but flat
  // parts of K (a box's face, a capsule's side) hold several coplanar triangles whose plane
  // distances tie to round-off, and the point lies in one of them: the nearest of their
  // triangles decides
  ostNum v[3] = {0, 0, 0}, len = HUGE_VAL;
  int fin = -1;
  for (int f = 0; f < nf; f++) {
    if (F[f].d <= F[best].d + OST_EPA_ACCEPT * scale) {
      ostNum vf[3], af[3], bf[3];
      int inside;
      ostNum lf = osti_epaWitness(F + f, P, vf, af, bf, &inside);
      if (lf < len) {
        len = lf;
        fin = inside ? f : -1;
        for (int c = 0; c < 3; c++) {
          v[c] = vf[c];
          a[c] = af[c];
          b[c] = bf[c];
        }
      }
    }
  }
  if (fin >= 0) {
    *depth = F[fin].d > 0 ? F[fin].d : 0;
    for (int c = 0; c < 3; c++) {
      n[c] = F[fin].n[c];
    }
    return converged ? 1 : 2;
  }
  if (!(len > OST_MINVAL) || !(len <= upper + OST_EPA_ACCEPT * scale)) {
    return 0;  // the origin on the polytope's surface (touching: normal undefined), or no face
  }
  *depth = len;
  for (int c = 0; c < 3; c++) {
    n[c] = v[c] / len;
  }
  return converged ? 1 : 2;
}


// radius of the ball a geom is the Minkowski sum of (sphere: a point, capsule: a segment), or 0
OST_HD ostNum osti_epaBall(const ostGeom* g) {
  return g->type == OST_GEOM_SPHERE || g->type == OST_GEOM_CAPSULE ? g->size[0] : 0;
}


// penetration of overlapping geoms g1 and g2 (margin 0): returns 1 with the depth (>= 0), the
// unit normal n from g1 to g2 and the witness points a (on g1) and b (on g2), a - b = depth n,
// the depth certified to OST_EPA_REL of the size; 2 with the same outputs where the polytope
// stopped at capacity with bounds within OST_EPA_ACCEPT (curved surfaces whose supports jump:
// cylinders; witnesses located to about 1e-4 of the size); 0 if the geoms are separated or EPA
// cannot bound the depth (the origin on the GJK simplex: touching; a degenerate polytope).
// Spheres and capsules are a point or segment plus a ball of radius r: while their cores stay
// apart, depth = r1 + r2 - |core distance| from GJK (exact, and no polytope has to approximate
// the ball's curvature, where EPA converges slowly). *iters (optional): support evaluations of
// the polytope (0 for the cores' route).
OST_HD int osti_epaPenetration(const ostGeom* g1, const ostGeom* g2, ostNum* depth,
                               ostNum n[3], ostNum a[3], ostNum b[3], int* iters) {
  ostNum r1 = osti_epaBall(g1), r2 = osti_epaBall(g2);
  if (r1 + r2 > 0) {
    ostGeom c1 = *g1, c2 = *g2;
    ostNum dist, pa[3], pb[3];
    c1.size[0] = r1 > 0 ? 0 : c1.size[0];
    c2.size[0] = r2 > 0 ? 0 : c2.size[0];
    if (osti_gjkDistance(&c1, &c2, &dist, pa, pb) && dist > 0) {
      if (iters) {
        *iters = 0;
      }
      if (!(dist < r1 + r2)) {
        return 0;  // separated
      }
      *depth = r1 + r2 - dist;
      for (int c = 0; c < 3; c++) {
        n[c] = (pb[c] - pa[c]) / dist;
        a[c] = pa[c] + r1 * n[c];
        b[c] = pb[c] - r2 * n[c];
      }
      return 1;
    }
  }
  return osti_epaPolytope(g1, g2, depth, n, a, b, iters);
}

#ifdef __cplusplus
}
#endif

#endif  // OSTRICH_CORE_OST_COLLISION_EPA_H_
