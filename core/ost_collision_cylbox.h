// ost_collision_cylbox.h: Ostrich's own cylinder : box contacts (both geometry providers use it;
// MuJoCo 2.2.2 finds this pair with one MPR contact, which wanders along a wheel's bottom line
// and whose normal is inexact under penetration, so Newton stalls at a wheel-edge contact).
// Method, in the box frame (box centred at 0, half sizes e; cylinder centre c, unit axis a,
// radius r, half length hl). The cylinder is seen through its two halves: for each rim (centre
// C = c +- hl a) a separating axis test of the half cylinder between c and C (centre H, half
// length hl/2) picks one feature,
//   sep(n) = min_half(n) - max_box(n),   max_box(n) = sum_k e_k |n_k|,
//   min_half(n) = n.H - hl/2 |n.a| - r sqrt(1 - (n.a)^2),
// over the 3 face normals facing C and, for each edge direction, the edge nearest C with
// n = (Ci - q)/|Ci - q|, Ci = C moved OST_CYLBOX_INSET x hl inwards along the axis and q its
// projection on the edge, clamped to the edge (so an edge parallel to the axis beats the
// vertex at its end when a rim is flush with a side face). A face
// keeps ties (an edge must separate more by OST_CYLBOX_TIE). The rim's contact:
//   - face: the rim's deepest point p along -n; dist = n.p - e_k, its height over the face;
//     contact point midway, clamped onto the face's rectangle. When p is not over the face's
//     rectangle, the deepest rim point that is (osti_cylboxFacePoint), or the best edge axis
//     when none is. When the rim faces the face
//     (n within 3 degrees of the axis), four points of the rim instead.
//   - edge: the edge point at the rim's end (or nearest the axis, osti_cylboxEdgeDeepest)
//     against the cylinder: the exact point-cylinder signed distance (curved surface, cap or rim circle),
//     its gradient as the normal.
// So a wheel on a face has two contacts (the ends of its bottom line), on an edge two contacts
// whose normals are the wheel's own surface normals (smooth in yaw and roll), and at a tie
// (a rim right above an edge, or a rim flush with a side face) both features give the same
// point, distance and normal: the contacts are continuous in the poses. Edge points that both
// rims project to the same place (an edge across the axis) give one contact.
// Invariant: at most 8 contacts, all with dist < margin, normals from the cylinder (geom1, lower
// type) to the box, frames completed as MuJoCo's driver does (osti_makeFrame, no tangent hint).
#ifndef OSTRICH_CORE_OST_COLLISION_CYLBOX_H_
#define OSTRICH_CORE_OST_COLLISION_CYLBOX_H_

#include <math.h>

#include "ost_collision_boxbox.h"
#include "ost_collision_primitive.h"
#include "ost_geom.h"
#include "ost_hd.h"

#ifdef __cplusplus
extern "C" {
#endif

#define OST_CYLBOX_CAP_SIN 0.05  // rim direction |w| below this: the cap faces the box (~3 deg)
#define OST_CYLBOX_TIE 1e-9     // an edge axis beats a face axis by more than this (x (r+hl))
#define OST_CYLBOX_INSET 0.01    // edge points: projections of axis points this fraction of hl
                                 // inside the rims

// the box's support value along n: max over the box of n.x = sum_k e_k |n_k|
OST_HD ostNum osti_cylboxMaxBox(const ostNum e[3], const ostNum n[3]) {
  return e[0] * fabs(n[0]) + e[1] * fabs(n[1]) + e[2] * fabs(n[2]);
}


// distance from a box point p (on an edge) to the cylinder and its unit normal n (outward from
// the cylinder towards p), z = a.(p - c), rho = (p - c) - a z:
//   |z| <= hl: curved surface, |rho| - r, n = rho/|rho| (also inside: an edge meets the curved
//              surface; a box point through a cap is a face or cap contact, found by those axes)
//   |z| >  hl: rim circle |p - rim point| when |rho| > r, else cap |z| - hl, n = +-a
// continuous across |z| = hl outside the radius; the edge points are inset from the rims
// (OST_CYLBOX_INSET) so that a wheel's edge contacts stay on the curved branch
OST_HD ostNum osti_cylboxPointDist(const ostNum c[3], const ostNum a[3], ostNum r, ostNum hl,
                                   const ostNum p[3], ostNum n[3]) {
  ostNum d[3] = {p[0] - c[0], p[1] - c[1], p[2] - c[2]};
  ostNum z = osti_primDot(a, d), side = z < 0 ? -1 : 1, az = fabs(z);
  ostNum rho[3] = {d[0] - z * a[0], d[1] - z * a[1], d[2] - z * a[2]};
  ostNum lr = osti_primNormalize(rho);  // rho is now the unit radial direction
  int radial_ok = lr > 1e-12;
  if (az <= hl && radial_ok) {
    n[0] = rho[0]; n[1] = rho[1]; n[2] = rho[2];
    return lr - r;
  }
  if (az > hl && lr > r && radial_ok) {
    for (int i = 0; i < 3; i++) {
      n[i] = p[i] - (c[i] + side * hl * a[i] + r * rho[i]);
    }
    return osti_primNormalize(n);
  }
  n[0] = side * a[0]; n[1] = side * a[1]; n[2] = side * a[2];
  return az - hl;
}


// the face k (normal n = +-e_k) as the rim's feature. The face branch below puts the contact at
// the rim's deepest point along -n, P(0), with the rim P(th) = C + r (cos th w + sin th v),
// w = -(n - a (a.n)) / |.| (unit, n.P(th) = n.C - r |n - a (a.n)| cos th), v = a x w. That point
// must lie over the face's rectangle (|P_i| <= e_i, i != k): a rim beside the box whose tilted
// edge dips below the face's plane outside the face (a wheel rolled by a step, its inner rim next
// to the box's side face) otherwise reads as a penetration of several cm while it is centimetres
// away (and the face beat the edge axes, a vertex at its exact distance, by a hair, switching the
// contact between +2 cm and -3 cm from one Newton iterate to the next). So the point is the
// deepest rim point over the rectangle: P(0) when it is there, else the rim's crossing of a
// side plane x_i = +-e_i of the rectangle nearest th = 0 (over the rectangle), so that the
// distance is continuous as the deepest point leaves the face. The rectangle is grown by tol
// (the caller: OST_CYLBOX_INSET (r + hl)), so that a rim flush with a side face (a wheel on the
// pallet, its outer rim at the pallet's side) keeps P(0) under rounding and finite-difference
// perturbations (ost_transition vs mjd_transitionFD). Writes it to p and returns how
// much shallower it is than P(0), r |n - a (a.n)| (1 - cos th) >= 0 (0: P(0), the separating
// axis value), or -1 when no rim point is over the rectangle (the face is no feature). When the
// rim faces the face (|w| <= OST_CYLBOX_CAP_SIN: four rim points) the rim's disk must come within
// tol of the rectangle; returns 0 then.
OST_HD ostNum osti_cylboxFacePoint(const ostNum e[3], const ostNum C[3], const ostNum a[3],
                                   ostNum r, int k, const ostNum n[3], ostNum tol, ostNum p[3]) {
  ostNum na = osti_primDot(n, a);
  ostNum w[3] = {-(n[0] - na * a[0]), -(n[1] - na * a[1]), -(n[2] - na * a[2])};
  ostNum lw = osti_primNormalize(w);
  if (!(lw > OST_CYLBOX_CAP_SIN)) {
    ostNum out2 = 0;
    for (int i = 0; i < 3; i++) {
      ostNum o = fabs(C[i]) - e[i];
      out2 += i != k && o > 0 ? o * o : 0 * o;
    }
    return out2 <= (r + tol) * (r + tol) ? 0 * r : -1 + 0 * r;
  }
  ostNum v[3] = {a[1] * w[2] - a[2] * w[1], a[2] * w[0] - a[0] * w[2], a[0] * w[1] - a[1] * w[0]};
  ostNum best_cos = -2;
  // candidates: th = 0, then th = phi +- acos(rhs) on the planes x_i = +-e_i, i != k
  for (int cand = 0; cand < 9; cand++) {
    ostNum cs = 1, sn = 0;
    if (cand > 0) {
      int i = (cand - 1) / 4, side = ((cand - 1) / 2) % 2, pm = (cand - 1) % 2;
      i = i < k ? i : i + 1;  // the two lateral axes of face k
      ostNum A = w[i], B = v[i], R = sqrt(A * A + B * B);
      if (!(R > 1e-12)) {
        continue;  // the rim's plane parallel to the side plane: no crossing
      }
      ostNum rhs = ((side ? e[i] + tol : -e[i] - tol) - C[i]) / (r * R);
      if (!(fabs(rhs) <= 1)) {
        continue;
      }
      // cos(th - phi) = rhs, (cos phi, sin phi) = (A, B) / R
      ostNum ca = rhs, sa = (pm ? -1 : 1) * sqrt(1 - rhs * rhs);
      cs = (A * ca - B * sa) / R;
      sn = (B * ca + A * sa) / R;
    }
    if (!(cs > best_cos)) {
      continue;
    }
    ostNum P[3];
    int over = 1;
    for (int j = 0; j < 3; j++) {
      P[j] = C[j] + r * (cs * w[j] + sn * v[j]);
      over &= j == k || fabs(P[j]) <= (e[j] + tol) * (1 + 1e-12);
    }
    if (over) {
      best_cos = cs;
      p[0] = P[0];
      p[1] = P[1];
      p[2] = P[2];
    }
    if (cand == 0 && over) {
      return 0 * r;  // the deepest point is over the face: the separating axis value
    }
  }
  return best_cos < -1 ? -1 + 0 * r : r * lw * (1 - best_cos);
}


// the contact point of an edge (box axis j, through q, |s| <= ej) with the half cylinder whose
// axial coordinates z = a.(x - c) run from 0 to zt (the rim's end, inset): the edge point nearest
// the axis, s* (rho(s)^2 = |p0 + s e_j|^2 - z(s)^2 with p0 = q - c, q_j = 0, z(s) = a.p0 + s a_j,
// a convex quadratic), when its z lies inside the half, else the edge point at the rim's end,
// z(s) = zt. The point nearest Ci (the separating axis above) is axially off by a_k (q_k - c_k)
// when the wheel is rolled or yawed against an edge nearly parallel to its axis (a wheel climbing
// a step at an angle: 5 cm for a 9 degree roll), beyond the rim: one rim's contact went to the
// cap or was lost, and the edge, running deeper into the wheel towards that rim, sank 5 mm into
// it unseen until the wheel left the edge. Both rims' ends are the ends of the edge's line of
// contact, where it is deepest (rho is linear along a nearly parallel edge); s* inside a half is
// the deepest point of an oblique edge (an edge across the axis: both halves find the same s*).
// Continuous in the pose, except that s* crossing the wheel's middle plane (where both rim ends
// are equally deep) swaps which rim end is reported. Returns s.
OST_HD ostNum osti_cylboxEdgeDeepest(const ostNum c[3], const ostNum a[3], const ostNum q[3],
                                     int j, ostNum ej, ostNum zt) {
  ostNum p0[3] = {q[0] - c[0], q[1] - c[1], q[2] - c[2]};
  p0[j] = -c[j];
  ostNum ap = osti_primDot(a, p0), aj = a[j], den = 1 - aj * aj;
  ostNum s = (zt - ap) / aj;  // the rim's end (aj = 0 only with den = 1 below)
  if (den > 1e-12) {
    ostNum ss = (aj * ap - p0[j]) / den, u = (ap + ss * aj) / zt;  // s*, its fraction of the half
    if ((u > 0 && u < 1) || !(fabs(aj) > 1e-12)) {
      s = ss;
    }
  }
  return s < -ej ? -ej : (s > ej ? ej : s);
}


// one contact: box point q (box frame) at signed distance dist from the cylinder, with the
// cylinder's outward normal n there (box frame); pos midway, normal cylinder -> box (world)
OST_HD void osti_cylboxPointContact(ostContact* con, const ostGeom* box, const ostNum q[3],
                                    ostNum dist, const ostNum n[3]) {
  ostNum pl[3], pw[3], nw[3];
  osti_primAxpy(pl, q, dist / 2, n);
  osti_boxMulMatVec(pw, box->mat, pl);
  osti_primAxpy(pw, pw, 1, box->pos);
  osti_boxMulMatVec(nw, box->mat, n);
  osti_primSetContact(con, dist, pw, nw, 0);
}


// the contacts of the rim at axis offset t (= +-hl) of the cylinder (c, a, r, hl) with the box
// of half sizes e (box frame); box: the box geom (pose for world output); returns the count
OST_HD int osti_cylboxRim(ostContact* con, const ostGeom* box, const ostNum c[3],
                          const ostNum a[3], ostNum r, ostNum hl, ostNum t, ostNum margin) {
  const ostNum* e = box->size;
  ostNum C[3] = {c[0] + t * a[0], c[1] + t * a[1], c[2] + t * a[2]};
  ostNum H[3] = {c[0] + t / 2 * a[0], c[1] + t / 2 * a[1], c[2] + t / 2 * a[2]};  // half's centre

  // separating axes of the rim's disk: faces (k = 0..2), nearest edges (k = 3..5)
  ostNum best[3] = {0, 0, 0}, best_sep = 0, best_q[3] = {0, 0, 0};
  int best_k = -1, edge_k = -1;  // the best axis, the best edge axis
  ostNum edge_sep = 0, edge_q[3] = {0, 0, 0};
  for (int k = 0; k < 6; k++) {
    ostNum n[3] = {0, 0, 0}, q[3] = {0, 0, 0};
    if (k < 3) {
      n[k] = C[k] < 0 ? -1 : 1;
    } else {
      // the edge along axis j nearest C; q the projection of the rim's centre moved inwards
      // along the axis (Ci), n from q to Ci
      int j = k - 3;
      ostNum Ci[3];
      osti_primAxpy(Ci, c, (1 - OST_CYLBOX_INSET) * t, a);
      for (int i = 0; i < 3; i++) {
        q[i] = C[i] < 0 ? -e[i] : e[i];
      }
      q[j] = Ci[j] < -e[j] ? -e[j] : (Ci[j] > e[j] ? e[j] : Ci[j]);
      for (int i = 0; i < 3; i++) {
        n[i] = Ci[i] - q[i];
      }
      if (osti_primNormalize(n) < 1e-12) {
        continue;  // the rim's centre on the edge: no direction
      }
      q[j] = osti_cylboxEdgeDeepest(c, a, q, j, e[j], (1 - OST_CYLBOX_INSET) * t);
    }
    ostNum na = osti_primDot(n, a), s2 = 1 - na * na;
    ostNum sep = osti_primDot(n, H) - hl / 2 * fabs(na) - (s2 > 1e-30 ? r * sqrt(s2) : 0 * s2)
                 - osti_cylboxMaxBox(e, n);
    ostNum tie = k < 3 ? 0 * r : OST_CYLBOX_TIE * (r + hl);
    if (k >= 3 && (edge_k < 0 || sep > edge_sep + tie)) {
      edge_sep = sep;
      edge_k = k;
      for (int i = 0; i < 3; i++) {
        edge_q[i] = q[i];
      }
    }
    if (best_k < 0 || sep > best_sep + tie) {
      best_sep = sep;
      best_k = k;
      for (int i = 0; i < 3; i++) {
        best[i] = n[i];
        best_q[i] = k < 3 ? 0 * r : q[i];
      }
    }
  }
  if (best_k < 0 || best_sep > margin) {
    return 0;
  }

  // face whose rim point is not over the face (osti_cylboxFacePoint): the deepest rim point over
  // it, or, when none is, the best edge axis
  ostNum pface[3] = {0, 0, 0};
  if (best_k < 3 && osti_cylboxFacePoint(e, C, a, r, best_k, best,
                                            OST_CYLBOX_INSET * (r + hl), pface) < 0) {
    if (edge_k < 0 || edge_sep > margin) {
      return 0;
    }
    best_k = edge_k;
    for (int i = 0; i < 3; i++) {
      best_q[i] = edge_q[i];
    }
  }

  // edge: the edge point against the cylinder
  if (best_k >= 3) {
    ostNum nq[3];
    ostNum dist = osti_cylboxPointDist(c, a, r, hl, best_q, nq);
    if (!(dist < margin)) {
      return 0;
    }
    osti_cylboxPointContact(con, box, best_q, dist, nq);
    return 1;
  }

  // face: the rim's deepest point along -n, or four rim points when the rim faces the face;
  // rim directions w = -(n - a (a.n))
  ostNum na = osti_primDot(best, a);
  ostNum w[3] = {-(best[0] - na * a[0]), -(best[1] - na * a[1]), -(best[2] - na * a[2])};
  ostNum pts[4][3];
  int npt = 1;
  if (osti_primNormalize(w) > OST_CYLBOX_CAP_SIN) {
    pts[0][0] = pface[0];  // osti_cylboxFacePoint's point
    pts[0][1] = pface[1];
    pts[0][2] = pface[2];
  } else {
    // along the box axis most normal to a and its cross product with a
    int j = 0;
    for (int i = 1; i < 3; i++) {
      j = fabs(a[i]) < fabs(a[j]) ? i : j;
    }
    ostNum u[3] = {-a[j] * a[0], -a[j] * a[1], -a[j] * a[2]};
    u[j] += 1;
    osti_primNormalize(u);
    ostNum v[3] = {a[1] * u[2] - a[2] * u[1], a[2] * u[0] - a[0] * u[2], a[0] * u[1] - a[1] * u[0]};
    for (int q = 0; q < 4; q++) {
      osti_primAxpy(pts[q], C, (q % 2 ? -1 : 1) * r, q < 2 ? u : v);
    }
    npt = 4;
  }
  ostNum nw[3];
  osti_boxMulMatVec(nw, box->mat, best);
  ostNum normal[3] = {-nw[0], -nw[1], -nw[2]};  // cylinder -> box
  int ncon = 0;
  for (int q = 0; q < npt; q++) {
    ostNum dist = osti_primDot(best, pts[q]) - e[best_k];
    if (!(dist < margin)) {
      continue;
    }
    ostNum pl[3], pw[3];
    osti_primAxpy(pl, pts[q], -dist / 2, best);
    for (int i = 0; i < 3; i++) {
      if (i != best_k) {
        pl[i] = pl[i] < -e[i] ? -e[i] : (pl[i] > e[i] ? e[i] : pl[i]);
      }
    }
    osti_boxMulMatVec(pw, box->mat, pl);
    osti_primAxpy(pw, pw, 1, box->pos);
    osti_primSetContact(con + ncon, dist, pw, normal, 0);
    ncon++;
  }
  return ncon;
}


// cylinder g1 : box g2: the contacts of both rims; an edge point that both rims find (an edge
// across the axis) is kept once
OST_HD int osti_collideCylinderBox(ostContact* con, const ostGeom* g1, const ostGeom* g2,
                                   ostNum margin) {
  // cylinder centre and axis (the geom's z axis) in the box frame
  ostNum dif[3] = {g1->pos[0] - g2->pos[0], g1->pos[1] - g2->pos[1], g1->pos[2] - g2->pos[2]};
  ostNum zw[3] = {g1->mat[2], g1->mat[5], g1->mat[8]};
  ostNum c[3], a[3];
  osti_boxMulMatTVec(c, g2->mat, dif);
  osti_boxMulMatTVec(a, g2->mat, zw);
  ostNum r = g1->size[0], hl = g1->size[1];
  int n = osti_cylboxRim(con, g2, c, a, r, hl, -hl, margin);
  int m = osti_cylboxRim(con + n, g2, c, a, r, hl, hl, margin);
  if (n == 1 && m == 1) {
    ostNum d0 = con[0].pos[0] - con[1].pos[0], d1 = con[0].pos[1] - con[1].pos[1];
    ostNum d2 = con[0].pos[2] - con[1].pos[2];
    if (d0 * d0 + d1 * d1 + d2 * d2 < 1e-24 && fabs(con[0].dist - con[1].dist) < 1e-12) {
      m = 0;  // the same edge point from both rims
    }
  }
  return n + m;
}

#ifdef __cplusplus
}
#endif

#endif  // OSTRICH_CORE_OST_COLLISION_CYLBOX_H_
