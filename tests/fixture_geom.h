// fixture_geom.h: random shapes and rigid motions for the collision tests (header only: the
// tests of core's collision headers link no library of their own). Random numbers come from
// drand48, which each test seeds with srand48.
#ifndef OSTRICH_TESTS_FIXTURE_GEOM_H_
#define OSTRICH_TESTS_FIXTURE_GEOM_H_

#include <math.h>
#include <stdlib.h>
#include <string.h>

#include <mujoco/mujoco.h>

#include "ost_geom.h"

// uniform in [a, b)
static inline double ost_fixtureUniform(double a, double b) {
  return a + (b - a) * drand48();
}


// a uniformly random rotation matrix (row-major)
static inline void ost_fixtureRandMat(double mat[9]) {
  double q[4], n = 0;
  while (n < 1e-3) {
    for (int i = 0; i < 4; i++) q[i] = ost_fixtureUniform(-1, 1);
    n = sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3]);
  }
  for (int i = 0; i < 4; i++) q[i] /= n;
  mju_quat2Mat(mat, q);
}


// a geom of the given type and sizes at the origin, unrotated
static inline void ost_fixtureGeom(ostGeom* g, int type, double sx, double sy, double sz) {
  memset(g, 0, sizeof(*g));
  g->type = type;
  g->size[0] = sx;
  g->size[1] = sy;
  g->size[2] = sz;
  g->mat[0] = g->mat[4] = g->mat[8] = 1;
}


// g moved rigidly by eps along the twist (v, w): translation v, rotation w about its own origin
static inline void ost_fixtureMoveGeom(ostGeom* out, const ostGeom* g, const double v[3],
                                       const double w[3], double eps) {
  *out = *g;
  double q[4], rot[9], ax[3] = {w[0], w[1], w[2]};
  mju_normalize3(ax);  // mju_axisAngle2Quat takes a unit axis
  mju_axisAngle2Quat(q, ax, eps * mju_norm3(w));
  mju_quat2Mat(rot, q);
  mju_mulMatMat(out->mat, rot, g->mat, 3, 3, 3);
  for (int k = 0; k < 3; k++) out->pos[k] = g->pos[k] + eps * v[k];
}

// n.(velocity of point p of a geom at origin o moving with the twist (v, w)): the first-order
// rate of a contact distance along n (n from geom 1 to geom 2: + for a point of geom 2, - for
// geom 1), and *scale = |v| + |w| |p - o|, the point's largest speed
static inline double ost_fixturePointRate(const double n[3], const double p[3], const double o[3],
                                          const double v[3], const double w[3], double* scale) {
  double r[3] = {p[0] - o[0], p[1] - o[1], p[2] - o[2]}, wr[3];
  mju_cross(wr, w, r);
  double pv[3] = {v[0] + wr[0], v[1] + wr[1], v[2] + wr[2]};
  *scale = mju_norm3(v) + mju_norm3(w) * mju_norm3(r);
  return mju_dot3(n, pv);
}

// 1 if a contact's distance and point are finite and its normal has unit length (to 1e-9)
static inline int ost_fixtureContactValid(const ostContact* c) {
  const double* f = c->frame;
  int finite = isfinite(c->dist);
  for (int k = 0; k < 3; k++) finite &= isfinite(c->pos[k]);
  return finite && fabs(f[0] * f[0] + f[1] * f[1] + f[2] * f[2] - 1) < 1e-9;
}

#endif  // OSTRICH_TESTS_FIXTURE_GEOM_H_
