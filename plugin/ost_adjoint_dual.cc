// ost_adjoint_dual.cc: the plugin's dual-number translation unit. core/ (native kinematics,
// dynamics, collision, rows and the step's residual) compiled once more with ostNum =
// ostDual<OSTX_CHUNK>, and core/ost_adjoint_jacobian.h's exact step Jacobian behind the C seam of
// ost_adjoint_dual.h. The work owns a dual copy of the model, so parameters can be seeded.
// Invariant: reads the packed model and the step's inputs; writes only its work block and G.
#include <stdlib.h>
#include <string.h>

#include "ost_dual.h"

#define OSTX_CHUNK 8
#define OST_NUM_TYPE ostDual<OSTX_CHUNK>

#include "ost_adjoint_dual.h"
#include "../core/ost_adjoint_jacobian.h"

namespace {

struct Work {                     // a dual model and the evaluation's block
  ostModel   m;
  void*      m_block;
  void*      block;
  ostJacWork jw;
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

}  // namespace


extern "C" void* ostd_workCreate(const void* model, int nrow_max) {
  const ostModelDouble* src = (const ostModelDouble*)model;
  Work* wk = (Work*)calloc(1, sizeof(Work));
  if (!wk) {
    return NULL;
  }
  wk->m_block = alignedZero(ostx_dualModelSize(src->s));
  wk->block = alignedZero(ostx_jacWorkSize(src->s, nrow_max));
  if (!wk->m_block || !wk->block) {
    ostd_workFree(wk);
    return NULL;
  }
  ostx_dualModel(&wk->m, wk->m_block, src);
  ostx_jacWorkInit(&wk->jw, wk->block, &wk->m, nrow_max);
  return wk;
}


extern "C" void ostd_workFree(void* work) {
  Work* wk = (Work*)work;
  if (!wk) {
    return;
  }
  free(wk->m_block);
  free(wk->block);
  free(wk);
}


extern "C" int ostd_stepJacobian(void* work, const ostdStep* st, double* G, size_t G_cap,
                                 int* n_out, double* resid, int dense) {
  return ostx_stepJacobian(&((Work*)work)->jw, st, G, G_cap, n_out, resid, dense);
}


extern "C" size_t ostd_jacWorkSize(const void* model, int nrow_max) {
  return ostx_jacWorkSize(((const ostModelDouble*)model)->s, nrow_max);
}


extern "C" void ostd_recordStructure(void* work, const ostAdjointLayout* A, char* lanes, int l,
                                     int i, int nworld, int j, const ostAdjointSettings* as,
                                     const double* gq, const double* gu) {
  ostx_recordStructure(&((Work*)work)->m, A, lanes, l, i, nworld, j, as, gq, gu);
}


extern "C" void ostd_recordColumns(void* work, const ostAdjointLayout* A, char* lanes, int l,
                                   int t, int j, const ostAdjointSettings* as) {
  ostx_recordColumns(&((Work*)work)->m, A, lanes, l, t, j, as, NULL);
}
