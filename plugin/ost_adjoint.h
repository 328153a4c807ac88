// ost_adjoint.h: the internal seam between the adjoint's host code (ost_adjoint.c, C) and the
// dual-number evaluation of a step's residual (ost_adjoint_dual.cc, C++). Plain C types only,
// so that it can be included where ostNum is double and where it is a dual number.
// Invariant: the dual side reads the packed model and the inputs, and writes only its own work
// block and the caller's output matrix.
#ifndef OSTRICH_PLUGIN_OST_ADJOINT_H_
#define OSTRICH_PLUGIN_OST_ADJOINT_H_

#include <stddef.h>

#ifdef __cplusplus
extern "C" {
#endif

typedef struct ostdStep_ {        // one committed (sub)step, as the backward pass needs it
  const void*   model;            // the packed ostModel (double) the step is evaluated with
  const double* qpos_prev;        // q-                                                 (nq)
  const double* qvel_prev;        // u-                                                 (nv)
  const double* qvel;             // u+, the step's solution                            (nv)
  const double* ctrl;             // controls                                           (nu)
  const double* qfrc_applied;     // applied generalized forces (NULL: none)            (nv)
  const double* xfrc_applied;     // applied body wrenches (NULL: none)          (nbody x 6)
  const void*   rows;             // the solution's rows (ostRow, double)             (nrow)
  const double* lambda;           // the solution's multipliers                       (nrow)
  int           nrow;             // rows of the solution
  int           truncate;         // 1: contact geometry held fixed within the step
  double        h;                // step size (s)
  double        lookahead;        // Ostrich's look-ahead distance (m)
  double        reg;              // relative compliance (ostOptions.regularization)
  double        creep;            // sticking creep (ostOptions.friction_creep, s/kg)
  double        fb_eps;           // Fischer-Burmeister smoothing
  int           nparam;           // parameter columns (0: none)
  const int*    param_adr;        // offsets of the ostParam groups in theta (OST_NPARAM + 1)
  const int*    pair_fric_geom;   // per candidate pair: the geoms whose friction it takes
                                  // (-1: none), so dmu/dtheta                  (npair x 2)
  const double* pair_fric_weight; // their weights (1, or 1/2 each at a tie)     (npair x 2)
} ostdStep;

// Work block of the dual evaluation for a packed model with row capacity nrow_max (NULL if
// allocation fails).
void* ostd_workCreate(const void* model, int nrow_max);

// Release a work block (NULL is ignored).
void ostd_workFree(void* work);

// Exact Jacobian of the step's residual and outputs by forward-mode dual numbers. The native
// rows at q+ are recomputed and the recorded multipliers matched onto them (by object and
// contact key); n = nv + their count. G ((n + 2 nv) x ncol, row-major, ncol = n + 2 nv + nu +
// nparam) receives the rows R (n) then O = (dq+, u+) (2 nv), differentiated by the columns
// y = (u, lambda) (n) then xi = (dq-, u-, ctrl, theta). *resid gets |R| at the solution.
// Returns 0, 1 if G needs more than G_cap doubles (*n still set), 2 if the rows overflow.
int ostd_stepJacobian(void* work, const ostdStep* s, double* G, size_t G_cap, int* n,
                      double* resid);

#ifdef __cplusplus
}
#endif

#endif  // OSTRICH_PLUGIN_OST_ADJOINT_H_
