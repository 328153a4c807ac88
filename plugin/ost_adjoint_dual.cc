// ost_adjoint_dual.cc: the exact Jacobian of one Ostrich step's residual by forward-mode dual
// numbers. This is core's own portable code (native kinematics, dynamics, collision, rows and
// core/ost_adjoint.h's residual) compiled once more with ostNum = ostDual<OSTD_CHUNK>; each pass
// seeds OSTD_CHUNK input directions and reads their derivatives off every output. Nothing here
// is hand-differentiated: how contact points, normals and distances move with the pose, the
// mass matrix and bias forces with q-, and ball/free joints' exponential map all enter exactly
// (DESIGN.md section 2, "forward-mode dual numbers on the residual code").
// Invariant: reads the packed model and the step's inputs; writes only its work block and G.
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "ost_dual.h"

#define OSTD_CHUNK 8
#define OST_NUM_TYPE ostDual<OSTD_CHUNK>

#include "ost_adjoint.h"
#include "ost_rows_native.h"
#include "../core/ost_adjoint.h"

typedef ostDual<OSTD_CHUNK> ostdNum;

namespace {

struct Work {                     // the dual evaluation's state, one allocation per array
  const ostModelDouble* src;      // the packed double model it was made from
  ostModel m;                     // dual copy of the model (parameters can be seeded)
  void*    m_block;
  ostKin   k;                     // dual kinematics
  void*    k_block;
  ostWorld w;                     // dual world: rows, J, Mt, f at the step
  void*    w_block;
  ostdNum* v;                     // every dual vector below, one block
  ostdNum *qpos, *qplus, *qref, *dqm, *dqp, *u, *uprev, *ctrl, *qfrc, *xfrc, *lambda, *R;
  ostRow*  rec;                   // the recorded rows as dual rows (matching keys)
  ostdNum* rec_lambda;            // their multipliers
  unsigned char* used;            // matching scratch
  int      nrow_max;
};

// 64-byte aligned, zeroed block of sz bytes
void* alignedZero(size_t sz) {
  sz = (sz + 63) / 64 * 64;
  void* p = aligned_alloc(64, sz ? sz : 64);
  if (p) {
    memset(p, 0, sz);
  }
  return p;
}


// set the derivatives of every parameter array the columns may seed back to zero
void clearParamSeeds(Work* wk) {
  ostModel* m = &wk->m;
  ostSizes s = m->s;
  for (int i = 0; i < s.npair; i++) m->pair_friction[i] = (double)m->pair_friction[i];
  for (int i = 0; i < s.nbody; i++) m->body_mass[i] = (double)m->body_mass[i];
  for (int i = 0; i < s.nv; i++) m->dof_damping[i] = (double)m->dof_damping[i];
  for (int i = 0; i < s.nu; i++) m->actuator_gainprm[i] = (double)m->actuator_gainprm[i];
  for (int i = 0; i < 3 * s.nu; i++) m->actuator_biasprm[i] = (double)m->actuator_biasprm[i];
}


// seed parameter p (index into theta) with direction k
void seedParam(Work* wk, const ostdStep* st, int p, int k) {
  ostModel* m = &wk->m;
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


// one evaluation of R and O at the step's values with the columns [col0, col0 + OSTD_CHUNK)
// seeded (col0 < 0: no seeds). ny = nv + nrow of the native rows (known after the first call).
// Returns OST_ROWS_* or -1 if the rows differ from the first evaluation's.
int evaluate(Work* wk, const ostdStep* st, int col0, int ny, int nrow_expect) {
  ostModel* m = &wk->m;
  int nq = m->s.nq, nv = m->s.nv, nu = m->s.nu;
  for (int i = 0; i < nq; i++) wk->qpos[i] = st->qpos_prev[i];
  for (int i = 0; i < nv; i++) {
    wk->dqm[i] = 0;
    wk->u[i] = st->qvel[i];
    wk->uprev[i] = st->qvel_prev[i];
    wk->qfrc[i] = st->qfrc_applied ? st->qfrc_applied[i] : 0;
  }
  for (int i = 0; i < nu; i++) wk->ctrl[i] = st->ctrl[i];
  for (int i = 0; i < 6 * m->s.nbody; i++) wk->xfrc[i] = st->xfrc_applied ? st->xfrc_applied[i] : 0;
  for (int i = 0; i < nrow_expect; i++) wk->lambda[i] = (double)wk->lambda[i];
  clearParamSeeds(wk);

  // seeds: column c is direction c - col0
  for (int k = 0; col0 >= 0 && k < OSTD_CHUNK; k++) {
    int c = col0 + k;
    if (c < nv) {
      wk->u[c].d[k] = 1;
    } else if (c < ny) {
      wk->lambda[c - nv].d[k] = 1;
    } else if ((c -= ny) < nv) {
      wk->dqm[c].d[k] = 1;
    } else if ((c -= nv) < nv) {
      wk->uprev[c].d[k] = 1;
    } else if ((c -= nv) < nu) {
      wk->ctrl[c].d[k] = 1;
    } else if ((c -= nu) < st->nparam) {
      seedParam(wk, st, c, k);
    }
  }

  // q- (+) dq-, the step's start (Mt, f), then q+ = q- (+) h u and the rows there
  osti_integratePos(m, wk->qpos, wk->dqm, 1);
  osti_nativeStart(m, &wk->k, &wk->w, wk->qpos, wk->uprev, wk->ctrl, wk->qfrc, wk->xfrc, st->h);
  for (int i = 0; i < nq; i++) wk->qplus[i] = wk->qpos[i];
  osti_integratePos(m, wk->qplus, wk->u, st->h);
  int rc = osti_nativeIterate(m, &wk->k, &wk->w, wk->qplus, wk->ctrl, st->lookahead, st->h);
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

}  // namespace


extern "C" void* ostd_workCreate(const void* model, int nrow_max) {
  const ostModelDouble* src = (const ostModelDouble*)model;
  Work* wk = (Work*)calloc(1, sizeof(Work));
  if (!wk) {
    return NULL;
  }
  ostSizes s = src->s;
  wk->src = src;
  wk->nrow_max = nrow_max;
  wk->m_block = alignedZero(ostx_dualModelSize(s));
  wk->k_block = alignedZero(ostu_kinSize(s));
  wk->w_block = alignedZero(ostu_worldSize(s.nv, nrow_max));
  size_t nvec = 3 * (size_t)s.nq + 6 * (size_t)s.nv + s.nu + 6 * (size_t)s.nbody
                + 2 * (size_t)nrow_max + (size_t)s.nv + nrow_max;
  wk->v = (ostdNum*)alignedZero(nvec * sizeof(ostdNum));
  wk->rec = (ostRow*)alignedZero(nrow_max * sizeof(ostRow));
  wk->used = (unsigned char*)alignedZero(nrow_max);
  if (!wk->m_block || !wk->k_block || !wk->w_block || !wk->v || !wk->rec || !wk->used) {
    ostd_workFree(wk);
    return NULL;
  }
  ostx_dualModel(&wk->m, wk->m_block, src);
  ostu_kinInit(&wk->k, wk->k_block, s);
  ostu_worldInit(&wk->w, wk->w_block, s.nv, nrow_max, 0);
  ostdNum* p = wk->v;
  wk->qpos = p;   p += s.nq;
  wk->qplus = p;  p += s.nq;
  wk->qref = p;   p += s.nq;
  wk->dqm = p;    p += s.nv;
  wk->dqp = p;    p += s.nv;
  wk->u = p;      p += s.nv;
  wk->uprev = p;  p += s.nv;
  wk->qfrc = p;   p += s.nv;
  wk->ctrl = p;   p += s.nu;
  wk->xfrc = p;   p += 6 * s.nbody;
  wk->lambda = p; p += nrow_max;
  wk->R = p;      p += s.nv + nrow_max;
  wk->rec_lambda = p;
  return wk;
}


extern "C" void ostd_workFree(void* work) {
  Work* wk = (Work*)work;
  if (!wk) {
    return;
  }
  free(wk->m_block);
  free(wk->k_block);
  free(wk->w_block);
  free(wk->v);
  free(wk->rec);
  free(wk->used);
  free(wk);
}


extern "C" int ostd_stepJacobian(void* work, const ostdStep* st, double* G, size_t G_cap,
                                 int* n_out, double* resid) {
  Work* wk = (Work*)work;
  int nv = wk->m.s.nv, nu = wk->m.s.nu;
  if (st->nrow > wk->nrow_max) {
    return 2;
  }

  // structure pass: the native rows at q+, and the recorded multipliers matched onto them
  int rc = evaluate(wk, st, -1, 0, -1);
  if (rc) {
    return 2;
  }
  int nrow = wk->w.nrow, ny = nv + nrow;
  const ostRowDouble* rr = (const ostRowDouble*)st->rows;
  for (int i = 0; i < st->nrow; i++) {
    ostRow* r = wk->rec + i;
    memset(r, 0, sizeof(ostRow));
    r->type = rr[i].type;
    r->obj[0] = rr[i].obj[0];
    r->obj[1] = rr[i].obj[1];
    r->normal = rr[i].normal;
    for (int c = 0; c < 3; c++) r->key[c] = rr[i].key[c];
    wk->rec_lambda[i] = st->lambda[i];
  }
  osti_matchRows(wk->lambda, wk->w.rows, nrow, wk->rec_lambda, wk->rec, st->nrow, wk->used);
  *n_out = ny;
  int nout = ny + 2 * nv, ncol = ny + 2 * nv + nu + st->nparam;
  if ((size_t)nout * ncol > G_cap) {
    return 1;
  }

  // column chunks: every output's derivatives in the seeded directions
  double r2 = 0;
  for (int col0 = 0; col0 < ncol; col0 += OSTD_CHUNK) {
    if ((rc = evaluate(wk, st, col0, ny, nrow))) {
      return 2;
    }
    for (int k = 0; k < OSTD_CHUNK && col0 + k < ncol; k++) {
      int c = col0 + k;
      for (int i = 0; i < ny; i++) G[(size_t)i * ncol + c] = wk->R[i].d[k];
      for (int i = 0; i < nv; i++) {
        G[(size_t)(ny + i) * ncol + c] = wk->dqp[i].d[k];
        G[(size_t)(ny + nv + i) * ncol + c] = wk->u[i].d[k];
      }
    }
    if (col0 == 0) {
      for (int i = 0; i < ny; i++) r2 += wk->R[i].v * wk->R[i].v;
    }
  }
  *resid = sqrt(r2);
  return 0;
}
