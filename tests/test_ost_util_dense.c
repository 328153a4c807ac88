// test_ost_util_dense.c: dense Cholesky factor/solve and products against hand-made answers.
#include "ost_util_dense.h"

#include "fixture.h"

START_TEST(test_cholesky) {
  // A = B B' + I with known B; solve A x = b and check A x - b
  double A[9] = {4, 2, 0.6, 2, 5, 1.5, 0.6, 1.5, 3}, L[9], x[3], b[3] = {1, -2, 0.5}, y[3];
  for (int i = 0; i < 9; i++) L[i] = A[i];
  ck_assert_int_eq(ostu_cholFactor(L, 3), 0);
  ostu_cholSolve(x, L, b, 3);
  ostu_mulMatVec(y, A, x, 3, 3);
  for (int i = 0; i < 3; i++) ck_assert_double_eq_tol(y[i], b[i], 1e-14);
  // b' A^-1 b equals the squared norm of L^-1 b
  ck_assert_double_eq_tol(ostu_cholNormSqr(y, L, b, 3), ostu_dot(b, x, 3), 1e-14);
  // an indefinite matrix is reported with its failing column
  double N[4] = {1, 2, 2, 1};
  ck_assert_int_eq(ostu_cholFactor(N, 2), 2);
}
END_TEST

START_TEST(test_products) {
  double A[6] = {1, 2, 3, 4, 5, 6}, x[3] = {1, 0, -1}, v[2] = {1, 1}, r[3];
  ostu_mulMatVec(r, A, x, 2, 3);
  ck_assert_double_eq(r[0], -2);
  ck_assert_double_eq(r[1], -2);
  ostu_mulMatTVec(r, A, v, 2, 3);
  ck_assert_double_eq(r[0], 5);
  ck_assert_double_eq(r[2], 9);
}
END_TEST

int main(void) {
  Suite* s = suite_create("ost_util_dense");
  TCase* tc = tcase_create("dense");
  tcase_add_test(tc, test_cholesky);
  tcase_add_test(tc, test_products);
  suite_add_tcase(s, tc);
  return ost_fixtureRun(s);
}
