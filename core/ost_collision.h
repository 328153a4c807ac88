// ost_collision.h: the native collision driver (mirrors engine_collision_driver.c's
// mj_collision / mj_collideGeoms). For every candidate pair packed in the model (the broadphase
// filter already ran once, in plugin/ost_pack.c) it prunes by bounding spheres and dispatches to
// the pair function: analytic primitives (ost_collision_primitive.h, ost_collision_box.h),
// Ostrich's cylinder-box, ellipsoid and ball pairs (ost_collision_cylbox.h, _ellipsoid.h,
// _ball.h; not MuJoCo's algorithms), MPR
// for general convex pairs (ost_collision_convex.h), height fields and terrain meshes
// (ost_collision_terrain.h). Contacts go to k->contact with their pair index.
// Invariant: pairs are visited in packed order and each pair's contacts keep the pair function's
// order, so the same configuration always yields the same contact list (bitwise).
#ifndef OSTRICH_CORE_OST_COLLISION_H_
#define OSTRICH_CORE_OST_COLLISION_H_

#include "ost_collision_ball.h"
#include "ost_collision_box.h"
#include "ost_collision_convex.h"
#include "ost_collision_cylbox.h"
#include "ost_collision_ellipsoid.h"
#include "ost_collision_ellmesh.h"
#include "ost_collision_terrain.h"
#include "ost_geom.h"
#include "ost_hd.h"
#include "ost_kinematics.h"
#include "ost_model.h"

#ifdef __cplusplus
extern "C" {
#endif

// contacts of candidate pair p at the current kinematics into con (room for OST_MAXCONPAIR)
OST_HD int osti_collidePair(const ostModel* m, const ostKin* k, int p, ostContact* con) {
  int ncon_max = OST_MAXCONPAIR;
  int g1 = m->pair_geom1[p], g2 = m->pair_geom2[p];
  ostNum margin = m->pair_margin[p];
  ostGeom a, b;
  osti_geom(m, k, g1, &a);
  osti_geom(m, k, g2, &b);

  // bounding spheres (rbound 0: unbounded, planes, height fields and terrain)
  if (a.rbound > 0 && b.rbound > 0) {
    ostNum dx = a.pos[0] - b.pos[0], dy = a.pos[1] - b.pos[1], dz = a.pos[2] - b.pos[2];
    ostNum r = a.rbound + b.rbound + margin;
    if (dx * dx + dy * dy + dz * dz > r * r) {
      return 0;
    }
  }

  // terrain surfaces: height field, or a mesh marked as terrain (packed as geom1)
  if (a.type == OST_GEOM_HFIELD) {
    int id = m->geom_dataid[g1];
    ostHField hf;
    hf.nrow = m->hfield_nrow[id];
    hf.ncol = m->hfield_ncol[id];
    for (int i = 0; i < 4; i++) {
      hf.size[i] = m->hfield_size[4 * id + i];
    }
    hf.data = m->hfield_data + m->hfield_adr[id];
    return osti_collideHField(con, ncon_max, &hf, &a, &b, margin, m->mpr_tolerance,
                              m->mpr_iterations);
  }
  if (m->geom_terrain[g1]) {
    // the packed terrain is in the world frame: an identity pose stands for the geom
    int id = m->geom_dataid[g1];
    for (int i = 0; i < 9; i++) {
      a.mat[i] = i % 4 == 0;
    }
    a.pos[0] = a.pos[1] = a.pos[2] = 0;
    const int* grid = m->mesh_grid + 3 * id;
    const ostNum* box = m->mesh_gridbox + 5 * id;
    ostTerrain t;
    t.nvert = m->mesh_vertnum[id];
    t.nface = m->mesh_facenum[id];
    t.vert = m->mesh_vert + 3 * m->mesh_vertadr[id];
    t.face = m->mesh_face + 3 * m->mesh_faceadr[id];
    t.gnx = grid[0];
    t.gny = grid[1];
    t.gx0 = box[0];
    t.gy0 = box[1];
    t.gdx = box[2];
    t.gdy = box[3];
    t.base = box[4];
    t.cell_adr = m->cell_adr + grid[2];
    t.cell_num = m->cell_num + grid[2];
    t.cell_face = m->cell_face;
    return osti_collideTerrain(con, ncon_max, &t, &a, &b, margin, m->mpr_tolerance,
                               m->mpr_iterations);
  }

  // analytic pairs, Ostrich's cylinder-box, ellipsoid and ball pairs, then plane vs general
  // convex, then MPR
  ostContact buf[OST_MAXCONPAIR];
  int handled = 0, n = osti_collidePrimitive(buf, &a, &b, margin, &handled);
  if (!handled && a.type == OST_GEOM_CYLINDER && b.type == OST_GEOM_BOX) {
    n = osti_collideCylinderBox(buf, &a, &b, margin);
    handled = 1;
  }
  if (!handled && a.type == OST_GEOM_ELLIPSOID && b.type == OST_GEOM_BOX) {
    n = osti_collideEllipsoidBox(buf, &a, &b, margin, m->mpr_tolerance, m->mpr_iterations);
    handled = 1;
  }
  if (!handled && a.type == OST_GEOM_ELLIPSOID && b.type == OST_GEOM_MESH && b.nface > 0) {
    n = osti_collideEllipsoidMesh(buf, &a, &b, margin, m->mpr_tolerance, m->mpr_iterations);
    handled = 1;
  }
  if (!handled && (a.type == OST_GEOM_SPHERE || a.type == OST_GEOM_CAPSULE)
      && (b.type == OST_GEOM_ELLIPSOID || b.type == OST_GEOM_CYLINDER
          || b.type == OST_GEOM_MESH)) {
    n = osti_collideBall(buf, &a, &b, margin, m->mpr_tolerance, m->mpr_iterations);
    handled = 1;
  }
  if (!handled) {
    n = a.type == OST_GEOM_PLANE
        ? osti_collidePlaneConvex(buf, &a, &b, margin)
        : osti_collideConvex(buf, &a, &b, margin, m->mpr_tolerance, m->mpr_iterations);
  }
  n = n < ncon_max ? n : ncon_max;
  for (int i = 0; i < n; i++) {
    con[i] = buf[i];
  }
  return n;
}


// all contacts at the current kinematics (osti_kinematics ran) of every pair, or of the pairs
// k->pair_only when set, into k->contact, whose OST_MAXCONPAIR slack entries past ncon_max let
// each pair write freely; sets k->overflow and keeps the first ncon_max contacts when there are
// more
OST_HD void osti_collision(const ostModel* m, ostKin* k) {
  int ncon_max = m->s.ncon_max;
  k->ncon = 0;
  k->overflow = 0;
  if (m->disableflags & OST_DSBL_CONTACT) {
    return;
  }
  int npair = k->pair_only ? k->npair_only : m->s.npair;
  for (int ip = 0; ip < npair; ip++) {
    int p = k->pair_only ? k->pair_only[ip] : ip;
    int n = osti_collidePair(m, k, p, k->contact + k->ncon);
    for (int i = 0; i < n; i++) {
      k->contact_pair[k->ncon + i] = p;
    }
    k->ncon += n;
    if (k->ncon > ncon_max) {
      k->overflow = 1;
      k->ncon = ncon_max;
      return;
    }
  }
}

#ifdef __cplusplus
}
#endif

#endif  // OSTRICH_CORE_OST_COLLISION_H_
