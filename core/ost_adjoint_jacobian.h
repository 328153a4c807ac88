// ost_adjoint_jacobian.h: the exact Jacobian of one Ostrich step's residual by forward-mode
// dual numbers, for a translation unit that compiles core/ with ostNum = ostDual<OSTX_CHUNK>
// (core/ost_dual.h): plugin/ost_adjoint_dual.cc (the plugin's adjoint), plugin/ost_batch_adjoint.cc
// (the CPU batch) and cuda/ost_batch_adjoint.cu (the CUDA batch). Each pass seeds OSTX_CHUNK input
// directions and reads their derivatives off every output. Nothing here is hand-differentiated:
// contact points, normals and distances, the mass matrix and bias forces, and ball/free joints'
// exponential map all enter exactly (core/README.md section 2).
// No allocation: the work's arrays live in one caller-provided block (ostx_jacWorkSize bytes).
// Invariant: reads the step's inputs; writes only the work block, G and the model's parameter
// derivatives (only when parameters are seeded, st->nparam > 0).
#ifndef OSTRICH_CORE_OST_ADJOINT_JACOBIAN_H_
#define OSTRICH_CORE_OST_ADJOINT_JACOBIAN_H_

#ifndef OST_NUM_TYPE
#error "ost_adjoint_jacobian.h needs ostNum = ostDual<OSTX_CHUNK> (define OST_NUM_TYPE)"
#endif
#ifndef OSTX_CHUNK
#error "define OSTX_CHUNK, the directions of one dual pass (OST_NUM_TYPE = ostDual<OSTX_CHUNK>)"
#endif

#include <math.h>

#include "ost_activation.h"
#include "ost_adjoint.h"
#include "ost_dual.h"
#include "ost_rows_native.h"

typedef struct ostJacWork_ {      // the dual evaluation's state: pointers into one block
  ostModel* m;                    // dual model (parameters seeded here when nparam > 0)
  ostKin    k;                    // dual kinematics (at q+)
  ostKin    km;                   // dual kinematics at q- (ostx_jacColumnsSplit)
  ostWorld  w;                    // dual world: rows, J, Mt, f at the step
  ostNum *qpos, *qplus, *qref, *dqm, *dqp, *u, *uprev, *ctrl, *qfrc, *xfrc, *lambda, *R;
  ostNum *act, *act_next, *input; // act- (na), act+ (na), actuator inputs (nu): ost_activation.h
  ostNum *M0, *f0, *fp0;          // the step's Mt (unfactored, nv x nv), f (nv) and f without
                                  // the explicit actuators (nv), at the values
  double *Rq, *T;                 // dR/dq+ ((nv + nrow_max) x nv) and d(dq+)/d(u, dq-) (nv x 2 nv)
  ostRow*   rec;                  // the recorded rows as dual rows (matching keys)
  ostNum*   rec_lambda;           // their multipliers
  unsigned char* used;            // matching scratch
  int       nrow_max;
} ostJacWork;

// dual vectors of the work: 3 nq + 6 nv + nu + 6 nbody + 2 nrow_max + nv + nrow_max, then
// 2 na + nu for the activations, nv^2 + 2 nv for Mt, f and f without actuators
OST_HD size_t ostx_jacVectors(ostSizes s, int nrow_max) {
  return 3 * (size_t)s.nq + 7 * (size_t)s.nv + s.nu + 6 * (size_t)s.nbody + 3 * (size_t)nrow_max
         + 2 * (size_t)s.na + s.nu + (size_t)s.nv * s.nv + 2 * (size_t)s.nv;
}


// doubles of the work: dR/dq+ and d(dq+)/d(u, dq-)
OST_HD size_t ostx_jacDoubles(ostSizes s, int nrow_max) {
  return ((size_t)s.nv + nrow_max) * s.nv + 2 * (size_t)s.nv * s.nv;
}


// bytes of a work block for sizes s and row capacity nrow_max (each part 64-byte aligned)
OST_HD size_t ostx_jacWorkSize(ostSizes s, int nrow_max) {
  return 2 * ostu_kinSize(s) + ostu_worldSizeFor(s.nv, s.nv, nrow_max, 0)
         + OST_ALIGN64(ostx_jacVectors(s, nrow_max) * sizeof(ostNum))
         + OST_ALIGN64(ostx_jacDoubles(s, nrow_max) * sizeof(double))
         + OST_ALIGN64((size_t)nrow_max * sizeof(ostRow)) + OST_ALIGN64((size_t)nrow_max);
}


// point a work at block (64-byte aligned, ostx_jacWorkSize bytes; zeroed once before first use)
// for the dual model m
OST_HD void ostx_jacWorkInit(ostJacWork* wk, void* block, ostModel* m, int nrow_max) {
  ostSizes s = m->s;
  char* p = (char*)block;
  wk->m = m;
  wk->nrow_max = nrow_max;
  ostu_kinInit(&wk->k, p, s);
  p += ostu_kinSize(s);
  ostu_kinInit(&wk->km, p, s);
  p += ostu_kinSize(s);
  ostu_worldInitFor(&wk->w, p, s.nv, s.nv, nrow_max, 0, 0);  // residual only: no solver arrays
  p += ostu_worldSizeFor(s.nv, s.nv, nrow_max, 0);
  ostNum* v = (ostNum*)p;
  p += OST_ALIGN64(ostx_jacVectors(s, nrow_max) * sizeof(ostNum));
  wk->Rq = (double*)p;
  wk->T = wk->Rq + ((size_t)s.nv + nrow_max) * s.nv;
  p += OST_ALIGN64(ostx_jacDoubles(s, nrow_max) * sizeof(double));
  wk->rec = (ostRow*)p;
  p += OST_ALIGN64((size_t)nrow_max * sizeof(ostRow));
  wk->used = (unsigned char*)p;
  wk->qpos = v;   v += s.nq;
  wk->qplus = v;  v += s.nq;
  wk->qref = v;   v += s.nq;
  wk->dqm = v;    v += s.nv;
  wk->dqp = v;    v += s.nv;
  wk->u = v;      v += s.nv;
  wk->uprev = v;  v += s.nv;
  wk->qfrc = v;   v += s.nv;
  wk->ctrl = v;   v += s.nu;
  wk->xfrc = v;   v += 6 * s.nbody;
  wk->lambda = v; v += nrow_max;
  wk->R = v;      v += s.nv + nrow_max;
  wk->rec_lambda = v; v += nrow_max;
  wk->act = v;    v += s.na;
  wk->act_next = v; v += s.na;
  wk->input = v;  v += s.nu;
  wk->M0 = v;     v += (size_t)s.nv * s.nv;
  wk->f0 = v;     v += s.nv;
  wk->fp0 = v;
}


// set the derivatives of every parameter array the columns may seed back to zero
OST_HD void ostx_clearParamSeeds(ostModel* m) {
  ostSizes s = m->s;
  for (int i = 0; i < s.npair; i++) m->pair_friction[i] = (double)m->pair_friction[i];
  for (int i = 0; i < s.nbody; i++) m->body_mass[i] = (double)m->body_mass[i];
  for (int i = 0; i < s.nv; i++) m->dof_damping[i] = (double)m->dof_damping[i];
  for (int i = 0; i < s.nu; i++) m->actuator_gainprm[i] = (double)m->actuator_gainprm[i];
  for (int i = 0; i < 3 * s.nu; i++) m->actuator_biasprm[i] = (double)m->actuator_biasprm[i];
}


// seed parameter p (index into theta, groups at st->param_adr) with direction k
OST_HD void ostx_seedParam(ostModel* m, const ostdStep* st, int p, int k) {
  const int* adr = st->param_adr;
  int g = 0;
  while (g + 1 < 7 && p >= adr[g + 1]) {
    g++;
  }
  int i = p - adr[g];
  switch (g) {
  case 0:  // geom friction: every pair whose coefficient it sets
    for (int q = 0; q < m->s.npair; q++) {
      for (int e = 0; e < 2; e++) {
        if (st->pair_fric_geom[2 * q + e] == i) {
          m->pair_friction[q].d[k] += st->pair_fric_weight[2 * q + e];
        }
      }
    }
    break;
  case 1: m->body_mass[i].d[k] = 1; break;
  case 2: m->dof_damping[i].d[k] = 1; break;
  case 3: m->actuator_gainprm[i].d[k] = 1; break;
  case 4: m->actuator_biasprm[3 * i + 1].d[k] = 1; break;
  case 5: m->actuator_biasprm[3 * i + 2].d[k] = 1; break;
  default: break;
  }
}


// the step's values into the work, no derivatives: q-, act-, dq- = 0, u, u-, qfrc, ctrl,
// xfrc, and the first nrow_expect multipliers (lam, or the values the work holds); the
// parameters' seeds cleared when the step has parameter columns (a batch's lanes share one dual
// model and never seed it, so it is only written where parameters are seeded)
OST_HD void ostx_jacLoad(ostJacWork* wk, const ostdStep* st, int nrow_expect, const double* lam) {
  ostModel* m = wk->m;
  int nq = m->s.nq, nv = m->s.nv, nu = m->s.nu, na = m->s.na;
  for (int i = 0; i < nq; i++) wk->qpos[i] = st->qpos_prev[i];
  for (int i = 0; i < na; i++) wk->act[i] = st->act_prev[i];
  for (int i = 0; i < nv; i++) {
    wk->dqm[i] = 0;
    wk->u[i] = st->qvel[i];
    wk->uprev[i] = st->qvel_prev[i];
    wk->qfrc[i] = st->qfrc_applied ? st->qfrc_applied[i] : 0;
  }
  for (int i = 0; i < nu; i++) wk->ctrl[i] = st->ctrl[i];
  for (int i = 0; i < 6 * m->s.nbody; i++) {
    wk->xfrc[i] = st->xfrc_applied ? st->xfrc_applied[i] : 0;
  }
  for (int i = 0; i < nrow_expect; i++) wk->lambda[i] = lam ? lam[i] : (double)wk->lambda[i];
  if (st->nparam > 0) {
    ostx_clearParamSeeds(m);
  }
}


// one evaluation of R and O at the step's values with the columns [col0, col0 + OSTX_CHUNK)
// seeded (col0 < 0: no seeds). ny = nv + nrow of the native rows (known after the first call);
// lam: the multipliers matched onto them (NULL: the values wk->lambda already holds).
// Returns OST_ROWS_* or -1 if the rows differ from the first evaluation's.
OST_HD int ostx_jacEvaluate(ostJacWork* wk, const ostdStep* st, int col0, int ny,
                            int nrow_expect, const double* lam) {
  ostModel* m = wk->m;
  int nq = m->s.nq, nv = m->s.nv, nu = m->s.nu, na = m->s.na;
  ostx_jacLoad(wk, st, nrow_expect, lam);
  (void)nu;

  // seeds: column c is direction c - col0
  for (int k = 0; col0 >= 0 && k < OSTX_CHUNK; k++) {
    int c = col0 + k;
    if (c < nv) {
      wk->u[c].d[k] = 1;
    } else if (c < ny) {
      wk->lambda[c - nv].d[k] = 1;
    } else if ((c -= ny) < nv) {
      wk->dqm[c].d[k] = 1;
    } else if ((c -= nv) < nv) {
      wk->uprev[c].d[k] = 1;
    } else if ((c -= nv) < na) {
      wk->act[c].d[k] = 1;
    } else if ((c -= na) < nu) {
      wk->ctrl[c].d[k] = 1;
    } else if ((c -= nu) < st->nparam) {
      ostx_seedParam(m, st, c, k);
    }
  }

  // the actuators' inputs with act+ (eq. 8b), q- (+) dq-, the step's start (Mt, f), then
  // q+ = q- (+) h u and the rows there
  osti_actuation(m, wk->ctrl, wk->act, st->h, wk->act_next, wk->input);
  osti_integratePos(m, wk->qpos, wk->dqm, 1);
  osti_nativeStart(m, &wk->k, &wk->w, wk->qpos, wk->uprev, wk->input, wk->qfrc, wk->xfrc, st->h);
  for (int i = 0; i < nq; i++) wk->qplus[i] = wk->qpos[i];
  osti_integratePos(m, wk->qplus, wk->u, st->h);
  int rc = osti_nativeIterate(m, &wk->k, &wk->w, wk->qplus, wk->input, st->lookahead, st->h);
  if (rc) {
    return rc;
  }
  if (nrow_expect >= 0 && wk->w.nrow != nrow_expect) {
    return -1;
  }
  for (int i = 0; i < nq; i++) wk->qref[i] = (double)wk->qplus[i];
  osti_tangentLinear(m, wk->dqp, wk->qplus, wk->qref);
  if (st->truncate) {
    osti_truncateContacts(&wk->w, wk->dqp);
  }
  for (int i = 0; i < nv; i++) wk->w.qvel_prev[i] = wk->uprev[i];
  wk->w.h = st->h;
  osti_stepResidual(&wk->w, wk->u, wk->lambda, st->reg, st->creep, st->fb_eps, wk->R);
  return 0;
}


// The structure pass of a step's Jacobian: the native rows at q+ are recomputed and the
// recorded multipliers matched onto them (by object and contact key); their values go to lam
// (nrow_max, or NULL) and n = nv + their count to *n_out. Returns 0, or 2 if the rows overflow.
OST_HD int ostx_jacStructure(ostJacWork* wk, const ostdStep* st, double* lam, int* n_out) {
  if (st->nrow > wk->nrow_max) {
    return 2;
  }
  // the rows at q+ = (q- (+) 0) (+) h u alone (no start, no residual), as every pass makes them
  ostModel* m = wk->m;
  ostx_jacLoad(wk, st, 0, NULL);
  osti_actuation(m, wk->ctrl, wk->act, st->h, wk->act_next, wk->input);
  osti_integratePos(m, wk->qpos, wk->dqm, 1);
  for (int i = 0; i < m->s.nq; i++) wk->qplus[i] = wk->qpos[i];
  osti_integratePos(m, wk->qplus, wk->u, st->h);
  if (osti_nativeIterate(m, &wk->k, &wk->w, wk->qplus, wk->input, st->lookahead, st->h)) {
    return 2;
  }
  int nrow = wk->w.nrow;
  const ostRowDouble* rr = (const ostRowDouble*)st->rows;
  for (int i = 0; i < st->nrow; i++) {
    ostRow* r = wk->rec + i;
    r->type = rr[i].type;
    r->obj[0] = rr[i].obj[0];
    r->obj[1] = rr[i].obj[1];
    r->normal = rr[i].normal;
    for (int c = 0; c < 3; c++) r->key[c] = rr[i].key[c];
    r->pos = r->mu = r->alpha = r->lo = r->hi = 0;
    wk->rec_lambda[i] = st->lambda[i];
  }
  osti_matchRows(wk->lambda, wk->w.rows, nrow, wk->rec_lambda, wk->rec, st->nrow, wk->used);
  for (int i = 0; lam && i < nrow; i++) lam[i] = (double)wk->lambda[i];
  *n_out = wk->m->s.nv + nrow;
  return 0;
}


// The column chunks col0 = c0, c0 + cstep, .. (< ncol) of G (layout of ostx_stepJacobian) after
// the structure pass gave ny and lam (NULL: this work's own pass). Threads with their own works
// may fill disjoint chunks of one G. *r2 (if not NULL) gets |R|^2 when chunk 0 is among them.
// Returns 0, or 2 if the rows differ from the structure pass's.
OST_HD int ostx_jacColumns(ostJacWork* wk, const ostdStep* st, const double* lam, int ny,
                           int c0, int cstep, double* G, int ncol, double* r2) {
  int nv = wk->m->s.nv, na = wk->m->s.na;
  for (int col0 = c0; col0 < ncol; col0 += cstep) {
    if (ostx_jacEvaluate(wk, st, col0, ny, ny - nv, lam)) {
      if (st->nparam > 0) {
        ostx_clearParamSeeds(wk->m);
      }
      return 2;
    }
    for (int k = 0; k < OSTX_CHUNK && col0 + k < ncol; k++) {
      int c = col0 + k;
      for (int i = 0; i < ny; i++) G[(size_t)i * ncol + c] = wk->R[i].d[k];
      for (int i = 0; i < nv; i++) {
        G[(size_t)(ny + i) * ncol + c] = wk->dqp[i].d[k];
        G[(size_t)(ny + nv + i) * ncol + c] = wk->u[i].d[k];
      }
      for (int i = 0; i < na; i++) G[(size_t)(ny + 2 * nv + i) * ncol + c] = wk->act_next[i].d[k];
    }
    if (col0 == 0 && r2) {
      *r2 = 0;
      for (int i = 0; i < ny; i++) *r2 += wk->R[i].v * wk->R[i].v;
    }
  }
  if (st->nparam > 0) {
    ostx_clearParamSeeds(wk->m);  // the model leaves without seeds, whatever the next step asks
  }
  return 0;
}


// The fast path to ostx_jacColumns' G (which stays its oracle): each input column is
// evaluated through the part of the step that it moves, and its path through
// q+ = (q- (+) dq-) (+) h u by the chain rule, d/dc = d/dc|q+ held + (dR/dq+) T_c with
// T = d(dq+)/d(u, dq-), dq+ the tangent of q+ (osti_tangentLinear). After the values (the start
// at q-, the rows at q+, the residual with its factor and row diagonal), units of OSTX_CHUNK
// columns of one kind each, in this order:
//   Y    y = (u, lambda): the dynamics rows in closed form (linear in y), the constraint rows
//        by the residual alone on the step's factor and row diagonal (cheap)
//   UM   u-: the start's velocity part (f) and the dynamics rows
//   AC   act-, ctrl: the inputs (act+), the actuators' forces and the servo rows' fields
//   DQ   dq-: the start at q- (+) dq- (Mt, f, the row diagonal), q+ held
//   TH   theta: the whole evaluation, q+ held
//   GEO  dR/dq+ into Rq ((nv + nrow) x nv): kinematics, collision and rows at q+ (+) delta, nv
//        directions, the only units through collision
//   TT   T into T (nv x 2 nv): the exponential maps alone
// Thread t of nt takes units t, t + nt, .. (each thread its own work, all writing one G, Rq and
// T: the units' columns are disjoint); a unit leaves the work as the later kinds need it, so a
// thread's units run in the order above. Written: rows R of every column, act+ rows of the AC
// columns, Rq and T; osti_jacAssemble then completes G (the chain rule and the outputs' rows).
// Same inputs and result as ostx_jacColumns with c0 = 0, cstep = OSTX_CHUNK (the columns differ
// from the oracle's by rounding only, and not at all with nt). rows_ready: this work (the same
// ostJacWork, not only its block) ran the step's structure pass last, so its rows are reused.
OST_HD int ostx_jacColumnsSplit(ostJacWork* wk, const ostdStep* st, const double* lam, int ny,
                                double* G, int ncol, double* r2, int rows_ready, int t, int nt,
                                double* Rq, double* T) {
  ostModel* m = wk->m;
  ostWorld* w = &wk->w;
  int nq = m->s.nq, nv = m->s.nv, nu = m->s.nu, na = m->s.na, nrow = ny - nv;
  int np = st->nparam, nx = 2 * nv + na;
  ostNum h = st->h;
  const int C = OSTX_CHUNK;

  // the values: start at q-, rows at q+, the residual (factor and diagonal kept)
  ostx_jacLoad(wk, st, nrow, lam);
  osti_actuation(m, wk->ctrl, wk->act, h, wk->act_next, wk->input);
  osti_integratePos(m, wk->qpos, wk->dqm, 1);
  osti_nativeStartPos(m, &wk->km, w, wk->qpos, h);
  osti_nativeStartVel(m, &wk->km, w, wk->qpos, wk->uprev, NULL, wk->qfrc, wk->xfrc, h);
  for (int i = 0; i < nv; i++) wk->fp0[i] = w->qfrc_explicit[i];
  osti_nativeActuatorForces(m, &wk->km, w->qfrc_explicit, wk->uprev, wk->input);
  for (int i = 0; i < nv * nv; i++) wk->M0[i] = w->M[i];
  for (int i = 0; i < nv; i++) wk->f0[i] = w->qfrc_explicit[i];
  for (int i = 0; i < nq; i++) wk->qplus[i] = wk->qpos[i];
  osti_integratePos(m, wk->qplus, wk->u, h);
  for (int i = 0; i < nq; i++) wk->qref[i] = (double)wk->qplus[i];
  if ((!rows_ready && osti_nativeIterate(m, &wk->k, w, wk->qplus, wk->input, st->lookahead, h))
      || w->nrow != nrow) {
    return 2;
  }
  for (int i = 0; i < nv; i++) w->qvel_prev[i] = wk->uprev[i];
  w->h = h;
  osti_stepResidual(w, wk->u, wk->lambda, st->reg, st->creep, st->fb_eps, wk->R);
  if (r2) {
    *r2 = 0;
    for (int i = 0; i < ny; i++) *r2 += wk->R[i].v * wk->R[i].v;
  }

#define OSTX_CEIL(n) (((n) + C - 1) / C)
#define OSTX_COLUMN(c, k) \
  for (int i_ = 0; i_ < ny; i_++) G[(size_t)i_ * ncol + (c)] = wk->R[i_].d[k]
  enum { Y, UM, AC, DQ, TH, GEO, TT, NKIND };
  int nunit[NKIND] = {OSTX_CEIL(ny), OSTX_CEIL(nv), OSTX_CEIL(na + nu), OSTX_CEIL(nv),
                      OSTX_CEIL(np), OSTX_CEIL(nv), OSTX_CEIL(2 * nv)};
  int ju_seeded = 0;  // w->Ju holds derivatives by u (a Y unit's), so J u must be made again
  for (int kind = 0, first = 0; kind < NKIND; first += nunit[kind++]) {
    for (int unit = first + ((t - first) % nt + nt) % nt; unit < first + nunit[kind]; unit += nt) {
      int c0 = (unit - first) * C;
      switch (kind) {
      case Y: {  // the dynamics rows' columns are Mt's and -h J's; the constraint rows by R
        int has_u = c0 < nv;
        for (int k = 0; k < C && c0 + k < ny; k++) {
          int c = c0 + k;
          if (c < nv) wk->u[c].d[k] = 1; else wk->lambda[c - nv].d[k] = 1;
          for (int i = 0; i < nv; i++) {
            G[(size_t)i * ncol + c] = c < nv ? (double)wk->M0[(size_t)i * nv + c]
                                             : -(double)h * (double)w->J[(size_t)(c - nv) * nv + i];
          }
        }
        osti_residualRowsJu(w, wk->u, wk->lambda, st->reg, st->creep, st->fb_eps, wk->R + nv,
                            has_u || ju_seeded);
        ju_seeded = has_u;
        for (int k = 0; k < C && c0 + k < ny; k++) {
          int c = c0 + k;
          for (int i = nv; i < ny; i++) G[(size_t)i * ncol + c] = wk->R[i].d[k];
          if (c < nv) wk->u[c] = (double)wk->u[c]; else wk->lambda[c - nv] = (double)wk->lambda[c - nv];
        }
        break;
      }
      case UM: {  // f and the dynamics rows (the constraint rows do not read u-)
        for (int k = 0; k < C && c0 + k < nv; k++) wk->uprev[c0 + k].d[k] = 1;
        for (int i = 0; i < nv; i++) w->qvel_prev[i] = wk->uprev[i];
        osti_nativeStartVel(m, &wk->km, w, wk->qpos, wk->uprev, wk->input, wk->qfrc, wk->xfrc, h);
        osti_residualDynamics(w, wk->M0, wk->u, wk->lambda, wk->R);
        for (int k = 0; k < C && c0 + k < nv; k++) {
          int c = ny + nv + c0 + k;
          for (int i = 0; i < ny; i++) G[(size_t)i * ncol + c] = i < nv ? wk->R[i].d[k] : 0;
          wk->uprev[c0 + k] = (double)wk->uprev[c0 + k];
        }
        for (int i = 0; i < nv; i++) w->qvel_prev[i] = wk->uprev[i];
        break;
      }
      case AC: {  // act+, the inputs, the actuators' forces and the servo rows
        for (int k = 0; k < C && c0 + k < na + nu; k++) {
          int c = c0 + k;
          if (c < na) wk->act[c].d[k] = 1; else wk->ctrl[c - na].d[k] = 1;
        }
        osti_actuation(m, wk->ctrl, wk->act, h, wk->act_next, wk->input);
        for (int i = 0; i < nv; i++) w->qfrc_explicit[i] = wk->fp0[i];
        osti_nativeActuatorForces(m, &wk->km, w->qfrc_explicit, wk->uprev, wk->input);
        osti_nativeServoRows(m, &wk->k, w, wk->input, h);
        osti_residualDynamics(w, wk->M0, wk->u, wk->lambda, wk->R);
        osti_residualRowsJu(w, wk->u, wk->lambda, st->reg, st->creep, st->fb_eps, wk->R + nv,
                            ju_seeded);
        ju_seeded = 0;
        for (int k = 0; k < C && c0 + k < na + nu; k++) {
          int c = c0 + k;
          OSTX_COLUMN(ny + 2 * nv + c, k);
          for (int i = 0; i < na; i++) {
            G[(size_t)(ny + 2 * nv + i) * ncol + ny + 2 * nv + c] = wk->act_next[i].d[k];
          }
          if (c < na) wk->act[c] = (double)wk->act[c]; else wk->ctrl[c - na] = (double)wk->ctrl[c - na];
        }
        osti_actuation(m, wk->ctrl, wk->act, h, wk->act_next, wk->input);
        osti_nativeServoRows(m, &wk->k, w, wk->input, h);
        break;
      }
      case DQ: {  // the start at q- (+) dq- with q+ held; Mt moves the factor and the diagonal
        for (int i = 0; i < nq; i++) wk->qpos[i] = st->qpos_prev[i];
        for (int k = 0; k < C && c0 + k < nv; k++) wk->dqm[c0 + k].d[k] = 1;
        osti_integratePos(m, wk->qpos, wk->dqm, 1);
        osti_nativeStart(m, &wk->km, w, wk->qpos, wk->uprev, wk->input, wk->qfrc, wk->xfrc, h);
        osti_stepResidual(w, wk->u, wk->lambda, st->reg, st->creep, st->fb_eps, wk->R);
        for (int k = 0; k < C && c0 + k < nv; k++) {
          OSTX_COLUMN(ny + c0 + k, k);
          wk->dqm[c0 + k] = 0;
        }
        break;
      }
      case TH: {  // everything, q+ held
        for (int k = 0; k < C && c0 + k < np; k++) ostx_seedParam(m, st, c0 + k, k);
        for (int i = 0; i < nq; i++) wk->qpos[i] = st->qpos_prev[i];
        osti_integratePos(m, wk->qpos, wk->dqm, 1);
        osti_nativeStart(m, &wk->km, w, wk->qpos, wk->uprev, wk->input, wk->qfrc, wk->xfrc, h);
        for (int i = 0; i < nq; i++) wk->qplus[i] = wk->qref[i];
        int rc = osti_nativeIterate(m, &wk->k, w, wk->qplus, wk->input, st->lookahead, h);
        if (!rc && w->nrow == nrow && st->truncate) {
          // contact J held (its derivative by the friction scale dropped)
          osti_tangentLinear(m, wk->dqp, wk->qplus, wk->qref);
          osti_truncateContacts(w, wk->dqp);
        }
        if (!rc && w->nrow == nrow) {
          osti_stepResidual(w, wk->u, wk->lambda, st->reg, st->creep, st->fb_eps, wk->R);
        }
        ostx_clearParamSeeds(m);
        if (rc || w->nrow != nrow) {
          return 2;
        }
        for (int k = 0; k < C && c0 + k < np; k++) OSTX_COLUMN(ny + nx + nu + c0 + k, k);
        break;
      }
      case GEO: {  // the rows at q+ (+) delta (delta in dq-'s storage), the start held
        for (int i = 0; i < nq; i++) wk->qplus[i] = wk->qref[i];
        for (int k = 0; k < C && c0 + k < nv; k++) wk->dqm[c0 + k].d[k] = 1;
        osti_integratePos(m, wk->qplus, wk->dqm, 1);
        if (osti_nativeIterate(m, &wk->k, w, wk->qplus, wk->input, st->lookahead, h)
            || w->nrow != nrow) {
          return 2;
        }
        if (st->truncate) {
          osti_tangentLinear(m, wk->dqp, wk->qplus, wk->qref);
          osti_truncateContacts(w, wk->dqp);
        }
        for (int i = 0; i < nv * nv; i++) w->M[i] = wk->M0[i];
        for (int i = 0; i < nv; i++) w->qfrc_explicit[i] = wk->f0[i];
        osti_stepResidual(w, wk->u, wk->lambda, st->reg, st->creep, st->fb_eps, wk->R);
        for (int k = 0; k < C && c0 + k < nv; k++) {
          for (int i = 0; i < ny; i++) Rq[(size_t)i * nv + c0 + k] = wk->R[i].d[k];
          wk->dqm[c0 + k] = 0;
        }
        break;
      }
      default: {  // TT: the exponential maps alone
        for (int k = 0; k < C && c0 + k < 2 * nv; k++) {
          int c = c0 + k;
          if (c < nv) wk->u[c].d[k] = 1; else wk->dqm[c - nv].d[k] = 1;
        }
        for (int i = 0; i < nq; i++) wk->qplus[i] = st->qpos_prev[i];
        osti_integratePos(m, wk->qplus, wk->dqm, 1);
        osti_integratePos(m, wk->qplus, wk->u, h);
        osti_tangentLinear(m, wk->dqp, wk->qplus, wk->qref);
        for (int k = 0; k < C && c0 + k < 2 * nv; k++) {
          int c = c0 + k;
          for (int i = 0; i < nv; i++) T[(size_t)i * 2 * nv + c] = wk->dqp[i].d[k];
          if (c < nv) wk->u[c] = (double)wk->u[c]; else wk->dqm[c - nv] = 0;
        }
        break;
      }
      }
    }
  }
#undef OSTX_COLUMN
#undef OSTX_CEIL
  return 0;
}


// Exact Jacobian of the step's residual and outputs: the structure pass, then every column
// chunk; n = nv + the count of the rows at q+. G ((n + 2 nv + na) x ncol, row-major, ncol = n +
// 2 nv + na + nu + nparam) receives the rows R (n) then O = (dq+, u+, act+) (2 nv + na),
// differentiated by the columns y = (u, lambda) (n) then xi = (dq-, u-, act-, ctrl, theta).
// *resid gets |R| at the solution. dense: 1 every column through the whole evaluation (the
// oracle, ostx_jacColumns), 0 ostx_jacColumnsSplit (2: split as 3 threads, for tests). Returns 0, 1 if G needs more than G_cap
// doubles (*n still set), 2 if the rows overflow or differ between evaluations.
OST_HD int ostx_stepJacobian(ostJacWork* wk, const ostdStep* st, double* G, size_t G_cap,
                             int* n_out, double* resid, int dense) {
  int nx = 2 * wk->m->s.nv + wk->m->s.na, nu = wk->m->s.nu, ny;
  if (ostx_jacStructure(wk, st, NULL, &ny)) {
    return 2;
  }
  *n_out = ny;
  int nout = ny + nx, ncol = ny + nx + nu + st->nparam;
  if ((size_t)nout * ncol > G_cap) {
    return 1;
  }
  double r2 = 0;
  if (dense == 1) {
    if (ostx_jacColumns(wk, st, NULL, ny, 0, OSTX_CHUNK, G, ncol, &r2)) {
      return 2;
    }
  } else {
    // the split passes, in one thread (dense == 2: as 3 threads one after another, in this
    // work, for the tests); the first reuses the structure pass's rows
    int nt = dense == 2 ? 3 : 1;
    for (int t = 0; t < nt; t++) {
      if (ostx_jacColumnsSplit(wk, st, NULL, ny, G, ncol, t == 0 ? &r2 : NULL, t == 0, t, nt,
                               wk->Rq, wk->T)) {
        return 2;
      }
    }
    osti_jacAssemble(G, ncol, ny, wk->m->s.nv, wk->m->s.na, wk->m->s.nu, wk->Rq, wk->T);
  }
  *resid = sqrt(r2);
  return 0;
}


// Phase 3 of a batch world's backward pass (core/ost_batch_adjoint.h), on record nrec - 1 - j of
// lane l's segment (nothing if j >= nrec or the world failed), in three parts so that a record's
// column chunks can run in parallel: 3a ostx_recordStructure (in the lane's dual work),
// 3b ostx_recordColumns (column thread t of njac), 3c osti_recordSolve (double build). m: the dual
// model, shared by all lanes (no parameters are seeded).

// 3a: the cotangents of the steps after the record's are injected; the structure pass sets
// info[OST_ADJ_NY] (0: nothing to do) and the lane's matched multipliers
OST_HD void ostx_recordStructure(ostModel* m, const ostAdjointLayout* A, char* lanes, int l,
                                 int i, int nworld, int j, const ostAdjointSettings* as,
                                 const double* gq, const double* gu) {
  ostAdjointLane al;
  ostu_adjointLane(&al, A, lanes, l);
  int* info = al.info;
  info[OST_ADJ_NY] = 0;
  if (info[OST_ADJ_FAILED] || j >= info[OST_ADJ_NREC]) {
    return;
  }
  ostStepRec r;
  ostdStep st;
  ostu_recordStep(&st, &r, A, &al, j, as);
  while (info[OST_ADJ_STEP] > *r.step + 1) {
    info[OST_ADJ_STEP]--;
    osti_adjointInject(A, &al, i, nworld, info[OST_ADJ_STEP], gq, gu);
  }
  ostJacWork jw;
  ostx_jacWorkInit(&jw, al.jac, m, A->nrow_max);
  int ny;
  if (ostx_jacStructure(&jw, &st, al.lam, &ny) || ny > A->ny_max) {
    info[OST_ADJ_FAILED] = OST_STEP_OVERFLOW;  // the rows at q+ exceed the capacity
    return;
  }
  info[OST_ADJ_NY] = ny;
}


// 3b: thread t of A->njac of the record's split passes (ostx_jacColumnsSplit) into the lane's
// G, Rq and T, in the dual work block `work` (NULL: the lane's own; the rows are made again, as
// 3a's world struct is gone); 3c assembles G (osti_jacAssemble). OST_STEP_OVERFLOW if the rows differ
// from the structure pass's.
OST_HD void ostx_recordColumns(ostModel* m, const ostAdjointLayout* A, char* lanes, int l, int t,
                               int j, const ostAdjointSettings* as, char* work) {
  ostAdjointLane al;
  ostu_adjointLane(&al, A, lanes, l);
  int ny = al.info[OST_ADJ_NY];
  if (ny == 0) {
    return;
  }
  ostStepRec r;
  ostdStep st;
  ostu_recordStep(&st, &r, A, &al, j, as);
  ostJacWork jw;
  ostx_jacWorkInit(&jw, work ? work : al.jac, m, A->nrow_max);
  int ncol = ny + 2 * A->s.nv + A->s.na + A->s.nu;
  if (ostx_jacColumnsSplit(&jw, &st, al.lam, ny, al.G, ncol, NULL, 0, t, A->njac, al.Rq, al.T)) {
    al.info[OST_ADJ_FAILED] = OST_STEP_OVERFLOW;
  }
}

#endif  // OSTRICH_CORE_OST_ADJOINT_JACOBIAN_H_
