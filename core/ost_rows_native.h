// ost_rows_native.h: the `native` geometry provider's rows (the portable twin of
// plugin/ost_rows_mujoco.c; mirrors engine_core_constraint.c's mj_makeConstraint for joint
// limits and contacts). At a Newton iterate q it runs core's kinematics, transmission and
// collision, then packs the solver rows: joint limits, dry friction, contacts (normal + two
// tangents in the contact frame) and implicit servo rows. Also the explicit forces and the mass matrix of a
// step's start, so that a whole step runs without MuJoCo (CPU batch and GPU).
// Invariant: rows come in a deterministic order (limits by joint, dry friction by dof, contacts
// by candidate pair, servos by actuator), so evaluating the same q twice yields identical rows.
#ifndef OSTRICH_CORE_OST_ROWS_NATIVE_H_
#define OSTRICH_CORE_OST_ROWS_NATIVE_H_

#include <math.h>
#include <string.h>

#include "ost_collision.h"
#include "ost_kinematics.h"
#include "ost_model.h"
#include "ost_muscle.h"
#include "ost_solver.h"

#ifdef __cplusplus
extern "C" {
#endif

#define OST_ROWS_OK 0
#define OST_ROWS_ROW_OVERFLOW 1       // more rows than w->nrow_max
#define OST_ROWS_CONTACT_OVERFLOW 2   // more contacts than ncon_max
#define OST_ROWS_WIDTH_OVERFLOW 3     // a row's pattern wider than w->ncol (osti_rowStore)


// matching key of contact i: its position in the frame of geom2's body (geom1's if geom2 is
// on the world), as ost_contactKey in the plugin
OST_HD void osti_contactKey(const ostModel* m, const ostKin* k, int i, ostNum key[3]) {
  int p = k->contact_pair[i];
  int b = m->geom_bodyid[m->pair_geom2[p]];
  if (b == 0) {
    b = m->geom_bodyid[m->pair_geom1[p]];
  }
  osti_contactKeyOf(key, k->contact[i].pos, k->xpos + 3 * b, k->xmat + 9 * b);
}


// the rows of contact i into J (rows apart by nv): the normal, then its nf friction rows of the
// given slots and scales (osti_frictionSlots): frame rows times (J(body2) - J(body1)) at the
// contact point, rotational Jacobians for torsion and rolling; returns 0 if the contact moves
// no degree of freedom (a frictionless one: beyond rounding, osti_normalMoves)
OST_HD int osti_contactJacobian(const ostModel* m, ostKin* k, int i, int nf, const int* slot,
                                const ostNum* scale, ostNum* J) {
  int nv = m->s.nv, p = k->contact_pair[i];
  const ostContact* con = k->contact + i;
  int b1 = m->geom_bodyid[m->pair_geom1[p]], b2 = m->geom_bodyid[m->pair_geom2[p]];
  ostNum* j1 = k->jac;
  ostNum* j2 = k->jac + 3 * nv;
  for (int j = 0; j < 6 * nv; j++) {
    k->jac[j] = 0;
  }
  if (b1 > 0) osti_jac(m, k, j1, NULL, con->pos, b1);
  if (b2 > 0) osti_jac(m, k, j2, NULL, con->pos, b2);
  // the normal and the sliding rows, then (a second pass through the same scratch) the
  // torsional and rolling rows of the rotational Jacobians
  int ntr = 0;
  while (ntr < nf && slot[ntr] <= 2) {
    ntr++;
  }
  int any = osti_contactRows(con->frame, j1, j2, nv, J, NULL, NULL);
  if (nf == 0 && any) {
    ostNum jn2 = 0, rel2 = 0;  // a frictionless normal that moves nothing but rounding
    for (int j = 0; j < nv; j++) {
      ostNum dx = j2[j] - j1[j], dy = j2[nv + j] - j1[nv + j], dz = j2[2 * nv + j] - j1[2 * nv + j];
      jn2 += J[j] * J[j];
      rel2 += dx * dx + dy * dy + dz * dz;
    }
    any = osti_normalMoves(jn2, rel2);
  }
  osti_frictionJacobian(con->frame, j1, j2, NULL, NULL, nv, ntr, slot, scale, J + nv);
  if (nf > ntr) {
    for (int j = 0; j < 6 * nv; j++) {
      k->jac[j] = 0;
    }
    if (b1 > 0) osti_jac(m, k, NULL, j1, con->pos, b1);
    if (b2 > 0) osti_jac(m, k, NULL, j2, con->pos, b2);
    osti_frictionJacobian(con->frame, NULL, NULL, j1, j2, nv, nf - ntr, slot + ntr, scale + ntr,
                          J + (size_t)(1 + ntr) * nv);
  }
  return any;
}


// a zeroed row of the given type
OST_HD ostRow* osti_newRow(ostWorld* w, int n, int type) {
  ostRow* r = w->rows + n;
  memset(r, 0, sizeof(ostRow));
  r->type = type;
  r->normal = -1;
  return r;
}


// the input of actuator i: ctrl clamped to ctrlrange as MuJoCo does, or for an actuator with
// activation dynamics the entry as given, its act+ (the caller's osti_actuation, eq. 8b). The
// `ctrl` arrays of the functions below are these inputs.
OST_HD ostNum osti_ctrl(const ostModel* m, const ostNum* ctrl, int i) {
  ostNum c = ctrl[i];
  if (m->actuator_actadr[i] >= 0) {
    return c;
  }
  if (m->actuator_ctrllimited[i] && !(m->disableflags & OST_DSBL_CLAMPCTRL)) {
    const ostNum* r = m->actuator_ctrlrange + 2 * i;
    c = c < r[0] ? r[0] : (c > r[1] ? r[1] : c);
  }
  return c;
}


// the servo row of actuator i (its fields, not its Jacobian, the moment) with the actuators'
// inputs ctrl and the transmission at the row's configuration in k
OST_HD void osti_nativeServoRow(const ostModel* m, const ostKin* k, ostRow* r, int i,
                                const ostNum* ctrl, ostNum h) {
  osti_servoRow(r, i, m->actuator_gainprm[i], m->actuator_biasprm + 3 * i, osti_ctrl(m, ctrl, i),
                k->actuator_length[i], h, m->actuator_forcelimited[i],
                m->actuator_forcerange + 2 * i);
}


// the servo rows of w (built by osti_nativeRows with k's transmission) again for new inputs
// ctrl: only their fields move, J (the moment) does not depend on the inputs
OST_HD void osti_nativeServoRows(const ostModel* m, const ostKin* k, ostWorld* w,
                                 const ostNum* ctrl, ostNum h) {
  for (int n = 0; n < w->nrow; n++) {
    if (w->rows[n].type == OST_ROW_SERVO) {
      osti_nativeServoRow(m, k, w->rows + n, w->rows[n].obj[0], ctrl, h);
    }
  }
}


// the rows at configuration qpos (osti_kinematics, osti_comPos, osti_transmission ran at qpos):
// joint limits within their margin, dof dry friction, contacts from osti_collision, implicit
// servo rows.
// lookahead: Ostrich's look-ahead distance, already added to the packed margins; a row's gap
// is the user's (dist - margin + gap + lookahead). Returns OST_ROWS_* (0: ok).
OST_HD int osti_nativeRows(const ostModel* m, ostKin* k, ostWorld* w, const ostNum* qpos,
                           const ostNum* ctrl, ostNum lookahead, ostNum h) {
  int nv = m->s.nv, n = 0;

  // joint limits (hinge and slide): lower side dist = q - lo, upper side dist = hi - q, a row
  // while dist < margin; J = +1 / -1 on the joint's dof (as MuJoCo's efc rows)
  if (!(m->disableflags & OST_DSBL_LIMIT)) {
    for (int j = 0; j < m->s.njnt; j++) {
      if (!m->jnt_limited[j]) {
        continue;
      }
      ostNum q = qpos[m->jnt_qposadr[j]];
      for (int side = 0; side < 2; side++) {
        ostNum dist = side == 0 ? q - m->jnt_range[2 * j] : m->jnt_range[2 * j + 1] - q;
        if (!(dist < m->jnt_margin[j])) {
          continue;
        }
        if (n + 1 > w->nrow_max) {
          return OST_ROWS_ROW_OVERFLOW;
        }
        ostRow* r = osti_newRow(w, n, OST_ROW_LIMIT);
        r->obj[0] = j;
        r->obj[1] = side == 0;
        r->pos = dist - m->jnt_margin[j] + lookahead;
        ostNum* J = osti_rowScratch(w, n);
        for (int c = 0; c < nv; c++) {
          J[c] = 0;
        }
        J[m->jnt_dofadr[j]] = side == 0 ? 1 : -1;
        if (osti_rowStore(w, n, 1)) {
          return OST_ROWS_WIDTH_OVERFLOW;
        }
        n++;
      }
    }
  }

  // dry friction (frictionloss): one box-constrained row per dof, J = 1 on the dof (as
  // MuJoCo's mjCNSTR_FRICTION_DOF rows, which exist whatever the state)
  if (!(m->disableflags & OST_DSBL_FRICTIONLOSS)) {
    for (int j = 0; j < nv; j++) {
      if (!(m->dof_frictionloss[j] > 0)) {
        continue;
      }
      if (n + 1 > w->nrow_max) {
        return OST_ROWS_ROW_OVERFLOW;
      }
      ostRow* r = osti_newRow(w, n, OST_ROW_DRY);
      r->obj[0] = j;
      r->mu = m->dof_frictionloss[j];
      ostNum* J = osti_rowScratch(w, n);
      for (int c = 0; c < nv; c++) {
        J[c] = 0;
      }
      J[j] = 1;
      if (osti_rowStore(w, n, 1)) {
        return OST_ROWS_WIDTH_OVERFLOW;
      }
      n++;
    }
  }

  // contacts: normal then its friction rows in the contact frame (frame[0:3] from geom1 to
  // geom2, so J_n u > 0 separates)
  osti_collision(m, k);
  if (k->overflow) {
    return OST_ROWS_CONTACT_OVERFLOW;
  }
  for (int i = 0; i < k->ncon; i++) {
    int p = k->contact_pair[i];
    ostNum mu = m->pair_friction[p];
    int slot[OST_MAXFRIC];
    ostNum scale[OST_MAXFRIC];
    int nf = osti_frictionSlots(m->pair_condim[p], mu, m->pair_torsion[p], m->pair_rolling[p],
                                slot, scale);
    if (n + 1 + nf > w->nrow_max) {
      return OST_ROWS_ROW_OVERFLOW;
    }
    if (!osti_contactJacobian(m, k, i, nf, slot, scale, osti_rowScratch(w, n))) {
      continue;
    }
    if (osti_rowStore(w, n, 1 + nf)) {
      return OST_ROWS_WIDTH_OVERFLOW;
    }
    ostNum key[3];
    osti_contactKey(m, k, i, key);
    for (int c = 0; c <= nf; c++) {
      ostRow* r = osti_newRow(w, n + c, c == 0 ? OST_ROW_CONTACT : OST_ROW_FRICTION);
      r->normal = c == 0 ? -1 : n;
      r->obj[0] = m->pair_geom1[p];
      r->obj[1] = m->pair_geom2[p];
      r->key[0] = key[0];
      r->key[1] = key[1];
      r->key[2] = key[2];
      r->pos = k->contact[i].dist - (m->pair_margin[p] - m->pair_gap[p]) + lookahead;
      r->mu = mu;
      if (c > 0) {
        r->alpha = scale[c - 1];
        r->lo = slot[c - 1];
      }
    }
    n += 1 + nf;
  }

  // implicit servo rows: force = g ctrl + b0 + b1 L(q) + b2 V, V = moment u          (eq. 8)
  if (!(m->disableflags & OST_DSBL_ACTUATION)) {
    for (int i = 0; i < m->s.nu; i++) {
      if (!m->actuator_servo[i]) {
        continue;
      }
      if (n + 1 > w->nrow_max) {
        return OST_ROWS_ROW_OVERFLOW;
      }
      osti_nativeServoRow(m, k, w->rows + n, i, ctrl, h);
      ostNum* J = osti_rowScratch(w, n);
      for (int c = 0; c < nv; c++) {
        J[c] = k->actuator_moment[(size_t)i * nv + c];
      }
      if (osti_rowStore(w, n, 1)) {
        return OST_ROWS_WIDTH_OVERFLOW;
      }
      n++;
    }
  }
  w->nrow = n;
  return OST_ROWS_OK;
}


// geometry of a Newton iterate: kinematics, com frames, transmission and rows at qpos
OST_HD int osti_nativeIterate(const ostModel* m, ostKin* k, ostWorld* w, const ostNum* qpos,
                              const ostNum* ctrl, ostNum lookahead, ostNum h) {
  osti_kinematics(m, k, qpos);
  osti_comPos(m, k);
  osti_transmission(m, k, qpos);
  return osti_nativeRows(m, k, w, qpos, ctrl, lookahead, h);
}


// the springs of hinge and slide joints taken implicitly (backward Euler in q): with
// q+ = q- + h u+, M (u+ - u-) = h (f(q-, u-) - h k u+) becomes
//   (M + h D + h^2 K) (u+ - u-) = h (f(q-, u-) - h K u-),
// so Mt (nv x nv, or NULL) gets h^2 k on the joint's dof and f (nv, or NULL) gets -h k u- (f
// already holds the spring force at q-). A stiff spring then stays stable at any h (MuJoCo's
// Euler keeps springs explicit). Ball and free joints' springs stay explicit. The joint arrays
// (njnt) are the packed model's or MuJoCo's (osttJoint numbers joints as mjtJoint); both
// providers call this.
OST_HD void osti_implicitSprings(ostNum* Mt, ostNum* f, int nv, int njnt, const int* jnt_type,
                                 const int* jnt_dofadr, const ostNum* jnt_stiffness,
                                 const ostNum* qvel, ostNum h) {
  for (int j = 0; j < njnt; j++) {
    int t = jnt_type[j];
    ostNum k = jnt_stiffness[j];
    if ((t != OST_JNT_HINGE && t != OST_JNT_SLIDE) || !(k > 0)) {
      continue;
    }
    int d = jnt_dofadr[j];
    if (Mt) {
      Mt[(size_t)d * nv + d] += h * h * k;
    }
    if (f) {
      f[d] -= h * k * qvel[d];
    }
  }
}


// the start of a step at (q-, u-): Mt = M(q-) + h D into w->M (unfactored) and the explicit
// forces f = qfrc_passive - qfrc_bias + explicit actuator forces + qfrc_applied (+ J' xfrc)
// into w->qfrc_explicit (core/README.md section 1). qfrc_applied and xfrc_applied may be NULL.
// In two parts, so that the adjoint can vary the velocities and inputs alone: the position
// part (kinematics, Mt) and the velocity part (f, reading k's kinematics at q-).
OST_HD void osti_nativeStartPos(const ostModel* m, ostKin* k, ostWorld* w, const ostNum* qpos,
                                ostNum h) {
  int nv = m->s.nv;
  osti_kinematicsBodies(m, k, qpos);  // no geoms: the start collides nothing
  osti_comPos(m, k);
  osti_crb(m, k);
  osti_transmission(m, k, qpos);
  // M is tree-sparse and factored without fill (ost_util_tree.h), which reads only the lower
  // triangle on the tree's pattern; a residual-only world (no row patterns) multiplies by the
  // whole matrix (osti_stepResidual) and gets all of it
  if (w->Jnnz) {
    for (int i = 0; i < nv; i++) {
      for (int j = i; j >= 0; j = m->dof_parentid[j]) {
        w->M[(size_t)i * nv + j] = k->qM[(size_t)i * nv + j];
      }
    }
  } else {
    for (int i = 0; i < nv * nv; i++) {
      w->M[i] = k->qM[i];
    }
  }
  w->dof_parent = m->dof_parentid;
  for (int j = 0; j < nv; j++) {
    w->M[j * nv + j] += h * m->dof_damping[j];
  }
  if (!(m->disableflags & OST_DSBL_PASSIVE)) {
    osti_implicitSprings(w->M, NULL, nv, m->s.njnt, m->jnt_type, m->jnt_dofadr, m->jnt_stiffness,
                         NULL, h);
  }
}


// the explicit actuators' forces added to f (nv), k's transmission at q-: force = gain input +
// bias clamped to forcerange, times moment, with gain g or a muscle's -F FL FV, bias b0 + b1 L
// + b2 V or a muscle's -F FP (eq. 8c), all at (q-, u-); input the clamped ctrl or act+ (eq. 8b)
OST_HD void osti_nativeActuatorForces(const ostModel* m, const ostKin* k, ostNum* f,
                                      const ostNum* qvel, const ostNum* ctrl) {
  int nv = m->s.nv;
  if (!(m->disableflags & OST_DSBL_ACTUATION)) {
    for (int i = 0; i < m->s.nu; i++) {
      if (m->actuator_servo[i]) {
        continue;
      }
      // a native transmission is a joint: the moment is the gear on the joint's dof alone
      // (osti_transmission), so V = moment u and f += moment force touch that dof only
      int dof = m->jnt_dofadr[m->actuator_trnid[i]];
      ostNum mom = k->actuator_moment[(size_t)i * nv + dof];
      const ostNum* b = m->actuator_biasprm + 3 * i;
      ostNum L = k->actuator_length[i], V = mom * qvel[dof];
      const ostNum* lr = m->actuator_lengthrange + 2 * i;
      ostNum gain = m->actuator_gaintype[i] == OST_GAIN_MUSCLE
                    ? osti_muscleGain(L, V, lr, m->actuator_acc0[i], m->actuator_gainmus + 9 * i)
                    : m->actuator_gainprm[i];
      ostNum bias = m->actuator_biastype[i] == OST_BIAS_MUSCLE
                    ? osti_muscleBias(L, lr, m->actuator_acc0[i], m->actuator_biasmus + 9 * i)
                    : b[0] + b[1] * L + b[2] * V;
      ostNum force = gain * osti_ctrl(m, ctrl, i) + bias;
      if (m->actuator_forcelimited[i]) {
        const ostNum* r = m->actuator_forcerange + 2 * i;
        force = force < r[0] ? r[0] : (force > r[1] ? r[1] : force);
      }
      f[dof] += mom * force;
    }
  }
}


// the velocity part of the start: f into w->qfrc_explicit (w->M is not touched), the explicit
// actuators' forces last (osti_nativeActuatorForces; none if ctrl is NULL)
OST_HD void osti_nativeStartVel(const ostModel* m, ostKin* k, ostWorld* w, const ostNum* qpos,
                                const ostNum* qvel, const ostNum* ctrl,
                                const ostNum* qfrc_applied, const ostNum* xfrc_applied, ostNum h) {
  int nv = m->s.nv;
  osti_rne(m, k, qvel);
  osti_passive(m, k, qpos, qvel);
  for (int j = 0; j < nv; j++) {
    w->qfrc_explicit[j] = k->qfrc_passive[j] - k->qfrc_bias[j]
                          + (qfrc_applied ? qfrc_applied[j] : 0);
  }
  if (!(m->disableflags & OST_DSBL_PASSIVE)) {
    osti_implicitSprings(NULL, w->qfrc_explicit, nv, m->s.njnt, m->jnt_type, m->jnt_dofadr,
                         m->jnt_stiffness, qvel, h);
  }

  // body wrenches (force, torque) applied at the center of mass: f += Jp' F + Jr' T
  if (xfrc_applied) {
    for (int b = 1; b < m->s.nbody; b++) {
      const ostNum* x = xfrc_applied + 6 * b;
      if (x[0] == 0 && x[1] == 0 && x[2] == 0 && x[3] == 0 && x[4] == 0 && x[5] == 0) {
        continue;
      }
      osti_jac(m, k, k->jac, k->jac + 3 * nv, k->xipos + 3 * b, b);
      for (int j = 0; j < nv; j++) {
        for (int r = 0; r < 3; r++) {
          w->qfrc_explicit[j] += k->jac[r * nv + j] * x[r] + k->jac[(3 + r) * nv + j] * x[3 + r];
        }
      }
    }
  }
  if (ctrl) {
    osti_nativeActuatorForces(m, k, w->qfrc_explicit, qvel, ctrl);
  }
}


// the whole start of a step (osti_nativeStartPos, then osti_nativeStartVel)
OST_HD void osti_nativeStart(const ostModel* m, ostKin* k, ostWorld* w, const ostNum* qpos,
                             const ostNum* qvel, const ostNum* ctrl, const ostNum* qfrc_applied,
                             const ostNum* xfrc_applied, ostNum h) {
  osti_nativeStartPos(m, k, w, qpos, h);
  osti_nativeStartVel(m, k, w, qpos, qvel, ctrl, qfrc_applied, xfrc_applied, h);
}

#ifdef __cplusplus
}
#endif

#endif  // OSTRICH_CORE_OST_ROWS_NATIVE_H_
