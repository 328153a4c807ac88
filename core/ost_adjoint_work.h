// ost_adjoint_work.h: the dual evaluation of one Ostrich step for its Jacobian (the part of
// core/ost_adjoint_jacobian.h that the split passes, ost_adjoint_split.h, build on): the work
// block, loading a recorded step, seeding parameters, one whole evaluation of R and O with a
// chunk of columns seeded, the structure pass (the rows at q+ and the recorded multipliers
// matched onto them) and the dense columns, every column through the whole evaluation (the
// oracle of the split passes). For a translation unit with ostNum = ostDual<OSTX_CHUNK>.
// No allocation: the work's arrays live in one caller-provided block (ostx_jacWorkSize bytes).
// Invariant: reads the step's inputs; writes only the work block, G and the model's parameter
// derivatives (only when parameters are seeded, st->nparam > 0).
#ifndef OSTRICH_CORE_OST_ADJOINT_WORK_H_
#define OSTRICH_CORE_OST_ADJOINT_WORK_H_

#ifndef OST_NUM_TYPE
#error "ost_adjoint_work.h needs ostNum = ostDual<OSTX_CHUNK> (define OST_NUM_TYPE)"
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
  double *X, *diag0;              // x_i = Mt^-1 J_i' (nrow_max x nv) and J_i Mt^-1 J_i' (nrow_max)
                                  // at the values (ostx_rowSolves)
  double*   Rdyn0;                // the dynamics rows' values (nv)
  int*      pairs;                // the pairs in contact at the values (npair), ascending
  int*      color;                // the dR/dq+ directions' colors (nv; ostx_colorDofs), then
  int*      subtree;              // each dof's subtree size (nv) and the colors' marks (nv)
  ostRow*   rec;                  // the recorded rows as dual rows (matching keys)
  ostNum*   rec_lambda;           // their multipliers
  unsigned char* used;            // matching scratch
  ostModel* own;                  // room for a model of the work's own (ostx_jacOwnParams)
  ostNum*   own_param;            // and for its parameter arrays
  int       nrow_max;
} ostJacWork;

// dual vectors of the work: 3 nq + 6 nv + nu + 6 nbody + 2 nrow_max + nv + nrow_max, then
// 2 na + nu for the activations, nv^2 + 2 nv for Mt, f and f without actuators
OST_HD size_t ostx_jacVectors(ostSizes s, int nrow_max) {
  return 3 * (size_t)s.nq + 7 * (size_t)s.nv + s.nu + 6 * (size_t)s.nbody + 3 * (size_t)nrow_max
         + 2 * (size_t)s.na + s.nu + (size_t)s.nv * s.nv + 2 * (size_t)s.nv;
}


// doubles of the work: dR/dq+, d(dq+)/d(u, dq-), the rows' Mt^-1 J_i' and their diagonal, the
// dynamics rows' values
OST_HD size_t ostx_jacDoubles(ostSizes s, int nrow_max) {
  return ((size_t)s.nv + nrow_max) * s.nv + 2 * (size_t)s.nv * s.nv
         + (size_t)nrow_max * (s.nv + 1) + s.nv;
}


// dual entries of the parameter arrays that ostx_seedParam writes: pair_friction (npair),
// body_mass (nbody), dof_damping (nv), actuator_gainprm (nu) and actuator_biasprm (3 nu)
OST_HD size_t ostx_jacParamVectors(ostSizes s) {
  return (size_t)s.npair + s.nbody + s.nv + 4 * (size_t)s.nu;
}


// bytes of a work block for sizes s and row capacity nrow_max (each part 64-byte aligned)
OST_HD size_t ostx_jacWorkSize(ostSizes s, int nrow_max) {
  return 2 * ostu_kinSize(s) + ostu_worldSizeFor(s.nv, s.nv, nrow_max, 0)
         + OST_ALIGN64(ostx_jacVectors(s, nrow_max) * sizeof(ostNum))
         + OST_ALIGN64(ostx_jacDoubles(s, nrow_max) * sizeof(double))
         + OST_ALIGN64((size_t)nrow_max * sizeof(ostRow)) + OST_ALIGN64((size_t)nrow_max)
         + OST_ALIGN64(sizeof(ostModel)) + OST_ALIGN64(ostx_jacParamVectors(s) * sizeof(ostNum))
         + OST_ALIGN64(((size_t)s.npair + 3 * (size_t)s.nv) * sizeof(int));
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
  wk->X = wk->T + 2 * (size_t)s.nv * s.nv;
  wk->diag0 = wk->X + (size_t)nrow_max * s.nv;
  wk->Rdyn0 = wk->diag0 + nrow_max;
  p += OST_ALIGN64(ostx_jacDoubles(s, nrow_max) * sizeof(double));
  wk->rec = (ostRow*)p;
  p += OST_ALIGN64((size_t)nrow_max * sizeof(ostRow));
  wk->used = (unsigned char*)p;
  p += OST_ALIGN64((size_t)nrow_max);
  wk->own = (ostModel*)p;
  p += OST_ALIGN64(sizeof(ostModel));
  wk->own_param = (ostNum*)p;
  p += OST_ALIGN64(ostx_jacParamVectors(s) * sizeof(ostNum));
  wk->pairs = (int*)p;
  wk->color = wk->pairs + s.npair;
  wk->subtree = wk->color + s.nv;
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


// Give the work a model of its own: a copy of its model whose parameter arrays (those
// ostx_seedParam writes) live in the work's block, so that works sharing one dual model (a
// batch's lanes and column threads) may seed parameters at the same time. The copies start
// without seeds when the shared model has none.
OST_HD void ostx_jacOwnParams(ostJacWork* wk) {
  if (wk->m == wk->own) {
    return;
  }
  const ostModel* m = wk->m;
  ostSizes s = m->s;
  *wk->own = *m;
  ostNum* v = wk->own_param;
#define OSTX_OWN(name, n)                                   \
  for (size_t i_ = 0; i_ < (size_t)(n); i_++) v[i_] = m->name[i_]; \
  wk->own->name = v;                                        \
  v += (n);
  OSTX_OWN(pair_friction, s.npair)
  OSTX_OWN(body_mass, s.nbody)
  OSTX_OWN(dof_damping, s.nv)
  OSTX_OWN(actuator_gainprm, s.nu)
  OSTX_OWN(actuator_biasprm, 3 * s.nu)
#undef OSTX_OWN
  wk->m = wk->own;
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
  while (g + 1 < OST_PARAM_ADR && p >= adr[g + 1]) {
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

#endif  // OSTRICH_CORE_OST_ADJOINT_WORK_H_
