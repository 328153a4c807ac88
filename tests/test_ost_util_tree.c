// test_ost_util_tree.c: the tree-sparse L'DL factor of a mass matrix against the dense Cholesky,
// on random trees (chains, stars, free-joint-like branches) and on MuJoCo's own mass matrix.
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "ost_util_tree.h"

#include "fixture.h"

// a random tree of n dofs: parent[k] < k or -1
static void randomTree(int* parent, int n, unsigned* seed) {
  for (int k = 0; k < n; k++) {
    int r = rand_r(seed) % (k + 2);  // k + 1 choices of parent, one of them "root"
    parent[k] = r <= k - 1 ? r : -1;
    if (k > 0 && rand_r(seed) % 3 == 0) parent[k] = k - 1;  // long chains too
  }
}


static double urand(unsigned* seed) {
  return rand_r(seed) / (double)RAND_MAX;
}


// M = L' D L with random unit lower L on the tree's pattern and D in [0.1, 1.1]: symmetric,
// positive definite and non-zero only between a dof and its ancestors
static void randomTreeMatrix(double* M, double* Lg, double* Dg, const int* parent, int n,
                             unsigned* seed) {
  memset(Lg, 0, sizeof(double) * n * n);
  for (int k = 0; k < n; k++) {
    Lg[k * n + k] = 1;
    Dg[k] = 0.1 + urand(seed);
    for (int j = parent[k]; j >= 0; j = parent[j]) Lg[k * n + j] = 2 * urand(seed) - 1;
  }
  for (int i = 0; i < n; i++) {
    for (int j = 0; j < n; j++) {
      double s = 0;
      for (int k = 0; k < n; k++) s += Lg[k * n + i] * Dg[k] * Lg[k * n + j];
      M[i * n + j] = s;
    }
  }
}


// 200 random trees up to 40 dofs: the factor recovers L and D, the solve and b' M^-1 b equal the
// dense Cholesky's to rounding (1e-10 relative: the matrices' condition numbers stay below 1e5)
START_TEST(test_randomTrees) {
  unsigned seed = 12345;
  enum { NMAX = 40 };
  static double M[NMAX * NMAX], F[NMAX * NMAX], C[NMAX * NMAX], Lg[NMAX * NMAX];
  double Dg[NMAX], b[NMAX], x[NMAX], y[NMAX], z[NMAX];
  int parent[NMAX];
  for (int trial = 0; trial < 200; trial++) {
    int n = 1 + trial % NMAX;
    randomTree(parent, n, &seed);
    randomTreeMatrix(M, Lg, Dg, parent, n, &seed);
    memcpy(F, M, sizeof(double) * n * n);
    memcpy(C, M, sizeof(double) * n * n);
    ck_assert_int_eq(ostu_treeFactor(F, parent, n), 0);
    ck_assert_int_eq(ostu_cholFactor(C, n), 0);
    for (int k = 0; k < n; k++) {
      ck_assert_double_eq_tol(F[k * n + k], Dg[k], 1e-10 * Dg[k]);
      for (int j = parent[k]; j >= 0; j = parent[j]) {
        ck_assert_double_eq_tol(F[k * n + j], Lg[k * n + j], 1e-9);
      }
    }
    for (int i = 0; i < n; i++) b[i] = 2 * urand(&seed) - 1;
    ostu_treeSolve(x, F, parent, b, n);
    ostu_cholSolve(z, C, b, n);
    double xn = 0;
    for (int i = 0; i < n; i++) xn = fmax(xn, fabs(z[i]));
    for (int i = 0; i < n; i++) ck_assert_double_eq_tol(x[i], z[i], 1e-10 * xn);
    // in place (x and b alias)
    memcpy(y, b, sizeof(double) * n);
    ostu_treeSolve(y, F, parent, y, n);
    for (int i = 0; i < n; i++) ck_assert_double_eq(y[i], x[i]);
    double q = ostu_treeNormSqr(y, F, parent, b, n), qd = ostu_cholNormSqr(y, C, b, n);
    ck_assert_double_eq_tol(q, qd, 1e-10 * qd);
  }
}
END_TEST


// an indefinite tree matrix is reported with a failing dof, as the dense factor reports one
START_TEST(test_indefinite) {
  int parent[3] = {-1, 0, 1};
  double M[9] = {1, 2, 0, 2, 1, 0, 0, 0, 1};
  ck_assert_int_gt(ostu_treeFactor(M, parent, 3), 0);
}
END_TEST


// a free body with a ball-jointed branch and a hinge chain (16 dofs): the factor of MuJoCo's
// own mass matrix solves M x = b to rounding
static const char* branched =
  "<mujoco><worldbody><body><freejoint/><geom size='.2'/>"
  "<body pos='.3 0 0'><joint type='ball'/><geom type='capsule' fromto='0 0 0 .3 0 0' size='.05'/>"
  "<body pos='.3 0 0'><joint axis='0 1 0'/><geom size='.05'/></body></body>"
  "<body pos='-.3 0 0'><joint axis='0 0 1'/><geom type='box' size='.1 .05 .02'/>"
  "<body pos='-.2 0 0'><joint axis='1 0 0'/><geom size='.05'/>"
  "<body pos='-.2 0 0'><joint axis='0 1 0'/><joint axis='0 0 1'/><geom size='.04'/>"
  "<body pos='-.1 0 0'><joint axis='1 0 0'/><joint axis='0 1 0'/><geom size='.03'/>"
  "</body></body></body></body></body></worldbody></mujoco>";

START_TEST(test_mujocoMassMatrix) {
  ost_fixtureSetup();
  mjModel* m = ost_fixtureLoadString(branched);
  mjData* d = mj_makeData(m);
  for (int i = 0; i < m->nq; i++) d->qpos[i] += 0.1 * sin(i);
  mj_forward(m, d);
  int n = m->nv;
  double* M = calloc(n * n, sizeof(double));
  double* F = calloc(n * n, sizeof(double));
  double *b = calloc(n, sizeof(double)), *x = calloc(n, sizeof(double));
  double* r = calloc(n, sizeof(double));
  mj_fullM(m, M, d->qM);
  memcpy(F, M, sizeof(double) * n * n);
  ck_assert_int_eq(ostu_treeFactor(F, m->dof_parentid, n), 0);
  for (int i = 0; i < n; i++) b[i] = cos(3.0 * i);
  ostu_treeSolve(x, F, m->dof_parentid, b, n);
  ostu_mulMatVec(r, M, x, n, n);
  for (int i = 0; i < n; i++) ck_assert_double_eq_tol(r[i], b[i], 1e-11);
  free(M);
  free(F);
  free(b);
  free(x);
  free(r);
  mj_deleteData(d);
  mj_deleteModel(m);
}
END_TEST


int main(void) {
  Suite* s = suite_create("ost_util_tree");
  TCase* tc = tcase_create("tree");
  tcase_add_test(tc, test_randomTrees);
  tcase_add_test(tc, test_indefinite);
  tcase_add_test(tc, test_mujocoMassMatrix);
  suite_add_tcase(s, tc);
  return ost_fixtureRun(s);
}
