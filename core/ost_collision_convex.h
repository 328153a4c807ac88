// ost_collision_convex.h: the general convex collision pairs of Ostrich's native geometry:
// convex-convex by MPR (cylinder, ellipsoid and mesh pairs, sphere/capsule against those) and
// plane against ellipsoid or mesh, with MuJoCo's repair of smooth-surface normals.
// Mirrors MuJoCo 2.2.2's engine_collision_convex.c (mjc_Convex with multiCCD off,
// mjc_PlaneConvex, mjc_fixNormal); support functions and MPR are in ost_collision_mpr.h.
// Invariant: contacts follow ost_geom.h's conventions and equal MuJoCo 2.2.2's d->contact
// (count, dist, pos, frame) to round-off for the same geoms; nothing here allocates, recurses,
// prints or touches MuJoCo, and every loop has a fixed bound.
#ifndef OSTRICH_CORE_OST_COLLISION_CONVEX_H_
#define OSTRICH_CORE_OST_COLLISION_CONVEX_H_

#include <math.h>

#include "ost_collision_mpr.h"
#include "ost_geom.h"

#ifdef __cplusplus
extern "C" {
#endif

#define OST_PLANEMESH_MAX 3          // contacts of a plane-mesh pair (maxplanemesh)
#define OST_PLANEMESH_TOL 0.3        // minimal spacing of plane-mesh contacts / rbound


//---------------------------------- contact normal repair (mjc_fixNormal) -------------------------

// normal at the ellipsoid point hit by the ray pos + x nrm (pos inside), iterated: 1 if found
OST_HD int osti_cvxEllipsoidInside(ostNum nrm[3], const ostNum pos[3], const ostNum size[3]) {
  ostNum s2inv[3] = {1/(size[0]*size[0]), 1/(size[1]*size[1]), 1/(size[2]*size[2])};
  ostNum c = pos[0]*pos[0]*s2inv[0] + pos[1]*pos[1]*s2inv[1] + pos[2]*pos[2]*s2inv[2] - 1;
  if (c > 0) {
    return 0;
  }
  osti_cvxNormalizeMj(nrm);
  for (int iter = 0; iter < 30; iter++) {
    // |pos + x nrm|_S = 1:  a x^2 + 2 b x + c = 0
    ostNum a = nrm[0]*nrm[0]*s2inv[0] + nrm[1]*nrm[1]*s2inv[1] + nrm[2]*nrm[2]*s2inv[2];
    ostNum b = pos[0]*nrm[0]*s2inv[0] + pos[1]*nrm[1]*s2inv[1] + pos[2]*nrm[2]*s2inv[2];
    ostNum det = b*b - a*c;
    if (det < OST_MINVAL || a < OST_MINVAL) {
      return iter > 0;
    }
    ostNum x = (-b + sqrt(det))/a;
    if (x < 0) {
      return iter > 0;
    }

    // surface normal there: S^-2 (pos + x nrm), normalized
    ostNum nn[3];
    for (int k = 0; k < 3; k++) {
      nn[k] = (pos[k] + nrm[k]*x) * s2inv[k];
    }
    osti_cvxNormalizeMj(nn);
    ostNum e0 = nrm[0] - nn[0], e1 = nrm[1] - nn[1], e2 = nrm[2] - nn[2];
    ostNum change = sqrt(e0*e0 + e1*e1 + e2*e2);
    nrm[0] = nn[0]; nrm[1] = nn[1]; nrm[2] = nn[2];
    if (change < 1e-6) {
      break;
    }
  }
  return 1;
}


// normal at the ellipsoid point closest to pos (outside): nrm ~ pos/(S^2 + la), with la the
// root of sum pos_i^2 s_i^2/(s_i^2 + la)^2 = 1 found by Newton's method
OST_HD int osti_cvxEllipsoidOutside(ostNum nrm[3], const ostNum pos[3], const ostNum size[3]) {
  ostNum s2[3] = {size[0]*size[0], size[1]*size[1], size[2]*size[2]};
  ostNum ps2[3] = {pos[0]*pos[0]*s2[0], pos[1]*pos[1]*s2[1], pos[2]*pos[2]*s2[2]};
  ostNum la = 0;
  for (int iter = 0; iter < 30; iter++) {
    ostNum r[3] = {1/(s2[0] + la), 1/(s2[1] + la), 1/(s2[2] + la)};
    ostNum val = ps2[0]*r[0]*r[0] + ps2[1]*r[1]*r[1] + ps2[2]*r[2]*r[2] - 1;
    if (val < 1e-6) {
      break;
    }
    ostNum deriv = -2*(ps2[0]*r[0]*r[0]*r[0] + ps2[1]*r[1]*r[1]*r[1] + ps2[2]*r[2]*r[2]*r[2]);
    if (deriv > -OST_MINVAL) {
      break;
    }
    ostNum delta = -val/deriv;
    if (delta < 1e-6) {
      break;
    }
    la += delta;
  }
  nrm[0] = pos[0]/(s2[0] + la);
  nrm[1] = pos[1]/(s2[1] + la);
  nrm[2] = pos[2]/(s2[2] + la);
  osti_cvxNormalizeMj(nrm);
  return 1;
}


// replace the MPR normal by the analytic surface normal of smooth geoms (sphere, capsule,
// ellipsoid, cylinder wall) at the contact point; both smooth: the normalized difference
OST_HD void osti_fixNormal(ostContact* con, const ostGeom* g1, const ostGeom* g2) {
  const ostGeom* g[2] = {g1, g2};
  ostNum normal[2][3] = {{con->frame[0], con->frame[1], con->frame[2]},
                         {-con->frame[0], -con->frame[1], -con->frame[2]}};
  int done[2] = {0, 0};
  for (int i = 0; i < 2; i++) {
    int type = g[i]->type;
    if (type != OST_GEOM_SPHERE && type != OST_GEOM_CAPSULE && type != OST_GEOM_ELLIPSOID &&
        type != OST_GEOM_CYLINDER) {
      continue;
    }

    // contact point and normal in the geom frame
    const ostNum* mat = g[i]->mat;
    const ostNum* size = g[i]->size;
    ostNum dif[3], pos[3], nrm[3];
    osti_cvxSub(dif, con->pos, g[i]->pos);
    for (int k = 0; k < 3; k++) {
      pos[k] = mat[k]*dif[0] + mat[k + 3]*dif[1] + mat[k + 6]*dif[2];
      nrm[k] = mat[k]*normal[i][0] + mat[k + 3]*normal[i][1] + mat[k + 6]*normal[i][2];
    }

    switch (type) {
    case OST_GEOM_SPHERE:
      nrm[0] = pos[0]; nrm[1] = pos[1]; nrm[2] = pos[2];
      done[i] = 1;
      break;

    case OST_GEOM_CAPSULE:
      // radial from the axis segment
      if (pos[2] < -size[1]) {
        nrm[2] = pos[2] + size[1];
      } else if (pos[2] > size[1]) {
        nrm[2] = pos[2] - size[1];
      } else {
        nrm[2] = 0;
      }
      nrm[0] = pos[0];
      nrm[1] = pos[1];
      done[i] = 1;
      break;

    case OST_GEOM_ELLIPSOID: {
      if (size[0] < OST_MINVAL || size[1] < OST_MINVAL || size[2] < OST_MINVAL) {
        break;
      }
      ostNum e = pos[0]*pos[0]/(size[0]*size[0]) + pos[1]*pos[1]/(size[1]*size[1]) +
                 pos[2]*pos[2]/(size[2]*size[2]);
      done[i] = e <= 1 ? osti_cvxEllipsoidInside(nrm, pos, size)
                       : osti_cvxEllipsoidOutside(nrm, pos, size);
      break;
    }

    case OST_GEOM_CYLINDER: {
      // round wall only: away from the caps and 4x closer to the wall than to a cap
      if (fabs(pos[2]) > 0.95*size[1]) {
        break;
      }
      ostNum dcap = fabs(size[1] - fabs(pos[2]));
      ostNum dwall = fabs(size[0] - sqrt(pos[0]*pos[0] + pos[1]*pos[1]));
      if (dcap < 0.25*dwall) {
        break;
      }
      nrm[0] = pos[0]; nrm[1] = pos[1]; nrm[2] = 0;
      done[i] = 1;
      break;
    }
    }

    // back to the world
    if (done[i]) {
      osti_cvxNormalizeMj(nrm);
      for (int k = 0; k < 3; k++) {
        normal[i][k] = mat[3*k]*nrm[0] + mat[3*k + 1]*nrm[1] + mat[3*k + 2]*nrm[2];
      }
    }
  }

  if (done[0] && done[1]) {
    osti_cvxSub(con->frame, normal[0], normal[1]);
    osti_cvxNormalizeMj(con->frame);
  } else if (done[0]) {
    con->frame[0] = normal[0][0]; con->frame[1] = normal[0][1]; con->frame[2] = normal[0][2];
  } else if (done[1]) {
    con->frame[0] = -normal[1][0]; con->frame[1] = -normal[1][1]; con->frame[2] = -normal[1][2];
  }
  if (done[0] || done[1]) {
    con->frame[3] = con->frame[4] = con->frame[5] = 0;
  }
}


//---------------------------------- pair functions ------------------------------------------------

// convex pair by MPR (mjc_Convex, multiCCD off): at most one contact, returns the count.
// g1, g2 in MuJoCo's order (g1->type <= g2->type); margin: the pair's margin.
//   dist = margin - depth, normal = MPR direction repaired by osti_fixNormal, pos = MPR point
OST_HD int osti_collideConvex(ostContact* con, const ostGeom* g1, const ostGeom* g2,
                              ostNum margin, ostNum tol, int maxiter) {
  ostNum depth, dir[3], pos[3];
  if (osti_mprPenetration(g1, g2, margin, tol, maxiter, &depth, dir, pos) != 0) {
    return 0;
  }

  // contact found but the normal is undefined (touching)
  if (osti_cvxIsOrigin(dir)) {
    return 0;
  }
  con->dist = margin - depth;
  for (int k = 0; k < 3; k++) {
    con->frame[k] = dir[k];
    con->frame[k + 3] = 0;
    con->pos[k] = pos[k];
  }
  osti_fixNormal(con, g1, g2);
  osti_makeFrame(con->frame);
  return 1;
}


// one extra plane-mesh contact at mesh vertex v (geom frame), unless it lies within
// OST_PLANEMESH_TOL*rbound of the first contact: dist = n.(p - p_plane), pos = p - n dist/2
OST_HD int osti_cvxAddPlaneMesh(ostContact* con, const ostNum v[3], const ostGeom* plane,
                                const ostNum normal[3], const ostGeom* mesh,
                                const ostNum first[3]) {
  const ostNum* mat = mesh->mat;
  ostNum pnt[3], dif[3], e[3];
  for (int k = 0; k < 3; k++) {
    pnt[k] = mat[3*k]*v[0] + mat[3*k + 1]*v[1] + mat[3*k + 2]*v[2];
    pnt[k] += mesh->pos[k];
  }
  osti_cvxSub(e, pnt, first);
  if (sqrt(e[0]*e[0] + e[1]*e[1] + e[2]*e[2]) < OST_PLANEMESH_TOL*mesh->rbound) {
    return 0;
  }
  osti_cvxSub(dif, pnt, plane->pos);
  con->dist = osti_cvxDot(normal, dif);
  for (int k = 0; k < 3; k++) {
    con->pos[k] = pnt[k];
    con->pos[k] += normal[k] * (-0.5*con->dist);
    con->frame[k] = normal[k];
    con->frame[k + 3] = 0;
  }
  osti_makeFrame(con->frame);
  return 1;
}


// plane (g1) against ellipsoid or mesh (g2), as mjc_PlaneConvex, with the mesh's convex graph
// (see osti_meshBest; NULL: MuJoCo's branch for meshes without a graph): the deepest support
// point along -normal, then for meshes up to OST_PLANEMESH_MAX-1 further vertices within the
// margin (with a graph: only graph neighbours of the deepest vertex). Returns the count.
//   dist = n.(s(-n) - p_plane),  pos = s - n dist/2,  normal = the plane's z axis
OST_HD int osti_collidePlaneMesh(ostContact* con, const ostGeom* g1, const ostGeom* g2,
                                 ostNum margin, const int* graph) {
  ostNum normal[3] = {g1->mat[2], g1->mat[5], g1->mat[8]};
  ostNum dir[3] = {-g1->mat[2], -g1->mat[5], -g1->mat[8]};
  const ostNum* mat = g2->mat;
  ostNum vec[3], dif[3], locdir[3];
  int ibest = -1;

  // deepest point of g2 (no margin inflation)
  if (g2->type == OST_GEOM_MESH) {
    for (int k = 0; k < 3; k++) {
      locdir[k] = mat[k]*dir[0] + mat[k + 3]*dir[1] + mat[k + 6]*dir[2];
    }
    ibest = osti_meshBest(g2, locdir, graph);
    if (ibest < 0) {
      return 0;
    }
    ostNum r[3];
    for (int k = 0; k < 3; k++) {
      r[k] = g2->vert[3*ibest + k];
      r[k] += locdir[k] * 0.0/2;
    }
    for (int k = 0; k < 3; k++) {
      vec[k] = mat[3*k]*r[0] + mat[3*k + 1]*r[1] + mat[3*k + 2]*r[2];
      vec[k] += g2->pos[k];
    }
  } else {
    osti_support(vec, g2, dir, 0);
  }
  osti_cvxSub(dif, vec, g1->pos);
  ostNum dist = osti_cvxDot(normal, dif);
  if (dist > margin) {
    return 0;
  }
  con->dist = dist;
  for (int k = 0; k < 3; k++) {
    con->pos[k] = vec[k];
    con->pos[k] += normal[k] * (-0.5*dist);
    con->frame[k] = normal[k];
    con->frame[k + 3] = 0;
  }
  osti_makeFrame(con->frame);
  if (g2->type != OST_GEOM_MESH) {
    return 1;
  }

  // further vertices below the margin: projection along -n beyond the center's height - margin
  osti_cvxSub(dif, g2->pos, g1->pos);
  ostNum threshold = osti_cvxDot(normal, dif) - margin;
  int count = 1;
  if (!graph) {
    for (int i = 0; i < g2->nvert && count < OST_PLANEMESH_MAX; i++) {
      const ostNum* v = g2->vert + 3*i;
      ostNum vdot = locdir[0]*v[0] + locdir[1]*v[1] + locdir[2]*v[2];
      if (vdot > threshold && i != ibest) {
        count += osti_cvxAddPlaneMesh(con + count, v, g1, normal, g2, con->pos);
      }
    }
  } else {
    const int* edge = graph + 2 + 2*graph[0];
    int locid;
    for (int i = graph[2 + ibest]; (locid = edge[i]) >= 0 && count < OST_PLANEMESH_MAX; i++) {
      const ostNum* v = g2->vert + 3*locid;
      ostNum vdot = locdir[0]*v[0] + locdir[1]*v[1] + locdir[2]*v[2];
      if (vdot > threshold) {
        count += osti_cvxAddPlaneMesh(con + count, v, g1, normal, g2, con->pos);
      }
    }
  }
  return count;
}


// plane (g1) against ellipsoid or mesh (g2) without a mesh graph (see osti_collidePlaneMesh)
OST_HD int osti_collidePlaneConvex(ostContact* con, const ostGeom* g1, const ostGeom* g2,
                                   ostNum margin) {
  return osti_collidePlaneMesh(con, g1, g2, margin, 0);
}

#ifdef __cplusplus
}
#endif

#endif  // OSTRICH_CORE_OST_COLLISION_CONVEX_H_
