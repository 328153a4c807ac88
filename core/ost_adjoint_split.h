// ost_adjoint_split.h: the split passes of a step's Jacobian (core/README.md eq. 15), each
// input column through the part of the step it moves; the dense evaluation of
// ost_adjoint_work.h is their oracle. For a translation unit with ostNum = ostDual<OSTX_CHUNK>.
// Invariant: reads the step's inputs; writes only the work block and the caller's G, Rq and T
// (and the model's parameter derivatives while a theta unit runs; cleared after it).
#ifndef OSTRICH_CORE_OST_ADJOINT_SPLIT_H_
#define OSTRICH_CORE_OST_ADJOINT_SPLIT_H_

#include "ost_adjoint_color.h"
#include "ost_adjoint_work.h"

// After the values pass (w->M holds Mt's factor, w->diag the rows' diagonal, the rows at q+):
// x_i = Mt^-1 J_i' and d_i = J_i Mt^-1 J_i' at the values into wk->X and wk->diag0, and the
// pairs in contact into wk->pairs (ascending; returns their count).
OST_HD int ostx_rowSolves(ostJacWork* wk, int nrow) {
  ostWorld* w = &wk->w;
  int nv = w->nv, np = 0;
  ostNum* x = w->tmp;
  for (int i = 0; i < nrow; i++) {
    for (int j = 0; j < nv; j++) x[j] = (double)w->J[(size_t)i * nv + j];
    osti_massSolve(w, x);
    for (int j = 0; j < nv; j++) wk->X[(size_t)i * nv + j] = (double)x[j];
    wk->diag0[i] = (double)w->diag[i];
  }
  for (int i = 0; i < wk->k.ncon; i++) {
    int p = wk->k.contact_pair[i];
    if (np == 0 || wk->pairs[np - 1] != p) wk->pairs[np++] = p;
  }
  return np;
}


// The dynamics rows R (nv) of osti_residualDynamics, Mt (u - u-) - h (f + J' lambda), in a pass
// that varies f and only some of the other parts: Mt (dM), u- (du) or J (dJ), never u or lambda.
// The values are the values pass's (wk->Rdyn0), the derivatives only the products' parts that
// can be non-zero (the terms dropped are exact zeros).
OST_HD void ostx_residualDynamicsPart(ostJacWork* wk, const ostNum* Mt, int dM, int du, int dJ) {
  ostWorld* w = &wk->w;
  int nv = w->nv, nrow = w->nrow;
  double h = (double)w->h;
  ostNum* g = w->tmp;  // J' lambda's derivatives
  for (int i = 0; i < nv; i++) {
    for (int c = 0; c < OSTX_CHUNK; c++) g[i].d[c] = 0;
  }
  for (int r = 0; dJ && r < nrow; r++) {
    double lam = (double)wk->lambda[r];
    const ostNum* Jr = w->J + (size_t)r * nv;
    for (int i = 0; i < nv && lam != 0; i++) {
      for (int c = 0; c < OSTX_CHUNK; c++) g[i].d[c] += Jr[i].d[c] * lam;
    }
  }
  for (int i = 0; i < nv; i++) {
    const ostNum* Mi = Mt + (size_t)i * nv;
    double d[OSTX_CHUNK];
    for (int c = 0; c < OSTX_CHUNK; c++) d[c] = 0;
    for (int j = 0; j < nv && (dM || du); j++) {
      double tj = (double)wk->u[j] - (double)wk->uprev[j];
      for (int c = 0; c < OSTX_CHUNK; c++) {
        if (dM) d[c] += Mi[j].d[c] * tj;
        if (du) d[c] -= Mi[j].v * wk->uprev[j].d[c];
      }
    }
    wk->R[i].v = wk->Rdyn0[i];
    for (int c = 0; c < OSTX_CHUNK; c++) {
      wk->R[i].d[c] = d[c] - h * (w->qfrc_explicit[i].d[c] + g[i].d[c]);
    }
  }
}


// The residual R of a pass that moved J (dJ) or Mt (dM, unfactored in Mt) but not the point:
// the Jacobi diagonal takes its values from the values pass and its derivatives in closed form,
//   d(J_i Mt^-1 J_i') = 2 x_i' dJ_i' - x_i' dMt x_i,      x_i = Mt^-1 J_i'                (15b)
// (Mt symmetric, read in its lower triangle over each dof's ancestors, as the tree factor
// reads it), instead of Mt's factor and a solve per row in dual numbers.
OST_HD void ostx_residualAtValues(ostJacWork* wk, const ostdStep* st, const ostNum* Mt, int dJ,
                                  int dM) {
  ostWorld* w = &wk->w;
  int nv = w->nv;
  const int* par = w->dof_parent;
  if (dJ && dM) {
    osti_residualDynamics(w, Mt, wk->u, wk->lambda, wk->R);
  } else {
    ostx_residualDynamicsPart(wk, Mt, dM, 0, dJ);
  }
  for (int i = 0; i < w->nrow; i++) {
    const double* x = wk->X + (size_t)i * nv;
    const ostNum* J = w->J + (size_t)i * nv;
    double dd[OSTX_CHUNK];
    for (int c = 0; c < OSTX_CHUNK; c++) dd[c] = 0;
    for (int k = 0; k < nv; k++) {
      double xk = x[k];
      if (xk == 0) {
        continue;
      }
      for (int c = 0; dJ && c < OSTX_CHUNK; c++) dd[c] += 2 * xk * J[k].d[c];
      if (dM) {  // x_k (dMt_kk x_k + 2 sum over k's ancestors j of dMt_kj x_j)
        const ostNum* Mk = Mt + (size_t)k * nv;
        double a[OSTX_CHUNK];
        for (int c = 0; c < OSTX_CHUNK; c++) a[c] = Mk[k].d[c] * xk;
        for (int j = par ? par[k] : k - 1; j >= 0; j = par ? par[j] : j - 1) {
          for (int c = 0; c < OSTX_CHUNK; c++) a[c] += 2 * Mk[j].d[c] * x[j];
        }
        for (int c = 0; c < OSTX_CHUNK; c++) dd[c] -= a[c] * xk;
      }
    }
    w->diag[i].v = wk->diag0[i];
    for (int c = 0; c < OSTX_CHUNK; c++) w->diag[i].d[c] = wk->diag0[i] > 1e-300 ? dd[c] : 0;
  }
  osti_residualRows(w, wk->u, wk->lambda, st->reg, st->creep, st->fb_eps, wk->R + nv);
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
// skip_start: the UM, AC and DQ columns are left out (their R and act+ rows zero), for a
// backward pass that takes w' dR/dxi of those inputs by a reverse sweep instead
// (plugin/ost_adjoint_rev.h).
OST_HD int ostx_jacColumnsSplit(ostJacWork* wk, const ostdStep* st, const double* lam, int ny,
                                double* G, int ncol, double* r2, int rows_ready, int t, int nt,
                                double* Rq, double* T, int skip_start) {
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
  int npair = ostx_rowSolves(wk, nrow);
  int ncolor = ostx_colorDofs(wk, nrow);
  for (int i = 0; i < nv; i++) wk->Rdyn0[i] = wk->R[i].v;

#define OSTX_CEIL(n) (((n) + C - 1) / C)
#define OSTX_COLUMN(c, k) \
  for (int i_ = 0; i_ < ny; i_++) G[(size_t)i_ * ncol + (c)] = wk->R[i_].d[k]
  enum { Y, UM, AC, DQ, TH, GEO, TT, NKIND };
  int nunit[NKIND] = {OSTX_CEIL(ny), OSTX_CEIL(nv), OSTX_CEIL(na + nu), OSTX_CEIL(nv),
                      OSTX_CEIL(np), OSTX_CEIL(ncolor), OSTX_CEIL(2 * nv)};
  int ju_seeded = 0;  // w->Ju holds derivatives by u (a Y unit's), so J u must be made again
  for (int kind = 0, first = 0; kind < NKIND; first += nunit[kind++]) {
    for (int unit = first + ((t - first) % nt + nt) % nt; unit < first + nunit[kind]; unit += nt) {
      int c0 = (unit - first) * C;
      if (skip_start && (kind == UM || kind == AC || kind == DQ)) {
        int col0 = kind == DQ ? ny : (kind == UM ? ny + nv : ny + 2 * nv);
        int ncols = kind == AC ? na + nu : nv;
        for (int k = 0; k < C && c0 + k < ncols; k++) {
          for (int i = 0; i < ny + 2 * nv + na; i++) {
            if (i < ny || (kind == AC && i >= ny + 2 * nv)) G[(size_t)i * ncol + col0 + c0 + k] = 0;
          }
        }
        continue;
      }
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
          if (c < nv) {
            wk->u[c] = (double)wk->u[c];
          } else {
            wk->lambda[c - nv] = (double)wk->lambda[c - nv];
          }
        }
        break;
      }
      case UM: {  // f and the dynamics rows (the constraint rows do not read u-)
        for (int k = 0; k < C && c0 + k < nv; k++) wk->uprev[c0 + k].d[k] = 1;
        for (int i = 0; i < nv; i++) w->qvel_prev[i] = wk->uprev[i];
        osti_nativeStartVel(m, &wk->km, w, wk->qpos, wk->uprev, wk->input, wk->qfrc, wk->xfrc, h);
        ostx_residualDynamicsPart(wk, wk->M0, 0, 1, 0);
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
        ostx_residualDynamicsPart(wk, wk->M0, 0, 0, 0);
        osti_residualRowsJu(w, wk->u, wk->lambda, st->reg, st->creep, st->fb_eps, wk->R + nv,
                            ju_seeded);
        ju_seeded = 0;
        for (int k = 0; k < C && c0 + k < na + nu; k++) {
          int c = c0 + k;
          OSTX_COLUMN(ny + 2 * nv + c, k);
          for (int i = 0; i < na; i++) {
            G[(size_t)(ny + 2 * nv + i) * ncol + ny + 2 * nv + c] = wk->act_next[i].d[k];
          }
          if (c < na) {
            wk->act[c] = (double)wk->act[c];
          } else {
            wk->ctrl[c - na] = (double)wk->ctrl[c - na];
          }
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
        ostx_residualAtValues(wk, st, w->M, 0, 1);
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
        wk->k.pair_only = wk->pairs;  // a pair's contacts depend on its own geoms alone
        wk->k.npair_only = npair;
        int rc = osti_nativeIterate(m, &wk->k, w, wk->qplus, wk->input, st->lookahead, h);
        wk->k.pair_only = NULL;
        if (!rc && w->nrow == nrow && st->truncate) {
          // contact J held (its derivative by the friction scale dropped)
          osti_tangentLinear(m, wk->dqp, wk->qplus, wk->qref);
          osti_truncateContacts(w, wk->dqp);
        }
        if (!rc && w->nrow == nrow) {
          ostx_residualAtValues(wk, st, w->M, 1, 1);
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
        for (int l = 0; l < nv; l++) {  // the dofs of the unit's colours (eq. 15c)
          int k = wk->color[l] - c0;
          if (k >= 0 && k < C) wk->dqm[l].d[k] = 1;
        }
        osti_integratePos(m, wk->qplus, wk->dqm, 1);
        wk->k.pair_only = wk->pairs;
        wk->k.npair_only = npair;
        int rc = osti_nativeIterate(m, &wk->k, w, wk->qplus, wk->input, st->lookahead, h);
        wk->k.pair_only = NULL;
        if (rc || w->nrow != nrow) {
          return 2;
        }
        if (st->truncate) {
          osti_tangentLinear(m, wk->dqp, wk->qplus, wk->qref);
          osti_truncateContacts(w, wk->dqp);
        }
        for (int i = 0; i < nv; i++) w->qfrc_explicit[i] = wk->f0[i];
        ostx_residualAtValues(wk, st, wk->M0, 1, 0);
        ostx_colorColumns(wk, nrow, c0, Rq);
        for (int l = 0; l < nv; l++) wk->dqm[l] = 0;
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

#endif  // OSTRICH_CORE_OST_ADJOINT_SPLIT_H_
