// test_core_nvcc.cu: every core/ header compiles under nvcc, and the per-world functions are
// callable from a kernel (host+device inline): the solver, and the native geometry provider
// (kinematics, dynamics, collision of every pair type, rows). Compiled, not run, in CI.
#include "ost_collision.h"
#include "ost_collision_ball.h"
#include "ost_collision_box.h"
#include "ost_collision_boxbox.h"
#include "ost_collision_convex.h"
#include "ost_collision_ellipsoid.h"
#include "ost_collision_epa.h"
#include "ost_collision_gjk.h"
#include "ost_collision_mpr.h"
#include "ost_collision_primitive.h"
#include "ost_collision_terrain.h"
#include "ost_constraint.h"
#include "ost_geom.h"
#include "ost_hd.h"
#include "ost_kinematics.h"
#include "ost_model.h"
#include "ost_rows_native.h"
#include "ost_solver.h"
#include "ost_util_dense.h"
#include "ost_batch.h"
#include "ost_math.h"
#include "ost_step.h"

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


__global__ void ost_nativeCompile_kernel(ostModel m, ostKin* kin, ostWorld* worlds,
                                         const ostNum* qpos, const ostNum* qvel,
                                         const ostNum* ctrl, int nworld, int* status) {
  int w = blockIdx.x * blockDim.x + threadIdx.x;
  if (w >= nworld) {
    return;  // guard first
  }
  osti_nativeStart(&m, kin + w, worlds + w, qpos, qvel, ctrl, NULL, NULL, 0.01);
  status[w] = osti_nativeIterate(&m, kin + w, worlds + w, qpos, ctrl, 0.01, 0.01);
  osti_passive(&m, kin + w, qpos, qvel);
}


// EPA's penetration of geom pairs (2i, 2i+1): its depth, or -1 where it returns 0
__global__ void ost_epaCompile_kernel(const ostGeom* g, ostNum* depth, int npair) {
  int i = blockIdx.x * blockDim.x + threadIdx.x;
  if (i >= npair) {
    return;  // guard first
  }
  ostNum d, n[3], a[3], b[3];
  depth[i] = osti_epaPenetration(g + 2*i, g + 2*i + 1, &d, n, a, b, NULL) ? d : -1;
}
