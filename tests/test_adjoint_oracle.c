// test_adjoint_oracle.c: the adjoint's split column passes (core/ost_adjoint_jacobian.h,
// ostx_jacColumnsSplit: each input through the part of the step it moves, q+ by the chain rule)
// against the dense dual Jacobian that evaluates every column through the whole step (the
// oracle, ostContext.adj_oracle = 1). Both differentiate the same function exactly, so they
// agree to rounding, while a dropped or doubled path is O(1) relative. Per step of a rollout:
// the step Jacobians themselves (ost_adjointOracleDiff), the vector-Jacobian product
// (ost_adjoint) with random cotangents, complete and truncated, with parameters; and the
// transition Jacobians (ost_transition).
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "fixture.h"
#include "ost_adjoint_dual.h"
#include "ost_adjoint_rev.h"
#include "ost_internal.h"

// TOL_JAC: per column, relative to its largest entry. The split passes sum the same derivatives
// in another order (the chain rule through q+) and take the rows' diagonal J_i Mt^-1 J_i' by the
// closed form (15b) where the oracle differentiates Mt's factor: both are sums of terms of the
// size of the diagonal times |dMt| / |Mt| or |dJ| / |J| that can cancel to 1e-6 of it (a dof that
// barely changes a contact's effective mass), so either carries rounding of 1e-16 / 1e-6 =
// 1e-10 of such a column (measured 2.1e-10 at most; a wrong term is of order 1).
// TOL: the gradients solve K' w = .. with either Jacobian, and K's condition number amplifies
// that rounding (stiff kv = 300 servos and wheel contacts at h = 0.1 s): measured 1.7e-9 on the
// pallet, 4e-10 or less on the other scenes.
#define TOL_JAC 1e-9
// TOL_REV: the default backward pass takes w' dR/dxi of the start's inputs by one reverse sweep,
// the forward_only one by their columns: the same products summed in another order, so the
// gradients differ by the rounding of the implicit-function solve that both share (TOL's
// conditioning), far below TOL; a wrong partial derivative is of order 1.
#define TOL_REV 1e-10
#define TOL 1e-8

static double uniform(unsigned* s) {
  *s = *s * 1103515245u + 12345u;
  return ((*s >> 8) & 0xffff) / 65536.0 * 2 - 1;
}


// max |a - b| / max(max |b|, floor) over n entries
static double relDiff(const mjtNum* a, const mjtNum* b, int n, double floor) {
  double e = 0, s = floor;
  for (int i = 0; i < n; i++) {
    e = fmax(e, fabs(a[i] - b[i]));
    s = fmax(s, fabs(b[i]));
  }
  return e / s;
}


// the largest relative difference of two VJPs over the groups (dq-, du-, ctrl, theta)
static double groupsDiff(const mjtNum* a, const mjtNum* b, int nv, int nu, int np) {
  double e[4] = {relDiff(a, b, nv, 1e-300), relDiff(a + nv, b + nv, nv, 1e-300),
                 relDiff(a + 2 * nv, b + 2 * nv, nu, 1e-300),
                 relDiff(a + 2 * nv + nu, b + 2 * nv + nu, np, 1e-300)};
  return fmax(fmax(e[0], e[1]), fmax(e[2], e[3]));
}


// one VJP of the last step with the split passes and with the oracle; returns the largest
// relative difference over the groups between the default (the start's inputs by a reverse
// sweep) and the oracle, *rev the one between the default and the forward passes alone
static double vjpDiff(const mjModel* m, mjData* d, int truncate, const mjtNum* gq,
                      const mjtNum* gu, double* rev) {
  ostContext* c = ost_context(m, d);
  int nv = m->nv, nu = m->nu, np = ost_nparam(m);
  size_t n = 2 * (size_t)nv + nu + np;
  mjtNum* out = (mjtNum*)calloc(5 * n, sizeof(mjtNum));
  ostGradOptions go = {truncate, 1, 0};
  c->adj_reverse_all = 1;  // the reverse sweep on the small models too
  // 0: the split passes and the reverse sweep (the default), 1: the dense oracle, 2: the split
  // passes shared by 3 threads (run one after another), 3: the split passes alone
  // (forward_only), which must give the bits of 2; 4: 0 again from a reverse tape of 16 nodes,
  // which must grow to the step's and give the bits of 0
  for (int k = 0; k < 5; k++) {
    mjtNum* o = out + k * n;
    c->adj_oracle = k < 3 ? k : 0;
    go.forward_only = k == 3;
    if (k == 4) {
      ck_assert_int_eq(ostr_reserve(c->adj_rev, 16), 0);
    }
    int status = ost_adjoint(m, d, &go, gq, gu, o, o + nv, o + 2 * nv, o + 2 * nv + nu);
    ck_assert_msg(status == OST_OK, "ost_adjoint (variant %d): %s", k, ost_lastError(d));
  }
  c->adj_oracle = 0;
  c->adj_reverse_all = 0;
  ck_assert_msg(!memcmp(out + 3 * n, out + 2 * n, n * sizeof(mjtNum)),
                "the split passes give other bits when 3 threads share them");
  ck_assert_msg(!memcmp(out + 4 * n, out, n * sizeof(mjtNum)),
                "the reverse sweep gives other bits after its tape grew");
  *rev = groupsDiff(out, out + 3 * n, nv, nu, np);
  double e = groupsDiff(out, out + n, nv, nu, np);
  free(out);
  return e;
}


// transition Jacobians A, B from d's state, split against oracle; a first call leaves the
// context as ost_transition does (cold), so that both differentiate the same solution
static double transitionDiff(const mjModel* m, mjData* d) {
  ostContext* c = ost_context(m, d);
  int nx = 2 * m->nv + m->na, nu = m->nu;
  size_t n = (size_t)nx * (nx + nu);
  mjtNum* J = (mjtNum*)calloc(2 * n, sizeof(mjtNum));
  ck_assert_int_eq(ost_transition(m, d, J, NULL), OST_OK);
  for (int oracle = 0; oracle < 2; oracle++) {
    c->adj_oracle = oracle;
    int status = ost_transition(m, d, J + oracle * n, J + oracle * n + (size_t)nx * nx);
    ck_assert_msg(status == OST_OK, "ost_transition (oracle %d): %s", oracle, ost_lastError(d));
  }
  c->adj_oracle = 0;
  double e = fmax(relDiff(J, J + n, nx * nx, 1e-300),
                  relDiff(J + (size_t)nx * nx, J + n + (size_t)nx * nx, nx * nu, 1e-300));
  free(J);
  return e;
}


// a rollout of nstep steps at h with controls ctrl (1 + 0.2 noise) from keyframe key (-1: none),
// comparing every `every`-th step; returns the largest difference
static double rollout(const mjModel* m, double h, int nstep, int every, double ctrl, int key,
                      double* jac, double* rev_worst) {
  mjData* d = mj_makeData(m);
  if (key >= 0) {
    mj_resetDataKeyframe(m, d, key);
  }
  ostOptions opt;
  ck_assert_int_eq(ost_readOptions(m, &opt, NULL, 0), OST_OK);
  opt.timestep = h;
  opt.newton_iter = 100;
  opt.tol = 1e-11;
  opt.geometry = OST_GEOMETRY_NATIVE;
  ck_assert_int_eq(ost_setOptions(m, d, &opt), OST_OK);
  unsigned seed = 7;
  int nv = m->nv;
  mjtNum* g = (mjtNum*)malloc(2 * nv * sizeof(mjtNum));
  double worst = 0;
  int checked = 0;
  for (int k = 0; k < nstep; k++) {
    for (int i = 0; i < m->nu; i++) d->ctrl[i] = ctrl * (1 + 0.2 * uniform(&seed));
    if (k % every == every - 1) {
      double e = transitionDiff(m, d);
      worst = fmax(worst, e);
    }
    int status = ost_step(m, d);
    ck_assert_msg(status == OST_OK, "step %d: status %d %s", k, status, ost_lastError(d));
    if (k % every == every - 1) {
      for (int i = 0; i < 2 * nv; i++) g[i] = uniform(&seed);
      for (int truncate = 0; truncate < 2; truncate++) {
        double e;
        ck_assert_int_eq(ost_adjointOracleDiff(m, d, truncate, 1, &e), OST_OK);
        *jac = fmax(*jac, e);
        double rev;
        worst = fmax(worst, vjpDiff(m, d, truncate, g, g + nv, &rev));
        *rev_worst = fmax(*rev_worst, rev);
      }
      checked++;
    }
  }
  ck_assert_int_gt(checked, 0);
  free(g);
  ost_deleteData(d);
  return worst;
}


static void check(const char* name, mjModel* m, double h, int nstep, int every, double ctrl,
                  int key) {
  double jac = 0, rev = 0;
  double e = rollout(m, h, nstep, every, ctrl, key, &jac, &rev);
  printf("%-32s split vs oracle: Jacobian %.1e, gradients %.1e; reverse vs forward %.1e\n",
         name, jac, e, rev);
  ck_assert_msg(rev <= TOL_REV, "%s: the reverse sweep's gradients differ from the forward "
                "passes' by %.3g", name, rev);
  ck_assert_msg(jac <= TOL_JAC, "%s: the split Jacobian differs from the oracle's by %.3g", name,
                jac);
  ck_assert_msg(e <= TOL, "%s: split gradients differ from the oracle's by %.3g", name, e);
  mj_deleteModel(m);
}


START_TEST(test_robot) {
  ost_fixtureSetup();
  check("robot_box (h 0.1)", ost_fixtureLoadModel("robot_box.xml"), 0.1, 30, 3, 4, -1);
  check("robot_pallet (h 0.1)", ost_fixtureLoadModel("robot_pallet.xml"), 0.1, 30, 3, 4, -1);
}
END_TEST


START_TEST(test_terrainStack) {
  ost_fixtureSetup();
  check("terrain_mesh (h 0.05)", ost_fixtureLoadModel("terrain_mesh.xml"), 0.05, 20, 4, 3, -1);
  check("stack_heavy_light (h 0.01)", ost_fixtureLoadModel("stack_heavy_light.xml"), 0.01, 40, 8,
        0, -1);
}
END_TEST


START_TEST(test_humanoid) {
  ost_fixtureSetup();
  char err[512];
  mjModel* m = mj_loadXML(OST_HUMANOID, NULL, err, sizeof(err));
  ck_assert_msg(m != NULL, "%s: %s", OST_HUMANOID, err);
  check("humanoid (h 0.01)", m, 0.01, 60, 12, 0.3, -1);
}
END_TEST


// every row kind the split passes treat apart: dry friction, condim 4 and 6 (friction_rows);
// joint limits, springs, damping, servo rows with filter and integrator activations (inline)
START_TEST(test_rowKinds) {
  ost_fixtureSetup();
  char path[1024];
  snprintf(path, sizeof(path), "%s/../tests/models/friction_rows.xml", OST_MODEL_DIR);
  char err[512];
  mjModel* m = mj_loadXML(path, NULL, err, sizeof(err));
  ck_assert_msg(m != NULL, "%s", err);
  check("friction_rows (h 0.01)", m, 0.01, 30, 5, 0.8, 0);
  const char* xml =
    "<mujoco><option timestep='0.02'/><worldbody>"
    "<geom type='plane' size='2 2 .1'/>"
    "<body pos='0 0 1'><joint name='a' type='hinge' axis='0 1 0' limited='true' range='-20 30'"
    " stiffness='40' damping='0.5'/>"
    "<geom type='capsule' fromto='0 0 0 0.4 0 0' size='0.04' mass='1'/>"
    "<body pos='0.4 0 0'><joint name='b' type='hinge' axis='0 1 0' frictionloss='0.2'/>"
    "<geom type='capsule' fromto='0 0 0 0 0 -0.9' size='0.05' mass='0.7'/></body></body>"
    "</worldbody><actuator>"
    "<velocity joint='b' kv='5'/>"
    "<general joint='a' gaintype='fixed' gainprm='300' biastype='affine' biasprm='0 -300 0'"
    " dyntype='filter' dynprm='0.05'/>"
    "<general joint='b' gaintype='fixed' gainprm='2' dyntype='integrator' biastype='affine'"
    " biasprm='0 0 -0.5' actlimited='true' actrange='-1 1'/>"
    "</actuator></mujoco>";
  check("arm: limits, servo, activation", ost_fixtureLoadString(xml), 0.02, 40, 5, 0.6, -1);
}
END_TEST


// the dual passes' width: steps run 2 directions per pass (ost_adjoint_dual.cc), which must give
// the same bits as 8 (ost_adjoint_dual8.cc; each direction is computed on its own): ost_adjoint
// with parameters on the cart-pole, the arm and the robot over the box (contacts), each way
START_TEST(test_chunkWidths) {
  ost_fixtureSetup();
  const char* names[] = {"cartpole.xml", "arm_position_servo.xml", "robot_box.xml"};
  for (int q = 0; q < 3; q++) {
    mjModel* m = ost_fixtureLoadModel(names[q]);
    mjData* d = mj_makeData(m);
    ostOptions opt;
    ck_assert_int_eq(ost_readOptions(m, &opt, NULL, 0), OST_OK);
    opt.geometry = OST_GEOMETRY_NATIVE;
    ck_assert_int_eq(ost_setOptions(m, d, &opt), OST_OK);
    int nv = m->nv, nu = m->nu, nx = 2 * nv + m->na, np = ost_nparam(m);
    size_t n = 2 * (size_t)nv + nu + np + (size_t)nx * (nx + nu);
    double* out[2] = {(double*)calloc(n, sizeof(double)), (double*)calloc(n, sizeof(double))};
    double g[64];
    for (int i = 0; i < 2 * nv; i++) g[i] = sin(1.0 + i);
    for (int k = 0; k < 20; k++) {
      for (int i = 0; i < nu; i++) d->ctrl[i] = 0.5 * sin(0.3 * k + i);
      ck_assert_int_eq(ost_step(m, d), OST_OK);
      if (k % 5 != 4) continue;
      ostContext* c = ost_context(m, d);
      for (int w = 0; w < 2; w++) {
        double* o = out[w];
        memset(o, 0, n * sizeof(double));
        ostGradOptions go = {0, 1, 0};
        ck_assert_int_eq(ost_adjoint(m, d, &go, g, g + nv, o, o + nv, o + 2 * nv, o + 2 * nv + nu),
                         OST_OK);
        // next: the same with a work of 8 directions in place of the model's own (2)
        if (w == 0) {
          ck_assert_int_eq(*(int*)c->adj_work, 2);
          ostd_workFree(c->adj_work);
          c->adj_work = ostd8_workCreate(&c->native, c->world.nrow_max);
          ck_assert_int_eq(*(int*)c->adj_work, 8);
        }
      }
      ck_assert_msg(!memcmp(out[0], out[1], (2 * (size_t)nv + nu + np) * sizeof(double)),
                    "%s step %d: gradients differ between 2 and 8 directions per pass",
                    names[q], k);
      ostd_workFree(c->adj_work);  // the model's own again at the next use
      c->adj_work = ostd_workCreate(&c->native, c->world.nrow_max);
    }
    printf("%-28s 2 and 8 directions per pass: the same bits\n", names[q]);
    free(out[0]);
    free(out[1]);
    ost_deleteData(d);
    mj_deleteModel(m);
  }
}
END_TEST


int main(void) {
  Suite* s = suite_create("adjoint_oracle");
  TCase* tc = tcase_create("split");
  tcase_add_test(tc, test_robot);
  tcase_add_test(tc, test_terrainStack);
  tcase_add_test(tc, test_humanoid);
  tcase_add_test(tc, test_rowKinds);
  tcase_add_test(tc, test_chunkWidths);
  suite_add_tcase(s, tc);
  return ost_fixtureRun(s);
}
