// ost_rows_mujoco.c: the `mujoco` geometry provider. At a Newton iterate q it runs MuJoCo's own
// kinematics, transmission and collision on the private model (margins widened by the
// look-ahead distance) and packs the constraint rows of the core solver: equality and joint
// limit rows from MuJoCo's efc rows, contact rows from d->contact and mj_jac (except
// cylinder-box and height field-cylinder pairs, whose contacts come from core's own functions
// at MuJoCo's geom poses, as in the native provider), servo rows from the actuators. Invariant: rows are produced in a deterministic order, so that evaluating the
// same q twice yields identical rows (the best iterate is re-evaluated by index).
#include <math.h>
#include <string.h>

#include "ost_collision_ball.h"
#include "ost_collision_boxbox.h"
#include "ost_collision_cylbox.h"
#include "ost_collision_ellipsoid.h"
#include "ost_collision_ellmesh.h"
#include "ost_collision_gjk.h"
#include "ost_collision_terrain.h"
#include "ost_internal.h"

// row i of a MuJoCo Jacobian (efc_J, ten_J) into the dense row J (nv): from the compressed rows
// (rowadr, rownnz, colind) when the model is sparse, else a copy of the dense row
static void denseRow(const mjModel* m, const mjtNum* val, const int* rowadr, const int* rownnz,
                     const int* colind, int i, mjtNum* J) {
  int nv = m->nv;
  if (mj_isSparse(m)) {
    memset(J, 0, nv * sizeof(mjtNum));
    for (int k = 0; k < rownnz[i]; k++) {
      J[colind[rowadr[i] + k]] = val[rowadr[i] + k];
    }
  } else {
    memcpy(J, val + (size_t)i * nv, nv * sizeof(mjtNum));
  }
}


// copy efc row i of d into the dense row J (nv); *cols, *k: the columns that may be non-zero
// when the model's Jacobians are sparse (efc_J_colind), else NULL and 0
static void efcRow(const mjModel* m, const mjData* d, int i, ostNum* J, const int** cols,
                   int* k) {
  denseRow(m, d->efc_J, d->efc_J_rowadr, d->efc_J_rownnz, d->efc_J_colind, i, J);
  int sparse = mj_isSparse(m);
  *cols = sparse ? d->efc_J_colind + d->efc_J_rowadr[i] : NULL;
  *k = sparse ? d->efc_J_rownnz[i] : 0;
}


void ost_tendonRow(const mjModel* m, const mjData* d, int t, mjtNum* J) {
  denseRow(m, d->ten_J, d->ten_J_rowadr, d->ten_J_rownnz, d->ten_J_colind, t, J);
}


// the translational Jacobian of body b at pos, on b's dof chain only, into jac (3 x nv, rows
// apart by nv; entries off the chain are left as they are), as mj_jac computes it
// (engine_support.c): column j = cdof_lin + cdof_ang x (pos - subtree_com of b's root); and
// the rotational Jacobian (column j = cdof_ang) into jacr unless it is NULL.
// Returns the chain's last dof, or -1 if b moves with the world.
static int chainJacobian(const mjModel* m, const mjData* d, mjtNum* jac, mjtNum* jacr,
                         const mjtNum pos[3], int b) {
  int nv = m->nv;
  mjtNum offset[3], tmp[3];
  mju_sub3(offset, pos, d->subtree_com + 3 * m->body_rootid[b]);
  while (b && !m->body_dofnum[b]) {
    b = m->body_parentid[b];
  }
  if (!b) {
    return -1;
  }
  int last = m->body_dofadr[b] + m->body_dofnum[b] - 1;
  for (int j = last; j >= 0; j = m->dof_parentid[j]) {
    const mjtNum* cdof = d->cdof + 6 * j;
    mju_cross(tmp, cdof, offset);
    jac[j] = cdof[3] + tmp[0];
    jac[nv + j] = cdof[4] + tmp[1];
    jac[2 * nv + j] = cdof[5] + tmp[2];
    if (jacr) {
      jacr[j] = cdof[0];
      jacr[nv + j] = cdof[1];
      jacr[2 * nv + j] = cdof[2];
    }
  }
  return last;
}


// zero the rows (apart by nv) of jac on the dof chain ending at last
static void chainZero(const mjModel* m, mjtNum* jac, int rows, int last) {
  for (int j = last; j >= 0; j = m->dof_parentid[j]) {
    for (int r = 0; r < rows; r++) {
      jac[r * m->nv + j] = 0;
    }
  }
}


// the normal row and the nf friction rows of the given slots and scales (apart by nv in J) of a
// contact on dof chain `last` (the arithmetic of osti_contactRows and osti_frictionJacobian,
// column by column) from the translational (j1, j2) and rotational (r1, r2) Jacobians; returns
// 1 if a column of the normal row is non-zero
static int chainRows(const mjModel* m, const mjtNum frame[9], const mjtNum* j1, const mjtNum* j2,
                     const mjtNum* r1, const mjtNum* r2, int last, int nf, const int* slot,
                     const mjtNum* scale, ostNum* J) {
  int nv = m->nv, any = 0;
  for (int j = last; j >= 0; j = m->dof_parentid[j]) {
    mjtNum dx = j2[j] - j1[j], dy = j2[nv + j] - j1[nv + j], dz = j2[2 * nv + j] - j1[2 * nv + j];
    J[j] = frame[0] * dx + frame[1] * dy + frame[2] * dz;
    for (int f = 0; f < nf; f++) {
      const mjtNum* e = frame + 3 * osti_slotAxis(slot[f]);
      mjtNum x = dx, y = dy, z = dz;
      if (slot[f] >= 3) {
        x = r2[j] - r1[j];
        y = r2[nv + j] - r1[nv + j];
        z = r2[2 * nv + j] - r1[2 * nv + j];
      }
      J[(size_t)(1 + f) * nv + j] = scale[f] * (e[0] * x + e[1] * y + e[2] * z);
    }
    any |= J[j] != 0;
  }
  return any;
}


// osti_normalMoves over the dofs of the chains ending at last1 and last2 (a dof the two share is
// counted twice in both sums) of a frictionless contact's normal row J and its bodies' point
// Jacobians j1, j2 (3 x nv each)
static int normalMoves(const mjModel* m, const mjtNum* j1, const mjtNum* j2, const ostNum* J,
                       int last1, int last2) {
  int nv = m->nv, last[2] = {last1, last2};
  mjtNum jn2 = 0, rel2 = 0;
  for (int b = 0; b < 2; b++) {
    for (int j = last[b]; j >= 0; j = m->dof_parentid[j]) {
      mjtNum dx = j2[j] - j1[j], dy = j2[nv + j] - j1[nv + j], dz = j2[2 * nv + j] - j1[2 * nv + j];
      jn2 += J[j] * J[j];
      rel2 += dx * dx + dy * dy + dz * dz;
    }
  }
  return osti_normalMoves(jn2, rel2);
}


// the rows of a contact between geoms g1, g2 at pos with frame into J (rows apart by nv, zero
// on entry and zero off the two bodies' dof chains): the normal and nf friction rows, frame rows
// times (J(body2) - J(body1)) at the contact point, computed on the chains only (O(depth), not
// O(nv)). c->jac (12 nv: translational and rotational of both bodies) is zero between calls.
// Returns 0 if the contact moves no degree of freedom (a frictionless one: beyond rounding);
// *last1, *last2 get the chains (for chainZero after the rows are stored).
static int contactJacobian(ostContext* c, const mjData* d, int g1, int g2, const mjtNum pos[3],
                           const mjtNum frame[9], int nf, const int* slot, const mjtNum* scale,
                           ostNum* J, int* last1, int* last2) {
  const mjModel* m = c->mo;
  int nv = m->nv, rot = nf > 0 && slot[nf - 1] >= 3;
  mjtNum* j1 = c->jac;
  mjtNum* j2 = c->jac + 3 * nv;
  mjtNum* r1 = c->jac + 6 * nv;
  mjtNum* r2 = c->jac + 9 * nv;
  int b1 = m->geom_bodyid[g1], b2 = m->geom_bodyid[g2];
  *last1 = b1 > 0 ? chainJacobian(m, d, j1, rot ? r1 : NULL, pos, b1) : -1;
  *last2 = b2 > 0 ? chainJacobian(m, d, j2, rot ? r2 : NULL, pos, b2) : -1;
  int any = chainRows(m, frame, j1, j2, r1, r2, *last1, nf, slot, scale, J);
  any |= chainRows(m, frame, j1, j2, r1, r2, *last2, nf, slot, scale, J);
  if (nf == 0 && any) {
    any = normalMoves(m, j1, j2, J, *last1, *last2);
  }
  chainZero(m, j1, 3, *last1);
  chainZero(m, j2, 3, *last2);
  chainZero(m, r1, 3, *last1);
  chainZero(m, r2, 3, *last2);
  return any;
}


// matching key of a contact of geoms g1, g2 at pos (see ost_contactKey)
static void contactKeyOf(const mjModel* m, const mjData* d, int g1, int g2, const mjtNum pos[3],
                         mjtNum key[3]) {
  int b = m->geom_bodyid[g2];
  if (b == 0) {
    b = m->geom_bodyid[g1];
  }
  osti_contactKeyOf(key, pos, d->xpos + 3 * b, d->xmat + 9 * b);
}


void ost_contactKey(const mjModel* m, const mjData* d, const mjContact* con, mjtNum key[3]) {
  contactKeyOf(m, d, con->geom1, con->geom2, con->pos, key);
}


// 1 if efc row i (a tendon limit) is its tendon's lower limit: MuJoCo's lower-side distance
// is L - lo, the upper side's hi - L (mj_instantiateLimit)
static int tendonLowerSide(const mjModel* m, const mjData* d, int i) {
  int t = d->efc_id[i];
  mjtNum L = d->ten_length[t], lo = m->tendon_range[2 * t], hi = m->tendon_range[2 * t + 1];
  return mju_abs(d->efc_pos[i] - (L - lo)) <= mju_abs(d->efc_pos[i] - (hi - L));
}


static int widthOverflow(ostContext* c) {
  return ost_fail(c, OST_ERR_OVERFLOW, "a constraint row touches more than %d dofs (the width "
                  "sized from the model's kinematic tree and tendons)", c->world.ncol);
}


// append the rows of one contact at rows[*n]: normal, then the friction rows of its condim and
// coefficients fr (sliding, torsional, rolling; osti_frictionSlots); dist is the row's gap (the
// user's margin - gap, with the look-ahead: dist - gap = row pos)
static int contactRows(ostContext* c, const mjData* d, int g1, int g2, const mjtNum pos[3],
                       const mjtNum frame[9], mjtNum dist, int condim, const mjtNum fr[3],
                       int* n) {
  ostWorld* w = &c->world;
  int slot[OST_MAXFRIC];
  mjtNum scale[OST_MAXFRIC];
  int nf = osti_frictionSlots(condim, fr[0], fr[1], fr[2], slot, scale);
  if (*n + 1 + nf > w->nrow_max) {
    return ost_capacityFail(c, "row", w->nrow_max);
  }
  ostNum* J = osti_rowScratch(w, *n);  // zero off the chains (ost_rowsMujoco)
  int last1, last2;
  int moves = contactJacobian(c, d, g1, g2, pos, frame, nf, slot, scale, J, &last1, &last2);
  int wide = moves && osti_rowStoreChains(w, *n, 1 + nf, last1, last2);
  chainZero(c->mo, J, 1 + nf, last1);  // keep the scratch zero for the next contact
  chainZero(c->mo, J, 1 + nf, last2);
  if (!moves) {
    return OST_OK;
  }
  if (wide) {
    return widthOverflow(c);
  }
  for (int k = 0; k <= nf; k++) {
    ostRow* r = w->rows + *n + k;
    memset(r, 0, sizeof(ostRow));
    r->type = k == 0 ? OST_ROW_CONTACT : OST_ROW_FRICTION;
    r->normal = k == 0 ? -1 : *n;
    r->obj[0] = g1;
    r->obj[1] = g2;
    contactKeyOf(c->mo, d, g1, g2, pos, r->key);
    r->pos = dist;
    r->mu = fr[0];
    if (k > 0) {
      r->alpha = scale[k - 1];
      r->lo = slot[k - 1];
    }
  }
  *n += 1 + nf;
  return OST_OK;
}


// geom g of m placed at d's kinematics, as core's collision functions see it (primitive types
// and height fields: no mesh vertices)
static void placedGeom(const mjModel* m, const mjData* d, int g, ostGeom* out) {
  memset(out, 0, sizeof(*out));
  out->type = m->geom_type[g];
  out->rbound = m->geom_rbound[g];
  for (int i = 0; i < 3; i++) {
    out->size[i] = m->geom_size[3 * g + i];
    out->pos[i] = d->geom_xpos[3 * g + i];
  }
  memcpy(out->mat, d->geom_xmat + 9 * g, 9 * sizeof(mjtNum));
}


// the count floats of src as ostNum in *buf (*n entries), reallocated when the count changed
static int floatsAsNum(const float* src, int count, ostNum** buf, int* n) {
  if (*n != count) {
    free(*buf);
    *buf = count ? malloc((size_t)count * sizeof(ostNum)) : NULL;
    *n = *buf ? count : 0;
    if (count && !*buf) {
      return OST_ERR_MEMORY;
    }
  }
  for (int i = 0; i < *n; i++) {
    (*buf)[i] = src[i];
  }
  return OST_OK;
}


int ost_hfieldData(const mjModel* m, ostNum** buf, int* n) {
  return floatsAsNum(m->hfield_data, m->nhfielddata, buf, n);
}


void ost_meshFree(ostMeshes* mesh) {
  free(mesh->vert);
  free(mesh->face);
  free(mesh->faceadr);
  free(mesh->facenum);
  memset(mesh, 0, sizeof(*mesh));
}


int ost_meshData(const mjModel* m, ostMeshes* mesh) {
  ost_meshFree(mesh);
  int nface = 0, nvert = 0;
  for (int id = 0; id < m->nmesh; id++) {
    nface += m->mesh_graphadr[id] >= 0 ? m->mesh_graph[m->mesh_graphadr[id] + 1] : 0;
    nvert = m->mesh_vertnum[id] > nvert ? m->mesh_vertnum[id] : nvert;
  }
  int* local = malloc(((size_t)nvert + 1) * sizeof(int));  // a mesh's vertex id -> hull id
  mesh->vert = malloc((3 * (size_t)m->nmeshvert + 1) * sizeof(ostNum));
  mesh->face = malloc((3 * (size_t)nface + 1) * sizeof(int));
  mesh->faceadr = calloc((size_t)m->nmesh + 1, sizeof(int));
  mesh->facenum = calloc((size_t)m->nmesh + 1, sizeof(int));
  if (!local || !mesh->vert || !mesh->face || !mesh->faceadr || !mesh->facenum) {
    free(local);
    ost_meshFree(mesh);
    return OST_ERR_MEMORY;
  }
  for (int i = 0; i < 3 * m->nmeshvert; i++) {
    mesh->vert[i] = m->mesh_vert[i];
  }
  // a mesh with a convex hull (MuJoCo's graph: numvert, numface, vert_edgeadr[numvert],
  // vert_globalid[numvert], edge_localid[numvert + 3 numface], face_globalid[3 numface])
  // lists the hull's vertices first in its slot: a support point is the largest of those (the
  // Shadow Hand's fingertip: 1,065 of 16,122 vertices); its triangles by those first ids
  for (int id = 0, f = 0; id < m->nmesh; id++) {
    if (m->mesh_graphadr[id] < 0) {
      continue;
    }
    const int* graph = m->mesh_graph + m->mesh_graphadr[id];
    int nv = graph[0], nf = graph[1];
    const int* globalid = graph + 2 + nv;
    const int* face = graph + 2 + 2 * nv + nv + 3 * nf;
    const float* src = m->mesh_vert + 3 * (size_t)m->mesh_vertadr[id];
    ostNum* dst = mesh->vert + 3 * (size_t)m->mesh_vertadr[id];
    for (int v = 0; v < nv; v++) {
      for (int k = 0; k < 3; k++) dst[3 * v + k] = src[3 * globalid[v] + k];
      local[globalid[v]] = v;
    }
    mesh->faceadr[id] = f;
    mesh->facenum[id] = nf;
    for (int i = 0; i < 3 * nf; i++) {
      mesh->face[3 * f + i] = local[face[i]];
    }
    f += nf;
  }
  free(local);
  return OST_OK;
}


// mesh geom g's vertices (the hull's, else all) and hull triangles from mesh into out
static void meshGeom(const mjModel* m, const ostMeshes* mesh, int g, ostGeom* out) {
  int id = m->geom_dataid[g];
  out->nvert = m->mesh_graphadr[id] >= 0 ? m->mesh_graph[m->mesh_graphadr[id]]
                                         : m->mesh_vertnum[id];
  out->vert = mesh->vert + 3 * (size_t)m->mesh_vertadr[id];
  out->nface = mesh->facenum[id];
  out->face = mesh->face + 3 * (size_t)mesh->faceadr[id];
}


int ost_collideCorePair(const mjModel* m, const mjData* d, const ostNum* hfield_data,
                        const ostMeshes* mesh, int g1, int g2, ostNum margin, ostContact* con) {
  ostGeom a, b;
  if (m->geom_type[g1] > m->geom_type[g2]) {
    int t = g1;
    g1 = g2;
    g2 = t;
  }
  placedGeom(m, d, g1, &a);
  placedGeom(m, d, g2, &b);
  if (a.type == mjGEOM_HFIELD) {
    int id = m->geom_dataid[g1];
    ostHField hf;
    hf.nrow = m->hfield_nrow[id];
    hf.ncol = m->hfield_ncol[id];
    for (int i = 0; i < 4; i++) {
      hf.size[i] = m->hfield_size[4 * id + i];
    }
    hf.data = hfield_data + m->hfield_adr[id];
    return osti_collideHField(con, OST_MAXCONPAIR, &hf, &a, &b, margin, m->opt.mpr_tolerance,
                              m->opt.mpr_iterations);
  }
  // a plane's pair whose other geom's bounding sphere lies above the plane by more than the
  // margin has no contact (MuJoCo's plane filter): the hull scans below need not run
  if (a.type == mjGEOM_PLANE) {
    mjtNum dx[3] = {b.pos[0] - a.pos[0], b.pos[1] - a.pos[1], b.pos[2] - a.pos[2]};
    mjtNum above = a.mat[2] * dx[0] + a.mat[5] * dx[1] + a.mat[8] * dx[2];
    if (above > b.rbound + margin) {
      return 0;
    }
  }
  if (a.type == mjGEOM_PLANE && b.type == mjGEOM_MESH) {
    // the hull's vertices (mesh_graph: numvert, numface, vert_edgeadr, vert_globalid, ...)
    int id = m->geom_dataid[g2];
    const float* vert = m->mesh_vert + 3 * m->mesh_vertadr[id];
    if (m->mesh_graphadr[id] < 0) {
      return osti_collidePlaneHull(con, &a, &b, vert, NULL, m->mesh_vertnum[id], margin);
    }
    const int* graph = m->mesh_graph + m->mesh_graphadr[id];
    return osti_collidePlaneHull(con, &a, &b, vert, graph + 2 + graph[0], graph[0], margin);
  }
  if (a.type == mjGEOM_PLANE && b.type == mjGEOM_CYLINDER) {
    return osti_collidePlaneCylinder(con, &a, &b, margin);
  }
  // bounding spheres apart, as MuJoCo's broadphase
  mjtNum dx[3] = {a.pos[0] - b.pos[0], a.pos[1] - b.pos[1], a.pos[2] - b.pos[2]};
  mjtNum reach = a.rbound + b.rbound + margin;
  if (mju_dot3(dx, dx) > reach * reach) {
    return 0;
  }
  if (a.type == mjGEOM_BOX && b.type == mjGEOM_BOX) {
    return osti_collideBoxBox(con, &a, &b, margin);
  }
  if (b.type == mjGEOM_MESH) {
    meshGeom(m, mesh, g2, &b);
  }
  if (a.type == mjGEOM_ELLIPSOID && b.type == mjGEOM_BOX) {
    return osti_collideEllipsoidBox(con, &a, &b, margin, m->opt.mpr_tolerance,
                                    m->opt.mpr_iterations);
  }
  if (a.type == mjGEOM_ELLIPSOID) {
    // a mesh: its hull's triangles, else (no hull graph) MPR as MuJoCo collides it
    return b.nface > 0 ? osti_collideEllipsoidMesh(con, &a, &b, margin, m->opt.mpr_tolerance,
                                                   m->opt.mpr_iterations)
                       : osti_collideConvex(con, &a, &b, margin, m->opt.mpr_tolerance,
                                            m->opt.mpr_iterations);
  }
  if ((a.type == mjGEOM_SPHERE || a.type == mjGEOM_CAPSULE)
      && (b.type == mjGEOM_ELLIPSOID || b.type == mjGEOM_CYLINDER || b.type == mjGEOM_MESH)) {
    return osti_collideBall(con, &a, &b, margin, m->opt.mpr_tolerance, m->opt.mpr_iterations);
  }
  return osti_collideCylinderBox(con, &a, &b, margin);
}


void ost_contactFrame(mjtNum frame[9]) {
  // the first tangent: e_y, or e_z where the normal is within 60 degrees of e_y, made
  // orthogonal to the normal; the second: normal x first
  mjtNum* t1 = frame + 3;
  mju_zero3(t1);
  t1[fabs(frame[1]) < 0.5 ? 1 : 2] = 1;
  mjtNum along[3];
  mju_scl3(along, frame, mju_dot3(frame, t1));
  mju_subFrom3(t1, along);
  mju_normalize3(t1);
  mju_cross(frame + 6, frame, t1);
}


// MuJoCo 2.2.2's general convex collision (mjc_Convex: MPR on both geoms inflated by margin/2)
// reports dist = margin - depth, and MPR's depth of the inflated shapes is not their true gap
// where their nearest features are not aligned with its search direction: inside the look-ahead,
// meshes 0.2 mm apart came out 2 mm deep, and a quadruped's chassis and leg meshes 0.97 mm apart
// 0.2 mm deep (compare/results/menagerie.md, Barkour). Pairs that MPR's intersection test finds
// apart at margin 0 get their distance, witness points and normal from GJK
// (core/ost_collision_gjk.h): dist = |b - a|, pos = (a + b)/2, normal (b - a)/dist from geom1 to
// geom2, so the gap and its normal agree to first order, and the tangents MuJoCo would make
// (ost_contactFrame). Overlapping pairs keep MuJoCo's contact: inflating both shapes by margin/2
// deepens an overlap by exactly the margin, and a depth re-measured at margin 0 (MPR's, good to
// mpr_tolerance) or along MPR's normal (not the face normal of resting faces) made resting
// contacts stall. Pairs with several contacts (MuJoCo's multiCCD, off by default) are left as
// they are. mesh: the model's meshes (ost_meshData).
void ost_refineConvexContacts(const mjModel* m, mjData* d, const ostMeshes* mesh) {
  mjfCollision convex = mjCOLLISIONFUNC[mjGEOM_MESH][mjGEOM_MESH];  // mjc_Convex
  if (mjENABLED(mjENBL_MULTICCD)) {
    return;
  }
  for (int i = 0; i < d->ncon; i++) {
    mjContact* con = d->contact + i;
    int g1 = con->geom1, g2 = con->geom2;
    if (mjCOLLISIONFUNC[m->geom_type[g1]][m->geom_type[g2]] != convex) {
      continue;
    }
    mjContact t;
    if (convex(m, d, &t, g1, g2, 0) == 1) {
      continue;  // overlapping: MuJoCo's contact of the inflated shapes stands
    }
    ostGeom g[2];
    ostNum dist, pa[3], pb[3];
    for (int k = 0; k < 2; k++) {
      int gk = k ? g2 : g1;
      placedGeom(m, d, gk, g + k);
      if (m->geom_type[gk] == mjGEOM_MESH) {
        meshGeom(m, mesh, gk, g + k);
      }
    }
    if (!osti_gjkDistance(g, g + 1, &dist, pa, pb) || !(dist > 0)) {
      continue;  // touching within GJK's tolerance: MuJoCo's contact stands
    }
    con->dist = dist;
    for (int k = 0; k < 3; k++) {
      con->pos[k] = 0.5 * (pa[k] + pb[k]);
      con->frame[k] = (pb[k] - pa[k]) / dist;
    }
    ost_contactFrame(con->frame);
  }
}


int ost_rowsMujoco(ostContext* c, mjData* d, mjtNum h) {
  const mjModel* m = c->mo;  // its nconmax and njmax are d's (ost_step.c evalGeometry)
  ostWorld* w = &c->world;
  int nv = m->nv, n = 0;
  int warn_con = d->warning[mjWARN_CONTACTFULL].number;
  int warn_efc = d->warning[mjWARN_CNSTRFULL].number;

  // MuJoCo's geometry at q (prerequisites: collision needs kinematics, Jacobians need comPos)
  mj_kinematics(m, d);
  mj_comPos(m, d);
  mj_tendon(m, d);
  if (c->servo_any) {
    // the servo rows' lengths and moments at q; without servos no row reads them, and the
    // publication runs the transmission at q+ itself (ost_publishPosition): MuJoCo zeroes and
    // fills nu x nv moments per call, 2.2 MB for 22 humanoids
    mj_transmission(m, d);
  }
  ost_collision(&c->col, m, d);
  if (c->opt.convex_distance) {
    ost_refineConvexContacts(m, d, &c->mesh);
  }
  // MuJoCo's rows for equalities and joint limits only: the contacts get Ostrich's own rows
  // below, so MuJoCo's contact rows (a pyramid or cone Jacobian per contact) are not built
  int ncon = d->ncon;
  d->ncon = 0;
  mj_makeConstraint(m, d);
  d->ncon = ncon;
  if (d->warning[mjWARN_CONTACTFULL].number != warn_con) {
    return ost_capacityFail(c, "contact", c->ncon_cap);
  }
  if (d->warning[mjWARN_CNSTRFULL].number != warn_efc) {
    return ost_capacityFail(c, "constraint", m->njmax);
  }
#define NEED_ROWS(k)                                                                   \
  if (n + (k) > w->nrow_max) {                                                         \
    return ost_capacityFail(c, "row", w->nrow_max);                                    \
  }

  // equality, dry-friction and limit rows: MuJoCo's rows, whose J is d(efc_pos)/dq in tangent
  // space (dry friction: the dof's unit row or the tendon's Jacobian)
  for (int i = 0, sub = 0; i < d->nefc; i++) {
    int type = d->efc_type[i];
    if (type != mjCNSTR_EQUALITY && type != mjCNSTR_LIMIT_JOINT && type != mjCNSTR_LIMIT_TENDON
        && type != mjCNSTR_FRICTION_DOF && type != mjCNSTR_FRICTION_TENDON) {
      continue;
    }
    NEED_ROWS(1);
    ostRow* r = w->rows + n;
    memset(r, 0, sizeof(ostRow));
    r->normal = -1;
    ostNum* J = osti_rowScratch(w, n);
    const int* cols;
    int ncols;
    efcRow(m, d, i, J, &cols, &ncols);
    if (type == mjCNSTR_EQUALITY) {
      // sub-row index within one equality object (connect: 3 rows, weld: 6)
      sub = (n > 0 && r[-1].type == OST_ROW_EQUALITY && r[-1].obj[0] == d->efc_id[i]) ? sub + 1 : 0;
      r->type = OST_ROW_EQUALITY;
      r->obj[0] = d->efc_id[i];
      r->obj[1] = sub;
      r->pos = d->efc_pos[i];
      r->alpha = c->opt.eq_compliance;
    } else if (type == mjCNSTR_FRICTION_DOF || type == mjCNSTR_FRICTION_TENDON) {
      r->type = OST_ROW_DRY;
      r->obj[0] = d->efc_id[i];
      r->obj[1] = type == mjCNSTR_FRICTION_TENDON;
      r->mu = d->efc_frictionloss[i];
    } else {
      // the private model's joint and tendon margins include the look-ahead; the gap keeps the
      // user's. Side: J = +1 on the lower limit (efc_J = d(dist)/dq = dq/dq or dL/dq)
      r->type = OST_ROW_LIMIT;
      r->obj[0] = d->efc_id[i];
      r->obj[1] = type == mjCNSTR_LIMIT_JOINT ? J[m->jnt_dofadr[d->efc_id[i]]] > 0
                                              : 2 + tendonLowerSide(m, d, i);
      r->pos = d->efc_pos[i] - d->efc_margin[i] + c->opt.margin;
    }
    if (cols ? osti_rowStoreCols(w, n, cols, ncols) : osti_rowStore(w, n, 1)) {
      return widthOverflow(c);
    }
    n++;
  }

  // contact rows: the scratch rows start at zero, each contact writes and clears its chains
  memset(osti_rowScratch(w, n), 0, (1 + OST_MAXFRIC) * (size_t)nv * sizeof(ostNum));
  memset(c->jac, 0, 12 * (size_t)nv * sizeof(mjtNum));

  // contact rows: normal then two tangents in the contact frame (frame[0:3] from geom1 to
  // geom2, so J_n u > 0 separates); contacts within the look-ahead distance are candidates.
  // Core pairs (cylinder-box, height field-cylinder, plane-mesh, plane-cylinder, box-box) are
  // replaced by core's contacts (below); the collision leaves them out (skip_core)
  int status;
  for (int i = 0; i < d->ncon; i++) {
    const mjContact* con = d->contact + i;
    if (con->exclude > 1 || ost_corePair(m, con->geom1, con->geom2)) {
      continue;  // fused, equality-joined or without degrees of freedom; or core's pair
    }
    mjtNum fr[3] = {con->friction[0], con->friction[2], con->friction[3]};
    mjtNum pos = con->dist - con->includemargin + c->opt.margin;  // user's margin - gap
    if ((status = contactRows(c, d, con->geom1, con->geom2, con->pos, con->frame, pos, con->dim,
                              fr, &n))) {
      return status;
    }
  }
  const ostModel* cp = &c->corepairs;
  for (int p = 0; p < cp->s.npair; p++) {
    ostContact con[OST_MAXCONPAIR];
    int g1 = cp->pair_geom1[p], g2 = cp->pair_geom2[p];
    int ncon = ost_collideCorePair(m, d, c->hfield_data, &c->mesh, g1, g2, cp->pair_margin[p],
                                   con);
    mjtNum fr[3] = {cp->pair_friction[p], cp->pair_torsion[p], cp->pair_rolling[p]};
    for (int i = 0; i < ncon; i++) {
      mjtNum pos = con[i].dist - (cp->pair_margin[p] - cp->pair_gap[p]) + c->opt.margin;
      if ((status = contactRows(c, d, g1, g2, con[i].pos, con[i].frame, pos,
                                cp->pair_condim[p], fr, &n))) {
        return status;
      }
    }
  }

  // implicit servo rows: force = g a + b0 + b1 L(q) + b2 V, V = moment u             (eq. 8)
  // with a the actuator's input: clamped ctrl, or act+ with activation dynamics (eq. 8b)
  if (!(m->opt.disableflags & mjDSBL_ACTUATION)) {
    for (int i = 0; i < m->nu; i++) {
      if (!c->servo[i]) {
        continue;
      }
      NEED_ROWS(1);
      const mjtNum* g = m->actuator_gainprm + i * mjNGAIN;
      const mjtNum* b = m->actuator_biasprm + i * mjNBIAS;
      osti_servoRow(w->rows + n, i, g[0], b, c->act_input[i], d->actuator_length[i], h,
                    m->actuator_forcelimited[i], m->actuator_forcerange + 2 * i);
      memcpy(osti_rowScratch(w, n), d->actuator_moment + (size_t)i * nv, nv * sizeof(ostNum));
      if (osti_rowStore(w, n, 1)) {
        return widthOverflow(c);
      }
      n++;
    }
  }
  // stiff tendon springs and dampers (c->ten_implicit, mujocoStart) as implicit rows: the servo
  // row of gain 0 and bias (k L0, -k, -b), force = -k (L(q+) - L0) - b J u+ (mj_passive's
  // tendon force, taken at the end of the step), stable at any h
  if (!(m->opt.disableflags & mjDSBL_PASSIVE)) {
    const ostNum none[2] = {0, 0};
    for (int t = 0; t < m->ntendon; t++) {
      mjtNum k = m->tendon_stiffness[t], b = m->tendon_damping[t];
      if (!c->ten_implicit[t]) {
        continue;
      }
      NEED_ROWS(1);
      mjtNum bias[3] = {k * m->tendon_lengthspring[t], -k, -b};
      osti_servoRow(w->rows + n, t, 0, bias, 0, d->ten_length[t], h, 0, none);
      w->rows[n].obj[1] = 1;  // a tendon, not an actuator
      ost_tendonRow(m, d, t, osti_rowScratch(w, n));
      if (osti_rowStore(w, n, 1)) {
        return widthOverflow(c);
      }
      n++;
    }
  }
#undef NEED_ROWS
  w->nrow = n;
  return OST_OK;
}
