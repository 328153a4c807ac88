// ost_adjoint_rev.cc: the vector-Jacobian product of a step's residual by the inputs of its start
// (dq-, u-, act-, ctrl) in one reverse sweep: core/ compiled once more with ostNum = ostRev
// (ost_rev.h), behind the C seam of ost_adjoint_rev.h. It replaces the forward-mode passes of
// those columns (core/ost_adjoint_split.h's UM, AC and DQ units, nv + nu + na + nv directions)
// where a backward pass needs only w' dR/dxi, not the columns (core/README.md section 2).
// Invariant: reads the packed model and the step's inputs; writes only its own work and `out`.
#include <stdlib.h>
#include <string.h>

#include "ost_dual.h"  // the double model's layout twin and its conversion (any ostNum)
#include "ost_rev.h"

#define OST_NUM_TYPE ostRev

#include "ost_adjoint_dual.h"  // ostd_alignedZero
#include "ost_adjoint_rev.h"
#include "../core/ost_activation.h"
#include "../core/ost_rows_native.h"

thread_local ostRevTape* ostr_tape = NULL;

namespace {

struct Work {
  ostModel   m;                   // the model as ostRev constants
  void*      m_block;
  void*      block;               // kinematics at q- and q+, the world, the vectors
  ostKin     km, k;
  ostWorld   w;
  ostRev *qpos, *dq, *u, *uprev, *qfrc, *xfrc, *lambda, *R, *ctrl, *act, *act_next, *input;
  int*       in;                  // input nodes: dq- (nv), u- (nv), act- (na), ctrl (nu)
  int*       diag_node;           // the rows' diagonal nodes (nrow_max)
  ostRowDouble* rows;             // staged by the caller (ostr_staging): the rows at q+ (nrow_max),
  double*    J;                   // their Jacobian (nrow_max x nv), the multipliers matched onto
  double*    lam;                 // them (nrow_max) and the actuators' lengths at q+ (nu)
  double*    length;
  int        nrow_max;
  ostRevTape tape;
  double*    adj;                 // tape.cap
};

void freeTape(Work* wk) {
  free(wk->tape.a);
  free(wk->tape.b);
  free(wk->tape.da);
  free(wk->tape.db);
  free(wk->adj);
  wk->tape.a = wk->tape.b = NULL;
  wk->tape.da = wk->tape.db = wk->adj = NULL;
  wk->tape.cap = 0;
}

// a tape of cap nodes; 0 or 1 (out of memory)
int allocTape(Work* wk, int cap) {
  freeTape(wk);
  wk->tape.a = (int*)malloc(cap * sizeof(int));
  wk->tape.b = (int*)malloc(cap * sizeof(int));
  wk->tape.da = (double*)malloc(cap * sizeof(double));
  wk->tape.db = (double*)malloc(cap * sizeof(double));
  wk->adj = (double*)malloc(cap * sizeof(double));
  if (!wk->tape.a || !wk->tape.b || !wk->tape.da || !wk->tape.db || !wk->adj) {
    freeTape(wk);
    return 1;
  }
  wk->tape.cap = cap;
  return 0;
}

// the step's residual R at its solution (y = (u, lambda) and q+ held), taped from the inputs of
// its start, as the split passes evaluate it; the rows at q+ are the staged values but for the
// servo rows' fields, which read the inputs; the rows' diagonal enters as input nodes (their
// dependence on Mt is added by hand between the two halves of the sweep, eq. 15b). Returns the
// first node of the rows' part (every node of Mt and f is below it).
int evaluate(Work* wk, const ostdStep* st, int nrow, const double* diag0) {
  ostModel* m = &wk->m;
  ostWorld* w = &wk->w;
  int nq = m->s.nq, nv = m->s.nv, nu = m->s.nu, na = m->s.na, ni = 0;
  (void)nq;
  double h = st->h;
  for (int i = 0; i < nq; i++) wk->qpos[i] = st->qpos_prev[i];
  for (int i = 0; i < nv; i++) {
    wk->dq[i] = ostr_input(0);
    wk->in[ni++] = wk->dq[i].i;
  }
  for (int i = 0; i < nv; i++) {
    wk->uprev[i] = ostr_input(st->qvel_prev[i]);
    wk->in[ni++] = wk->uprev[i].i;
    wk->u[i] = st->qvel[i];
    wk->qfrc[i] = st->qfrc_applied ? st->qfrc_applied[i] : 0;
  }
  for (int i = 0; i < na; i++) {
    wk->act[i] = ostr_input(st->act_prev[i]);
    wk->in[ni++] = wk->act[i].i;
  }
  for (int i = 0; i < nu; i++) {
    wk->ctrl[i] = ostr_input(st->ctrl[i]);
    wk->in[ni++] = wk->ctrl[i].i;
  }
  for (int i = 0; i < 6 * m->s.nbody; i++) {
    wk->xfrc[i] = st->xfrc_applied ? st->xfrc_applied[i] : 0;
  }
  for (int i = 0; i < nrow; i++) {
    const ostRowDouble* rd = wk->rows + i;
    ostRow* r = w->rows + i;
    wk->lambda[i] = wk->lam[i];
    r->type = rd->type;
    r->obj[0] = rd->obj[0];
    r->obj[1] = rd->obj[1];
    r->normal = rd->normal;
    for (int k = 0; k < 3; k++) r->key[k] = rd->key[k];
    r->pos = rd->pos;
    r->mu = rd->mu;
    r->alpha = rd->alpha;
    r->lo = rd->lo;
    r->hi = rd->hi;
    for (int j = 0; j < nv; j++) w->J[(size_t)i * nv + j] = wk->J[(size_t)i * nv + j];
  }
  w->nrow = nrow;
  for (int i = 0; i < nu; i++) wk->k.actuator_length[i] = wk->length[i];

  // the start at q- (+) dq- (Mt, f with the actuators' forces), the servo rows' fields
  osti_actuation(m, wk->ctrl, wk->act, h, wk->act_next, wk->input);
  osti_integratePos(m, wk->qpos, wk->dq, 1);
  osti_nativeStart(m, &wk->km, w, wk->qpos, wk->uprev, wk->input, wk->qfrc, wk->xfrc, h);
  osti_nativeServoRows(m, &wk->k, w, wk->input, h);
  for (int i = 0; i < nv; i++) w->qvel_prev[i] = wk->uprev[i];
  w->h = h;
  osti_residualDynamics(w, w->M, wk->u, wk->lambda, wk->R);
  int first = wk->tape.n;
  for (int i = 0; i < nrow; i++) {
    w->diag[i] = diag0[i] > 1e-300 ? ostr_input(diag0[i]) : ostRev(diag0[i]);
    wk->diag_node[i] = w->diag[i].i;
  }
  osti_residualRows(w, wk->u, wk->lambda, st->reg, st->creep, st->fb_eps, wk->R + nv);
  return first;
}

}  // namespace


extern "C" void ostr_workFree(void* work) {
  Work* wk = (Work*)work;
  if (!wk) {
    return;
  }
  freeTape(wk);
  free(wk->m_block);
  free(wk->block);
  free(wk);
}


extern "C" void* ostr_workCreate(const void* model, int nrow_max) {
  const ostModelDouble* src = (const ostModelDouble*)model;
  ostSizes s = src->s;
  Work* wk = (Work*)calloc(1, sizeof(Work));
  if (!wk) {
    return NULL;
  }
  size_t nvec = (size_t)s.nq + 5 * (size_t)s.nv + 6 * (size_t)s.nbody + 2 * (size_t)nrow_max
                + 2 * (size_t)s.nu + 2 * (size_t)s.na;
  size_t nint = 2 * (size_t)s.nv + s.na + s.nu + nrow_max;
  size_t nstage = (size_t)nrow_max * (s.nv + 1) + s.nu;  // doubles
  size_t kin = ostu_kinSize(s), world = ostu_worldSizeFor(s.nv, s.nv, nrow_max, 0);
  wk->m_block = ostd_alignedZero(ostx_dualModelSize(s));
  wk->block = ostd_alignedZero(2 * kin + world + OST_ALIGN64(nvec * sizeof(ostRev))
                          + OST_ALIGN64(nint * sizeof(int))
                          + OST_ALIGN64((size_t)nrow_max * sizeof(ostRowDouble))
                          + OST_ALIGN64(nstage * sizeof(double)));
  if (!wk->m_block || !wk->block || allocTape(wk, 1 << 15)) {
    ostr_workFree(wk);
    return NULL;
  }
  ostx_dualModel(&wk->m, wk->m_block, src);
  char* p = (char*)wk->block;
  ostu_kinInit(&wk->km, p, s);
  p += kin;
  ostu_kinInit(&wk->k, p, s);
  p += kin;
  ostu_worldInitFor(&wk->w, p, s.nv, s.nv, nrow_max, 0, 0);
  p += world;
  ostRev* v = (ostRev*)p;
  p += OST_ALIGN64(nvec * sizeof(ostRev));
  wk->qpos = v;     v += s.nq;
  wk->dq = v;       v += s.nv;
  wk->u = v;        v += s.nv;
  wk->uprev = v;    v += s.nv;
  wk->qfrc = v;     v += s.nv;
  wk->xfrc = v;     v += 6 * (size_t)s.nbody;
  wk->lambda = v;   v += nrow_max;
  wk->R = v;        v += s.nv + (size_t)nrow_max;
  wk->ctrl = v;     v += s.nu;
  wk->input = v;    v += s.nu;
  wk->act = v;      v += s.na;
  wk->act_next = v;
  wk->in = (int*)p;
  wk->diag_node = wk->in + 2 * s.nv + s.na + s.nu;
  p += OST_ALIGN64(nint * sizeof(int));
  wk->rows = (ostRowDouble*)p;
  p += OST_ALIGN64((size_t)nrow_max * sizeof(ostRowDouble));
  wk->J = (double*)p;
  wk->lam = wk->J + (size_t)nrow_max * s.nv;
  wk->length = wk->lam + nrow_max;
  wk->nrow_max = nrow_max;
  return wk;
}


extern "C" int ostr_reserve(void* work, int cap) {
  return allocTape((Work*)work, cap > 2 ? cap : 2);
}


extern "C" void ostr_staging(void* work, void** rows, double** J, double** lam,
                             double** length) {
  Work* wk = (Work*)work;
  *rows = wk->rows;
  *J = wk->J;
  *lam = wk->lam;
  *length = wk->length;
}


extern "C" int ostr_startVjp(void* work, const ostdStep* st, int nrow, const double* X,
                             const double* diag0, const double* wy, const double* gact,
                             double* out) {
  Work* wk = (Work*)work;
  ostModel* m = &wk->m;
  int nv = m->s.nv, na = m->s.na, nu = m->s.nu, first;
  if (nrow > wk->nrow_max) {
    return 2;
  }
  for (;;) {
    wk->tape.n = 1;  // node 0: the constants
    wk->tape.overflow = 0;
    ostr_tape = &wk->tape;
    first = evaluate(wk, st, nrow, diag0);
    ostr_tape = NULL;
    if (!wk->tape.overflow) {
      break;
    }
    if (wk->tape.cap > (1 << 28) || allocTape(wk, 2 * wk->tape.cap)) {
      return 1;
    }
  }

  // seeds: w on the residual, the act+ cotangents on act+
  const ostRevTape* t = &wk->tape;
  double* adj = wk->adj;
  memset(adj, 0, t->n * sizeof(double));
  for (int i = 0; i < nv + nrow; i++) adj[wk->R[i].i] += wy[i];
  for (int i = 0; i < na; i++) adj[wk->act_next[i].i] += gact[i];
  adj[0] = 0;

  // the rows' part, then each diagonal's pull on Mt, d(J_i Mt^-1 J_i') = -x_i' dMt x_i (15b),
  // on Mt's lower triangle over each dof's ancestors (as the tree factor reads it), then the rest
  ostr_sweep(t, adj, t->n, first);
  const ostRev* Mt = wk->w.M;
  const int* par = wk->w.dof_parent;
  for (int i = 0; i < nrow; i++) {
    double c = wk->diag_node[i] ? adj[wk->diag_node[i]] : 0;
    const double* x = X + (size_t)i * nv;
    for (int k = 0; k < nv && c != 0; k++) {
      if (x[k] == 0) {
        continue;
      }
      const ostRev* Mk = Mt + (size_t)k * nv;
      adj[Mk[k].i] -= c * x[k] * x[k];
      for (int j = par ? par[k] : k - 1; j >= 0; j = par ? par[j] : j - 1) {
        adj[Mk[j].i] -= 2 * c * x[k] * x[j];
      }
    }
  }
  adj[0] = 0;
  ostr_sweep(t, adj, first, 1);
  for (int i = 0; i < 2 * nv + na + nu; i++) {
    out[i] = wk->in[i] ? adj[wk->in[i]] : 0;
  }
  return 0;
}
