// ost_adjoint_dual.h: the internal seam between the adjoint's host code (ost_adjoint.c, C) and the
// dual-number evaluation of a step's residual (ost_adjoint_dual.cc, C++, on core's
// ost_adjoint_jacobian.h). Plain C types only, so that it can be included where ostNum is double
// and where it is a dual number.
// Invariant: the dual side reads the packed model and the inputs, and writes only its own work
// block and the caller's output matrix.
#ifndef OSTRICH_PLUGIN_OST_ADJOINT_DUAL_H_
#define OSTRICH_PLUGIN_OST_ADJOINT_DUAL_H_

#include <stddef.h>

#include "../core/ost_adjoint.h"

#ifdef __cplusplus
extern "C" {
#endif

// ostdStep (one committed substep) is core's, core/ost_adjoint.h

// A 64-byte aligned, zeroed block of sz bytes (free() releases it; NULL if allocation fails), for
// the dual and reverse works.
void* ostd_alignedZero(size_t sz);

// Work block of the dual evaluation for a packed model with row capacity nrow_max (NULL if
// allocation fails).
void* ostd_workCreate(const void* model, int nrow_max);

// Release a work block (NULL is ignored).
void ostd_workFree(void* work);

// Exact Jacobian of the step's residual and outputs by forward-mode dual numbers. The native
// rows at q+ are recomputed and the recorded multipliers matched onto them (by object and
// contact key); n = nv + their count. G ((n + 2 nv + na) x ncol, row-major, ncol = n + 2 nv +
// na + nu + nparam) receives the rows R (n) then O = (dq+, u+, act+) (2 nv + na), differentiated
// by the columns y = (u, lambda) (n) then xi = (dq-, u-, act-, ctrl, theta). *resid gets |R| at
// the solution. dense = 1: every column through the whole evaluation (the test oracle); 0: each
// input through the part of the step it moves (core/ost_adjoint_jacobian.h, ostx_jacColumnsSplit;
// 3: without the columns of the start's inputs, for ost_adjoint_rev.h).
// Returns 0, 1 if G needs more than G_cap doubles (*n still set), 2 if the rows overflow.
int ostd_stepJacobian(void* work, const ostdStep* s, double* G, size_t G_cap, int* n,
                      double* resid, int dense);

// after ostd_stepJacobian (split), the values at the step of the nrow rows at q+: x_i = Mt^-1 J_i'
// (nrow x nv) and J_i Mt^-1 J_i' (nrow) (pointers into the work, valid until its next call); the
// multipliers matched onto them into lam (nrow), the rows into rows (nrow ostRow of the double
// build), their Jacobian into J (nrow x nv) and the actuators' lengths at q+ into length (nu)
void ostd_stepValues(void* work, int nrow, const double** X, const double** diag0, double* lam,
                     void* rows, double* J, double* length);

// bytes of the dual work of one batch adjoint lane (ostAdjointLayout.jac_size)
size_t ostd_jacWorkSize(const void* model, int nrow_max);

// phases 3a and 3b of a batch world's backward pass (core/ost_adjoint_jacobian.h's
// ostx_recordStructure, ostx_recordColumns) on the dual model of a work from ostd_workCreate;
// many threads may share one work (ostd_recordColumns uses the lane's dual work: njac = 1)
void ostd_recordStructure(void* work, const ostAdjointLayout* A, char* lanes, int l, int i,
                          int nworld, int j, const ostAdjointSettings* as, const double* gq,
                          const double* gu);
void ostd_recordColumns(void* work, const ostAdjointLayout* A, char* lanes, int l, int t, int j,
                        const ostAdjointSettings* as);

// the same entry points of each dual build (ost_adjoint_dual.cc: 2 directions per pass, the
// width steps use; ost_adjoint_dual8.cc: 8, for the tests); those above dispatch on a work's
// width
#define OSTD_DECLARE(P)                                                                          \
  void* P##_workCreate(const void* model, int nrow_max);                                         \
  void P##_workFree(void* work);                                                                 \
  int P##_stepJacobian(void* work, const ostdStep* s, double* G, size_t G_cap, int* n,           \
                       double* resid, int dense);                                                \
  size_t P##_jacWorkSize(const void* model, int nrow_max);                                       \
  void P##_stepValues(void* work, int nrow, const double** X, const double** diag0, double* lam,  \
                      void* rows, double* J, double* length);                                   \
  void P##_recordStructure(void* work, const ostAdjointLayout* A, char* lanes, int l, int i,     \
                           int nworld, int j, const ostAdjointSettings* as, const double* gq,   \
                           const double* gu);                                                    \
  void P##_recordColumns(void* work, const ostAdjointLayout* A, char* lanes, int l, int t,       \
                         int j, const ostAdjointSettings* as);
OSTD_DECLARE(ostd2)
OSTD_DECLARE(ostd8)
#undef OSTD_DECLARE

#ifdef __cplusplus
}
#endif

#endif  // OSTRICH_PLUGIN_OST_ADJOINT_DUAL_H_
