// ost_adjoint_rev.h: the internal seam between the adjoint's host code (ost_adjoint.c, C) and the
// reverse-mode evaluation of a step's start (ost_adjoint_rev.cc, C++, ostNum = ostRev). Plain C
// types only.
// Invariant: the reverse side reads the packed model and the inputs, and writes only its own
// work and the caller's output.
#ifndef OSTRICH_PLUGIN_OST_ADJOINT_REV_H_
#define OSTRICH_PLUGIN_OST_ADJOINT_REV_H_

#include "../core/ost_adjoint.h"

#ifdef __cplusplus
extern "C" {
#endif

// Work of the reverse evaluation for a packed model with row capacity nrow_max (NULL if
// allocation fails); its tape grows as a step needs.
void* ostr_workCreate(const void* model, int nrow_max);

// Release a work (NULL is ignored).
void ostr_workFree(void* work);

// A tape of cap nodes in place of the work's (it still grows as a step needs; for the tests of
// that growth). Returns 0, 1 out of memory.
int ostr_reserve(void* work, int cap);

// The work's staging arrays for ostd_stepValues (row capacity nrow_max): the rows at q+ (ostRow
// of the double build), their Jacobian (nrow_max x nv), the multipliers matched onto them and
// the actuators' lengths at q+ (nu).
void ostr_staging(void* work, void** rows, double** J, double** lam, double** length);

// out (2 nv + na + nu) = w' dR/dxi + gact' dact+/dxi for xi = (dq-, u-, act-, ctrl) with q+ and
// y = (u+, lambda) held: the columns of those inputs in ostd_stepJacobian's G (without the chain
// rule through q+), times wy (nv + nrow) on R and gact (na) on act+. The nrow rows at q+ staged
// (ostr_staging); X (nrow x nv) and diag0 (nrow): x_i = Mt^-1 J_i' and J_i Mt^-1 J_i' at the
// values (ostd_stepValues). Returns 0, 1 out of memory, 2 if nrow exceeds the capacity.
int ostr_startVjp(void* work, const ostdStep* st, int nrow, const double* X, const double* diag0,
                  const double* wy, const double* gact, double* out);

#ifdef __cplusplus
}
#endif

#endif  // OSTRICH_PLUGIN_OST_ADJOINT_REV_H_
