// ost_step.c: ost_step / ost_step1 / ost_step2, the drop-in replacement of mj_step (mirrors
// engine_forward.c). One step: stock position and velocity stages at (q-, u-) and mjcb_control;
// explicit forces f and Mt = M + hD at q-; the non-smooth Newton loop of core/ost_solver.h with
// MuJoCo's geometry at every iterate q = q- (+) h u; best-iterate backtracking; commit; and
// publication of mjData at q+ (core/README.md section 4).
// Invariant: on any failure the state (qpos, qvel, act, time) is left as it was before the step
// and a message is recorded; the library never exits or calls mju_error.
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "ost_activation.h"
#include "ost_internal.h"
#include "ost_rows_native.h"
#include "ost_step.h"

// index of the first non-finite entry of x (n), or -1
static int firstNonFinite(const mjtNum* x, int n) {
  for (int i = 0; i < n; i++) {
    if (!isfinite(x[i])) {
      return i;
    }
  }
  return -1;
}


// refuse non-finite inputs, naming the array and index
static int checkInputs(ostContext* c, const mjModel* m, const mjData* d, int controls) {
  struct { const char* name; const mjtNum* x; int n; } in[] = {
    {"qpos", d->qpos, m->nq}, {"qvel", d->qvel, m->nv}, {"act", d->act, m->na},
    {"ctrl", d->ctrl, m->nu}, {"qfrc_applied", d->qfrc_applied, m->nv},
    {"xfrc_applied", d->xfrc_applied, 6 * m->nbody}};
  int narr = controls ? 6 : 3;
  for (int k = 0; k < narr; k++) {
    int i = firstNonFinite(in[k].x, in[k].n);
    if (i >= 0) {
      return ost_fail(c, OST_ERR_INPUT, "non-finite %s[%d] = %g", in[k].name, i, in[k].x[i]);
    }
  }
  return OST_OK;
}


// native provider: pack the private model (margins widened) and size the kinematics block, if
// the model changed since the last packing (ost_syncModel) or the look-ahead margin did
int ost_nativeReady(ostContext* c, const mjModel* m) {
  (void)m;
  if (c->native_block && !c->native_dirty && c->native_margin == c->opt.margin) {
    return OST_OK;
  }
  free(c->native_block);
  c->native_block = NULL;
  int status = ost_packModel(c->mo, c->ncon_cap, &c->native, &c->native_block, c->err,
                             sizeof(c->err));
  if (status) {
    return status;
  }
  c->native_dirty = 0;
  c->native_margin = c->opt.margin;
  size_t sz = ostu_kinSize(c->native.s);
  if (!c->kin_buf || memcmp(&c->kin.s, &c->native.s, sizeof(ostSizes))) {
    free(c->kin_buf);
    c->kin_buf = aligned_alloc(64, OST_ALIGN64(sz));
    if (!c->kin_buf) {
      return ost_fail(c, OST_ERR_MEMORY, "cannot allocate native kinematics (%zu bytes)", sz);
    }
    memset(c->kin_buf, 0, sz);
  }
  ostu_kinInit(&c->kin, c->kin_buf, c->native.s);
  return OST_OK;
}


ostSolverOptions ost_solverOptions(const ostOptions* o) {
  ostSolverOptions so = {o->newton_iter, o->pcr_iter, o->k_min, 0,      o->tol,
                         o->pcr_tol,     o->fb_eps,   o->regularization, o->friction_creep};
  return so;
}


void ost_setMargins(mjModel* mo, const mjModel* m, mjtNum lookahead) {
  for (int i = 0; i < mo->ngeom; i++) {
    mo->geom_margin[i] = m->geom_margin[i] + lookahead;
  }
  for (int i = 0; i < mo->npair; i++) {
    mo->pair_margin[i] = m->pair_margin[i] + lookahead;
  }
  for (int i = 0; i < mo->njnt; i++) {
    mo->jnt_margin[i] = m->jnt_margin[i] + lookahead;
  }
  for (int i = 0; i < mo->ntendon; i++) {
    mo->tendon_margin[i] = m->tendon_margin[i] + lookahead;
  }
}


// prepare the context for a step. The private model follows the user's (ost_syncModel: only
// changed arrays are copied); only when it or the options changed are the options re-read, the
// model checked and the model-derived data (servo flags, look-ahead margins, core pairs, the
// native packing) rebuilt. ostTotals.model_packs counts those rebuilds.
// changed: ost_syncModel's answer for this step
static int prepareSynced(ostContext* c, const mjModel* m, int changed) {
  int status;
  c->err[0] = 0;
  if (changed < 0) {
    return OST_ERR_MEMORY;
  }
  if (!changed && !c->model_dirty) {
    return c->opt.geometry == OST_GEOMETRY_NATIVE ? ost_nativeReady(c, m) : OST_OK;
  }
  // stays dirty until every stage below succeeded, so a refused model is refused every step
  c->model_dirty = 1;
  c->native_dirty = 1;
  if (!c->opt_user && (status = ost_readOptions(m, &c->opt, c->err, sizeof(c->err)))) {
    return status;
  }
  if ((status = ost_checkStep(m, &c->opt, c->err, sizeof(c->err)))) {
    return status;
  }
  c->servo_any = 0;
  for (int i = 0; i < m->nu; i++) {
    c->servo[i] = ost_actuatorKind(m, i, NULL, 0) == 1;
    c->servo_any |= c->servo[i];
  }
  ost_setMargins(c->mo, m, c->opt.margin);
  ost_collisionReset(&c->col);
  c->col.skip_core = 1;  // the rows replace MuJoCo's contacts of core pairs (ost_rowsMujoco)
  if (c->opt.geometry == OST_GEOMETRY_NATIVE) {
    status = ost_nativeReady(c, m);
  } else if (ost_packCorePairs(c->mo, &c->corepairs, &c->corepairs_block)
             || ost_hfieldData(c->mo, &c->hfield_data, &c->hfield_n)
             || ost_meshData(c->mo, &c->mesh)) {
    // the mujoco provider collides core pairs with core's functions (ost_rows_mujoco.c)
    status = ost_fail(c, OST_ERR_MEMORY, "cannot allocate the core pair list");
  }
  if (!status) {
    c->model_dirty = 0;
    c->totals.model_packs++;
  }
  return status;
}


int ost_prepareContext(ostContext* c, const mjModel* m) {
  return prepareSynced(c, m, ost_syncModel(c, m));
}


// a state snapshot (time, qpos, qvel, qacc_warmstart, act) into s (1 + nq + 2 nv + na): the
// start of ost_step2, so that a failure anywhere in the step (substeps included) leaves d as it
// was, and the end of the last step, which a step must continue from to be warm-started
static void saveState(const mjModel* m, const mjData* d, mjtNum* s) {
  s[0] = d->time;
  memcpy(s + 1, d->qpos, m->nq * sizeof(mjtNum));
  memcpy(s + 1 + m->nq, d->qvel, m->nv * sizeof(mjtNum));
  memcpy(s + 1 + m->nq + m->nv, d->qacc_warmstart, m->nv * sizeof(mjtNum));
  memcpy(s + 1 + m->nq + 2 * m->nv, d->act, m->na * sizeof(mjtNum));
}


static void restoreStart(ostContext* c, const mjModel* m, mjData* d) {
  const mjtNum* s = c->state_start;
  d->time = s[0];
  memcpy(d->qpos, s + 1, m->nq * sizeof(mjtNum));
  memcpy(d->qvel, s + 1 + m->nq, m->nv * sizeof(mjtNum));
  memcpy(d->qacc_warmstart, s + 1 + m->nq + m->nv, m->nv * sizeof(mjtNum));
  memcpy(d->act, s + 1 + m->nq + 2 * m->nv, m->na * sizeof(mjtNum));
}


// restore the pre-step state and recompute derived quantities after a failure
static int abortStep(ostContext* c, const mjModel* m, mjData* d, int status) {
  c->warm_valid = 0;
  c->published_valid = 0;
  c->rec_n = 0;
  c->rec_bytes = 0;
  restoreStart(c, m, d);
  d->ncon = d->nefc = d->ne = d->nf = 0;
  mj_fwdPosition(m, d);
  mj_fwdVelocity(m, d);
  return status;
}


// q = q- (+) h u into d->qpos, then the provider's rows at q. The native provider integrates
// with core's exponential map (as the batch does, so that both give the same bits), the mujoco
// provider with MuJoCo's; the two differ in rounding only.
static int evalGeometry(ostContext* c, mjData* d, const mjtNum* u, mjtNum h) {
  memcpy(d->qpos, c->qpos_prev, c->mo->nq * sizeof(mjtNum));
  if (c->opt.geometry != OST_GEOMETRY_NATIVE) {
    mj_integratePos(c->mo, d->qpos, u, h);
    // MuJoCo's stages on the private mjData, whose capacity can exceed d's (ost_growCapacity):
    // mo carries that capacity while they run
    mjData* dg = c->dg;
    memcpy(dg->qpos, d->qpos, c->mo->nq * sizeof(mjtNum));
    int nconmax = c->mo->nconmax, njmax = c->mo->njmax;
    c->mo->nconmax = c->ncon_cap;
    c->mo->njmax = c->njmax_cap;
    int status = ost_rowsMujoco(c, dg, h);
    c->mo->nconmax = nconmax;
    c->mo->njmax = njmax;
    return status;
  }
  osti_integratePos(&c->native, d->qpos, u, h);
  return ost_rowsNative(c, d, h);
}


// 1 if d's (time, qpos, qvel) equal the end of the last step: bitwise, except that qpos may
// differ by the rounding of MuJoCo's in-place quaternion normalization (mj_step1 and the
// published q+ each normalize again, which can move a component by an ulp)
static int continuesLastStep(ostContext* c, const mjData* d) {
  const mjModel* m = c->m;
  if (!c->warm_valid || c->state_end[0] != d->time
      || memcmp(c->state_end + 1 + m->nq, d->qvel, m->nv * sizeof(mjtNum))) {
    return 0;
  }
  for (int i = 0; i < m->nq; i++) {
    if (!(fabs(c->state_end[1 + i] - d->qpos[i]) <= 1e-14)) {
      return 0;
    }
  }
  return 1;
}


// the context of a step's callbacks (osti_stepDriven)
typedef struct stepContext_ {
  ostContext* c;
  mjData*     d;
  int         fresh;              // 1 until the first substep started: ost_step1 ran its stages
  mjtNum      merit_k[mjNSOLVER]; // the last Newton loop's merits per iterate
  int         nrow_k[mjNSOLVER];  // and rows
} stepContext;


// osti_newton's geometry callback: q = q- (+) h u into d->qpos and the provider's rows at q
static int geometryCallback(void* ctx, const ostNum* u) {
  stepContext* s = (stepContext*)ctx;
  return evalGeometry(s->c, s->d, u, s->c->world.h);
}


// a Newton loop's statistics into the context's and into d->solver (the last loop's); a
// non-finite loop becomes OST_ERR_NUMERIC with its message
static int newtonCallback(void* ctx, const ostNewtonStats* ns, int status) {
  stepContext* s = (stepContext*)ctx;
  ostContext* c = s->c;
  ostWorld* w = &c->world;
  mjData* d = s->d;
  ostStats* st = &c->stats;
  st->geometry_evals += ns->geometry_evals;
  st->retries += ns->retry == 1;
  st->geo_retries += ns->retry == 2;
  if (ns->nonfinite) {
    st->status |= OST_NAN;
  }
  if (status == OST_NEWTON_NONFINITE) {
    return ost_fail(c, OST_ERR_NUMERIC, "non-finite Newton iterate at k=%d", ns->iterates - 1);
  }
  if (status) {
    return status;
  }
  int nk = ns->iterates < mjNSOLVER ? ns->iterates : mjNSOLVER;
  for (int k = 0; k < nk && k < ns->iterates - ns->nonfinite; k++) {
    d->solver[k].gradient = s->merit_k[k];
    d->solver[k].nactive = s->nrow_k[k];
  }
  st->newton_iter += ns->iterates;
  st->best_iter = ns->best;
  st->pcr_iter += ns->pcr;
  if (st->substeps == 0) {
    st->residual_first = ns->first;
  }
  st->nrow = w->nrow;
  st->islands = w->nisland > st->islands ? w->nisland : st->islands;
  st->ncon = 0;
  for (int i = 0; i < w->nrow; i++) {
    st->ncon += w->rows[i].type == OST_ROW_CONTACT;
  }
  if (ns->relaxed) {
    st->status |= OST_DEPENETRATED;
    st->initial_violation = mju_max(st->initial_violation, ns->initial_violation);
  }
  d->solver_iter = nk;
  return OST_OK;
}


// write lambda into MuJoCo's efc rows at q+: equality and limit rows by (type, object),
// contacts by geom pair and nearest position; then qfrc_constraint = efc_J' efc_force
static void publishForces(ostContext* c, const mjModel* m, mjData* d) {
  ostWorld* w = &c->world;
  unsigned char* used = w->used;
  memset(used, 0, w->nrow);
  memset(d->efc_force, 0, d->nefc * sizeof(mjtNum));
  for (int i = 0, sub = 0; i < d->nefc; i++) {
    int type = d->efc_type[i], kind;
    if (type == mjCNSTR_EQUALITY) {
      sub = (i > 0 && d->efc_type[i - 1] == mjCNSTR_EQUALITY && d->efc_id[i - 1] == d->efc_id[i])
            ? sub + 1 : 0;
      kind = OST_ROW_EQUALITY;
    } else if (type == mjCNSTR_LIMIT_JOINT || type == mjCNSTR_LIMIT_TENDON) {
      kind = OST_ROW_LIMIT;
    } else if (type == mjCNSTR_FRICTION_DOF || type == mjCNSTR_FRICTION_TENDON) {
      kind = OST_ROW_DRY;
    } else {
      continue;
    }
    // the object class within a kind: equality sub-row; joint (side 0/1) or tendon (2 + side)
    // limit; dof (0) or tendon (1) dry friction
    int tendon = type == mjCNSTR_LIMIT_TENDON || type == mjCNSTR_FRICTION_TENDON;
    for (int r = 0; r < w->nrow; r++) {
      const ostRow* row = w->rows + r;
      int match = kind == OST_ROW_EQUALITY ? row->obj[1] == sub
                  : kind == OST_ROW_LIMIT  ? (row->obj[1] >= 2) == tendon
                                           : row->obj[1] == tendon;
      if (!used[r] && row->type == kind && row->obj[0] == d->efc_id[i] && match) {
        used[r] = 1;
        d->efc_force[i] = w->lambda[r];
        break;
      }
    }
  }
  for (int i = 0; i < d->ncon; i++) {
    mjContact* con = d->contact + i;
    if (con->efc_address < 0) {
      continue;
    }
    int best = -1;
    mjtNum best_d2 = HUGE_VAL, key[3];
    ost_contactKey(m, d, con, key);
    for (int r = 0; r < w->nrow; r++) {
      const ostRow* row = w->rows + r;
      if (used[r] || row->type != OST_ROW_CONTACT || row->obj[0] != con->geom1
          || row->obj[1] != con->geom2) {
        continue;
      }
      mjtNum d2 = 0;
      for (int k = 0; k < 3; k++) {
        d2 += (row->key[k] - key[k]) * (row->key[k] - key[k]);
      }
      if (d2 < best_d2) {
        best_d2 = d2;
        best = r;
      }
    }
    if (best < 0) {
      continue;
    }
    used[best] = 1;
    // MuJoCo's contact-frame force: normal, then each friction row's force s_k lambda_k in its
    // slot (ost_constraint.h: normalized rows)
    mjtNum f[6] = {w->lambda[best], 0, 0, 0, 0, 0};
    int nf = osti_frictionCount(w->rows, w->nrow, best);
    for (int k = 1; k <= nf; k++) {
      const ostRow* fr = w->rows + best + k;
      int slot = (int)fr->lo;
      if (slot < con->dim) {
        f[slot] = fr->alpha * w->lambda[best + k];
      }
    }
    if (m->opt.cone == mjCONE_ELLIPTIC || con->dim == 1) {
      memcpy(d->efc_force + con->efc_address, f, con->dim * sizeof(mjtNum));
    } else {
      mju_encodePyramid(d->efc_force + con->efc_address, f, con->friction, con->dim);
    }
  }
  for (int i = 0; i < d->nefc; i++) {
    d->efc_state[i] = d->efc_force[i] != 0 ? mjCNSTRSTATE_QUADRATIC : mjCNSTRSTATE_SATISFIED;
  }
  mj_mulJacTVec(m, d, d->qfrc_constraint, d->efc_force);
}


// bytes of a context's warm-start state at most: a header (validity, rows, the contact
// capacity they came with), the state it ended in, the multipliers and rows of the last result
size_t ost_warmSize(const ostContext* c) {
  const mjModel* m = c->m;
  return 4 * sizeof(int) + (1 + m->nq + 2 * (size_t)m->nv) * sizeof(mjtNum)
         + c->world.nrow_max * (sizeof(ostRow) + sizeof(mjtNum));
}


void ost_warmSave(const ostContext* c, void* buf) {
  const mjModel* m = c->m;
  const ostWorld* w = &c->world;
  int* head = (int*)buf;
  head[0] = c->warm_valid;
  head[1] = w->nrow_warm;
  head[2] = c->ncon_cap;
  head[3] = 0;
  mjtNum* p = (mjtNum*)(head + 4);
  memcpy(p, c->state_end, (1 + m->nq + 2 * m->nv) * sizeof(mjtNum));
  p += 1 + m->nq + 2 * m->nv;
  memcpy(p, w->lambda_warm, w->nrow_warm * sizeof(mjtNum));
  memcpy(p + w->nrow_warm, w->rows_warm, w->nrow_warm * sizeof(ostRow));
}


int ost_warmLoad(ostContext* c, const void* buf) {
  const mjModel* m = c->m;
  const int* head = (const int*)buf;
  // the rows came from a context whose capacity had grown: grow this one alike first (which
  // drops its own warm start)
  if (head[2] > c->ncon_cap && ost_growCapacity(c, head[2], c->njmax_cap)) {
    return ost_fail(c, OST_ERR_MEMORY, "cannot grow the contact capacity to %d", head[2]);
  }
  ostWorld* w = &c->world;
  c->warm_valid = head[0];
  w->nrow_warm = head[1];
  const mjtNum* p = (const mjtNum*)(head + 4);
  memcpy(c->state_end, p, (1 + m->nq + 2 * m->nv) * sizeof(mjtNum));
  p += 1 + m->nq + 2 * m->nv;
  memcpy(w->lambda_warm, p, w->nrow_warm * sizeof(mjtNum));
  memcpy(w->rows_warm, p + w->nrow_warm, w->nrow_warm * sizeof(ostRow));
  return OST_OK;
}


// count a step's outcome in the context's totals (ost_totals)
static int countStep(ostContext* c, int status) {
  ostTotals* t = &c->totals;
  t->steps++;
  if (status && !OST_IS_WARNING(status)) {
    t->failed++;
    t->last_failure = status;
    t->overflow += status == OST_ERR_OVERFLOW;
    return status;
  }
  const ostStats* st = &c->stats;
  t->unconverged += (st->status & OST_NOT_CONVERGED) != 0;
  t->depenetrated += (st->status & OST_DEPENETRATED) != 0;
  t->retries += st->retries;
  t->geo_retries += st->geo_retries;
  t->overflow += (st->status & OST_OVERFLOW) != 0;
  t->worst_residual = mju_max(t->worst_residual, st->residual);
  t->worst_initial_violation = mju_max(t->worst_initial_violation, st->initial_violation);
  return status;
}


int ost_step1(const mjModel* m, mjData* d) {
  if (!m) return -1;
  if (!d) return -2;
  ostContext* c = ost_context(m, d);
  if (!c) {
    return OST_ERR_MEMORY;
  }
  int status = checkInputs(c, m, d, 0);
  if (status) {
    return countStep(c, status);
  }
  // stock position/velocity stages at (q-, u-) and mjcb_control (mj_step1), unless the last
  // step published exactly these stages at this state (ost_published.c): then only the callback
  int reuse = ost_publishedCurrent(c, m, d);
  if (reuse < 0) {
    return countStep(c, OST_ERR_MEMORY);
  }
  c->step1_synced = reuse;  // ost_publishedCurrent compared the model (ost_step reads it)
  if (!reuse) {
    mj_step1(m, d);
  } else {
    c->totals.stages_reused++;
    if (mjcb_control) {
      mjcb_control(m, d);
    }
  }
  return OST_OK;
}


// the mujoco provider's start of a step: f = qfrc_smooth minus the servo forces that become
// rows, and Mt = M(q-) + h D (implicit joint damping, as MuJoCo's Euler), unfactored. Stages at
// q- are recomputed unless fresh (ost_step1 just ran them).
static void mujocoStart(ostContext* c, const mjModel* m, mjData* d, mjtNum h, int fresh) {
  ostWorld* w = &c->world;
  int nv = m->nv;
  if (!fresh) {
    mj_fwdPosition(m, d);
    mj_fwdVelocity(m, d);
  }

  // explicit forces at (q-, u-): f = qfrc_smooth minus the servo forces that become rows. An
  // actuator with activation dynamics applies gain act+ + bias (eq. 8b): mj_fwdActuation reads
  // d->act, which holds act+ while it runs and act- again after
  if (m->na) {
    mju_copy(c->act_next + m->na, d->act, m->na);
    mju_copy(d->act, c->act_next, m->na);
  }
  mj_fwdActuation(m, d);
  if (m->na) {
    mju_copy(d->act, c->act_next + m->na, m->na);
  }
  mj_fwdAcceleration(m, d);
  memcpy(w->qfrc_explicit, d->qfrc_smooth, nv * sizeof(mjtNum));
  if (!(m->opt.disableflags & mjDSBL_ACTUATION)) {
    for (int i = 0; i < m->nu; i++) {
      if (c->servo[i]) {
        for (int j = 0; j < nv; j++) {
          w->qfrc_explicit[j] -= d->actuator_moment[i * nv + j] * d->actuator_force[i];
        }
      }
    }
  }

  // a tendon spring or damper that the explicit step could not carry becomes an implicit row
  // (ost_rowsMujoco): with d_t = J M^-1 J' (the tendon's inverse effective mass), explicit Euler
  // needs h omega = h sqrt(k d_t) < 2 and h b d_t < 2; past half of either the tendon is a row,
  // and its force at (q-, u-), which mj_passive put into qfrc_smooth, leaves f. d_t moves with
  // the pose slowly: it is refreshed at a step that does not continue the last one and where
  // time / h is a multiple of 8 (a tendon would have to get 4 times stiffer in between to pass
  // the limit explicitly); both are part of the state, so a repeated step decides alike
  int refresh = c->step_cold || lround(d->time / h) % 8 == 0;
  c->step_cold = 0;
  for (int t = 0; t < m->ntendon; t++) {
    mjtNum k = m->tendon_stiffness[t], b = m->tendon_damping[t];
    c->ten_implicit[t] = 0;
    if ((m->opt.disableflags & mjDSBL_PASSIVE) || (!(k > 0) && !(b > 0))) {
      continue;
    }
    mjtNum* Jt = w->tmp;  // scratch of 2 nv
    mjtNum* x = w->tmp + nv;
    if (refresh) {
      ost_tendonRow(m, d, t, Jt);
      mj_solveM(m, d, x, Jt, 1);
      c->ten_dt[t] = mju_dot(Jt, x, nv);
    }
    mjtNum dt = c->ten_dt[t];
    if (!(h * h * k * dt > 1 || h * b * dt > 1)) {
      continue;
    }
    c->ten_implicit[t] = 1;
    if (!refresh) {
      ost_tendonRow(m, d, t, Jt);
    }
    mjtNum frc = -k * (d->ten_length[t] - m->tendon_lengthspring[t]) - b * d->ten_velocity[t];
    for (int j = 0; j < nv; j++) {
      w->qfrc_explicit[j] -= Jt[j] * frc;
    }
  }

  // Mt = M(q-) + h D (implicit joint damping, as MuJoCo's Euler), factored once per step. M by
  // the private model's CRB, which follows run-time mass edits (ost_prepareContext); only a
  // model with simple dofs needs it: otherwise d->qM already came from CRB on m
  int simple = 0;
  for (int j = 0; j < nv; j++) {
    simple |= m->dof_simplenum[j];
  }
  if (simple) {
    mj_crb(c->mo, d);
  }
  // M is tree-sparse: MuJoCo's qM holds, per dof i, M_ii then M_ij for i's ancestors j, which
  // is all the tree factor reads (the lower triangle on the tree's pattern): O(nM), not O(nv^2)
  for (int i = 0; i < nv; i++) {
    int adr = m->dof_Madr[i];
    for (int j = i; j >= 0; j = m->dof_parentid[j]) {
      w->M[(size_t)i * nv + j] = d->qM[adr++];
    }
    w->M[(size_t)i * nv + i] += h * m->dof_damping[i];
  }
  w->dof_parent = m->dof_parentid;

  // hinge and slide springs implicitly (core/ost_rows_native.h)
  if (!(m->opt.disableflags & mjDSBL_PASSIVE)) {
    osti_implicitSprings(w->M, w->qfrc_explicit, nv, m->njnt, m->jnt_type, m->jnt_dofadr,
                         m->jnt_stiffness, d->qvel, h);
  }
}


// the substep's actuator inputs and act+ (core/ost_activation.h, eq. 8b) from d's ctrl and its
// act-, as osti_actuation does on a packed model: c->act_input (nu) and c->act_next (na)
static void activation(ostContext* c, const mjModel* m, const mjData* d, mjtNum h) {
  int clamp = !(m->opt.disableflags & mjDSBL_CLAMPCTRL);
  int off = !!(m->opt.disableflags & mjDSBL_ACTUATION);
  for (int i = 0; i < m->nu; i++) {
    mjtNum u = osti_actClamp(d->ctrl[i], clamp && m->actuator_ctrllimited[i],
                             m->actuator_ctrlrange + 2 * i);
    if (m->actuator_dyntype[i] == mjDYN_NONE) {
      c->act_input[i] = u;
      continue;
    }
    int j = i - (m->nu - m->na);  // activation j belongs to actuator i (mj_fwdActuation)
    c->act_next[j] = off ? d->act[j]
                         : osti_actNext(m->actuator_dyntype[i], m->actuator_dynprm + i * mjNDYN,
                                        m->actuator_actlimited[i], m->actuator_actrange + 2 * i,
                                        d->act[j], u, h);
    c->act_input[i] = c->act_next[j];
  }
}


// the start of a substep at d's (q-, u-, act-): the actuator inputs, then Mt and f into the
// world. Stages at q- are recomputed unless fresh (ost_step1 just ran them for the step's first
// substep).
static int startCallback(void* ctx, ostNum h) {
  stepContext* s = (stepContext*)ctx;
  activation(s->c, s->c->m, s->d, h);
  if (s->c->opt.geometry == OST_GEOMETRY_NATIVE) {
    ost_startNative(s->c, s->d, h);  // core's own dynamics
  } else {
    mujocoStart(s->c, s->c->m, s->d, h, s->fresh);
  }
  s->fresh = 0;
  return OST_OK;
}


// a committed substep (d->qpos, d->qvel and d->qacc_warmstart already hold it): qacc, time, its
// record for the gradient (with act-), act = act+, the end state a next step continues from,
// statistics
static int commitCallback(void* ctx, ostNum h, const ostNewtonStats* ns, int bits) {
  stepContext* s = (stepContext*)ctx;
  ostContext* c = s->c;
  mjData* d = s->d;
  const mjModel* m = c->m;
  memcpy(d->qacc, d->qacc_warmstart, m->nv * sizeof(mjtNum));
  d->time += h;
  int status = ost_recordSubstep(c, m, d, h, ns->best_merit,
                                 (bits & OST_STEP_NOT_CONVERGED ? OST_NOT_CONVERGED : 0)
                                 | (bits & OST_STEP_DEPENETRATED ? OST_DEPENETRATED : 0));
  if (status) {
    return status;
  }
  memcpy(d->act, c->act_next, m->na * sizeof(mjtNum));
  saveState(m, d, c->state_end);
  c->warm_valid = 1;
  c->stats.substeps++;
  c->stats.residual = mju_max(c->stats.residual, ns->best_merit);
  if (bits & OST_STEP_NOT_CONVERGED) {
    c->stats.status |= OST_NOT_CONVERGED;
  }
  return OST_OK;
}


// the geometric Newton arrays for this context's steps, or NULL: the option is on and the
// geometry is MuJoCo's (the native provider keeps the fixed-J model of the batches, CPU and GPU,
// so that ost_step with it stays bitwise equal to them)
static ostGeoWork* geometricNewton(ostContext* c) {
  return (c->opt.geometric_newton || c->opt.geometric_retry)
         && c->opt.geometry != OST_GEOMETRY_NATIVE ? &c->geo : NULL;
}


// the host-only work of a step on the world: the geometric term's arrays and the rows'
// half-solve cache (same bits as without it; kept off the native provider like the term)
static void hostWork(ostContext* c) {
  // the options as the arrays' (re)initialization left them: a capacity grown within a step
  // (advanceGrowing) makes the arrays again, and the step's retry ran without the geometric
  // term (MuJoCo's hammock at 25 ms, whose look-ahead overflows its nconmax in the first step:
  // 854 Newton iterates and that step unconverged, against 198 and converged with room)
  c->geo.mode = c->opt.geometric_newton;
  c->geo.retry_on = c->opt.geometric_retry;
  c->world.geo = geometricNewton(c);
  c->world.yrow = c->opt.geometry != OST_GEOMETRY_NATIVE && !c->no_row_cache ? c->geo.yrow : NULL;
  c->world.yrow_sqrtd = c->world.yrow ? c->geo.yrow_sqrtd : NULL;
  c->world.env = c->world.yrow && !c->no_envelope ? &c->env : NULL;  // they read the cache
  c->env.decouple = c->opt.decouple_open;
}


static int failBits(int status) {
  return status == OST_ERR_OVERFLOW ? OST_STEP_OVERFLOW : OST_STEP_NAN;
}


// one step of size h from d's state by core's step driver (core/ost_step.h osti_stepDriven:
// substeps, splitting, commit) with the context's provider; fresh: ost_step1's stages at q- are
// current in d. Returns OST_OK or the failure's status, its message recorded; the caller
// restores the state on a failure.
static int advance(ostContext* c, mjData* d, mjtNum h, int fresh) {
  const ostOptions* o = &c->opt;
  ostStepSettings set = {ost_solverOptions(o), o->linesearch, o->split_depth, o->deep_splits,
                         o->warmstart, o->cold_retry, h, o->split_tol, o->margin,
                         o->depenetration_speed};
  stepContext s;  // merit_k and nrow_k are written before they are read (newtonCallback reads
                  // the iterates the loop just wrote): not zeroed, 12 KB per step
  s.c = c;
  s.d = d;
  s.fresh = fresh;
  ostStepDriver drv = {&s, startCallback, geometryCallback, newtonCallback, commitCallback,
                       failBits, s.merit_k, s.nrow_k, mjNSOLVER};
  // the multipliers start from the last step's if this step continues from its result
  // (bitwise), else from zero, so that a step repeated from a restored or perturbed state
  // (finite differences) is reproducible; u starts from u- + h qacc_warmstart
  int warm = continuesLastStep(c, d), substeps, status;
  c->step_cold = !warm;
  mjtNum worst;
  int bits = osti_stepDriven(&c->world, c->m->nq, d->qpos, c->qpos_prev, d->qvel,
                             d->qacc_warmstart, &warm, &set, &drv, &substeps, &worst, &status);
  if (bits & OST_STEP_CHOL_FAIL) {
    c->stats.status |= OST_CHOL_FAIL;
    return ost_fail(c, OST_ERR_NUMERIC, "M + hD is not positive definite");
  }
  return (bits & OST_STEP_FAILED) ? status : OST_OK;
}


// advance(), growing the iterates' capacity when the look-ahead overflows it: the contacts,
// constraint rows and rows are doubled (ost_growCapacity) and the step is taken again from its
// start, up to OST_GROWTH_MAX times the model's nconmax, as MuJoCo would go on past a full
// contact buffer. The capacity stays grown for the next steps.
static int advanceGrowing(ostContext* c, const mjModel* m, mjData* d, mjtNum h) {
  for (int fresh = 1;; fresh = 0) {
    int status = OST_OK;
    c->overflow_cap = 0;
    if (c->opt.geometry != OST_GEOMETRY_NATIVE) {
      mjData* dg = ost_geometryData(c);
      if (!dg) {
        return ost_fail(c, OST_ERR_MEMORY, "cannot allocate the iterates' mjData");
      }
      memcpy(dg->mocap_pos, d->mocap_pos, 3 * m->nmocap * sizeof(mjtNum));
      memcpy(dg->mocap_quat, d->mocap_quat, 4 * m->nmocap * sizeof(mjtNum));
    } else if ((status = ost_nativeReady(c, m))) {
      return status;
    }
    status = advance(c, d, h, fresh);
    c->stats.ncon_capacity = c->ncon_cap;
    if (status != OST_ERR_OVERFLOW || !c->overflow_cap) {
      return status;
    }
    int contacts = c->overflow_cap == 1;
    long cap = contacts ? c->ncon_cap : c->njmax_cap;
    long base = contacts ? m->nconmax : m->njmax;
    if (2 * cap > OST_GROWTH_MAX * (base > 0 ? base : 1)) {
      char why[sizeof(c->err)];
      memcpy(why, c->err, sizeof(why));
      return ost_fail(c, OST_ERR_OVERFLOW, "%s, after Ostrich grew its own capacity to %ld "
                      "(%d times %s; ostrich/margin %g m widens every margin, so Ostrich sees "
                      "contacts and limits MuJoCo's step does not): raise <size %s=...> or "
                      "lower ostrich/margin", why, cap, OST_GROWTH_MAX,
                      contacts ? "nconmax" : "njmax", c->opt.margin,
                      contacts ? "nconmax" : "njmax");
    }
    // again from the step's start, with room for twice the contacts
    restoreStart(c, m, d);
    c->rec_n = 0;
    c->rec_bytes = 0;
    memset(&c->stats, 0, sizeof(c->stats));
    if (ost_growCapacity(c, contacts ? 2 * c->ncon_cap : c->ncon_cap,
                         contacts ? c->njmax_cap : 2 * c->njmax_cap)) {
      return ost_fail(c, OST_ERR_MEMORY, "cannot grow the capacity to %ld", 2 * cap);
    }
    c->world.lookahead = c->opt.margin;
    c->world.depen_speed = c->opt.depenetration_speed;
    hostWork(c);
  }
}


static int step2(ostContext* c, const mjModel* m, mjData* d, int synced);

int ost_step2(const mjModel* m, mjData* d) {
  if (!m) return -1;
  if (!d) return -2;
  ostContext* c = ost_context(m, d);
  if (!c) {
    return OST_ERR_MEMORY;
  }
  return countStep(c, step2(c, m, d, 0));
}


// ost_step2 on its context: the step, publication and statistics (uncounted). synced: the
// model was compared with the private one since the last step (ost_step1 of this ost_step).
static int step2(ostContext* c, const mjModel* m, mjData* d, int synced) {
  int status;
  if ((status = prepareSynced(c, m, synced ? 0 : ost_syncModel(c, m)))
      || (status = checkInputs(c, m, d, 1))) {
    return status;
  }
  mjtNum h = c->opt.timestep > 0 ? c->opt.timestep : m->opt.timestep;
  ostWorld* w = &c->world;
  w->lookahead = c->opt.margin;
  w->depen_speed = c->opt.depenetration_speed;
  hostWork(c);
  memset(&c->stats, 0, sizeof(c->stats));
  c->rec_n = 0;
  c->rec_bytes = 0;
  c->published_valid = 0;
  saveState(m, d, c->state_start);
  status = advanceGrowing(c, m, d, h);
  c->world.yrow = NULL;  // the cache is the step's: the adjoint and others run without it
  c->world.yrow_sqrtd = NULL;
  c->world.env = NULL;
  if (status) {
    if (status == OST_ERR_OVERFLOW) {
      c->stats.status |= OST_OVERFLOW;
    }
    return abortStep(c, m, d, status);
  }
  d->solver_iter = c->stats.newton_iter < mjNSOLVER ? c->stats.newton_iter : mjNSOLVER;
  ostRecord last;
  ost_recordView(m, (char*)c->rec_buf + c->rec_last, &last);
  last.head->step_end = 1;

  // publish: MuJoCo's own contacts and rows at q+ (look-ahead model: contacts within the
  // look-ahead distance are listed, separated ones with zero force), forces = lambda
  int warn_con = d->warning[mjWARN_CONTACTFULL].number;
  ost_publishPosition(c, d);
  if (d->warning[mjWARN_CONTACTFULL].number != warn_con) {
    c->stats.status |= OST_OVERFLOW;
  }
  publishForces(c, m, d);
  mj_sensorPos(m, d);
  mj_energyPos(m, d);
  mj_fwdVelocity(m, d);
  mj_sensorVel(m, d);
  mj_energyVel(m, d);
  mj_fwdActuation(m, d);
  mj_fwdAcceleration(m, d);
  mj_sensorAcc(m, d);
  ost_publishedSave(c, m, d);
  if (c->opt.geometry == OST_GEOMETRY_NATIVE) {
    // native contacts at q+ (the best iterate's), e.g. of a terrain mesh MuJoCo cannot collide
    mjtNum pen = 0;
    for (int i = 0; i < c->kin.ncon; i++) {
      pen = mju_max(pen, -c->kin.contact[i].dist);
    }
    c->stats.max_penetration = pen;
  } else {
    // MuJoCo's contacts, and the core pairs this step packed (ost_prepareContext)
    c->stats.max_penetration = ost_penetrationWith(m, d, &c->corepairs, c->hfield_data,
                                                   &c->mesh);
  }
  // a step whose committed substeps did not all reach tol is taken, but says so, also to a
  // caller that prints ost_lastError
  if (c->stats.status & OST_NOT_CONVERGED) {
    return ost_fail(c, OST_WARN_NOT_CONVERGED, "the step did not converge: residual %.3g m/s "
                    "above tol %.3g after %d Newton iterates (the state was advanced; raise "
                    "ostrich/newton_iter or lower the timestep)", c->stats.residual, c->opt.tol,
                    c->stats.newton_iter);
  }
  return OST_OK;
}


// ost_step1 then the step: when ost_step1 reused the published stages it has compared the model
// already, and only mjcb_control ran since (a control callback that edits the model is followed
// from the next step on)
int ost_step(const mjModel* m, mjData* d) {
  int status = ost_step1(m, d);
  if (status) {
    return status;
  }
  ostContext* c = ost_context(m, d);
  return countStep(c, step2(c, m, d, c->step1_synced));
}
