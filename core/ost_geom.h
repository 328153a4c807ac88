// ost_geom.h: the types that the native collision functions share (mirrors the mjContact part of
// mjdata.h and the geom fields of mjmodel.h that collision reads).
// A collision function sees two geoms already placed in the world (ostGeom) and writes at most
// OST_MAXCONPAIR contacts (ostContact), with MuJoCo 2.2.2's conventions: the normal frame[0:3]
// points from geom1 to geom2, dist < 0 in penetration, pos midway between the two surfaces.
// Invariant: nothing here allocates or touches MuJoCo; every function is host+device inline.
#ifndef OSTRICH_CORE_OST_GEOM_H_
#define OSTRICH_CORE_OST_GEOM_H_

#include <math.h>

#include "ost_hd.h"

#ifdef __cplusplus
extern "C" {
#endif

#define OST_MAXCONPAIR 50  // contacts per geom pair (mjMAXCONPAIR)
#define OST_MINVAL 1e-15   // guard of divisions (mjMINVAL)

typedef enum osttGeom_ {   // geom types, numbered as mjtGeom
  OST_GEOM_PLANE = 0,
  OST_GEOM_HFIELD,
  OST_GEOM_SPHERE,
  OST_GEOM_CAPSULE,
  OST_GEOM_ELLIPSOID,
  OST_GEOM_CYLINDER,
  OST_GEOM_BOX,
  OST_GEOM_MESH,
  OST_GEOM_NTYPES,
  OST_GEOM_PRISM = 100     // internal: a triangular prism of terrain (6 vertices in vert)
} osttGeom;

typedef struct ostGeom_ {  // one geom placed in the world, as a collision function sees it
  int           type;      // osttGeom
  int           nvert;     // mesh and prism: number of vertices in vert
  const ostNum* vert;      // mesh: convex-hull vertices in the geom frame; prism: world (nvert x 3)
  int           nface;     // mesh: number of hull triangles in face (0: none known)
  const int*    face;      // mesh: hull triangles, vertex ids into vert (nface x 3)
  ostNum        size[3];   // geom_size
  ostNum        pos[3];    // geom_xpos: position of the geom frame (m)
  ostNum        mat[9];    // geom_xmat: rotation, row-major, columns are the geom's axes
  ostNum        rbound;    // geom_rbound: bounding-sphere radius (0: infinite, planes)
} ostGeom;

typedef struct ostContact_ {  // one contact, as mjContact's geometric part
  ostNum dist;                // signed distance (m), negative in penetration
  ostNum pos[3];              // contact point, midway between the surfaces (world, m)
  ostNum frame[9];            // rows: normal (geom1 -> geom2), tangent 1, tangent 2
} ostContact;

OST_STATIC_ASSERT(sizeof(ostContact) == 13 * sizeof(ostNum),
                  "ostContact crosses the gcc/nvcc boundary: keep it unpadded");


// complete a contact frame from its normal frame[0:3] and tangent hint frame[3:6], as MuJoCo
// 2.2.2's collision driver does after every pair function (probed with mj_collision). Callers
// must set frame[3:6] first: zero (most pair functions), or a hint (plane-capsule: the axis):
//   n  = frame[0:3] / |frame[0:3]|
//   t0 = frame[3:6] if |frame[3:6]| >= 0.5, else (0,1,0) if |n_y| < 0.5, else (0,0,1)
//   t1 = (t0 - n (n.t0)) / |t0 - n (n.t0)|,   t2 = n x t1
// a normal shorter than OST_MINVAL (MuJoCo stops with an error there) becomes (1,0,0), and so
// does t1 when t0 is parallel to n (a hint along the normal), as mju_normalize3 does
OST_HD void osti_makeFrame(ostNum frame[9]) {
  // normalize the normal
  ostNum nn = frame[0]*frame[0] + frame[1]*frame[1] + frame[2]*frame[2];
  ostNum len = nn > 0 ? sqrt(nn) : 0;
  if (len < OST_MINVAL) {
    frame[0] = 1; frame[1] = 0; frame[2] = 0;
  } else {
    ostNum inv = 1 / len;
    frame[0] *= inv; frame[1] *= inv; frame[2] *= inv;
  }

  // first tangent: the hint, else the y axis, or the z axis when the normal is close to y
  ostNum t[3] = {frame[3], frame[4], frame[5]};
  if (t[0]*t[0] + t[1]*t[1] + t[2]*t[2] < 0.25) {
    ostNum ny = frame[1] < 0 ? -frame[1] : frame[1];
    t[0] = 0; t[1] = 0; t[2] = 0;
    t[ny < 0.5 ? 1 : 2] = 1;
  }
  ostNum proj = frame[0]*t[0] + frame[1]*t[1] + frame[2]*t[2];
  for (int i = 0; i < 3; i++) {
    t[i] -= proj * frame[i];
  }
  ostNum tl = sqrt(t[0]*t[0] + t[1]*t[1] + t[2]*t[2]);
  if (tl < OST_MINVAL) {
    frame[3] = 1; frame[4] = 0; frame[5] = 0;
  } else {
    ostNum tinv = 1 / tl;
    frame[3] = t[0] * tinv; frame[4] = t[1] * tinv; frame[5] = t[2] * tinv;
  }

  // second tangent: normal x first tangent
  frame[6] = frame[1]*frame[5] - frame[2]*frame[4];
  frame[7] = frame[2]*frame[3] - frame[0]*frame[5];
  frame[8] = frame[0]*frame[4] - frame[1]*frame[3];
}

#ifdef __cplusplus
}
#endif

#endif  // OSTRICH_CORE_OST_GEOM_H_
