// ost_adjoint_dual.cc: the plugin's dual-number translation unit. core/ (native kinematics,
// dynamics, collision, rows and the step's residual) compiled once more with ostNum =
// ostDual<OSTX_CHUNK>, and core/ost_adjoint_jacobian.h's exact step Jacobian behind the C seam of
// ost_adjoint_dual.h. The work owns a dual copy of the model, so parameters can be seeded.
// Compiled twice: OSTX_CHUNK 2 here, the width steps use, and 8 by ost_adjoint_dual8.cc for the
// tests. Measured on one core (ostrich bench adjoint, 100 steps): passes of 2 directions take
// 1.7-3 times less time in all than passes of 4 or 8 on every model tried (robot 110 against
// 235-270 us per step, humanoid 860 against 1,480, cart-pole 14 against 49), although a model
// then needs more passes. Each direction is computed on its own, so the widths give the same
// bits; this build also holds the ostd_* entry points, which dispatch on a work's width.
// Invariant: reads the packed model and the step's inputs; writes only its work block and G.
#include <stdlib.h>
#include <string.h>

#include "ost_dual.h"

#ifndef OSTX_CHUNK
#define OSTX_CHUNK 2
#endif
#define OST_NUM_TYPE ostDual<OSTX_CHUNK>

#include "ost_adjoint_dual.h"
#include "../core/ost_adjoint_jacobian.h"

// this chunk's entry points: ostd2_name or ostd8_name
#define OSTD_CAT2(a, b) a##b
#define OSTD_CAT(a, b) OSTD_CAT2(a, b)
#define OSTD(name) OSTD_CAT(OSTD_CAT(ostd, OSTX_CHUNK), name)

namespace {

struct Work {                     // a dual model and the evaluation's block
  int        chunk;               // OSTX_CHUNK (first: the entry points dispatch on it)
  ostModel   m;
  void*      m_block;
  void*      block;
  ostJacWork jw;
};

}  // namespace


extern "C" void OSTD(_workFree)(void* work) {
  Work* wk = (Work*)work;
  if (!wk) {
    return;
  }
  free(wk->m_block);
  free(wk->block);
  free(wk);
}


extern "C" void* OSTD(_workCreate)(const void* model, int nrow_max) {
  const ostModelDouble* src = (const ostModelDouble*)model;
  Work* wk = (Work*)calloc(1, sizeof(Work));
  if (!wk) {
    return NULL;
  }
  wk->chunk = OSTX_CHUNK;
  wk->m_block = ostd_alignedZero(ostx_dualModelSize(src->s));
  wk->block = ostd_alignedZero(ostx_jacWorkSize(src->s, nrow_max));
  if (!wk->m_block || !wk->block) {
    OSTD(_workFree)(wk);
    return NULL;
  }
  ostx_dualModel(&wk->m, wk->m_block, src);
  ostx_jacWorkInit(&wk->jw, wk->block, &wk->m, nrow_max);
  return wk;
}


extern "C" int OSTD(_stepJacobian)(void* work, const ostdStep* st, double* G, size_t G_cap,
                                   int* n_out, double* resid, int dense) {
  return ostx_stepJacobian(&((Work*)work)->jw, st, G, G_cap, n_out, resid, dense);
}


extern "C" void OSTD(_stepValues)(void* work, int nrow, const double** X, const double** diag0,
                                  double* lam, void* rows, double* J, double* length) {
  const ostJacWork* jw = &((Work*)work)->jw;
  int nv = jw->m->s.nv;
  *X = jw->X;
  *diag0 = jw->diag0;
  ostRowDouble* rd = (ostRowDouble*)rows;
  for (int i = 0; i < nrow; i++) {
    const ostRow* r = jw->w.rows + i;
    lam[i] = (double)jw->lambda[i];
    rd[i].type = r->type;
    rd[i].obj[0] = r->obj[0];
    rd[i].obj[1] = r->obj[1];
    rd[i].normal = r->normal;
    for (int k = 0; k < 3; k++) rd[i].key[k] = (double)r->key[k];
    rd[i].pos = (double)r->pos;
    rd[i].mu = (double)r->mu;
    rd[i].alpha = (double)r->alpha;
    rd[i].lo = (double)r->lo;
    rd[i].hi = (double)r->hi;
    for (int j = 0; j < nv; j++) J[(size_t)i * nv + j] = (double)jw->w.J[(size_t)i * nv + j];
  }
  for (int i = 0; i < jw->m->s.nu; i++) length[i] = (double)jw->k.actuator_length[i];
}


extern "C" size_t OSTD(_jacWorkSize)(const void* model, int nrow_max) {
  return ostx_jacWorkSize(((const ostModelDouble*)model)->s, nrow_max);
}


extern "C" void OSTD(_recordStructure)(void* work, const ostAdjointLayout* A, char* lanes,
                                       int l, int i, int nworld, int j,
                                       const ostAdjointSettings* as, const double* gq,
                                       const double* gu) {
  ostx_recordStructure(&((Work*)work)->m, A, lanes, l, i, nworld, j, as, gq, gu);
}


extern "C" void OSTD(_recordColumns)(void* work, const ostAdjointLayout* A, char* lanes, int l,
                                     int t, int j, const ostAdjointSettings* as) {
  ostx_recordColumns(&((Work*)work)->m, A, lanes, l, t, j, as, NULL);
}


#if OSTX_CHUNK == 2
//---------------------------------- the entry points ----------------------------------------------

// the width of a new work's passes: 2 for every model (see the top of this file)
static int chunkFor(const void* model) {
  (void)model;
  return 2;
}

static int chunkOf(const void* work) {
  return *(const int*)work;
}

extern "C" void* ostd_alignedZero(size_t sz) {
  sz = (sz + 63) / 64 * 64;
  void* p = aligned_alloc(64, sz ? sz : 64);
  if (p) {
    memset(p, 0, sz);
  }
  return p;
}

// the entry point P of a work's (or a model's) chunk, called with args
#define OSTD_BY_CHUNK(chunk, P, args) \
  ((chunk) == 2 ? ostd2_##P args : ostd8_##P args)

extern "C" void* ostd_workCreate(const void* model, int nrow_max) {
  return OSTD_BY_CHUNK(chunkFor(model), workCreate, (model, nrow_max));
}

extern "C" void ostd_workFree(void* work) {
  if (work) OSTD_BY_CHUNK(chunkOf(work), workFree, (work));
}

extern "C" int ostd_stepJacobian(void* work, const ostdStep* st, double* G, size_t G_cap,
                                 int* n_out, double* resid, int dense) {
  return OSTD_BY_CHUNK(chunkOf(work), stepJacobian, (work, st, G, G_cap, n_out, resid, dense));
}

extern "C" void ostd_stepValues(void* work, int nrow, const double** X, const double** diag0,
                                double* lam, void* rows, double* J, double* length) {
  OSTD_BY_CHUNK(chunkOf(work), stepValues, (work, nrow, X, diag0, lam, rows, J, length));
}

extern "C" size_t ostd_jacWorkSize(const void* model, int nrow_max) {
  return OSTD_BY_CHUNK(chunkFor(model), jacWorkSize, (model, nrow_max));
}

extern "C" void ostd_recordStructure(void* work, const ostAdjointLayout* A, char* lanes, int l,
                                     int i, int nworld, int j, const ostAdjointSettings* as,
                                     const double* gq, const double* gu) {
  OSTD_BY_CHUNK(chunkOf(work), recordStructure, (work, A, lanes, l, i, nworld, j, as, gq, gu));
}

extern "C" void ostd_recordColumns(void* work, const ostAdjointLayout* A, char* lanes, int l,
                                   int t, int j, const ostAdjointSettings* as) {
  OSTD_BY_CHUNK(chunkOf(work), recordColumns, (work, A, lanes, l, t, j, as));
}
#undef OSTD_BY_CHUNK
#endif
