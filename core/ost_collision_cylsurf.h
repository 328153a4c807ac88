// ost_collision_cylsurf.h: Ostrich's own cylinder : terrain contacts, for a height field and a
// terrain mesh alike (both providers use it; MuJoCo 2.2.2 collides a cylinder with one prism per
// triangle through MPR, which gives many nearly redundant contacts whose normals jump, so Newton
// does not converge on a wheel rolling over a terrain).
// Method, in the terrain frame (z up), streaming over the candidate triangles: the cylinder
// (centre c, unit axis a, radius r, half length hl) is seen through its two halves, each from c
// to its rim centre C = c +- hl a. For each half:
//   - face of a triangle (unit normal n, n_z > 0): the rim's deepest point p along -n
//     (p = C + r w, w the unit part of -n normal to a; four rim points when the rim faces the
//     triangle, n within 3 degrees of a), valid when p's projection on the triangle's plane lies
//     in the triangle; dist = n.(p - v0), its height over the plane. Every valid face is a
//     contact (a valley gives one per side).
//   - edge of a triangle, used only when no face of this half is valid (the half rests on a
//     ridge): q, the edge point nearest the rim's deepest point along -n (the face's witness),
//     moved OST_CYLBOX_INSET x hl inwards, against the cylinder by the exact point-cylinder distance (curved surface, rim circle or
//     cap) and its gradient as the normal, accepted when that points out of its triangle (above
//     the plane and beyond that edge); the half keeps its smallest one. (As for boxes: a wheel
//     on a ridge keeps two contacts whatever its yaw.)
// At a face's boundary its witness lies on the edge, where the edge candidate gives the same
// point and (for an edge parallel to the axis, and at contact in general) the same distance, and a
// coplanar neighbour's face takes over at the same point: the contacts are continuous in the pose.
// Invariant: contacts have dist < margin, normals from the terrain (geom1) to the
// cylinder, pos midway between the surfaces, in the terrain frame until osti_cylSurfFinish.
#ifndef OSTRICH_CORE_OST_COLLISION_CYLSURF_H_
#define OSTRICH_CORE_OST_COLLISION_CYLSURF_H_

#include <math.h>

#include "ost_collision_cylbox.h"
#include "ost_collision_primitive.h"
#include "ost_geom.h"
#include "ost_hd.h"

#ifdef __cplusplus
extern "C" {
#endif

#define OST_CYLSURF_CAP_SIN 0.05  // rim direction |w| below this: the rim faces the triangle

typedef struct ostCylSurf_ {  // a cylinder against a stream of terrain triangles
  ostNum c[3], a[3];          // centre and unit axis in the terrain frame
  ostNum r, hl, margin;       // radius, half length, detection margin
  int    nface[2];            // face contacts of each half so far
  int    has_edge[2];         // 1 if the half has an edge candidate
  ostNum edge_dist[2];        // its distance
  ostNum edge_q[2][3];        // its terrain point
  ostNum edge_n[2][3];        // its normal (terrain -> cylinder)
} ostCylSurf;


// start: the cylinder geom loc already in the terrain frame (osti_terrainLocal)
OST_HD void osti_cylSurfInit(ostCylSurf* s, const ostGeom* loc, ostNum margin) {
  for (int i = 0; i < 3; i++) {
    s->c[i] = loc->pos[i];
    s->a[i] = loc->mat[3 * i + 2];
  }
  s->r = loc->size[0];
  s->hl = loc->size[1];
  s->margin = margin;
  for (int h = 0; h < 2; h++) {
    s->nface[h] = 0;
    s->has_edge[h] = 0;
    s->edge_dist[h] = 0 * margin;
    for (int k = 0; k < 3; k++) {
      s->edge_q[h][k] = 0 * margin;
      s->edge_n[h][k] = 0 * margin;
    }
  }
}


// 1 if x (in the plane of triangle v0 v1 v2 with normal n) lies in the triangle, edges included;
// either vertex order (x is inside when it is on the same side of all three edges)
OST_HD int osti_cylSurfInside(const ostNum* v[3], const ostNum n[3], const ostNum x[3]) {
  int pos = 0, neg = 0;
  for (int i = 0; i < 3; i++) {
    const ostNum* p = v[i];
    const ostNum* q = v[(i + 1) % 3];
    ostNum e[3] = {q[0] - p[0], q[1] - p[1], q[2] - p[2]};
    ostNum d[3] = {x[0] - p[0], x[1] - p[1], x[2] - p[2]};
    ostNum cr[3] = {e[1] * d[2] - e[2] * d[1], e[2] * d[0] - e[0] * d[2], e[0] * d[1] - e[1] * d[0]};
    ostNum side = osti_primDot(cr, n);
    pos += side > 0;
    neg += side < 0;
  }
  return pos == 0 || neg == 0;
}


// the point of segment p0..p1 nearest x (x's projection on the line, clamped to the segment)
OST_HD void osti_cylSurfProject(ostNum q[3], const ostNum p0[3], const ostNum p1[3],
                                const ostNum x[3]) {
  ostNum d[3] = {p1[0] - p0[0], p1[1] - p0[1], p1[2] - p0[2]};
  ostNum rx[3] = {x[0] - p0[0], x[1] - p0[1], x[2] - p0[2]};
  ostNum dd = osti_primDot(d, d), s = dd > 0 ? osti_primDot(rx, d) / dd : 0 * dd;
  s = s < 0 ? 0 * s : (s > 1 ? 0 * s + 1 : s);
  osti_primAxpy(q, p0, s, d);
}


// one contact in the terrain frame: dist, point midway, normal n (terrain -> cylinder)
OST_HD void osti_cylSurfContact(ostContact* con, ostNum dist, const ostNum pos[3],
                                const ostNum n[3]) {
  con->dist = dist;
  for (int i = 0; i < 3; i++) {
    con->pos[i] = pos[i];
    con->frame[i] = n[i];
    con->frame[3 + i] = 0 * dist;
    con->frame[6 + i] = 0 * dist;
  }
}


// one triangle (vertices in the terrain frame): face contacts go to con[n..), at most nmax in
// all; edge candidates are kept in s. Returns the new count.
OST_HD int osti_cylSurfTriangle(ostCylSurf* s, const ostNum v0[3], const ostNum v1[3],
                                const ostNum v2[3], ostContact* con, int n, int nmax) {
  const ostNum* v[3] = {v0, v1, v2};
  ostNum e1[3] = {v1[0] - v0[0], v1[1] - v0[1], v1[2] - v0[2]};
  ostNum e2[3] = {v2[0] - v0[0], v2[1] - v0[1], v2[2] - v0[2]};
  ostNum nt[3] = {e1[1] * e2[2] - e1[2] * e2[1], e1[2] * e2[0] - e1[0] * e2[2],
                  e1[0] * e2[1] - e1[1] * e2[0]};
  if (nt[2] < 0) {
    nt[0] = -nt[0]; nt[1] = -nt[1]; nt[2] = -nt[2];
  }
  if (osti_primNormalize(nt) < OST_MINVAL || !(nt[2] > 0)) {
    return n;  // degenerate or vertical: its neighbours carry the surface
  }
  ostNum na = osti_primDot(nt, s->a);
  ostNum w[3] = {-(nt[0] - na * s->a[0]), -(nt[1] - na * s->a[1]), -(nt[2] - na * s->a[2])};
  ostNum lw = osti_primNormalize(w);
  for (int h = 0; h < 2; h++) {
    ostNum t = h ? s->hl : -s->hl;
    ostNum C[3];
    osti_primAxpy(C, s->c, t, s->a);

    // face: the rim's deepest point(s) along -n, valid over the triangle
    ostNum pts[4][3];
    int npt = 1;
    if (lw > OST_CYLSURF_CAP_SIN) {
      osti_primAxpy(pts[0], C, s->r, w);
    } else {
      // the rim faces the triangle: four rim points along a horizontal direction normal to a
      ostNum u[3] = {-s->a[1], s->a[0], 0 * na};
      if (osti_primNormalize(u) < 1e-6) {
        u[0] = 1; u[1] = 0; u[2] = 0;
      }
      ostNum vv[3] = {s->a[1] * u[2] - s->a[2] * u[1], s->a[2] * u[0] - s->a[0] * u[2],
                      s->a[0] * u[1] - s->a[1] * u[0]};
      for (int q = 0; q < 4; q++) {
        osti_primAxpy(pts[q], C, (q % 2 ? -1 : 1) * s->r, q < 2 ? u : vv);
      }
      npt = 4;
    }
    for (int q = 0; q < npt && n < nmax; q++) {
      ostNum dv[3] = {pts[q][0] - v0[0], pts[q][1] - v0[1], pts[q][2] - v0[2]};
      ostNum dist = osti_primDot(nt, dv);
      ostNum x[3];
      osti_primAxpy(x, pts[q], -dist, nt);
      if (dist < s->margin && osti_cylSurfInside(v, nt, x)) {
        ostNum pos[3];
        osti_primAxpy(pos, pts[q], -dist / 2, nt);
        osti_cylSurfContact(con + n, dist, pos, nt);
        n++;
        s->nface[h]++;
      }
    }

    // edges: the edge point nearest Ci (the rim's deepest point along -n, moved OST_CYLBOX_INSET
    // x hl inwards so that an edge parallel to the axis stays on the curved surface) against the
    // cylinder by the exact point-cylinder distance; where the face's witness reaches the edge
    // this is that witness, so face and edge contacts meet; the normal must point out of this
    // triangle
    ostNum Ci[3];
    osti_primAxpy(Ci, s->c, (1 - OST_CYLBOX_INSET) * t, s->a);
    if (lw > OST_CYLSURF_CAP_SIN) {
      osti_primAxpy(Ci, Ci, s->r, w);  // the rim's deepest point, inset: the face's witness
    }
    for (int i = 0; i < 3 && s->nface[h] == 0; i++) {
      const ostNum* p = v[i];
      const ostNum* q = v[(i + 1) % 3];
      const ostNum* o = v[(i + 2) % 3];
      ostNum qe[3], d[3];
      osti_cylSurfProject(qe, p, q, Ci);
      ostNum dist = osti_cylboxPointDist(s->c, s->a, s->r, s->hl, qe, d);
      d[0] = -d[0]; d[1] = -d[1]; d[2] = -d[2];  // terrain -> cylinder
      if (osti_primDot(d, nt) < 0) {
        continue;  // the cylinder below the triangle's plane
      }
      // beyond the edge: away from the opposite vertex, within the triangle's plane
      ostNum ed[3] = {q[0] - p[0], q[1] - p[1], q[2] - p[2]};
      ostNum m[3] = {ed[1] * nt[2] - ed[2] * nt[1], ed[2] * nt[0] - ed[0] * nt[2],
                     ed[0] * nt[1] - ed[1] * nt[0]};  // in-plane normal of the edge
      ostNum to[3] = {o[0] - p[0], o[1] - p[1], o[2] - p[2]};
      if (osti_primDot(m, to) > 0) {
        m[0] = -m[0]; m[1] = -m[1]; m[2] = -m[2];
      }
      if (osti_primDot(d, m) < 0) {
        continue;  // the cylinder is over the triangle: its face is the feature
      }
      if (dist < s->margin && (!s->has_edge[h] || dist < s->edge_dist[h])) {
        s->has_edge[h] = 1;
        s->edge_dist[h] = dist;
        for (int k = 0; k < 3; k++) {
          s->edge_q[h][k] = qe[k];
          s->edge_n[h][k] = d[k];
        }
      }
    }
  }
  return n;
}


// end of the stream: the edge contact of each half without a face contact (once if both halves
// found the same edge point), then every contact to the world through the terrain pose f and its
// frame completed. Returns the final count.
OST_HD int osti_cylSurfFinish(ostCylSurf* s, const ostGeom* f, ostContact* con, int n,
                              int nmax) {
  int first_edge = -1;
  for (int h = 0; h < 2 && n < nmax; h++) {
    if (s->nface[h] || !s->has_edge[h]) {
      continue;
    }
    if (first_edge >= 0) {
      const ostNum* q0 = s->edge_q[first_edge];
      const ostNum* q1 = s->edge_q[h];
      ostNum dd = (q0[0] - q1[0]) * (q0[0] - q1[0]) + (q0[1] - q1[1]) * (q0[1] - q1[1])
                  + (q0[2] - q1[2]) * (q0[2] - q1[2]);
      if (dd < 1e-24) {
        continue;
      }
    }
    ostNum pos[3];
    osti_primAxpy(pos, s->edge_q[h], s->edge_dist[h] / 2, s->edge_n[h]);
    osti_cylSurfContact(con + n, s->edge_dist[h], pos, s->edge_n[h]);
    n++;
    first_edge = h;
  }
  for (int i = 0; i < n; i++) {
    ostNum p[3], nw[3];
    for (int k = 0; k < 3; k++) {
      p[k] = f->mat[3 * k] * con[i].pos[0] + f->mat[3 * k + 1] * con[i].pos[1]
             + f->mat[3 * k + 2] * con[i].pos[2] + f->pos[k];
      nw[k] = f->mat[3 * k] * con[i].frame[0] + f->mat[3 * k + 1] * con[i].frame[1]
              + f->mat[3 * k + 2] * con[i].frame[2];
    }
    for (int k = 0; k < 3; k++) {
      con[i].pos[k] = p[k];
      con[i].frame[k] = nw[k];
    }
    osti_makeFrame(con[i].frame);
  }
  return n;
}

#ifdef __cplusplus
}
#endif

#endif  // OSTRICH_CORE_OST_COLLISION_CYLSURF_H_
