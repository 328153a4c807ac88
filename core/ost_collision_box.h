// ost_collision_box.h: analytic collisions of boxes with spheres, capsules and boxes, and the
// dispatcher over every analytic pair of Ostrich's native geometry.
// Mirrors engine_collision_box.c of MuJoCo 2.2.2 (mjc_SphereBox, mjc_CapsuleBox; mjc_BoxBox is in
// ost_collision_boxbox.h) and the analytic entries of mjCOLLISIONFUNC in
// engine_collision_driver.c.
// Invariant: as in ost_collision_primitive.h: n <= OST_MAXCONPAIR contacts, all within the
// margin, normals from g1 to g2, frames completed as MuJoCo's driver completes them.
#ifndef OSTRICH_CORE_OST_COLLISION_BOX_H_
#define OSTRICH_CORE_OST_COLLISION_BOX_H_

#include <math.h>

#include "ost_collision_boxbox.h"
#include "ost_collision_primitive.h"
#include "ost_geom.h"
#include "ost_hd.h"

#ifdef __cplusplus
extern "C" {
#endif

//---------------------------------- sphere : box -------------------------------------------------

// ball (center c1, radius r1) : box (pos2, mat2, size2); one contact
//   c = R2'(c1 - p2) box-local center,  q = clamp(c, -size2, size2) nearest box point,
//   t = (q - c)/|q - c| normal,  dist = |q - c| - r1,  pos = R2 (q + c + r1 t)/2 + p2
// a center inside the box pushes out through the nearest face, with dist = -r1 as in MuJoCo
OST_HD int osti_boxBallBox(ostContact* con, ostNum margin, const ostNum c1[3], ostNum r1,
                           const ostNum pos2[3], const ostNum mat2[9], const ostNum size2[3]) {
  ostNum dif[3] = {c1[0] - pos2[0], c1[1] - pos2[1], c1[2] - pos2[2]};
  ostNum c[3], q[3], t[3], pl[3], n[3], pos[3];
  osti_boxMulMatTVec(c, mat2, dif);
  for (int i = 0; i < 3; i++) {
    q[i] = c[i] < -size2[i] ? -size2[i] : (c[i] > size2[i] ? size2[i] : c[i]);
    t[i] = q[i] - c[i];
  }
  ostNum len = osti_primNormalize(t);
  if (len - r1 > margin) {
    return 0;
  }

  // center inside: the face k (2 axis + side) nearest to c, normal into the box
  if (len <= OST_MINVAL) {
    ostNum best = 2 * (size2[0] + size2[1] + size2[2]);
    int k = 0;
    for (int i = 0; i < 6; i++) {
      ostNum gap = fabs((i % 2 ? 1 : -1) * size2[i/2] - c[i/2]);
      if (gap < best) {
        best = gap;
        k = i;
      }
    }
    ostNum dir[3] = {0, 0, 0};
    dir[k/2] = (k % 2) ? -1 : 1;
    osti_primAxpy(pl, c, (r1 - best) / 2, dir);
    osti_boxMulMatVec(n, mat2, dir);
  }

  // center outside: midway between q and the deepest sphere point c + r1 t
  else {
    ostNum deep[3];
    osti_primAxpy(deep, c, r1, t);
    for (int i = 0; i < 3; i++) {
      pl[i] = 0.5*q[i] + 0.5*deep[i];
    }
    osti_boxMulMatVec(n, mat2, t);
  }
  osti_boxMulMatVec(pos, mat2, pl);
  osti_primAxpy(pos, pos, 1, pos2);
  osti_primSetContact(con, len - r1, pos, n, 0);
  return 1;
}


// sphere : box
OST_HD int osti_collideSphereBox(ostContact* con, const ostGeom* g1, const ostGeom* g2,
                                 ostNum margin) {
  return osti_boxBallBox(con, margin, g1->pos, g1->size[0], g2->pos, g2->mat, g2->size);
}


//---------------------------------- capsule : box ------------------------------------------------

// capsule : box; in the box frame, the segment point nearest to the box (over the segment's two
// ends against the faces and the 12 edges), then a second point along the segment chosen from
// how the segment leans over the nearest corner, edge or face; each point is a sphere : box test
OST_HD int osti_collideCapsuleBox(ostContact* con, const ostGeom* g1, const ostGeom* g2,
                                  ostNum margin) {
  const ostNum* s = g2->size;
  ostNum radius = g1->size[0], half = g1->size[1];
  ostNum dif[3], pos[3], z1[3], axis[3], ha[3];

  // capsule center pos and half axis ha in the box frame
  for (int k = 0; k < 3; k++) {
    dif[k] = g1->pos[k] - g2->pos[k];
  }
  osti_boxMulMatTVec(pos, g2->mat, dif);
  osti_primAxis(z1, g1->mat, 2);
  osti_boxMulMatTVec(axis, g2->mat, z1);
  for (int k = 0; k < 3; k++) {
    ha[k] = axis[k] * half;
  }
  int axisdir = (ha[0] > 0) + 2*(ha[1] > 0) + 4*(ha[2] > 0);

  // closest feature, as squared distance best; type: -3/-1 segment end (-1/+1) over a face
  // (face = the one clamped axis, -1 inside), 0..8 = 3 s1 + s2 for an edge, where s1, s2 say
  // whether the box edge's and the segment's parameters are at -1 (0), inside (1) or +1 (2)
  ostNum best = margin + 2 * (radius + half + s[0] + s[1] + s[2]);
  ostNum bestseg = 0, bestbox = 0;
  int type = -4, face = -1, corner = 0, edge = 0;
  for (int i = -1; i <= 1; i += 2) {
    ostNum e[3], c[3];
    int nclamp = 0, last = -1;
    osti_primAxpy(e, pos, (ostNum)i, ha);
    for (int k = 0; k < 3; k++) {
      c[k] = e[k];
      if (c[k] < -s[k] || c[k] > s[k]) {
        nclamp++;
        last = k;
        c[k] = c[k] < -s[k] ? -s[k] : s[k];
      }
    }
    if (nclamp > 1) {
      continue;
    }
    for (int k = 0; k < 3; k++) {
      c[k] -= e[k];
    }
    ostNum d = osti_primDot(c, c);
    if (d < best) {
      best = d;
      bestseg = i;
      type = -2 + i;
      face = last;
    }
  }

  // edges along axis j through the edge centers cen (corner i with bit j cleared): box edge
  // cen + x1 s_j e_j, segment pos + x2 ha, both |x| <= 1, clipped as for two capsules
  for (int j = 0; j < 3; j++) {
    for (int i = 0; i < 8; i++) {
      if (i & (1 << j)) {
        continue;
      }
      ostNum cen[3] = {(i & 1) ? s[0] : -s[0], (i & 2) ? s[1] : -s[1], (i & 4) ? s[2] : -s[2]};
      cen[j] = 0;
      for (int k = 0; k < 3; k++) {
        dif[k] = cen[k] - pos[k];
      }
      ostNum ma = s[j] * s[j], mb = -s[j] * ha[j], mc = half * half;
      ostNum u = -s[j] * dif[j], v = osti_primDot(ha, dif);
      ostNum det = ma*mc - mb*mb;
      if (fabs(det) < OST_MINVAL) {
        continue;
      }
      ostNum idet = 1 / det;
      ostNum x1 = (mc*u - mb*v) * idet, x2 = (ma*v - mb*u) * idet;
      int f1 = 1, f2 = 1;
      if (x1 > 1) {
        x1 = 1; f1 = 2; x2 = (v - mb) * (1 / mc);
      } else if (x1 < -1) {
        x1 = -1; f1 = 0; x2 = (v + mb) * (1 / mc);
      }
      if (x2 > 1 || x2 < -1) {
        ostNum sg = x2 > 1 ? 1 : -1;
        x2 = sg;
        f2 = x2 > 0 ? 2 : 0;
        x1 = (u - sg*mb) * (1 / ma);
        if (x1 > 1) {
          x1 = 1; f1 = 2;
        } else if (x1 < -1) {
          x1 = -1; f1 = 0;
        }
      }
      for (int k = 0; k < 3; k++) {
        dif[k] = cen[k] - pos[k];
      }
      osti_primAxpy(dif, dif, -x2, ha);
      dif[j] += s[j] * x1;
      ostNum d = osti_primDot(dif, dif);
      if (d < best - OST_MINVAL) {
        best = d;
        bestseg = x2;
        bestbox = x1;
        corner = i + (1 << j) * ((3*f1 + f2) / 6);
        edge = j;
        type = 3*f1 + f2;
      }
    }
  }
  if (type == -4) {
    return 0;
  }

  // second point: signed offset sp along the segment from the first (-4: none)
  ostNum sp = -4, mul = 1;
  if (type >= 0 && type / 3 != 1) {
    // nearest to a box corner: lean = which of the corner's axes the segment runs along
    int lean = axisdir ^ corner;
    if (lean != 0 && lean != 7) {
      ostNum de, dp;
      if (lean == 1 || lean == 2 || lean == 4) {
        mul = 1;
        de = 1 - bestseg;
        dp = 1 + bestseg;
      } else {
        mul = -1;
        lean = 7 - lean;
        dp = 1 - bestseg;
        de = 1 + bestseg;
      }
      int ax = lean == 1 ? 0 : (lean == 2 ? 1 : 2);
      int ax1 = (ax + 1) % 3, ax2 = (ax + 2) % 3;
      if (axis[ax]*axis[ax] > 0.5) {
        // along the box edge: at most to its other corner
        sp = de;
        ostNum e1 = 2 * s[ax] / fabs(ha[ax]);
        if (e1 < sp) {
          sp = e1;
        }
        sp *= mul;
      } else {
        // over a face: at most to the face's far sides
        sp = dp;
        ostNum e1 = 2 * s[ax1] / fabs(ha[ax1]);
        if (e1 < sp) {
          sp = e1;
        }
        e1 = 2 * s[ax2] / fabs(ha[ax2]);
        if (e1 < sp) {
          sp = e1;
        }
        sp *= -mul;
      }
    }
  } else if (type >= 0) {
    // nearest to the inside of a box edge: only a crossing (not a T) gives a second point
    int lean = (axisdir ^ corner) & (7 - (1 << edge));
    if (lean == 1 || lean == 2 || lean == 4) {
      int ax = edge, ax1 = (edge + 1) % 3, ax2 = (edge + 2) % 3;
      if (fabs(axis[ax1]) > fabs(axis[ax2])) {
        ax1 = ax2;
      }
      ax2 = 3 - ax - ax1;
      if (lean & (1 << ax2)) {
        mul = 1;
        sp = 1 - bestseg;
      } else {
        mul = -1;
        sp = 1 + bestseg;
      }
      ostNum e1 = 2 * s[ax2] / fabs(ha[ax2]);
      if (e1 < sp) {
        sp = e1;
      }
      ostNum e2 = (((axisdir & (1 << ax)) != 0) == ((lean & (1 << ax2)) != 0)) ?
                  1 - bestbox : 1 + bestbox;
      e1 = s[ax] * e2 / fabs(ha[ax]);
      if (e1 < sp) {
        sp = e1;
      }
      sp *= mul;
    }
  } else if (face != -1) {
    // a segment end over a face: the other end, pulled back to where the segment leaves the
    // box's side slabs
    mul = type == -3 ? 1 : -1;
    sp = 2;
    ostNum o[3];
    osti_primAxpy(o, pos, -mul, ha);
    for (int i = 0; i < 3; i++) {
      if (i == face) {
        continue;
      }
      ostNum e1 = (s[i] - o[i]) / ha[i] * mul;
      if (e1 > 0 && e1 < sp) {
        sp = e1;
      }
      e1 = (-s[i] - o[i]) / ha[i] * mul;
      if (e1 > 0 && e1 < sp) {
        sp = e1;
      }
    }
    sp *= mul;
  }

  // sphere : box at the first point, and at the second
  ostNum c[3], cw[3];
  osti_primAxpy(c, pos, bestseg, ha);
  osti_boxMulMatVec(cw, g2->mat, c);
  osti_primAxpy(cw, cw, 1, g2->pos);
  int n = osti_boxBallBox(con, margin, cw, radius, g2->pos, g2->mat, s);
  if (sp > -3) {
    osti_primAxpy(c, pos, sp + bestseg, ha);
    osti_boxMulMatVec(cw, g2->mat, c);
    osti_primAxpy(cw, cw, 1, g2->pos);
    n += osti_boxBallBox(con + n, margin, cw, radius, g2->pos, g2->mat, s);
  }
  return n;
}


//---------------------------------- dispatcher ---------------------------------------------------

// collide an analytic pair (g1->type <= g2->type, as in MuJoCo's table); *handled = 0 and no
// contacts for pairs that MuJoCo 2.2.2 does not collide analytically (those go to MPR)
OST_HD int osti_collidePrimitive(ostContact* con, const ostGeom* g1, const ostGeom* g2,
                                 ostNum margin, int* handled) {
  int t1 = g1->type, t2 = g2->type;
  *handled = 1;
  if (t1 == OST_GEOM_PLANE) {
    switch (t2) {
    case OST_GEOM_SPHERE:   return osti_collidePlaneSphere(con, g1, g2, margin);
    case OST_GEOM_CAPSULE:  return osti_collidePlaneCapsule(con, g1, g2, margin);
    case OST_GEOM_CYLINDER: return osti_collidePlaneCylinder(con, g1, g2, margin);
    case OST_GEOM_BOX:      return osti_collidePlaneBox(con, g1, g2, margin);
    default:                break;
    }
  } else if (t1 == OST_GEOM_SPHERE) {
    switch (t2) {
    case OST_GEOM_SPHERE:   return osti_collideSphereSphere(con, g1, g2, margin);
    case OST_GEOM_CAPSULE:  return osti_collideSphereCapsule(con, g1, g2, margin);
    case OST_GEOM_BOX:      return osti_collideSphereBox(con, g1, g2, margin);
    default:                break;
    }
  } else if (t1 == OST_GEOM_BOX && t2 == OST_GEOM_BOX) {
    return osti_collideBoxBox(con, g1, g2, margin);
  } else if (t1 == OST_GEOM_CAPSULE) {
    switch (t2) {
    case OST_GEOM_CAPSULE:  return osti_collideCapsuleCapsule(con, g1, g2, margin);
    case OST_GEOM_BOX:      return osti_collideCapsuleBox(con, g1, g2, margin);
    default:                break;
    }
  }
  *handled = 0;
  return 0;
}

#ifdef __cplusplus
}
#endif

#endif  // OSTRICH_CORE_OST_COLLISION_BOX_H_
