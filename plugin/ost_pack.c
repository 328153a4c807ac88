// ost_pack.c: mjModel -> ostModel, the flat read-only model of the native geometry provider
// (core/ost_model.h), and the list of what `native` cannot do. Mirrors engine_io.c's model
// allocation and the broadphase filter of engine_collision_driver.c: candidate geom pairs are
// decided once here (contype/conaffinity, <exclude>, <pair>, welded bodies, parent-child), so a
// step only tests pairs that can collide.
// Invariant: a packed model carries every feature that native stepping needs, or packing fails
// with a message naming every feature it cannot represent; nothing is silently dropped.
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "ost_check.h"
#include "ost_collision_terrain.h"
#include "ost_internal.h"

// 1 if MuJoCo 2.2.2 has a collision function for the (ordered) type pair
static int typesCollide(int t1, int t2) {
  return !(t1 <= mjGEOM_HFIELD && t2 <= mjGEOM_HFIELD);
}


// geom id of the terrain mesh named in <custom><text name="ostrich/terrain">, or -1
int ost_terrainGeom(const mjModel* m) {
  int id = mj_name2id(m, mjOBJ_TEXT, "ostrich/terrain");
  if (id < 0) {
    return -1;
  }
  const char* gname = m->text_data + m->text_adr[id];
  return mj_name2id(m, mjOBJ_GEOM, gname);
}


// 1 if geoms g1, g2 (not an explicit pair) pass MuJoCo's broadphase filters
static int dynamicPair(const mjModel* m, int g1, int g2) {
  int b1 = m->geom_bodyid[g1], b2 = m->geom_bodyid[g2];
  int w1 = m->body_weldid[b1], w2 = m->body_weldid[b2];
  if (w1 == w2) {
    return 0;  // same rigid body (world-welded geoms included)
  }
  if (!((m->geom_contype[g1] & m->geom_conaffinity[g2])
        || (m->geom_contype[g2] & m->geom_conaffinity[g1]))) {
    return 0;
  }
  // parent-child filter on welded bodies; children of the world still touch it
  if (!(m->opt.disableflags & mjDSBL_FILTERPARENT)) {
    int p1 = m->body_weldid[m->body_parentid[w1]], p2 = m->body_weldid[m->body_parentid[w2]];
    if ((w1 != 0 && p2 == w1) || (w2 != 0 && p1 == w2)) {
      return 0;
    }
  }
  int lo = b1 < b2 ? b1 : b2, hi = b1 < b2 ? b2 : b1;
  int sig = ((lo + 1) << 16) + hi + 1;
  for (int i = 0; i < m->nexclude; i++) {
    if (m->exclude_signature[i] == sig) {
      return 0;
    }
  }
  for (int i = 0; i < m->npair; i++) {
    if ((m->pair_geom1[i] == g1 && m->pair_geom2[i] == g2)
        || (m->pair_geom1[i] == g2 && m->pair_geom2[i] == g1)) {
      return 0;  // the explicit pair replaces it
    }
  }
  return 1;
}


void ost_refusalsNative(const mjModel* m, ostRefusalList* l) {
  char nb[64], nb2[64], pair[160];
  int terrain = ost_terrainGeom(m);
  int text = mj_name2id(m, mjOBJ_TEXT, "ostrich/terrain");
  if (text >= 0 && (terrain < 0 || m->geom_type[terrain] != mjGEOM_MESH)) {
    ost_refuse(l, "", NULL, "ostrich/terrain names '%s', which is not a mesh geom",
               m->text_data + m->text_adr[text]);
  }
  for (int i = 0; i < m->neq; i++) {
    ost_refuse(l, "equality constraint", ost_objName(m, mjOBJ_EQUALITY, i, nb, sizeof(nb)),
               "equality rows, which the native geometry provider does not have yet (use "
               "ostrich/geometry 0, the mujoco provider)");
  }
  for (int i = 0; i < m->ntendon; i++) {
    ost_refuse(l, "tendon", ost_objName(m, mjOBJ_TENDON, i, nb, sizeof(nb)),
               "tendons, which the native geometry provider does not have");
  }
  for (int b = 0; b < m->nbody; b++) {
    if (m->body_mocapid[b] >= 0) {
      ost_refuse(l, "body", ost_objName(m, mjOBJ_BODY, b, nb, sizeof(nb)),
                 "mocap bodies, which the native geometry provider does not support");
    }
  }
  if (m->opt.viscosity > 0 || m->opt.density > 0) {
    ost_refuse(l, "", NULL, "fluid forces (option viscosity/density), which the native "
               "geometry provider does not support");
  }
  for (int j = 0; j < m->njnt; j++) {
    int t = m->jnt_type[j];
    if ((t == mjJNT_HINGE || t == mjJNT_SLIDE) && m->qpos0[m->jnt_qposadr[j]] != 0) {
      ost_refuse(l, "joint", ost_objName(m, mjOBJ_JOINT, j, nb, sizeof(nb)),
                 "a nonzero ref, which the native geometry provider does not support");
    }
    if (m->jnt_limited[j] && (t == mjJNT_BALL || t == mjJNT_FREE)) {
      ost_refuse(l, "joint", ost_objName(m, mjOBJ_JOINT, j, nb, sizeof(nb)),
                 "limits on a ball joint, which the native geometry provider does not support");
    }
  }
  for (int i = 0; i < m->nu; i++) {
    int t = m->actuator_trntype[i], j = m->actuator_trnid[2 * i];
    if (t != mjTRN_JOINT || (m->jnt_type[j] != mjJNT_HINGE && m->jnt_type[j] != mjJNT_SLIDE)) {
      ost_refuse(l, "actuator", ost_objName(m, mjOBJ_ACTUATOR, i, nb, sizeof(nb)),
                 "a transmission other than a hinge or slide joint, which the native geometry "
                 "provider does not support");
    }
  }
  for (int g = 0; g < m->ngeom; g++) {
    int t = m->geom_type[g];
    if (t == mjGEOM_MESH && g == terrain && m->geom_bodyid[g] != 0) {
      ost_refuse(l, "geom", ost_objName(m, mjOBJ_GEOM, g, nb, sizeof(nb)),
                 "a terrain mesh outside the worldbody (it must be a geom of the worldbody)");
    }
    if (t == mjGEOM_MESH && g != terrain) {
      for (int p = 0; p < m->ngeom; p++) {
        if (m->geom_type[p] == mjGEOM_PLANE && dynamicPair(m, p, g)) {
          snprintf(pair, sizeof(pair), "%s - %s", ost_objName(m, mjOBJ_GEOM, p, nb, sizeof(nb)),
                   ost_objName(m, mjOBJ_GEOM, g, nb2, sizeof(nb2)));
          ost_refuse(l, "geom pair", pair, "plane-mesh contacts, which need the mesh's "
                     "convex-hull graph that the native geometry provider does not pack yet");
        }
      }
    }
    if (t == mjGEOM_HFIELD && m->body_weldid[m->geom_bodyid[g]] != 0) {
      ost_refuse(l, "geom", ost_objName(m, mjOBJ_GEOM, g, nb, sizeof(nb)),
                 "a moving height field (the native geometry provider needs it static, "
                 "attached to the world)");
    }
  }
}


int ost_checkNativeList(const mjModel* m, ostRefusal* out, int nout) {
  if (!m || nout < 0 || (nout > 0 && !out)) {
    return -1;
  }
  ostRefusal item[OST_REFUSAL_CAP];
  ostRefusalList l = {item, OST_REFUSAL_CAP, 0, 0};
  ost_refusalsNative(m, &l);
  for (int i = 0; i < l.n && i < nout; i++) {
    out[i] = item[i];
  }
  return l.n + l.extra;
}


int ost_checkNative(const mjModel* m, char* err, int err_sz) {
  if (!m) {
    return -1;
  }
  ostRefusal item[OST_REFUSAL_CAP];
  ostRefusalList l = {item, OST_REFUSAL_CAP, 0, 0};
  ost_refusalsNative(m, &l);
  return ost_refusalMessage(&l, "unsupported by the native geometry provider", err, err_sz);
}


// append candidate pair (g1, g2) with its contact parameters (friction: sliding, torsional,
// rolling); geoms ordered by type as MuJoCo
static void addPair(ostModel* om, int* n, const mjModel* m, int terrain, int g1, int g2,
                    int condim, mjtNum margin, mjtNum gap, const mjtNum friction[3]) {
  // a terrain mesh goes first, like a height field, so normals point from the terrain out
  if (g2 == terrain || (g1 != terrain && m->geom_type[g1] > m->geom_type[g2])) {
    int t = g1;
    g1 = g2;
    g2 = t;
  }
  if (om) {
    om->pair_geom1[*n] = g1;
    om->pair_geom2[*n] = g2;
    om->pair_condim[*n] = condim;
    om->pair_margin[*n] = margin;
    om->pair_gap[*n] = gap;
    om->pair_friction[*n] = friction[0];
    om->pair_torsion[*n] = friction[1];
    om->pair_rolling[*n] = friction[2];
  }
  (*n)++;
}


// 1 if geom types t1, t2 (either order) are a pair that both providers collide with core's own
// functions: cylinder-box (ost_collision_cylbox.h), ellipsoid-box, -sphere and -capsule
// (_ellipsoid.h), ellipsoid-mesh (_ellmesh.h), sphere and capsule against cylinder and mesh
// (_ball.h): exact signed distances where MPR's depth and normal are off; height
// field-primitive (_terrain.h and _cylsurf.h: true gaps within the look-ahead, where MuJoCo
// 2.2.2 reports -depth),
// plane-mesh and plane-cylinder (ost_collision_primitive.h: contact sets that move continuously),
// box-box (ost_collision_boxbox.h: the signed distance, where MuJoCo reports half of it)
static int coreTypes(int t1, int t2) {
  int lo = t1 < t2 ? t1 : t2, hi = t1 < t2 ? t2 : t1;
  return ((lo == mjGEOM_CYLINDER || lo == mjGEOM_ELLIPSOID) && hi == mjGEOM_BOX)
         || (lo == mjGEOM_ELLIPSOID && hi == mjGEOM_MESH)
         || ((lo == mjGEOM_SPHERE || lo == mjGEOM_CAPSULE)
             && (hi == mjGEOM_ELLIPSOID || hi == mjGEOM_CYLINDER || hi == mjGEOM_MESH))
         || (lo == mjGEOM_HFIELD && hi > mjGEOM_HFIELD && hi != mjGEOM_MESH)
         || (lo == mjGEOM_PLANE && (hi == mjGEOM_MESH || hi == mjGEOM_CYLINDER))
         || (lo == mjGEOM_BOX && hi == mjGEOM_BOX);
}


int ost_corePair(const mjModel* m, int g1, int g2) {
  return coreTypes(m->geom_type[g1], m->geom_type[g2]);
}


// MuJoCo's friction of geoms g1, g2 (sliding, torsional, rolling; mj_contactParam): the larger
// of each coefficient, unless one geom has the higher priority: then its own
void ost_mixFriction(const mjModel* m, int g1, int g2, mjtNum fr[3]) {
  int p1 = m->geom_priority[g1], p2 = m->geom_priority[g2];
  for (int k = 0; k < 3; k++) {
    fr[k] = p1 > p2   ? m->geom_friction[3 * g1 + k]
            : p2 > p1 ? m->geom_friction[3 * g2 + k]
                      : mju_max(m->geom_friction[3 * g1 + k], m->geom_friction[3 * g2 + k]);
  }
}


// candidate pairs into om (NULL: count only), only core pairs (coreTypes) if core_only;
// explicit pairs first, as MuJoCo
static int candidatePairs(const mjModel* m, ostModel* om, int core_only) {
  int n = 0, terrain = ost_terrainGeom(m);
  if (m->opt.disableflags & mjDSBL_CONTACT) {
    return 0;
  }
  for (int i = 0; i < m->npair; i++) {
    int g1 = m->pair_geom1[i], g2 = m->pair_geom2[i];
    if (core_only && !coreTypes(m->geom_type[g1], m->geom_type[g2])) {
      continue;
    }
    if (typesCollide(m->geom_type[g1] < m->geom_type[g2] ? m->geom_type[g1] : m->geom_type[g2],
                     m->geom_type[g1] < m->geom_type[g2] ? m->geom_type[g2] : m->geom_type[g1])) {
      // MuJoCo's 5 coefficients (t1, t2, torsion, roll1, roll2); anisotropy is refused
      const mjtNum* f = m->pair_friction + 5 * i;
      mjtNum fr[3] = {f[0], f[2], f[3]};
      addPair(om, &n, m, terrain, g1, g2, m->pair_dim[i], m->pair_margin[i], m->pair_gap[i], fr);
    }
  }
  for (int g1 = 0; g1 < m->ngeom; g1++) {
    for (int g2 = g1 + 1; g2 < m->ngeom; g2++) {
      int t1 = m->geom_type[g1], t2 = m->geom_type[g2];
      if ((core_only && !coreTypes(t1, t2)) || !typesCollide(t1 < t2 ? t1 : t2, t1 < t2 ? t2 : t1)
          || !dynamicPair(m, g1, g2)) {
        continue;
      }
      int condim = m->geom_condim[g1] > m->geom_condim[g2] ? m->geom_condim[g1]
                                                            : m->geom_condim[g2];
      mjtNum margin = mju_max(m->geom_margin[g1], m->geom_margin[g2]);
      mjtNum gap = mju_max(m->geom_gap[g1], m->geom_gap[g2]);
      mjtNum fr[3];
      ost_mixFriction(m, g1, g2, fr);
      if (m->geom_priority[g1] != m->geom_priority[g2]) {
        condim = m->geom_condim[m->geom_priority[g1] > m->geom_priority[g2] ? g1 : g2];
      }
      addPair(om, &n, m, terrain, g1, g2, condim, margin, gap, fr);
    }
  }
  return n;
}


// the terrain mesh of geom g as an ostTerrain in the world frame: its vertices mapped through
// the geom's pose into vert (3 x nvert, caller-sized), faces from m, grid geometry (about four
// faces per cell) and base 0.5 m below the lowest vertex (the prisms' bottom)
static void terrainOf(const mjModel* m, int g, ostNum* vert, ostTerrain* t) {
  int id = m->geom_dataid[g];
  mjtNum R[9];
  mju_quat2Mat(R, m->geom_quat + 4 * g);
  memset(t, 0, sizeof(*t));
  t->nvert = m->mesh_vertnum[id];
  t->nface = m->mesh_facenum[id];
  t->vert = vert;
  t->face = m->mesh_face + 3 * m->mesh_faceadr[id];
  mjtNum zmin = HUGE_VAL;
  for (int v = 0; v < t->nvert; v++) {
    const float* p = m->mesh_vert + 3 * (m->mesh_vertadr[id] + v);
    mjtNum local[3] = {p[0], p[1], p[2]};
    mju_mulMatVec(vert + 3 * v, R, local, 3, 3);
    mju_addTo3(vert + 3 * v, m->geom_pos + 3 * g);
    zmin = mju_min(zmin, vert[3 * v + 2]);
  }
  t->base = zmin - 0.5;
  ostu_terrainGridInit(t, 0, 0);
}


int ost_packModel(const mjModel* m, int ncon_max, ostModel* om, void** block, char* err,
                  int err_sz) {
  int status = ost_checkNative(m, err, err_sz);
  if (status) {
    return status;
  }
  int terrain = ost_terrainGeom(m);

  // sizes
  ostSizes s;
  memset(&s, 0, sizeof(s));
  s.nq = m->nq;
  s.nv = m->nv;
  s.nbody = m->nbody;
  s.njnt = m->njnt;
  s.ngeom = m->ngeom;
  s.nu = m->nu;
  s.na = m->na;
  s.npair = candidatePairs(m, NULL, 0);
  s.nmesh = m->nmesh;
  s.nmeshvert = m->nmeshvert;
  s.nhfield = m->nhfield;
  s.nhfielddata = m->nhfielddata;
  s.ncon_max = ncon_max;
  s.ncol = ostu_rowWidth(m->dof_parentid, m->nv);
  ostNum* tvert = NULL;
  ostTerrain t;
  if (terrain >= 0) {
    tvert = (ostNum*)malloc(3 * sizeof(ostNum) * m->mesh_vertnum[m->geom_dataid[terrain]]);
    if (!tvert) {
      if (err) snprintf(err, err_sz, "cannot allocate the terrain mesh");
      return OST_ERR_MEMORY;
    }
    terrainOf(m, terrain, tvert, &t);
    s.nmeshface = t.nface;
    s.ncell = t.gnx * t.gny;
    s.ncellface = ostu_terrainGridSize(&t);
  }
  // the hull triangles of the other meshes (MuJoCo's convex-hull graph), for ellipsoid-mesh
  // contacts (core/ost_collision_ellmesh.h)
  for (int id = 0; id < m->nmesh; id++) {
    if (m->mesh_graphadr[id] >= 0 && (terrain < 0 || id != m->geom_dataid[terrain])) {
      s.nmeshface += m->mesh_graph[m->mesh_graphadr[id] + 1];
    }
  }

  // one block for every array
  size_t sz = ostu_modelSize(s);
  void* buf = aligned_alloc(64, OST_ALIGN64(sz > 0 ? sz : 64));
  if (!buf) {
    free(tvert);
    if (err) snprintf(err, err_sz, "cannot allocate the packed model (%zu bytes)", sz);
    return OST_ERR_MEMORY;
  }
  memset(buf, 0, sz);
  memset(om, 0, sizeof(ostModel));
  om->s = s;
  ostu_modelInit(om, buf);
  *block = buf;
  for (int k = 0; k < 3; k++) {
    om->gravity[k] = m->opt.gravity[k];
  }
  om->mpr_tolerance = m->opt.mpr_tolerance;
  om->mpr_iterations = m->opt.mpr_iterations;
  om->disableflags = m->opt.disableflags;

  // bodies, joints, dofs
#define COPY(dst, src, n)                          \
  for (int i_ = 0; i_ < (n); i_++) (dst)[i_] = (src)[i_];
  COPY(om->body_parentid, m->body_parentid, s.nbody);
  COPY(om->body_rootid, m->body_rootid, s.nbody);
  COPY(om->body_jntnum, m->body_jntnum, s.nbody);
  COPY(om->body_jntadr, m->body_jntadr, s.nbody);
  COPY(om->body_dofnum, m->body_dofnum, s.nbody);
  COPY(om->body_dofadr, m->body_dofadr, s.nbody);
  COPY(om->body_pos, m->body_pos, 3 * s.nbody);
  COPY(om->body_quat, m->body_quat, 4 * s.nbody);
  COPY(om->body_ipos, m->body_ipos, 3 * s.nbody);
  COPY(om->body_iquat, m->body_iquat, 4 * s.nbody);
  COPY(om->body_mass, m->body_mass, s.nbody);
  COPY(om->body_inertia, m->body_inertia, 3 * s.nbody);
  COPY(om->jnt_type, m->jnt_type, s.njnt);
  COPY(om->jnt_qposadr, m->jnt_qposadr, s.njnt);
  COPY(om->jnt_dofadr, m->jnt_dofadr, s.njnt);
  COPY(om->jnt_bodyid, m->jnt_bodyid, s.njnt);
  COPY(om->jnt_limited, m->jnt_limited, s.njnt);
  COPY(om->jnt_pos, m->jnt_pos, 3 * s.njnt);
  COPY(om->jnt_axis, m->jnt_axis, 3 * s.njnt);
  COPY(om->jnt_stiffness, m->jnt_stiffness, s.njnt);
  COPY(om->jnt_range, m->jnt_range, 2 * s.njnt);
  COPY(om->jnt_margin, m->jnt_margin, s.njnt);
  COPY(om->dof_bodyid, m->dof_bodyid, s.nv);
  COPY(om->dof_jntid, m->dof_jntid, s.nv);
  COPY(om->dof_parentid, m->dof_parentid, s.nv);
  COPY(om->dof_armature, m->dof_armature, s.nv);
  COPY(om->dof_damping, m->dof_damping, s.nv);
  COPY(om->dof_frictionloss, m->dof_frictionloss, s.nv);
  COPY(om->qpos_spring, m->qpos_spring, s.nq);

  // geoms
  COPY(om->geom_type, m->geom_type, s.ngeom);
  COPY(om->geom_bodyid, m->geom_bodyid, s.ngeom);
  COPY(om->geom_dataid, m->geom_dataid, s.ngeom);
  COPY(om->geom_pos, m->geom_pos, 3 * s.ngeom);
  COPY(om->geom_quat, m->geom_quat, 4 * s.ngeom);
  COPY(om->geom_size, m->geom_size, 3 * s.ngeom);
  COPY(om->geom_rbound, m->geom_rbound, s.ngeom);
  if (terrain >= 0) {
    om->geom_terrain[terrain] = 1;
  }
  candidatePairs(m, om, 0);
  for (int p = 0; p < s.npair; p++) {
    om->geom_paired[om->pair_geom1[p]] = om->geom_paired[om->pair_geom2[p]] = 1;
  }

  // meshes: all vertices (the support of a convex mesh over them equals its hull's) and the
  // hull's triangles; the terrain mesh keeps its faces and grid instead
  COPY(om->mesh_vertadr, m->mesh_vertadr, s.nmesh);
  COPY(om->mesh_vertnum, m->mesh_vertnum, s.nmesh);
  COPY(om->mesh_vert, m->mesh_vert, 3 * s.nmeshvert);
  if (terrain >= 0) {
    // world-frame vertices (the terrain is static on the world body), faces and grid
    int id = m->geom_dataid[terrain];
    om->mesh_faceadr[id] = 0;
    om->mesh_facenum[id] = t.nface;
    COPY(om->mesh_vert + 3 * m->mesh_vertadr[id], tvert, 3 * t.nvert);
    COPY(om->mesh_face, t.face, 3 * t.nface);
    int* grid = om->mesh_grid + 3 * id;
    ostNum* box = om->mesh_gridbox + 5 * id;
    grid[0] = t.gnx;
    grid[1] = t.gny;
    grid[2] = 0;
    box[0] = t.gx0;
    box[1] = t.gy0;
    box[2] = t.gdx;
    box[3] = t.gdy;
    box[4] = t.base;
    ostu_terrainGridBuild(om->cell_adr, om->cell_num, om->cell_face, &t);
    free(tvert);
  }
  // hull triangles after the terrain's: MuJoCo's face_globalid (graph: numvert, numface,
  // vert_edgeadr[numvert], vert_globalid[numvert], edge_localid[numvert + 3 numface],
  // face_globalid[3 numface]) are ids within the mesh's vertices, as packed here
  for (int id = 0, f = terrain >= 0 ? om->mesh_facenum[m->geom_dataid[terrain]] : 0;
       id < m->nmesh; id++) {
    if (m->mesh_graphadr[id] >= 0 && (terrain < 0 || id != m->geom_dataid[terrain])) {
      const int* graph = m->mesh_graph + m->mesh_graphadr[id];
      om->mesh_faceadr[id] = f;
      om->mesh_facenum[id] = graph[1];
      COPY(om->mesh_face + 3 * f, graph + 2 + 3 * graph[0] + 3 * graph[1], 3 * graph[1]);
      f += graph[1];
    }
  }

  // height fields
  COPY(om->hfield_nrow, m->hfield_nrow, s.nhfield);
  COPY(om->hfield_ncol, m->hfield_ncol, s.nhfield);
  COPY(om->hfield_adr, m->hfield_adr, s.nhfield);
  COPY(om->hfield_size, m->hfield_size, 4 * s.nhfield);
  COPY(om->hfield_data, m->hfield_data, s.nhfielddata);

  // actuators
  for (int i = 0; i < s.nu; i++) {
    om->actuator_trnid[i] = m->actuator_trnid[2 * i];
    om->actuator_servo[i] = ost_actuatorKind(m, i, NULL, 0) == 1;
    om->actuator_ctrllimited[i] = m->actuator_ctrllimited[i];
    om->actuator_forcelimited[i] = m->actuator_forcelimited[i];
    om->actuator_gear[i] = m->actuator_gear[6 * i];
    // gain and bias by type: MuJoCo reads biasprm only for an affine bias, and a muscle's
    // parameters are its curves' (gainmus, biasmus: core/ost_muscle.h)
    om->actuator_gaintype[i] = m->actuator_gaintype[i];
    om->actuator_biastype[i] = m->actuator_biastype[i];
    om->actuator_gainprm[i] = m->actuator_gainprm[mjNGAIN * i];
    if (m->actuator_biastype[i] == mjBIAS_AFFINE) {
      COPY(om->actuator_biasprm + 3 * i, m->actuator_biasprm + mjNBIAS * i, 3);
    }
    COPY(om->actuator_gainmus + 9 * i, m->actuator_gainprm + mjNGAIN * i, 9);
    COPY(om->actuator_biasmus + 9 * i, m->actuator_biasprm + mjNBIAS * i, 9);
    COPY(om->actuator_lengthrange + 2 * i, m->actuator_lengthrange + 2 * i, 2);
    om->actuator_acc0[i] = m->actuator_acc0[i];
    COPY(om->actuator_ctrlrange + 2 * i, m->actuator_ctrlrange + 2 * i, 2);
    COPY(om->actuator_forcerange + 2 * i, m->actuator_forcerange + 2 * i, 2);
    // activation i - (nu - na) belongs to actuator i (mj_fwdActuation)
    om->actuator_dyntype[i] = m->actuator_dyntype[i];
    om->actuator_actadr[i] = m->actuator_dyntype[i] == mjDYN_NONE ? -1 : i - (s.nu - s.na);
    om->actuator_actlimited[i] = m->actuator_actlimited[i];
    COPY(om->actuator_dynprm + 2 * i, m->actuator_dynprm + mjNDYN * i, 2);
    COPY(om->actuator_actrange + 2 * i, m->actuator_actrange + 2 * i, 2);
  }
#undef COPY
  return OST_OK;
}


int ost_packCorePairs(const mjModel* m, ostModel* pairs, void** block) {
  free(*block);
  *block = NULL;
  memset(pairs, 0, sizeof(*pairs));
  int n = candidatePairs(m, NULL, 1);
  if (n == 0) {
    return OST_OK;
  }
  size_t ints = 3 * (size_t)n * sizeof(int), nums = 5 * (size_t)n * sizeof(ostNum);
  char* b = malloc(ints + nums);
  if (!b) {
    return OST_ERR_MEMORY;
  }
  *block = b;
  pairs->s.npair = n;
  // the ostNum arrays first: malloc aligns them, and after 3 n ints they would not be for odd n
  pairs->pair_margin = (ostNum*)b;
  pairs->pair_gap = pairs->pair_margin + n;
  pairs->pair_friction = pairs->pair_gap + n;
  pairs->pair_torsion = pairs->pair_friction + n;
  pairs->pair_rolling = pairs->pair_torsion + n;
  pairs->pair_geom1 = (int*)(b + nums);
  pairs->pair_geom2 = pairs->pair_geom1 + n;
  pairs->pair_condim = pairs->pair_geom2 + n;
  candidatePairs(m, pairs, 1);
  return OST_OK;
}
