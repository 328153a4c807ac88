// ost_adjoint.c: gradients of Ostrich steps by the implicit function theorem (core/README.md
// section 2; paper section III-D; mirrors engine_derivative.c). Each committed substep is
// recorded at commit (ost_recordSubstep: state, controls and the converged forces, nothing of
// the Newton or PCR iterates). Its backward pass takes the exact Jacobian of the step's
// residual R(y; xi) = 0, y = (u+, lambda), xi = (dq-, u-, act-, ctrl, theta), and outputs
// O = (dq+, u+, act+) from ost_adjoint_dual.cc and solves
//   K' w = -O_y' g,     dL/dxi = O_xi' g + R_xi' w,     K = dR/dy,
// where g = (dL/dq+, dL/du+, dL/dact+). act+ is explicit in (act-, ctrl) (eq. 8b). K is not
// symmetric once the position pull-back, friction's dependence on the normal force and the
// exponential map enter, so it is factored by LU (its size is nv + rows, tens to a few hundred).
// Invariant: the forward state of a context (warm start, options) is never changed here.
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "ost_adjoint_dual.h"
#include "ost_adjoint_rev.h"
#include "ost_internal.h"

//---------------------------------- Parameters ----------------------------------------------------

int ost_paramAddress(const mjModel* m, int g) {
  int size[OST_NPARAM] = {m->ngeom, m->nbody, m->nv, m->nu, m->nu, m->nu};
  int adr = 0;
  for (int i = 0; i < g && i < OST_NPARAM; i++) {
    adr += size[i];
  }
  return adr;
}


int ost_nparam(const mjModel* m) {
  return ost_paramAddress(m, OST_NPARAM);
}


void ost_paramFrictionMap(const mjModel* m, const ostModel* native, int* geom, mjtNum* weight) {
  // friction of a dynamic pair is max(mu1, mu2), or the higher-priority geom's (MuJoCo's
  // mixing); an explicit <pair> has its own coefficient, which no geom parameter moves
  for (int p = 0; p < native->s.npair; p++) {
    int g1 = native->pair_geom1[p], g2 = native->pair_geom2[p], expl = 0;
    for (int i = 0; i < m->npair; i++) {
      expl |= (m->pair_geom1[i] == g1 && m->pair_geom2[i] == g2)
              || (m->pair_geom1[i] == g2 && m->pair_geom2[i] == g1);
    }
    mjtNum f1 = m->geom_friction[3 * g1], f2 = m->geom_friction[3 * g2];
    int p1 = m->geom_priority[g1], p2 = m->geom_priority[g2];
    geom[2 * p] = expl ? -1 : g1;
    geom[2 * p + 1] = expl ? -1 : g2;
    // the higher priority's coefficient, else the larger (ost_pack.c candidatePairs)
    weight[2 * p] = p1 != p2 ? (p1 > p2) : (f1 > f2 ? 1 : (f1 < f2 ? 0 : 0.5));
    weight[2 * p + 1] = 1 - weight[2 * p];
  }
}


int ost_paramDifferentiable(const mjModel* m, int i) {
  // MuJoCo reads gainprm[0] as a gain only when fixed and biasprm[1], [2] as feedback only for
  // an affine bias. A motor's biasprm is not read at all: derivative 0. A muscle's gainprm[0]
  // (the lower end of its operating range) and biasprm[1], [2] (the upper end, its peak force)
  // shape its curves, which the adjoint does not differentiate (core/README.md section 1):
  // unknown, NaN. (Affine and user gains and user biases are refused.)
  int nu = m->nu, gain0 = ost_paramAddress(m, OST_PARAM_GAIN);
  int bias1 = ost_paramAddress(m, OST_PARAM_BIASPOS), bias2 = ost_paramAddress(m, OST_PARAM_BIASVEL);
  int act = i >= bias2 ? i - bias2 : i - bias1;
  if (i >= bias1 && act < nu && m->actuator_biastype[act] != mjBIAS_AFFINE) {
    return m->actuator_biastype[act] == mjBIAS_MUSCLE ? -1 : 0;
  }
  if (i >= gain0 && i < gain0 + nu && m->actuator_gaintype[i - gain0] != mjGAIN_FIXED) {
    return m->actuator_gaintype[i - gain0] == mjGAIN_MUSCLE ? -1 : 0;
  }
  return 1;
}


void ost_defaultGradOptions(ostGradOptions* go) {
  go->truncate = 0;
  go->params = 0;
  go->forward_only = 0;
}


//---------------------------------- Records -------------------------------------------------------

// bytes of one record: a header, then q- (nq), u- (nv), u+ (nv), ctrl (nu), act- (na),
// qfrc_applied (nv), xfrc_applied (6 nbody), lambda (nrow) and rows (nrow) of the rows the
// substep used; independent of the budgets and of the row capacity
size_t ost_recordSize(const mjModel* m, int nrow) {
  size_t nnum = m->nq + 3 * (size_t)m->nv + m->nu + m->na + 6 * (size_t)m->nbody + nrow;
  return sizeof(ostRecordHead) + nnum * sizeof(mjtNum) + nrow * sizeof(ostRow);
}


size_t ost_recordView(const mjModel* m, void* rec, ostRecord* r) {
  r->head = (ostRecordHead*)rec;
  int nrow_max = r->head->nrow;
  mjtNum* p = (mjtNum*)((char*)rec + sizeof(ostRecordHead));
  r->qpos_prev = p;     p += m->nq;
  r->qvel_prev = p;     p += m->nv;
  r->qvel = p;          p += m->nv;
  r->ctrl = p;          p += m->nu;
  r->act_prev = p;      p += m->na;
  r->qfrc_applied = p;  p += m->nv;
  r->xfrc_applied = p;  p += 6 * m->nbody;
  r->lambda = p;        p += nrow_max;
  r->rows = (ostRow*)p;
  return ost_recordSize(m, nrow_max);
}


// append the substep just committed by advance() (ost_step.c) to the context's records
int ost_recordSubstep(ostContext* c, const mjModel* m, const mjData* d, mjtNum h,
                      mjtNum residual, int bits) {
  ostWorld* w = &c->world;
  size_t sz = ost_recordSize(m, w->nrow);
  if (c->rec_bytes + sz > c->rec_cap) {
    size_t cap = c->rec_cap ? 2 * c->rec_cap : 2 * sz;
    cap = cap < c->rec_bytes + sz ? c->rec_bytes + sz : cap;
    void* buf = realloc(c->rec_buf, cap);
    if (!buf) {
      return ost_fail(c, OST_ERR_MEMORY, "cannot record the step for its gradient");
    }
    c->rec_buf = buf;
    c->rec_cap = cap;
  }
  ostRecord r;
  ostRecordHead* head = (ostRecordHead*)((char*)c->rec_buf + c->rec_bytes);
  head->nrow = w->nrow;
  ost_recordView(m, head, &r);
  r.head->h = h;
  r.head->step_end = 0;
  r.head->bits = bits;
  r.head->pad = 0;
  r.head->residual = residual;
  memcpy(r.qpos_prev, c->qpos_prev, m->nq * sizeof(mjtNum));
  memcpy(r.qvel_prev, w->qvel_prev, m->nv * sizeof(mjtNum));
  memcpy(r.qvel, w->qvel, m->nv * sizeof(mjtNum));
  memcpy(r.ctrl, d->ctrl, m->nu * sizeof(mjtNum));
  memcpy(r.act_prev, d->act, m->na * sizeof(mjtNum));  // act-: committed after the record
  memcpy(r.qfrc_applied, d->qfrc_applied, m->nv * sizeof(mjtNum));
  memcpy(r.xfrc_applied, d->xfrc_applied, 6 * m->nbody * sizeof(mjtNum));
  memcpy(r.lambda, w->lambda, w->nrow * sizeof(mjtNum));
  memcpy(r.rows, w->rows, w->nrow * sizeof(ostRow));
  c->rec_last = c->rec_bytes;
  c->rec_bytes += sz;
  c->rec_n++;
  return OST_OK;
}


void ost_adjointFree(ostContext* c) {
  free(c->rec_buf);
  ostd_workFree(c->adj_work);
  ostr_workFree(c->adj_rev);
  free(c->adj_fric_geom);
  free(c->adj_fric_weight);
  free(c->adj_scratch);
}


//---------------------------------- One substep ---------------------------------------------------

// the dual work, scratch matrices and friction map for the context's packed native model
static int adjointPrepare(ostContext* c, const mjModel* m) {
  int status = ost_nativeReady(c, m);
  if (status) {
    return status;
  }
  if (c->adj_work && c->adj_model_block == c->native_block) {
    return OST_OK;
  }
  ostd_workFree(c->adj_work);
  ostr_workFree(c->adj_rev);
  free(c->adj_fric_geom);
  free(c->adj_fric_weight);
  c->adj_work = ostd_workCreate(&c->native, c->world.nrow_max);
  c->adj_rev = ostr_workCreate(&c->native, c->world.nrow_max);
  int npair = c->native.s.npair > 0 ? c->native.s.npair : 1;
  c->adj_fric_geom = (int*)malloc(2 * npair * sizeof(int));
  c->adj_fric_weight = (mjtNum*)malloc(2 * npair * sizeof(mjtNum));
  if (!c->adj_work || !c->adj_rev || !c->adj_fric_geom || !c->adj_fric_weight) {
    return ost_fail(c, OST_ERR_MEMORY, "cannot allocate the adjoint's work space");
  }
  c->adj_model_block = c->native_block;
  ost_paramFrictionMap(m, &c->native, c->adj_fric_geom, c->adj_fric_weight);
  return OST_OK;
}


// make the scratch hold at least n doubles (c->adj_scratch)
static int adjointScratch(ostContext* c, size_t n) {
  if (n <= c->adj_scratch_cap) {
    return OST_OK;
  }
  free(c->adj_scratch);
  c->adj_scratch = (mjtNum*)malloc(n * sizeof(mjtNum));
  c->adj_scratch_cap = c->adj_scratch ? n : 0;
  return c->adj_scratch ? OST_OK : ost_fail(c, OST_ERR_MEMORY, "cannot allocate adjoint scratch");
}


// record r as its backward pass reads it; adr (OST_NPARAM + 1) is filled
static ostdStep recordStep(ostContext* c, const mjModel* m, const ostRecord* r, int truncate,
                           int nparam, int* adr) {
  for (int g = 0; g <= OST_NPARAM; g++) {
    adr[g] = ost_paramAddress(m, g);
  }
  ostdStep s = {&c->native, r->qpos_prev, r->qvel_prev, r->qvel, r->ctrl, r->qfrc_applied,
                r->xfrc_applied, r->rows, r->lambda, r->head->nrow, truncate, r->head->h,
                c->opt.margin, c->opt.regularization, c->opt.friction_creep, c->opt.fb_eps, nparam,
                adr, c->adj_fric_geom, c->adj_fric_weight, r->act_prev};
  return s;
}


// the exact Jacobian G of record r into the scratch; *ny = nv + rows; with factor set, K =
// G[0:ny, 0:ny] is copied after G and LU-factored there (pivots after K). skip_start: without
// the columns of the start's inputs (dq-, u-, act-, ctrl), zero but for the chain rule through
// q+ (ostd_stepJacobian's dense = 3), for startVjp
static int recordJacobian(ostContext* c, const mjModel* m, const ostRecord* r, int truncate,
                          int params, int factor, int skip_start, int* ny, int** piv) {
  int nv = m->nv, nx = 2 * nv + m->na, nparam = params ? ost_nparam(m) : 0, status;
  int adr[OST_NPARAM + 1];
  ostdStep s = recordStep(c, m, r, truncate, nparam, adr);
  double resid;
  for (;;) {
    size_t cap = c->adj_scratch_cap > (size_t)nv ? c->adj_scratch_cap : 0;
    int rc = ostd_stepJacobian(c->adj_work, &s, c->adj_scratch, cap / 2, ny, &resid,
                               c->adj_oracle ? c->adj_oracle : (skip_start ? 3 : 0));
    if (rc == 0) {
      break;
    }
    if (rc == 2) {
      return ost_fail(c, OST_ERR_OVERFLOW, "row capacity exceeded re-evaluating a step's rows");
    }
    size_t ncol = *ny + nx + m->nu + nparam;
    if ((status = adjointScratch(c, 2 * (size_t)(*ny + nx) * ncol + 4 * ncol))) {
      return status;
    }
  }
  size_t ncol = *ny + nx + m->nu + nparam;
  mjtNum* G = c->adj_scratch;
  mjtNum* K = G + (size_t)(*ny + nx) * ncol;
  *piv = (int*)(K + (size_t)*ny * *ny);  // ny ints in the room of ny doubles
  if (!factor) {
    return OST_OK;
  }
  for (int i = 0; i < *ny; i++) {
    memcpy(K + (size_t)i * *ny, G + (size_t)i * ncol, *ny * sizeof(mjtNum));
  }
  if (ostu_luFactor(K, *piv, *ny)) {
    return ost_fail(c, OST_ERR_NUMERIC, "the step's Jacobian is singular (residual %.3g)", resid);
  }
  return OST_OK;
}


// gxi (2 nv + na + nu) += w' dR/dxi + g_act' dact+/dxi for the start's inputs xi = (dq-, u-,
// act-, ctrl) with q+ and y held, by one reverse sweep (ost_adjoint_rev.h): the part of the
// implicit function theorem's dL/dxi = O_xi' g + R_xi' w that recordJacobian left out with
// skip_start. scratch: 2 nv + na + nu doubles.
static int startVjp(ostContext* c, const mjModel* m, const ostRecord* r, int truncate, int ny,
                    const mjtNum* w, const mjtNum* g, mjtNum* gxi, mjtNum* scratch) {
  int nv = m->nv, na = m->na, nu = m->nu, nrow = ny - nv, adr[OST_NPARAM + 1];
  ostdStep s = recordStep(c, m, r, truncate, 0, adr);
  const double *X, *diag0;
  void* rows;
  double *J, *lam, *length;
  ostr_staging(c->adj_rev, &rows, &J, &lam, &length);
  ostd_stepValues(c->adj_work, nrow, &X, &diag0, lam, rows, J, length);
  int rc = ostr_startVjp(c->adj_rev, &s, nrow, X, diag0, w, g + 2 * nv, scratch);
  if (rc) {
    return rc == 1 ? ost_fail(c, OST_ERR_MEMORY, "cannot grow the adjoint's reverse tape")
                   : ost_fail(c, OST_ERR_OVERFLOW, "row capacity exceeded in a reverse sweep");
  }
  for (int i = 0; i < 2 * nv + na + nu; i++) {
    gxi[i] += scratch[i];
  }
  return OST_OK;
}


// the fewest forward directions (2 nv + na + nu) that the reverse sweep replaces: it costs about
// as much as 3 to 5 passes of 2 directions. Measured in instructions per backward step, the
// sweep took 9-25 % more on dm_control's pendulum, cart-pole, acrobot and reacher (3-6
// directions) and 13-18 % less on the robot and the cheetah (21 and 24)
#define OST_REVERSE_MIN 12

// backward pass of one record: g = (gq, gu, ga) at its q+, u+, act+ in; at its q-, u-, act- out
// (in place, 2 nv + na); gctrl (nu) and gtheta accumulate
static int recordBackward(ostContext* c, const mjModel* m, const ostRecord* r,
                          const ostGradOptions* go, mjtNum* g, mjtNum* gctrl, mjtNum* gtheta) {
  int nv = m->nv, nx = 2 * nv + m->na, nu = m->nu, ny, *piv, status;
  int nparam = go->params && gtheta ? ost_nparam(m) : 0;
  int reverse = !go->forward_only && !c->adj_oracle
                && (c->adj_reverse_all || nx + nu >= OST_REVERSE_MIN);
  if ((status = recordJacobian(c, m, r, go->truncate, nparam > 0, 0, reverse, &ny, &piv))) {
    return status;
  }
  int ncol = ny + nx + nu + nparam;
  const mjtNum* G = c->adj_scratch;
  mjtNum* K = c->adj_scratch + (size_t)(ny + nx) * ncol;
  mjtNum* w = K + (size_t)ny * ny + ny;
  mjtNum* gxi = w + ny;
  if (osti_adjointSolve(G, ny, nx, ncol, K, piv, w, g, gxi)) {
    return ost_fail(c, OST_ERR_NUMERIC, "the step's Jacobian is singular");
  }
  if (reverse && (status = startVjp(c, m, r, go->truncate, ny, w, g, gxi, gxi + ncol - ny))) {
    return status;
  }
  memcpy(g, gxi, nx * sizeof(mjtNum));
  for (int i = 0; gctrl && i < nu; i++) {
    gctrl[i] += gxi[nx + i];
  }
  for (int i = 0; i < nparam; i++) {
    int diff = ost_paramDifferentiable(m, i);
    if (diff > 0) {
      gtheta[i] += gxi[nx + nu + i];
    } else if (diff < 0) {
      gtheta[i] = NAN;  // read by MuJoCo, not differentiated here: unknown
    }
  }
  return OST_OK;
}


// OST_OK if every record [0, n) is a solved step, else OST_ERR_NOT_CONVERGED naming the first
// that is not: the implicit function theorem differentiates F(x-, x+) = 0, which holds only where
// Newton reached tol and no violation was kept (OST_DEPENETRATED shifts gaps by an allowance
// measured at q-, which the derivative does not follow)
static int recordsSolved(ostContext* c, const mjModel* m, void* recs, size_t nbytes) {
  for (size_t off = 0, k = 0; off < nbytes; k++) {
    ostRecord r;
    off += ost_recordView(m, (char*)recs + off, &r);
    if (r.head->bits & OST_NOT_CONVERGED) {
      return ost_fail(c, OST_ERR_NOT_CONVERGED, "substep %d did not converge (residual %.3g m/s "
                      "> tol %.3g): no exact gradient; raise ostrich/newton_iter or lower h",
                      (int)k, r.head->residual, c->opt.tol);
    }
    if (r.head->bits & OST_DEPENETRATED) {
      return ost_fail(c, OST_ERR_NOT_CONVERGED, "substep %d removed an initial violation at the "
                      "bounded depenetration speed: no exact gradient", (int)k);
    }
  }
  return OST_OK;
}


// backward pass over records [0, n) of a block (one step's substeps, or a tape's segment):
// g = (gq, gu, ga) (2 nv + na) holds the cotangents at the end on entry and at the start on
// return
int ost_recordsBackward(ostContext* c, const mjModel* m, void* recs, size_t nbytes,
                        const ostGradOptions* go, mjtNum* g, mjtNum* gctrl, mjtNum* gtheta) {
  int status = recordsSolved(c, m, recs, nbytes);
  if (!status) {
    status = adjointPrepare(c, m);
  }
  // records differ in size: their offsets first, then the pass from the last one
  int n = 0;
  for (size_t off = 0; off < nbytes; n++) {
    off += ost_recordSize(m, ((ostRecordHead*)((char*)recs + off))->nrow);
  }
  size_t* offs = (size_t*)malloc((n > 0 ? n : 1) * sizeof(size_t));
  if (!offs) {
    return ost_fail(c, OST_ERR_MEMORY, "cannot allocate");
  }
  for (size_t k = 0, off = 0; (int)k < n; k++) {
    offs[k] = off;
    off += ost_recordSize(m, ((ostRecordHead*)((char*)recs + off))->nrow);
  }
  for (int k = n - 1; k >= 0 && !status; k--) {
    ostRecord r;
    ost_recordView(m, (char*)recs + offs[k], &r);
    status = recordBackward(c, m, &r, go, g, gctrl, gtheta);
  }
  free(offs);
  return status;
}


// the largest difference between the split passes' and the oracle's Jacobian over the records
// of d's last step, per column relative to the column's largest entry (tests: the split passes
// must equal the oracle to rounding, ost_internal.h)
int ost_adjointOracleDiff(const mjModel* m, mjData* d, int truncate, int params, double* diff) {
  ostContext* c = ost_findContext(d);
  if (!c || c->rec_n == 0) {
    return OST_ERR_INPUT;
  }
  int status = recordsSolved(c, m, c->rec_buf, c->rec_bytes);
  if (status || (status = adjointPrepare(c, m))) {
    return status;
  }
  *diff = 0;
  int oracle = c->adj_oracle;
  for (size_t off = 0; off < c->rec_bytes && !status;) {
    ostRecord r;
    off += ost_recordView(m, (char*)c->rec_buf + off, &r);
    int ny, *piv, nx = 2 * m->nv + m->na;
    size_t ncol = 0, nG = 0;
    mjtNum* G0 = NULL;
    for (int pass = 0; pass < 2 && !status; pass++) {
      c->adj_oracle = pass;
      if ((status = recordJacobian(c, m, &r, truncate, params, 0, 0, &ny, &piv))) {
        break;
      }
      ncol = ny + nx + m->nu + (params ? ost_nparam(m) : 0);
      nG = (size_t)(ny + nx) * ncol;
      if (pass == 0) {
        G0 = (mjtNum*)malloc(nG * sizeof(mjtNum));
        if (!G0) {
          status = ost_fail(c, OST_ERR_MEMORY, "cannot allocate");
          break;
        }
        memcpy(G0, c->adj_scratch, nG * sizeof(mjtNum));
      }
    }
    for (size_t j = 0; !status && j < ncol; j++) {
      double e = 0, sc = 1e-300;
      for (size_t i = 0; i < nG / ncol; i++) {
        e = fmax(e, fabs(G0[i * ncol + j] - c->adj_scratch[i * ncol + j]));
        sc = fmax(sc, fabs(c->adj_scratch[i * ncol + j]));
      }
      *diff = fmax(*diff, e / sc);
    }
    free(G0);
  }
  c->adj_oracle = oracle;
  return status;
}


//---------------------------------- Public entry points -------------------------------------------

int ost_adjoint(const mjModel* m, const mjData* d, const ostGradOptions* go, const mjtNum* gq,
                const mjtNum* gu, mjtNum* gq_prev, mjtNum* gu_prev, mjtNum* gctrl,
                mjtNum* gtheta) {
  if (!m) return -1;
  if (!d) return -2;
  ostContext* c = ost_findContext(d);
  if (!c || c->rec_n == 0 || !c->warm_valid) {
    return c ? ost_fail(c, OST_ERR_INPUT, "ost_adjoint: no Ostrich step on this mjData") : -2;
  }
  ostGradOptions def;
  if (!go) {
    ost_defaultGradOptions(&def);
    go = &def;
  }
  // the activations' cotangent at the end is zero: L depends on (q+, u+)
  int nv = m->nv;
  mjtNum* g = (mjtNum*)calloc(2 * nv + m->na + 1, sizeof(mjtNum));
  if (!g) {
    return ost_fail(c, OST_ERR_MEMORY, "cannot allocate");
  }
  for (int i = 0; i < nv; i++) {
    g[i] = gq ? gq[i] : 0;
    g[nv + i] = gu ? gu[i] : 0;
  }
  if (gctrl) {
    memset(gctrl, 0, m->nu * sizeof(mjtNum));
  }
  int status = ost_recordsBackward(c, m, c->rec_buf, c->rec_bytes, go, g, gctrl, gtheta);
  if (!status) {
    if (gq_prev) memcpy(gq_prev, g, nv * sizeof(mjtNum));
    if (gu_prev) memcpy(gu_prev, g + nv, nv * sizeof(mjtNum));
  }
  free(g);
  return status;
}


// dense Jacobians of the records [0, n): x+ = (dq+, u+, act+) by x- = (dq-, u-, act-) into A
// (nx x nx, nx = 2nv + na) and by ctrl into B (nx x nu), chaining substeps: A = A_n..A_1,
// B = sum A_n..A_{k+1} B_k
static int recordsTransition(ostContext* c, const mjModel* m, void* recs, size_t nbytes,
                             mjtNum* A, mjtNum* B) {
  int nv = m->nv, nu = m->nu, nx = 2 * nv + m->na, status;
  if ((status = recordsSolved(c, m, recs, nbytes)) || (status = adjointPrepare(c, m))) {
    return status;
  }
  mjtNum* T = (mjtNum*)calloc((size_t)nx * (nx + nu) * 3, sizeof(mjtNum));
  if (!T) {
    return ost_fail(c, OST_ERR_MEMORY, "cannot allocate");
  }
  mjtNum* acc = T;                        // running [A B] (nx x (nx + nu))
  mjtNum* step = T + nx * (nx + nu);      // this substep's [A_k B_k]
  mjtNum* tmp = step + nx * (nx + nu);
  for (int i = 0; i < nx; i++) {
    acc[i * (nx + nu) + i] = 1;
  }
  for (size_t off = 0; off < nbytes && !status;) {
    ostRecord r;
    off += ost_recordView(m, (char*)recs + off, &r);
    int ny, *piv;
    if ((status = recordJacobian(c, m, &r, 0, 0, 1, 0, &ny, &piv))) {
      break;
    }
    int ncol = ny + nx + nu;
    const mjtNum* G = c->adj_scratch;
    const mjtNum* K = G + (size_t)(ny + nx) * ncol;
    mjtNum* col = (mjtNum*)K + (size_t)ny * ny + ny;
    // dy/dxi_j = -K^-1 R_xi_j, dO/dxi_j = O_xi_j + O_y dy/dxi_j
    for (int j = 0; j < nx + nu; j++) {
      for (int i = 0; i < ny; i++) {
        col[i] = -G[(size_t)i * ncol + ny + j];
      }
      ostu_luSolve(col, K, piv, col, ny);
      for (int i = 0; i < nx; i++) {
        mjtNum s = G[(size_t)(ny + i) * ncol + ny + j];
        for (int l = 0; l < ny; l++) {
          s += G[(size_t)(ny + i) * ncol + l] * col[l];
        }
        step[i * (nx + nu) + j] = s;
      }
    }
    // acc <- [A_k acc_A, A_k acc_B + B_k]
    for (int i = 0; i < nx; i++) {
      for (int j = 0; j < nx + nu; j++) {
        mjtNum s = j >= nx ? step[i * (nx + nu) + j] : 0;
        for (int l = 0; l < nx; l++) {
          s += step[i * (nx + nu) + l] * acc[l * (nx + nu) + j];
        }
        tmp[i * (nx + nu) + j] = s;
      }
    }
    memcpy(acc, tmp, (size_t)nx * (nx + nu) * sizeof(mjtNum));
  }
  for (int i = 0; i < nx && !status; i++) {
    for (int j = 0; j < nx + nu; j++) {
      if (j < nx && A) {
        A[i * nx + j] = acc[i * (nx + nu) + j];
      } else if (j >= nx && B) {
        B[i * nu + j - nx] = acc[i * (nx + nu) + j];
      }
    }
  }
  free(T);
  return status;
}


int ost_transition(const mjModel* m, mjData* d, mjtNum* A, mjtNum* B) {
  if (!m) return -1;
  if (!d) return -2;
  ostContext* c = ost_context(m, d);
  if (!c) {
    return OST_ERR_MEMORY;
  }
  // step from a copy of the state, differentiate the recorded substeps, restore everything
  int nstate = 1 + m->nq + 2 * m->nv + m->na;
  mjtNum* save = (mjtNum*)malloc((nstate + m->nu) * sizeof(mjtNum));
  if (!save) {
    return ost_fail(c, OST_ERR_MEMORY, "cannot allocate");
  }
  save[0] = d->time;
  memcpy(save + 1, d->qpos, m->nq * sizeof(mjtNum));
  memcpy(save + 1 + m->nq, d->qvel, m->nv * sizeof(mjtNum));
  memcpy(save + 1 + m->nq + m->nv, d->qacc_warmstart, m->nv * sizeof(mjtNum));
  memcpy(save + 1 + m->nq + 2 * m->nv, d->act, m->na * sizeof(mjtNum));
  memcpy(save + nstate, d->ctrl, m->nu * sizeof(mjtNum));
  int status = ost_step(m, d);
  if (!status || OST_IS_WARNING(status)) {
    status = recordsTransition(c, m, c->rec_buf, c->rec_bytes, A, B);
  }
  d->time = save[0];
  memcpy(d->qpos, save + 1, m->nq * sizeof(mjtNum));
  memcpy(d->qvel, save + 1 + m->nq, m->nv * sizeof(mjtNum));
  memcpy(d->qacc_warmstart, save + 1 + m->nq + m->nv, m->nv * sizeof(mjtNum));
  memcpy(d->act, save + 1 + m->nq + 2 * m->nv, m->na * sizeof(mjtNum));
  memcpy(d->ctrl, save + nstate, m->nu * sizeof(mjtNum));
  mj_forward(m, d);
  c->warm_valid = 0;
  c->rec_n = 0;
  c->rec_bytes = 0;
  free(save);
  return status;
}
