// test_core_nvcc.cu: every core/ header compiles under nvcc, and the per-world functions are
// callable from a kernel (host+device inline). Compiled, not run, in CI.
#include "ost_constraint.h"
#include "ost_hd.h"
#include "ost_solver.h"
#include "ost_util_dense.h"

__global__ void ost_coreCompile_kernel(ostWorld* worlds, const ostSolverOptions* opt, int nworld,
                                       ostNum* merit) {
  int w = blockIdx.x * blockDim.x + threadIdx.x;
  if (w >= nworld) {
    return;  // guard first
  }
  osti_factorMass(worlds + w);
  merit[w] = osti_evaluate(worlds + w, opt);
  osti_newtonUpdate(worlds + w, opt);
  osti_newtonDirection(worlds + w, opt);
  osti_trial(worlds + w, 0.5);
  osti_matchPrevious(worlds + w);
}
