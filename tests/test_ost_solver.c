// test_ost_solver.c: the per-world Newton step on hand-made problems with closed-form answers:
// PCR solves the Schur system exactly, a point mass lands on a hard floor, a velocity servo.
#include "ost_solver.h"

#include <math.h>
#include <stdlib.h>

#include "fixture.h"

static ostSolverOptions options(void) {
  ostSolverOptions o = {16, 50, 1, 0, 1e-12, 1e-14, 1e-12, 0};
  return o;
}

static void* makeWorld(ostWorld* w, int nv, int nrow_max, double h) {
  void* buf = aligned_alloc(64, ostu_worldSize(nv, nrow_max));
  ostu_worldInit(w, buf, nv, nrow_max, h);
  return buf;
}

// 1-dof mass m falling onto a floor 1 cm below with speed v: backward Euler with a hard
// contact gives u+ = gap / h (it lands exactly) and lambda = m (u+ - u-) / h + m g
START_TEST(test_landing) {
  ostWorld w;
  void* buf = makeWorld(&w, 1, 1, 0.1);
  ostSolverOptions o = options();
  double m = 2, g = 9.81, gap = 0.01, v = -1, h = 0.1;
  w.M[0] = m;
  ck_assert_int_eq(osti_factorMass(&w), 0);
  w.qvel_prev[0] = v;
  w.qfrc_explicit[0] = -m * g;
  w.qvel[0] = v;
  w.nrow = 1;
  w.rows[0] = (ostRow){0};
  w.rows[0].type = OST_ROW_CONTACT;
  w.rows[0].normal = -1;
  w.J[0] = 1;
  w.lambda[0] = 0;
  double merit = 1;
  for (int k = 0; k < 20 && merit > 1e-12; k++) {
    // the gap at q+ = q- + h u is linear in u: the geometry provider of this problem
    w.rows[0].pos = gap + h * w.qvel[0];
    merit = sqrt(osti_evaluate(&w, &o));
    if (merit > 1e-12) osti_newtonUpdate(&w, &o);
  }
  ck_assert_double_lt(merit, 1e-10);
  ck_assert_double_eq_tol(w.qvel[0], -gap / h, 1e-9);
  ck_assert_double_eq_tol(w.lambda[0], m * (-gap / h - v) / h + m * g, 1e-6);
  free(buf);
}
END_TEST

// velocity servo: force = kv (ubar - u+), so u+ = (m u- + h (f + kv ubar)) / (m + h kv)
START_TEST(test_velocityServo) {
  ostWorld w;
  void* buf = makeWorld(&w, 1, 1, 0.05);
  ostSolverOptions o = options();
  double m = 3, kv = 1e4, ubar = 2, f = -5, h = 0.05;
  w.M[0] = m;
  osti_factorMass(&w);
  w.qvel_prev[0] = 0.5;
  w.qvel[0] = 0.5;
  w.qfrc_explicit[0] = f;
  w.nrow = 1;
  w.rows[0] = (ostRow){0};
  w.rows[0].type = OST_ROW_SERVO;
  w.rows[0].normal = -1;
  w.rows[0].pos = kv * ubar;
  w.rows[0].mu = -kv;
  w.rows[0].alpha = 1 / kv;
  w.rows[0].lo = -HUGE_VAL;
  w.rows[0].hi = HUGE_VAL;
  w.J[0] = 1;
  w.lambda[0] = 0;
  for (int k = 0; k < 3; k++) {
    osti_evaluate(&w, &o);
    osti_newtonUpdate(&w, &o);
  }
  ck_assert_double_lt(sqrt(osti_evaluate(&w, &o)), 1e-10);
  ck_assert_double_eq_tol(w.qvel[0], (m * 0.5 + h * (f + kv * ubar)) / (m + h * kv), 1e-10);
  free(buf);
}
END_TEST

// PCR on a 3-row Schur system with nv = 2 converges to the direct solution
START_TEST(test_pcr) {
  ostWorld w;
  void* buf = makeWorld(&w, 2, 3, 0.1);
  w.M[0] = 2; w.M[1] = 0.5; w.M[2] = 0.5; w.M[3] = 1;
  osti_factorMass(&w);
  w.nrow = 3;
  double J[6] = {1, 0, 0, 1, 1, -1}, c[3] = {0.1, 0.2, 0.3}, diag[3];
  for (int i = 0; i < 6; i++) w.J[i] = J[i];
  for (int i = 0; i < 3; i++) {
    w.c[i] = c[i];
    diag[i] = ostu_cholNormSqr(w.tmp + 2, w.M, J + 2 * i, 2);
    w.diag[i] = diag[i];
  }
  double b[3] = {1, -1, 0.5}, x[3], y[3];
  int it = osti_pcr(&w, x, b, 10, 1e-15);
  ck_assert_int_le(it, 4);
  osti_schurApply(&w, y, x);
  for (int i = 0; i < 3; i++) ck_assert_double_eq_tol(y[i], b[i], 1e-12);
  free(buf);
}
END_TEST

int main(void) {
  Suite* s = suite_create("ost_solver");
  TCase* tc = tcase_create("solver");
  tcase_add_test(tc, test_landing);
  tcase_add_test(tc, test_velocityServo);
  tcase_add_test(tc, test_pcr);
  suite_add_tcase(s, tc);
  return ost_fixtureRun(s);
}
