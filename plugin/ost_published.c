// ost_published.c: reuse of the stages a step published. ost_step2 ends by running MuJoCo's
// position and velocity stages at q+ into the user's mjData (so that sensors, contacts and
// forces describe the new state). The next step's ost_step1 would run the same stages at the
// same state again: on small models that repeat cost a third of a step. ost_step1 skips it when
// d is provably where the publication left it: the state the stages read (time, qpos, qvel,
// act, mocap poses), a fingerprint of their outputs (mass matrix, bias forces, body poses and
// velocities, tendon lengths and velocities; a user who ran mj_forward or mj_kinematics at
// another state in between changes these) and the model (ost_syncModel) are all unchanged, and
// no user callback runs inside those stages. Every comparison is bitwise, so a reused step
// equals a recomputed one bit for bit.
#include <string.h>

#include "ost_internal.h"

// the arrays compared, as (pointer, length): the stages' inputs, then their outputs
#define OST_PUBLISHED_ARRAYS(m, d)                                                          \
  X(&(d)->time, 1) X((d)->qpos, (m)->nq) X((d)->qvel, (m)->nv) X((d)->act, (m)->na)         \
  X((d)->mocap_pos, 3 * (m)->nmocap) X((d)->mocap_quat, 4 * (m)->nmocap)                    \
  X((d)->qM, (m)->nM) X((d)->qfrc_bias, (m)->nv) X((d)->qfrc_passive, (m)->nv)              \
  X((d)->xpos, 3 * (m)->nbody) X((d)->xquat, 4 * (m)->nbody) X((d)->cvel, 6 * (m)->nbody)   \
  X((d)->ten_length, (m)->ntendon) X((d)->ten_velocity, (m)->ntendon)

// 1 if qpos, with its free and ball joints' quaternions normalized as mj_kinematics normalizes
// them in place, equals ref bitwise (every coordinate of qpos belongs to one joint)
static int kinematicQposEquals(const mjModel* m, const mjtNum* qpos, const mjtNum* ref) {
  for (int j = 0; j < m->njnt; j++) {
    int t = m->jnt_type[j], adr = m->jnt_qposadr[j];
    int quat = t == mjJNT_FREE || t == mjJNT_BALL;
    int plain = t == mjJNT_FREE ? 3 : quat ? 0 : 1;  // coordinates before the quaternion
    if (memcmp(qpos + adr, ref + adr, plain * sizeof(mjtNum))) {
      return 0;
    }
    if (quat) {
      mjtNum q[4];
      mju_copy4(q, qpos + adr + plain);
      mju_normalize4(q);
      if (memcmp(q, ref + adr + plain, sizeof(q))) {
        return 0;
      }
    }
  }
  return 1;
}


size_t ost_publishedSize(const mjModel* m) {
  size_t n = 0;
#define X(ptr, len) n += (size_t)(len);
  OST_PUBLISHED_ARRAYS(m, d)
#undef X
  return n;
}


void ost_publishedSave(ostContext* c, const mjModel* m, const mjData* d) {
  mjtNum* s = c->published;
#define X(ptr, len)                                 \
  memcpy(s, ptr, (size_t)(len) * sizeof(mjtNum));   \
  s += (len);
  OST_PUBLISHED_ARRAYS(m, d)
#undef X
  // stages that ran a user callback are not reused, even once the callback is gone; nor where
  // an actuator has a body (adhesion) transmission: MuJoCo takes its moment from the contacts
  // within the model's margins, and the published contacts are the look-ahead's (wider)
  int adhesion = 0;
  for (int i = 0; i < m->nu; i++) {
    adhesion |= m->actuator_trntype[i] == mjTRN_BODY;
  }
  c->published_valid = !(mjcb_passive || mjcb_sensor || mjcb_contactfilter || adhesion);
}


int ost_publishedCurrent(ostContext* c, const mjModel* m, const mjData* d) {
  // user callbacks inside these stages (passive forces, user sensors, a contact filter) may read
  // state of the user's own that changed since the publication: with any of them the stages
  // are run again, as mj_step1 would
  if (!c->published_valid || c->model_dirty || mjcb_passive || mjcb_sensor
      || mjcb_contactfilter) {
    return 0;
  }
  const mjtNum* s = c->published;
#define X(ptr, len)                                           \
  if (memcmp(s, ptr, (size_t)(len) * sizeof(mjtNum))) {      \
    return 0;                                                \
  }                                                          \
  s += (len);
  OST_PUBLISHED_ARRAYS(m, d)
#undef X
  // mj_kinematics normalizes qpos's quaternions in place, and normalizing a normalized
  // quaternion can move it by an ulp: then the stages at the moved qpos are not the published
  // ones, bitwise, and are run again
  if (!kinematicQposEquals(m, d->qpos, d->qpos)) {
    return 0;
  }
  // the model last: a changed model is copied now and packed by ost_step2 (model_dirty)
  int changed = ost_syncModel(c, m);
  if (changed) {
    c->model_dirty = 1;
    return changed < 0 ? -1 : 0;
  }
  return 1;
}


// MuJoCo's position stage that mj_kinematics, mj_comPos and mj_tendon write
// (mjxmacro.h's order), as (name, length): the iterates' mjData holds them at the last iterate
#define OST_POSITION_STAGE(X, m)                                                           \
  X(xpos, 3 * (m)->nbody) X(xquat, 4 * (m)->nbody) X(xmat, 9 * (m)->nbody)                 \
  X(xipos, 3 * (m)->nbody) X(ximat, 9 * (m)->nbody) X(xanchor, 3 * (m)->njnt)              \
  X(xaxis, 3 * (m)->njnt) X(geom_xpos, 3 * (m)->ngeom) X(geom_xmat, 9 * (m)->ngeom)        \
  X(site_xpos, 3 * (m)->nsite) X(site_xmat, 9 * (m)->nsite) X(subtree_com, 3 * (m)->nbody) \
  X(cdof, 6 * (m)->nv) X(cinert, 10 * (m)->nbody) X(ten_wrapadr, (m)->ntendon)             \
  X(ten_wrapnum, (m)->ntendon) X(ten_J_rownnz, (m)->ntendon) X(ten_J_rowadr, (m)->ntendon) \
  X(ten_J_colind, (m)->ntendon * (m)->nv) X(ten_length, (m)->ntendon)                      \
  X(ten_J, (m)->ntendon * (m)->nv) X(wrap_obj, 2 * (m)->nwrap) X(wrap_xpos, 6 * (m)->nwrap)

// and mj_transmission's, which the iterates compute only where servo rows read them
#define OST_TRANSMISSION_STAGE(X, m) \
  X(actuator_length, (m)->nu) X(actuator_moment, (m)->nu * (m)->nv)

// MuJoCo 2.2.2's contact parameters for geoms g1, g2 (mj_collideGeoms): an explicit <pair> of
// the two geoms with this condim, margin and gap gives its own, otherwise the geoms' mixed
// (ost_contactPairParams)
static void contactParams(const mjModel* m, int g1, int g2, int condim, mjtNum margin,
                          mjtNum gap, mjContact* con) {
  int ipair = -1;
  for (int i = 0; i < m->npair && ipair < 0; i++) {
    int a = m->pair_geom1[i], b = m->pair_geom2[i];
    if (((a == g1 && b == g2) || (a == g2 && b == g1)) && m->pair_dim[i] == condim
        && m->pair_margin[i] == margin && m->pair_gap[i] == gap) {
      ipair = i;
    }
  }
  ost_contactPairParams(m, g1, g2, ipair, con->friction, con->solref, con->solimp);
}


// the contacts of core's pairs (ost_corePair) in place of MuJoCo's: the rows of those pairs are
// core's contacts (ost_rows_mujoco.c), and MuJoCo 2.2.2's own differ there (its box-box reports
// centimetres of penetration for boxes millimetres apart at the look-ahead margin). MuJoCo's
// contacts of core pairs are removed, core's at the same q are appended with MuJoCo's parameters
// (contactParams), so the constraint rows, forces and touch sensors published after describe the
// contacts Ostrich solved. Beyond nconmax MuJoCo's warning is raised, as mj_collision would.
static void coreContacts(ostContext* c, const mjModel* mo, mjData* d) {
  const ostModel* cp = &c->corepairs;
  if (!cp->s.npair) {
    return;
  }
  int n = 0;
  for (int i = 0; i < d->ncon; i++) {
    if (!ost_corePair(mo, d->contact[i].geom1, d->contact[i].geom2)) {
      d->contact[n++] = d->contact[i];
    }
  }
  d->ncon = n;
  for (int p = 0; p < cp->s.npair; p++) {
    ostContact found[OST_MAXCONPAIR];
    int g1 = cp->pair_geom1[p], g2 = cp->pair_geom2[p];
    int nfound = ost_collideCorePair(mo, d, c->hfield_data, &c->mesh, g1, g2,
                                     cp->pair_margin[p], found);
    for (int k = 0; k < nfound; k++) {
      if (d->ncon >= mo->nconmax) {
        mj_warning(d, mjWARN_CONTACTFULL, d->ncon);
        return;
      }
      mjContact* con = d->contact + d->ncon++;
      memset(con, 0, sizeof(mjContact));
      con->dist = found[k].dist;
      mju_copy3(con->pos, found[k].pos);
      mju_copy(con->frame, found[k].frame, 9);
      con->includemargin = cp->pair_margin[p] - cp->pair_gap[p];
      con->dim = cp->pair_condim[p];
      con->geom1 = g1;
      con->geom2 = g2;
      con->efc_address = -1;
      contactParams(mo, g1, g2, cp->pair_condim[p], cp->pair_margin[p], cp->pair_gap[p], con);
    }
  }
}


// mj_fwdPosition's stages (MuJoCo 2.2.2, engine_forward.c), with the general convex contacts'
// true distances (ost_refineConvexContacts) and core's contacts in place of MuJoCo's for core
// pairs (coreContacts) between collision and the constraint rows
static void fwdPosition(ostContext* c, const mjModel* mo, mjData* d) {
  if (!c->corepairs.s.npair && !c->opt.convex_distance) {
    mj_fwdPosition(mo, d);
    return;
  }
  mj_kinematics(mo, d);
  mj_comPos(mo, d);
  mj_camlight(mo, d);
  mj_tendon(mo, d);
  mj_transmission(mo, d);
  mj_crb(mo, d);
  mj_factorM(mo, d);
  mj_collision(mo, d);
  if (c->opt.convex_distance) {
    ost_refineConvexContacts(mo, d, &c->mesh);
  }
  coreContacts(c, mo, d);
  mj_makeConstraint(mo, d);
  mj_projectConstraint(mo, d);
}


int ost_publishPosition(ostContext* c, mjData* d) {
  const mjModel* mo = c->mo;
  const mjData* dg = c->dg;
  if (c->publish_full || c->opt.geometry == OST_GEOMETRY_NATIVE || !dg
      || dg->ncon > mo->nconmax
      || memcmp(dg->mocap_pos, d->mocap_pos, 3 * mo->nmocap * sizeof(mjtNum))
      || memcmp(dg->mocap_quat, d->mocap_quat, 4 * mo->nmocap * sizeof(mjtNum))) {
    fwdPosition(c, mo, d);
    return 0;
  }
  // the iterate's qpos is d's as mj_kinematics leaves it: quaternions normalized in place
  if (!kinematicQposEquals(mo, d->qpos, dg->qpos)) {
    fwdPosition(c, mo, d);
    return 0;
  }
  memcpy(d->qpos, dg->qpos, mo->nq * sizeof(mjtNum));
#define X(name, len) memcpy(d->name, dg->name, (size_t)(len) * sizeof(*d->name));
  OST_POSITION_STAGE(X, mo)
  if (c->servo_any) {
    OST_TRANSMISSION_STAGE(X, mo)
  } else {
    mj_transmission(mo, d);  // from the kinematics and tendons just copied
  }
#undef X
  d->ncon = dg->ncon;
  memcpy(d->contact, dg->contact, dg->ncon * sizeof(mjContact));
  // the rest of mj_fwdPosition on d (MuJoCo 2.2.2, engine_forward.c)
  mj_camlight(mo, d);
  mj_crb(mo, d);
  mj_factorM(mo, d);
  coreContacts(c, mo, d);
  mj_makeConstraint(mo, d);
  mj_projectConstraint(mo, d);
  c->publish_copies++;
  return 1;
}
