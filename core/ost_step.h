// ost_step.h: one Ostrich step of one world (core/README.md section 1; paper section III-C), the
// driver above ost_solver.h. Mirrors engine_forward.c's mj_step for the implicit step:
//   osti_newton      the non-smooth Newton loop with a backtracking line search on the merit
//                    and best-iterate backtracking, for any geometry provider (a callback:
//                    the plugin's mujoco and native providers, core's native geometry below)
//   osti_stepNative  a whole step on core's own geometry, without MuJoCo: start forces and mass
//                    at (q-, u-), Newton at q+ = q- (+) h u+, step splitting, commit. The CPU
//                    batch (plugin/ost_batch.c) and the CUDA kernels (cuda/ost_batch.cu) run it.
// Invariant: writes only the world, kinematics and state arrays it is given; no allocation.
#ifndef OSTRICH_CORE_OST_STEP_H_
#define OSTRICH_CORE_OST_STEP_H_

#include <math.h>

#include "ost_activation.h"
#include "ost_adjoint.h"
#include "ost_geometric.h"
#include "ost_hd.h"
#include "ost_island.h"
#include "ost_model.h"
#include "ost_rows_native.h"
#include "ost_solver.h"

#ifdef __cplusplus
extern "C" {
#endif

// geometry of a Newton iterate u: q = q- (+) h u and the provider's rows at q into the world;
// returns 0 or the provider's own nonzero status, which ends the Newton loop
typedef int (*ostGeometryFn)(void* ctx, const ostNum* u);

// a Newton loop whose every iterate from k_min on has more than this times its first iterate's
// merit (and is above tol) diverged: it returns the first (osti_newton)
#define OST_DIVERGED 10

// the Newton loop ended without one finite iterate
#define OST_NEWTON_NONFINITE (-1)

typedef struct ostNewtonStats_ {  // one Newton loop's outcome
  int    iterates;                // iterates evaluated (last k + 1)
  int    best;                    // index of the returned iterate
  int    pcr;                     // Krylov (PCR or GMRES) iterations, all iterates
  int    geometry_evals;          // trial geometries evaluated
  int    nonfinite;               // 1 if an iterate's merit was not finite
  int    relaxed;                 // 1 if violations at q- were kept in part (osti_relaxStart)
  int    retry;                   // 1 if this loop was the step driver's cold retry of a loop
                                  // that failed from its warm start, 2 its geometric retry
                                  // (osti_stepDriven); 0 otherwise
  ostNum first;                   // merit of iterate 0 (m/s)
  ostNum best_merit;              // merit of the returned iterate (m/s)
  ostNum initial_violation;       // deepest violation at q- when relaxed (m or rad), else 0
} ostNewtonStats;


//---------------------------------- Bounded removal of violations ---------------------------------
// A violation present at the start of a step (a body placed into the floor, a joint started
// beyond its limit, an equality not satisfied by the initial qpos) would be removed by one hard
// step entirely, at speed depth / h: 5 cm in 2 ms is 25 m/s. Instead a step removes at most
// h * depen_speed of it: a contact or limit row's gap gets the allowance a = depth - h v (its
// NCP becomes gap + a >= 0), an equality row's target becomes the violation less h v. The
// allowances are keyed like multipliers (type, objects; contacts per geom pair, the deepest of
// the pair), measured at q- itself, and held fixed within the step, so Newton solves an
// ordinary step with shifted gaps. A resting contact (depth ~1e-7 m) is never touched: the
// check only runs when the first iterate suggests a violation at q- beyond h v / 2.

// violation of row r at its configuration: contacts and limits their penetration (>= 0),
// equalities |c(q)|; 0 for other rows
OST_HD ostNum osti_rowViolation(const ostRow* r) {
  if (r->type == OST_ROW_CONTACT || r->type == OST_ROW_LIMIT) {
    return r->pos < 0 ? -r->pos : 0;
  }
  return r->type == OST_ROW_EQUALITY ? fabs(r->pos) : 0;
}


// index of the relax entry with r's type and objects, or -1
OST_HD int osti_relaxFind(const ostWorld* w, const ostRow* r) {
  for (int j = 0; j < w->nrow_relax; j++) {
    const ostRow* e = w->rows_relax + j;
    if (e->type == r->type && e->obj[0] == r->obj[0] && e->obj[1] == r->obj[1]) {
      return j;
    }
  }
  return -1;
}


// shift the freshly filled rows by the violations this step keeps: gap + a for contacts and
// limits, c(q) - target for equalities
OST_HD void osti_relaxRows(ostWorld* w) {
  for (int i = 0; i < w->nrow; i++) {
    ostRow* r = w->rows + i;
    int j = osti_relaxFind(w, r);
    if (j >= 0) {
      r->pos += r->type == OST_ROW_EQUALITY ? -w->rows_relax[j].pos : w->rows_relax[j].pos;
    }
  }
}


// 1 if the evaluated first iterate (rows, J u) suggests a violation at q- beyond h v / 2:
// gap(q-) ~ gap(q) - h J u
OST_HD int osti_violationAhead(const ostWorld* w) {
  ostNum half = 0.5 * w->h * w->depen_speed;
  for (int i = 0; i < w->nrow; i++) {
    ostRow r = w->rows[i];
    ostNum at_q = osti_rowViolation(&r);
    r.pos -= w->h * w->Ju[i];
    if (at_q > half || osti_rowViolation(&r) > half) {
      return 1;
    }
  }
  return 0;
}


// the relax table from the rows at q- (just filled): each violation deeper than h v keeps
// depth - h v; returns the deepest violation kept (0 if none)
OST_HD ostNum osti_relaxTable(ostWorld* w) {
  ostNum hv = w->h * w->depen_speed, deepest = 0;
  w->nrow_relax = 0;
  for (int i = 0; i < w->nrow; i++) {
    const ostRow* r = w->rows + i;
    ostNum v = osti_rowViolation(r), keep = v - hv;
    if (keep <= 0) {
      continue;
    }
    deepest = v > deepest ? v : deepest;
    ostNum value = r->type == OST_ROW_EQUALITY ? (r->pos > 0 ? keep : -keep) : keep;
    int j = osti_relaxFind(w, r);
    if (j >= 0) {
      // contacts of one geom pair share the pair's deepest allowance
      if (value > w->rows_relax[j].pos) w->rows_relax[j].pos = value;
    } else {
      w->rows_relax[w->nrow_relax] = *r;
      w->rows_relax[w->nrow_relax++].pos = value;
    }
  }
  return deepest;
}


// an iterate's geometry: the provider's rows at q = q- (+) h u, shifted by the relax table
OST_HD int osti_iterateGeometry(ostWorld* w, ostGeometryFn geom, void* ctx, const ostNum* u) {
  int status = geom(ctx, u);
  if (!status && w->nrow_relax > 0) {
    osti_relaxRows(w);
  }
  return status;
}


// the trial iterate already set in qvel and lambda: its geometry, carried multipliers and merit
OST_HD int osti_evaluateTrial(ostWorld* w, const ostSolverOptions* so, ostGeometryFn geom,
                              void* ctx, ostNum* merit, ostNewtonStats* st) {
  int status = osti_iterateGeometry(w, geom, ctx, w->qvel);
  if (status) {
    return status;
  }
  osti_matchPrevious(w);
  *merit = sqrt(osti_evaluate(w, so));
  st->geometry_evals++;
  return 0;
}


// trial iterate base + alpha * direction: its geometry, carried multipliers and merit
OST_HD int osti_trialIterate(ostWorld* w, const ostSolverOptions* so, ostNum alpha,
                             ostGeometryFn geom, void* ctx, ostNum* merit, ostNewtonStats* st) {
  osti_trial(w, alpha);
  return osti_evaluateTrial(w, so, geom, ctx, merit, st);
}


// the Newton direction at the evaluated iterate (osti_newtonDirection), with the geometric term
// of ost_geometric.h where the world has its arrays and the loop engaged it (host only)
OST_HD int osti_newtonDirectionGeom(ostWorld* w, const ostSolverOptions* so, ostGeometryFn geom,
                                    void* ctx, ostNewtonStats* st) {
#if OST_GEO_HOST
  if (w->geo && w->geo->engaged && osti_geoLoaded(w)) {
    // its inner solves are nested in GMRES: OST_GEO_PCR times the Krylov budget, so that
    // their error does not set the floor of the outer Newton loop
    ostSolverOptions inner = *so;
    inner.pcr_iter *= OST_GEO_PCR;
    int evals = w->geo->evals;
    int it = osti_directionSaturated(w, &inner);
    it += osti_geoDirection(w, &inner, geom, ctx);
    st->geometry_evals += w->geo->evals - evals;
    osti_directionFinish(w);
    return it;
  }
#endif
  int it = osti_directionSaturated(w, so);
  osti_directionFinish(w);
  return it;
}


// After a line search of the Newton loop: 1 if the iterate goes back to its base. A sliding
// contact's friction bound moves with its normal force in the Newton model (osti_newtonApplySet);
// where the direction drives that force below zero (cpl_row[2 i], osti_directionSaturated) the
// trial projects it to zero and its friction with it, so the prediction is void there, and at
// high friction the coupled system can be nearly singular (dm_control's cheetah, a foot at
// mu = 1 against a joint limit: dlambda_n = -11,040 N from 310 N, the lowest trial 46 times the
// base's merit, a cycle of period 3). When such a direction finds no descent (descent 0), the
// iterate stays at its base and the next direction lags those contacts' coupling only
// (cpl_row[2 i + 1]; the bound held at the base's normal force). A direction that lagged some
// coupling already, or that found descent, clears the lags.
OST_HD int osti_couplingFallback(ostWorld* w, int descent) {
  if (!w->cpl_row) {
    return 0;
  }
  int lagged = 0;
  for (int i = 0; i < w->cpl_n; i++) {
    lagged |= w->cpl_row[2 * i + 1];
  }
  int back = !descent && w->cpl_used && !lagged;
  for (int i = 0; i < w->cpl_n; i++) {
    int lag = back && w->cpl_row[2 * i];
    if (lag != w->cpl_row[2 * i + 1]) {
      w->op_version++;  // a coupling lagged or no longer: a kept envelope factor is stale
    }
    w->cpl_row[2 * i + 1] = lag;
  }
  return back;
}


// the line search of islands: every island of the base iterate tries its own step, halved until
// its merit falls (Armijo, as osti_newton's) at most `linesearch` times, all islands in one
// geometry evaluation per trial; an island whose merit never fell takes its lowest trial (or
// its base, osti_couplingFallback). Done
// islands (no direction) keep their state. Leaves the accepted trial evaluated.
OST_HD int osti_islandLineSearch(ostWorld* w, const ostSolverOptions* so, int linesearch,
                                 ostGeometryFn geom, void* ctx, ostNum* merit,
                                 ostNewtonStats* st) {
  int nb = w->nisland, status = 0;
  for (int j = 0; j < w->nv; j++) w->dof_island_base[j] = w->dof_island[j];
  for (int i = 0; i < w->nrow; i++) w->row_island_prev[i] = w->row_island[i];
  for (int I = 0; I < nb; I++) {
    OST_ISL_BASE(w, I) = OST_ISL_MERIT(w, I);
    OST_ISL_ALPHA(w, I) = 1;
    OST_ISL_LOW(w, I) = HUGE_VAL;
    OST_ISL_ALOW(w, I) = 1;
    w->isl_acc[I] = w->isl_done[I];
  }
  st->pcr += osti_newtonDirectionGeom(w, so, geom, ctx, st);
  for (int ls = 0; ls <= linesearch; ls++) {
    osti_trialIslands(w);
    if ((status = osti_evaluateTrial(w, so, geom, ctx, merit, st))) {
      return status;
    }
    osti_islandMerits(w, w->dof_island_base, nb);
    int all = 1;
    for (int I = 0; I < nb; I++) {
      if (w->isl_acc[I]) {
        continue;
      }
      ostNum a = OST_ISL_ALPHA(w, I), m = OST_ISL_MERIT(w, I);
      OST_ISL_ALAST(w, I) = a;
      if (m < (1 - 1e-4 * a) * OST_ISL_BASE(w, I)) {
        w->isl_acc[I] = 1;
        continue;
      }
      if (m < OST_ISL_LOW(w, I)) {
        OST_ISL_LOW(w, I) = m;
        OST_ISL_ALOW(w, I) = a;
      }
      all = 0;
    }
    if (all) {
      w->sat_off = 0;
      osti_couplingFallback(w, 1);
      return 0;
    }
    for (int I = 0; I < nb && ls < linesearch; I++) {
      if (!w->isl_acc[I]) OST_ISL_ALPHA(w, I) *= 0.5;
    }
  }
  // a saturated direction that found no descent in some island: the next keeps sticking
  w->sat_off = w->sat_used;
  // a void coupled direction that found none: those islands go back to their base (alpha 0);
  // else they take their lowest trial
  int back = osti_couplingFallback(w, 0);
  int redo = 0;
  for (int I = 0; I < nb; I++) {
    if (!w->isl_acc[I]) {
      OST_ISL_ALPHA(w, I) = back ? 0 : OST_ISL_ALOW(w, I);
      redo |= OST_ISL_ALPHA(w, I) != OST_ISL_ALAST(w, I);
    }
  }
  if (redo) {
    osti_trialIslands(w);
    status = osti_evaluateTrial(w, so, geom, ctx, merit, st);
  }
  return status;
}


// violations at q- itself (the geometry at u = 0) into the relax table, then the first iterate
// again with its rows relaxed; costs two geometry evaluations, only in steps that need them
OST_HD int osti_relaxStart(ostWorld* w, const ostSolverOptions* so, ostGeometryFn geom,
                           void* ctx, ostNum* merit, ostNewtonStats* st) {
  for (int j = 0; j < w->nv; j++) w->qvel_best[j] = 0;
  int status = geom(ctx, w->qvel_best);
  if (status) {
    return status;
  }
  st->geometry_evals++;
  st->initial_violation = osti_relaxTable(w);
  st->relaxed = w->nrow_relax > 0;
  return osti_trialIterate(w, so, 0, geom, ctx, merit, st);
}


// the non-smooth Newton loop from the start osti_startStep set: iterates k = 0..newton_iter,
// each a direction (PCR/GMRES on the Schur system) and a line search that halves alpha until
// the merit falls (Armijo, sigma = 1e-4), at most `linesearch` times; if no trial lowers it the
// lowest trial is taken (the contact set changed between trials: the Newton model was wrong
// there), unless the direction drove coupled sliding contacts' normal forces below zero: then
// the iterate stays at its base and the next direction lags those contacts' coupling
// (osti_couplingFallback). Stops at merit <= tol once k >= k_min. Leaves the best iterate
// (k >= k_min) with its geometry in the world (re-evaluated if it is not the last: the rows are
// deterministic).
// merit_k / nrow_k (optional, nk entries) get each iterate's merit and row count.
// Returns 0, the geometry's status, or OST_NEWTON_NONFINITE.
OST_HD int osti_newton(ostWorld* w, const ostSolverOptions* so, int linesearch, ostGeometryFn geom,
                       void* ctx, ostNum* merit_k, int* nrow_k, int nk, ostNewtonStats* st) {
  int nv = w->nv, status = 0, best_k = -1, k, nrow_prev0 = w->nrow_prev;
  ostNum best = HUGE_VAL, merit = 0, merit_prev = HUGE_VAL;
  st->iterates = 0;
  st->best = -1;
  st->pcr = 0;
  st->geometry_evals = 0;
  st->nonfinite = 0;
  st->relaxed = 0;
  st->first = HUGE_VAL;
  st->best_merit = HUGE_VAL;
  st->initial_violation = 0;
  w->nrow_relax = 0;
  w->nisland = 0;
  w->sat_used = w->sat_off = 0;
  w->cpl_used = w->cpl_n = 0;  // no row marked (osti_directionSaturated)
  osti_islandsStart(w);
  for (k = 0; k <= so->newton_iter; k++) {
    if (k == 0) {
      status = osti_trialIterate(w, so, 0, geom, ctx, &merit, st);
      if (!status && w->depen_speed > 0 && w->rows_relax && osti_violationAhead(w)) {
        status = osti_relaxStart(w, so, geom, ctx, &merit, st);
      }
      st->first = merit;
      for (int j = 0; j < nv; j++) w->qvel_first[j] = w->qvel[j];
    } else if (w->nisland > 0) {
      status = osti_islandLineSearch(w, so, linesearch, geom, ctx, &merit, st);
    } else {
      ostNum base = merit, alpha = 1, lowest = HUGE_VAL, alpha_lowest = 1, alpha_last = 1;
      st->pcr += osti_newtonDirectionGeom(w, so, geom, ctx, st);
      for (int ls = 0; ls <= linesearch; ls++, alpha *= 0.5) {
        if ((status = osti_trialIterate(w, so, alpha, geom, ctx, &merit, st))) {
          return status;
        }
        alpha_last = alpha;
        if (merit < (1 - 1e-4 * alpha) * base) {
          break;
        }
        if (merit < lowest) {
          lowest = merit;
          alpha_lowest = alpha;
        }
      }
      int descent = merit < (1 - 1e-4 * alpha_last) * base;
      w->sat_off = !descent && w->sat_used;  // the next direction keeps the sticking model
      if (osti_couplingFallback(w, descent)) {  // back to the base
        status = osti_trialIterate(w, so, 0, geom, ctx, &merit, st);
      } else if (!descent && alpha_lowest != alpha_last) {
        status = osti_trialIterate(w, so, alpha_lowest, geom, ctx, &merit, st);
      }
    }
    if (status) {
      return status;
    }
    if (!isfinite(merit)) {
      st->nonfinite = 1;
      break;
    }
    if (k > 0) {
      osti_krylovStall(w, merit, merit_prev);
    }
    merit_prev = merit;
#if OST_GEO_HOST
    if (w->geo) {
      osti_geoTrack(w->geo, k, merit);
    }
#endif
    if (k < nk) {
      if (merit_k) merit_k[k] = merit;
      if (nrow_k) nrow_k[k] = w->nrow;
    }
    // islands of this iterate: each keeps its own best iterate and stops at its own tol
    osti_islands(w);
    if (w->nisland > 0) {
      int done = osti_islandsUpdate(w, k, so->k_min, so->tol);
      for (int j = 0; j < nv && k >= so->k_min; j++) {
        best_k = w->bestk_dof[j] > best_k ? w->bestk_dof[j] : best_k;
      }
      if (done || k == so->newton_iter) {
        break;
      }
      continue;
    }
    if (k >= so->k_min && merit < best) {
      best = merit;
      best_k = k;
      for (int j = 0; j < nv; j++) w->qvel_best[j] = w->qvel[j];
      for (int i = 0; i < w->nrow; i++) w->lambda_best[i] = w->lambda[i];
    }
    if ((k >= so->k_min && merit <= so->tol) || k == so->newton_iter) {
      break;
    }
  }
  st->iterates = k + 1;  // the loop always leaves through a break after evaluating iterate k
  st->best = best_k;
  if (best_k < 0) {
    st->best_merit = best;
    return OST_NEWTON_NONFINITE;
  }

  // a loop that diverged returns its first iterate: when every iterate from k_min on stayed
  // above tol and above OST_DIVERGED times the first iterate's merit (Newton left the start's
  // basin, e.g. misled by constraints that conflict), the first is evaluated again as at k = 0
  // (same rows, multipliers and relaxation). A loop that merely stalled near its start keeps its
  // best later iterate, which moves on (the first may be the warm start's u- at rest: returning
  // it would freeze the state step after step).
  ostNum returned = w->nisland > 0 ? 0 : best;
  for (int j = 0; w->nisland > 0 && j < nv; j++) {
    returned = w->best_dof[j] > returned ? w->best_dof[j] : returned;
  }
  if (returned > so->tol && returned > OST_DIVERGED * st->first) {
    osti_startStep(w, w->qvel_first, nrow_prev0 > 0);
    if ((status = osti_trialIterate(w, so, 0, geom, ctx, &merit, st))) {
      return status;
    }
    osti_islands(w);
    st->best = 0;
    st->best_merit = merit;
    return 0;
  }

  if (w->nisland > 0) {
    // the step's residual is its worst island's; each island returns its best iterate. A done
    // island was held at its best since (no direction), so the last iterate holds it already;
    // when an island that is not done had its best earlier, the mixed state is evaluated again,
    // as any iterate (rows kept from the last base, multipliers carried), and each island's
    // best multipliers are put back on its rows
    int mixed = 0;
    best = 0;
    for (int j = 0; j < nv; j++) {
      best = w->best_dof[j] > best ? w->best_dof[j] : best;
      mixed |= w->bestk_dof[j] != k && !w->isl_done[w->dof_island[j]];
    }
    st->best_merit = best;
    if (mixed) {
      for (int j = 0; j < nv; j++) w->qvel[j] = w->qvel_best[j];
      if ((status = osti_iterateGeometry(w, geom, ctx, w->qvel))) {
        return status;
      }
      osti_matchPrevious(w);
      osti_matchRowsSorted(w->lambda, w->rows, w->nrow, w->lambda_best, w->rows_best,
                           w->nrow_best, w->used, w->match_order);
    }
    return 0;
  }
  st->best_merit = best;

  // return the best iterate: re-evaluate its geometry (deterministic, same rows)
  if (best_k != k) {
    for (int j = 0; j < nv; j++) w->qvel[j] = w->qvel_best[j];
    if ((status = osti_iterateGeometry(w, geom, ctx, w->qvel))) {
      return status;
    }
    for (int i = 0; i < w->nrow; i++) w->lambda[i] = w->lambda_best[i];
  }
  return 0;
}


//---------------------------------- A whole step on core's geometry -------------------------------

// a failed loop whose best iterate is among its last this many was still improving: the step
// driver's geometric retry is for such loops (osti_stepDriven)
#define OST_GEO_RETRY_LATE 3
// Newton budget of a geometric retry at most (with the terms Newton converges in 10-25 iterates
// where the retry succeeds: MuJoCo's rope and loop samples)
#define OST_GEO_RETRY_ITER 32

// deepest step splitting osti_stepNative supports (ostOptions.split_depth is at most 10)
#define OST_SPLIT_MAX 10
// levels of splitting a step takes freely: below it each split spends one of the step's
// deep_splits. An impact onto a sharp feature needs one failed substep per level (a chain, a few
// splits), a stall or an unsolvable start fails at every level (2^depth loops): the budget lets
// the first go deep and bounds the second
#define OST_SPLIT_FREE 3

typedef struct ostStepSettings_ { // what a native step needs besides the model and state
  ostSolverOptions so;            // Newton and PCR settings
  int    linesearch;              // halvings of the line search
  int    split_depth;             // deepest splitting of a step whose merit stays above split_tol
  int    deep_splits;             // splits of substeps at depth OST_SPLIT_FREE or deeper, per step
  int    warmstart;               // 1: multipliers start from the last step's result
  int    cold_retry;              // 1: a loop that failed from a warm start is redone once cold
  ostNum h;                       // step (s)
  ostNum split_tol;               // merit above which a step is redone as two halves (m/s)
  ostNum lookahead;               // contacts are reported up to this gap (m)
  ostNum depen_speed;             // bounded removal speed of violations at q- (0: at once)
} ostStepSettings;

typedef struct ostNativeGeometry_ { // the context of osti_nativeGeometry
  const ostModel* m;
  ostKin*         k;
  ostWorld*       w;
  const ostNum*   qpos_prev;      // q- (nq)
  ostNum*         qpos;           // q = q- (+) h u (nq, written)
  const ostNum*   ctrl;           // controls (nu)
  ostNum          lookahead;      // look-ahead distance (m)
} ostNativeGeometry;


// core's geometry provider: q = q- (+) h u, then kinematics, collision and rows at q
OST_HD int osti_nativeGeometry(void* ctx, const ostNum* u) {
  ostNativeGeometry* g = (ostNativeGeometry*)ctx;
  for (int i = 0; i < g->m->s.nq; i++) {
    g->qpos[i] = g->qpos_prev[i];
  }
  osti_integratePos(g->m, g->qpos, u, g->w->h);
  return osti_nativeIterate(g->m, g->k, g->w, g->qpos, g->ctrl, g->lookahead, g->w->h);
}


// qpos's quaternions times 1/|q| (mj_normalizeQuat, rounded as mju_normalize4). MuJoCo does
// this in place whenever it evaluates positions, so ost_step sees it at the start of a step
// (mj_step1) and leaves it at the end (the published q+); a native step does both, so that its
// bits equal ost_step's with the native provider
OST_HD void osti_normalizeQuat(const ostModel* m, ostNum* qpos) {
  for (int j = 0; j < m->s.njnt; j++) {
    int type = m->jnt_type[j];
    if (type == OST_JNT_FREE || type == OST_JNT_BALL) {
      ostNum* q = qpos + m->jnt_qposadr[j] + (type == OST_JNT_FREE ? 3 : 0);
      ostNum n = sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3]);
      if (n < OST_MINVAL) {
        q[0] = 1; q[1] = 0; q[2] = 0; q[3] = 0;
      } else {
        ostNum inv = 1 / n;
        q[0] *= inv; q[1] *= inv; q[2] *= inv; q[3] *= inv;
      }
    }
  }
}


typedef struct ostRecordSink_ {    // where osti_stepNative records committed substeps (or NULL)
  char*    base;                  // cap records of ostu_stepRecSize(s, nrow_max) bytes
  ostSizes s;
  int      nrow_max;
  int      cap;                   // records base holds
  int      n;                     // substeps committed so far (> cap: some were not recorded)
  int      step;                  // the step being taken (stored with its records)
  int      bits;                  // OST_STEP_NOT_CONVERGED / _DEPENETRATED of any committed
                                  // substep: its gradient is not that of a solved step
} ostRecordSink;


// record the substep just solved in the world (q- in qpos_prev, size h; controls ctrl as given,
// activations act- at its start) as sink's next record
OST_HD void osti_recordSubstep(ostRecordSink* sink, const ostWorld* w, const ostNum* qpos_prev,
                               const ostNum* ctrl, const ostNum* act_prev, ostNum h) {
  ostSizes s = sink->s;
  if (sink->n++ >= sink->cap) {
    return;
  }
  ostStepRec r;
  ostu_stepRecView(&r, sink->base + (size_t)(sink->n - 1) * ostu_stepRecSize(s, sink->nrow_max),
                   s, sink->nrow_max);
  *r.step = sink->step;
  *r.nrow = w->nrow;
  *r.h = (double)h;
  for (int i = 0; i < s.nq; i++) r.qpos_prev[i] = (double)qpos_prev[i];
  for (int j = 0; j < s.nv; j++) {
    r.qvel_prev[j] = (double)w->qvel_prev[j];
    r.qvel[j] = (double)w->qvel[j];
  }
  for (int a = 0; a < s.nu; a++) r.ctrl[a] = (double)ctrl[a];
  for (int a = 0; a < s.na; a++) r.act_prev[a] = (double)act_prev[a];
  for (int i = 0; i < w->nrow; i++) {
    r.lambda[i] = (double)w->lambda[i];
    ((ostRow*)r.rows)[i] = w->rows[i];  // the double build's row (only called there)
  }
}


//---------------------------------- The step driver -----------------------------------------------
// One driver takes every Ostrich step, whatever the provider: the plugin's ost_step (mujoco or
// native geometry, state in mjData) and the batches (core's geometry, state in batch arrays). The
// caller supplies what differs by callbacks: the start of a substep (Mt and f), the geometry of an
// iterate, what to keep of each Newton loop (statistics) and of each committed substep (records).

typedef struct ostStepDriver_ {   // the caller's part of a step (osti_stepDriven)
  void*  ctx;                     // passed to every callback
  // Mt (unfactored) and f at (q-, u-) = the state arrays into the world, for a substep of size h;
  // returns 0 or a nonzero status that ends the step
  int (*start)(void* ctx, ostNum h);
  ostGeometryFn geometry;         // rows at q = q- (+) h u; writes q into the qpos array
  // each Newton loop's outcome (substeps kept or split), with its status: returns the status
  // that counts (0 to go on); may be NULL
  int (*newton)(void* ctx, const ostNewtonStats* st, int status);
  // a committed substep of size h with its OST_STEP_NOT_CONVERGED / _DEPENETRATED bits, after
  // the state arrays advanced: returns 0 or a nonzero status; may be NULL
  int (*commit)(void* ctx, ostNum h, const ostNewtonStats* st, int bits);
  // the failure bits (OST_STEP_OVERFLOW, OST_STEP_NAN) of a nonzero status of the callbacks
  int (*failBits)(int status);
  ostNum* merit_k;                // optional: each Newton loop's merits per iterate (nk)
  int*    nrow_k;                 // and rows per iterate (nk)
  int     nk;
} ostStepDriver;


// one Ostrich step of size set->h (core/README.md section 1) in place on (qpos, qvel,
// qacc_warm): for each substep, q- into qpos_prev (nq) and u- into the world, the caller's start,
// the factor of Mt, Newton from u- + h qacc_warm (multipliers from the last result when *warm
// and set->warmstart), then either a split or the commit (qvel = u+, qacc_warm = (u+ - u-) / h,
// the world's warm rows, *warm = 1). Splitting: a substep whose best merit stays above split_tol
// is redone from its start as two half steps, up to split_depth levels, depth first (a stack of
// depths; both halves of a split have the same depth); below depth OST_SPLIT_FREE a step splits at
// most deep_splits substeps, the later ones are committed as at the deepest level. Cold retry (set->cold_retry): a loop that
// failed from a warm start (u- + h qacc_warm != u-, or carried multipliers) is first redone once
// at the same h from u- with no carried multipliers. Geometric retry (w->geo->retry_on, option
// geometric_retry; host only): a loop that failed while still improving, not redone cold or
// whose cold retry failed too, is redone once more from u- with the geometric terms T and R
// over all rows from its first iterate (ost_geometric.h). Only if these fail too is the
// substep split. At the deepest level the best of its loops is committed (run again if it was
// not the last: loops are deterministic). Once a retry of a kind has failed, the step's trouble
// is not what that retry mends: its remaining substeps do not retry that way, so a step pays at
// most one failed retry of each kind. Converging loops never take these paths, so their bits do
// not depend on them.
// Returns OST_STEP_* bits; on a failure bit the state is undefined (the caller restores it) and
// *status holds the callbacks' or Newton's nonzero status (OST_NEWTON_NONFINITE included; 0 for
// a factor failure). *substeps and *worst get the substeps committed and their largest best
// merit.
OST_HD int osti_stepDriven(ostWorld* w, int nq, ostNum* qpos, ostNum* qpos_prev, ostNum* qvel,
                           ostNum* qacc_warm, int* warm, const ostStepSettings* set,
                           const ostStepDriver* drv, int* substeps, ostNum* worst, int* status) {
  // the stack's entries: 8 depth + the kind of loop (OST_LOOP_AGAIN: the substep's best failed
  // loop run again, to be committed as it is)
  enum { OST_LOOP_WARM = 0, OST_LOOP_COLD = 1, OST_LOOP_GEO = 2, OST_LOOP_AGAIN = 4 };
  int nv = w->nv, stack[OST_SPLIT_MAX + 2], top = 0, bits = 0;
  ostNum sub_merit = 0;   // best merit of the substep's failed loops so far
  int sub_kind = 0;       // and the kind of the loop that reached it
  int retry_failed = 0;   // 1 once a cold retry of this step failed
  int geo_failed = 0;     // 1 once a geometric retry of this step failed
  int geo_retry = 0;      // 1: the world can retry with the geometric terms (ost_geometric.h)
  int deep_left = set->deep_splits;  // splits left at depth OST_SPLIT_FREE or deeper
#if OST_GEO_HOST
  geo_retry = w->geo && w->geo->retry_on;
#endif
  *substeps = 0;
  *worst = 0;
  *status = 0;
  stack[top++] = 8 * 0 + OST_LOOP_WARM;
  while (top > 0) {
    int depth = stack[top - 1] / 8, kind = stack[top - 1] % 8;
    int loop = kind & 3, again = kind & OST_LOOP_AGAIN;
    top--;
    ostNum h = set->h;
    for (int d = 0; d < depth; d++) h *= 0.5;
    w->h = h;
    w->lookahead = set->lookahead;
    w->depen_speed = set->depen_speed;
    for (int i = 0; i < nq; i++) qpos_prev[i] = qpos[i];
    for (int j = 0; j < nv; j++) w->qvel_prev[j] = qvel[j];
    if ((*status = drv->start(drv->ctx, h))) {
      return bits | drv->failBits(*status);
    }
    if (osti_factorMass(w)) {
      return bits | OST_STEP_CHOL_FAIL;
    }
    // u starts from u- + h qacc_warm, the multipliers from the last result if warm; a retry
    // starts from u- without multipliers. started_warm: a cold start would differ
    int cold = loop != OST_LOOP_WARM, started_warm = *warm && set->warmstart && w->nrow_warm > 0;
    for (int j = 0; j < nv; j++) {
      w->tmp[j] = qvel[j] + (cold ? 0 : h * qacc_warm[j]);
      started_warm |= w->tmp[j] != qvel[j];
    }
    osti_startStep(w, w->tmp, !cold && *warm && set->warmstart);
    ostNewtonStats st;
#if OST_GEO_HOST
    if (w->geo) w->geo->retry = loop == OST_LOOP_GEO;
#endif
    ostSolverOptions so = set->so;
    if (loop == OST_LOOP_GEO && so.newton_iter > OST_GEO_RETRY_ITER) {
      so.newton_iter = OST_GEO_RETRY_ITER;  // a bound on the retry's cost; it converges fast
    }
    *status = osti_newton(w, &so, set->linesearch, drv->geometry, drv->ctx, drv->merit_k,
                          drv->nrow_k, drv->nk, &st);
#if OST_GEO_HOST
    if (w->geo) w->geo->retry = 0;
#endif
    st.retry = again ? 0 : loop;
    if (drv->newton) {
      *status = drv->newton(drv->ctx, &st, *status);
    }
    if (*status) {
      return bits | drv->failBits(*status);
    }
    int failed = st.best_merit > set->split_tol;
    if (failed && !again) {
      if (loop == OST_LOOP_WARM || st.best_merit < sub_merit) {
        sub_merit = st.best_merit;
        sub_kind = loop;
      }
      retry_failed |= loop == OST_LOOP_COLD;
      geo_failed |= loop == OST_LOOP_GEO;
      int next = -1;
      if (loop == OST_LOOP_WARM && started_warm && set->cold_retry && !retry_failed) {
        // a warm start can put Newton in a cycle (a contact's friction alternating between
        // sticking and sliding iterates) that a cold start avoids: redo this substep once cold
        next = OST_LOOP_COLD;
      } else if (loop != OST_LOOP_GEO && geo_retry && !geo_failed
                 && st.best >= st.iterates - OST_GEO_RETRY_LATE) {
        // a loop that ran out of budget while still improving (its best iterate among its last)
        // converged too slowly, which is what the geometric terms cause where they are large (a
        // chain of bodies lying in contact under load): redo it cold with them. A loop whose
        // best came early cycled (friction between sticking and sliding) or stalled, which the
        // terms do not mend, and is split as before
        next = OST_LOOP_GEO;
      }
      if (next >= 0) {
        for (int i = 0; i < nq; i++) qpos[i] = qpos_prev[i];
        stack[top++] = 8 * depth + next;
        continue;
      }
      if (depth < set->split_depth && (depth < OST_SPLIT_FREE || deep_left > 0)) {
        // redo from this substep's start as two halves
        deep_left -= depth >= OST_SPLIT_FREE;
        for (int i = 0; i < nq; i++) qpos[i] = qpos_prev[i];
        stack[top++] = 8 * (depth + 1) + OST_LOOP_WARM;
        stack[top++] = 8 * (depth + 1) + OST_LOOP_WARM;
        continue;
      }
      if (sub_kind != loop) {
        // the deepest level (or no deep split left): an earlier loop of this substep did better; run it again (loops
        // are deterministic) and commit it
        for (int i = 0; i < nq; i++) qpos[i] = qpos_prev[i];
        stack[top++] = 8 * depth + (sub_kind | OST_LOOP_AGAIN);
        continue;
      }
    }

    // commit (q+, u+): qpos holds q- (+) h u+ from the best iterate's geometry
    int sub = (st.best_merit > set->so.tol ? OST_STEP_NOT_CONVERGED : 0)
              | (st.relaxed ? OST_STEP_DEPENETRATED : 0);
    bits |= sub;
    for (int j = 0; j < nv; j++) {
      qacc_warm[j] = (w->qvel[j] - w->qvel_prev[j]) / h;
      qvel[j] = w->qvel[j];
    }
    osti_saveWarm(w);
    *warm = 1;
    (*substeps)++;
    if (st.best_merit > *worst) {
      *worst = st.best_merit;
    }
    if (drv->commit && (*status = drv->commit(drv->ctx, h, &st, sub))) {
      return bits | drv->failBits(*status);
    }
  }
  return bits;
}


typedef struct ostNativeStep_ {   // the context of a native step's callbacks
  ostNativeGeometry g;            // its geometry; g.ctrl is `input`
  const ostNum*     qvel;         // u- of the substep (nv)
  const ostNum*     ctrl;         // the controls as given (nu)
  ostNum*           act;          // activations: act- of the substep, act+ once committed (na)
  ostNum*           act_next;     // the substep's act+ (na)
  ostNum*           input;        // its actuator inputs: clamped ctrl or act+ (nu)
  ostRecordSink*    sink;         // records of committed substeps (or NULL)
} ostNativeStep;


// the substep's actuator inputs and act+ (eq. 8b; every substep integrates the activations over
// its own size, as ost_step's), then Mt and f at (q-, u-) from core's dynamics
OST_HD int osti_nativeStepStart(void* ctx, ostNum h) {
  ostNativeStep* n = (ostNativeStep*)ctx;
  osti_actuation(n->g.m, n->ctrl, n->act, h, n->act_next, n->input);
  osti_nativeStart(n->g.m, n->g.k, n->g.w, n->g.qpos, n->qvel, n->input, NULL, NULL, h);
  return 0;
}


// a committed substep into the record sink (with its act-), then act = act+
OST_HD int osti_nativeStepCommit(void* ctx, ostNum h, const ostNewtonStats* st, int bits) {
  ostNativeStep* n = (ostNativeStep*)ctx;
  (void)st;
  if (n->sink) {
    osti_recordSubstep(n->sink, n->g.w, n->g.qpos_prev, n->ctrl, n->act, h);
    n->sink->bits |= bits;
  }
  for (int j = 0; j < n->g.m->s.na; j++) {
    n->act[j] = n->act_next[j];
  }
  return 0;
}


// core's geometry statuses as failure bits
OST_HD int osti_nativeFailBits(int status) {
  return status == OST_ROWS_ROW_OVERFLOW || status == OST_ROWS_CONTACT_OVERFLOW
         || status == OST_ROWS_WIDTH_OVERFLOW ? OST_STEP_OVERFLOW : OST_STEP_NAN;
}


// numbers of osti_stepNative's scratch for sizes s
#define OST_STEP_SCRATCH(s) (2 * (s).nq + (s).nv + 3 * (s).na + (s).nu)

// one Ostrich step of size set->h on core's geometry (osti_stepDriven), in place on (qpos,
// qvel, act, qacc_warm), with MuJoCo's quaternion normalization before and after (as ost_step's
// mj_step1 and publication), so that its bits equal ost_step's with the native provider. ctrl:
// the controls as given (nu); act: the activations (na; may be NULL when na = 0), integrated
// implicitly with each substep (core/ost_activation.h). `warm` (0/1, in and out) says whether
// the world's last result (rows_warm) belongs to this state. scratch: OST_STEP_SCRATCH(m->s)
// numbers. Returns OST_STEP_* bits: on a failure bit the state is restored to the step's start.
// *substeps and *worst get the substeps taken and their largest best merit. sink (or NULL)
// records every committed substep for the backward pass.
OST_HD int osti_stepNative(const ostModel* m, ostKin* k, ostWorld* w, ostNum* qpos, ostNum* qvel,
                           ostNum* act, const ostNum* ctrl, ostNum* qacc_warm, int* warm,
                           ostNum* scratch, const ostStepSettings* set, int* substeps,
                           ostNum* worst, ostRecordSink* sink) {
  int nq = m->s.nq, nv = m->s.nv, na = m->s.na, status;
  ostNum* qpos_prev = scratch;                   // q- of the substep (nq)
  ostNum* qpos_start = scratch + nq;             // the step's start, for a failure (nq, nv, na)
  ostNum* act_next = qpos_start + nq + nv + na;  // a substep's act+ (na)
  ostNum* input = act_next + na;                 // and its actuator inputs (nu)
  osti_normalizeQuat(m, qpos);
  for (int i = 0; i < nq; i++) qpos_start[i] = qpos[i];
  for (int j = 0; j < nv; j++) qpos_start[nq + j] = qvel[j];
  for (int j = 0; j < na; j++) qpos_start[nq + nv + j] = act[j];
  ostNativeStep n = {{m, k, w, qpos_prev, qpos, input, set->lookahead}, qvel, ctrl, act, act_next,
                     input, sink};
  ostStepDriver drv = {&n, osti_nativeStepStart, osti_nativeGeometry, NULL, osti_nativeStepCommit,
                       osti_nativeFailBits, NULL, NULL, 0};
  int bits = osti_stepDriven(w, nq, qpos, qpos_prev, qvel, qacc_warm, warm, set, &drv, substeps,
                             worst, &status);
  if (bits & OST_STEP_FAILED) {
    for (int i = 0; i < nq; i++) qpos[i] = qpos_start[i];
    for (int j = 0; j < nv; j++) qvel[j] = qpos_start[nq + j];
    for (int j = 0; j < na; j++) act[j] = qpos_start[nq + nv + j];
    *warm = 0;
    return bits;
  }
  osti_normalizeQuat(m, qpos);
  return bits;
}


#ifdef __cplusplus
}
#endif

#endif  // OSTRICH_CORE_OST_STEP_H_
