// test_ost_constraint.c: the FB function (zeros exactly on the complementarity set, derivatives
// against finite differences), the cone projection and the matching of multipliers.
#include "ost_constraint.h"

#include <math.h>

#include <stdlib.h>

#include "fixture.h"

START_TEST(test_fischerBurmeister) {
  double fa, fb;
  // zero on the complementarity set (eps -> 0), non-zero off it
  ck_assert_double_eq_tol(osti_fb(0, 3, 1e-12, &fa, &fb), 0, 1e-12);
  ck_assert_double_eq_tol(osti_fb(2, 0, 1e-12, &fa, &fb), 0, 1e-12);
  // phi(a, b) = a + b - sqrt(a^2 + b^2): phi(-1, 2) = 1 - sqrt(5) = -1.24 and
  // phi(1, 1) = 2 - sqrt(2) = 0.59
  ck_assert_double_lt(osti_fb(-1, 2, 1e-12, &fa, &fb), -0.9);
  ck_assert_double_lt(osti_fb(1, 1, 1e-12, &fa, &fb), 0.6);
  ck_assert_double_gt(osti_fb(1, 1, 1e-12, &fa, &fb), 0.5);
  // derivatives against central differences
  double a = 0.3, b = -0.7, e = 1e-6, d1, d2;
  osti_fb(a, b, 1e-9, &fa, &fb);
  double fda = (osti_fb(a + e, b, 1e-9, &d1, &d2) - osti_fb(a - e, b, 1e-9, &d1, &d2)) / (2 * e);
  double fdb = (osti_fb(a, b + e, 1e-9, &d1, &d2) - osti_fb(a, b - e, 1e-9, &d1, &d2)) / (2 * e);
  // central differences with e = 1e-6: O(e^2) truncation plus 1e-16 / e round-off
  ck_assert_double_eq_tol(fa, fda, 1e-8);
  ck_assert_double_eq_tol(fb, fdb, 1e-8);
}
END_TEST

static ostRow contactRow(int g1, int g2, double x, double mu) {
  ostRow r = {0};
  r.type = OST_ROW_CONTACT;
  r.obj[0] = g1;
  r.obj[1] = g2;
  r.normal = -1;
  r.key[0] = x;
  r.mu = mu;
  return r;
}

START_TEST(test_projection) {
  ostRow rows[4];
  rows[0] = contactRow(0, 1, 0, 0.5);
  rows[1] = rows[0]; rows[1].type = OST_ROW_FRICTION; rows[1].normal = 0;
  rows[2] = rows[1];
  rows[3] = (ostRow){0};
  rows[3].type = OST_ROW_SERVO; rows[3].lo = -1; rows[3].hi = 2;
  double lam[4] = {2, 3, 4, 5};
  osti_projectRows(lam, rows, 4);
  // friction clamped onto the cone |lambda_f| = mu lambda_n = 1, direction kept
  ck_assert_double_eq_tol(hypot(lam[1], lam[2]), 1, 1e-14);
  ck_assert_double_eq_tol(lam[2] / lam[1], 4.0 / 3.0, 1e-14);
  ck_assert_double_eq(lam[3], 2);
  double neg[4] = {-1, 1, 1, -3};
  osti_projectRows(neg, rows, 4);
  ck_assert_double_eq(neg[0], 0);
  ck_assert_double_eq(neg[1], 0);
  ck_assert_double_eq(neg[3], -1);
}
END_TEST

START_TEST(test_matching) {
  // previous: two contacts of pair (0,1) at x = 0 and x = 1, each with friction
  ostRow prev[6], rows[6];
  for (int c = 0; c < 2; c++) {
    prev[3 * c] = contactRow(0, 1, c, 1);
    prev[3 * c + 1] = prev[3 * c]; prev[3 * c + 1].type = OST_ROW_FRICTION;
    prev[3 * c + 1].normal = 3 * c;
    prev[3 * c + 2] = prev[3 * c + 1];
  }
  double plam[6] = {10, 1, 2, 20, 3, 4};
  // new: the same contacts in reverse order, slightly moved
  for (int c = 0; c < 2; c++) {
    rows[3 * c] = contactRow(0, 1, 1 - c + 0.01, 1);
    rows[3 * c + 1] = rows[3 * c]; rows[3 * c + 1].type = OST_ROW_FRICTION;
    rows[3 * c + 1].normal = 3 * c;
    rows[3 * c + 2] = rows[3 * c + 1];
  }
  double lam[6];
  unsigned char used[6];
  osti_matchRows(lam, rows, 6, plam, prev, 6, used);
  ck_assert_double_eq(lam[0], 20);
  ck_assert_double_eq(lam[1], 3);
  ck_assert_double_eq(lam[2], 4);
  ck_assert_double_eq(lam[3], 10);
  ck_assert_double_eq(lam[5], 2);
}
END_TEST

// the sorted matching gives osti_matchRows' result, bit for bit, on random row lists: several
// contacts per geom pair (friction or not), limits and equalities, repeated keys (ties), rows
// that appear and vanish; half of the lists are long enough to be sorted (more than
// OST_MATCH_SORT_MIN previous rows), the others take the direct search
START_TEST(test_matchingSorted) {
  enum { N = 100 };
  int sorted = 0;
  unsigned seed = 3;
  ostRow prev[N], rows[N];
  double plam[N], lam1[N], lam2[N];
  unsigned char used[N];
  int order[2 * N];
  for (int trial = 0; trial < 300; trial++) {
    int lists[2] = {0, 0};
    ostRow* dst[2] = {prev, rows};
    for (int l = 0; l < 2; l++) {
      while (lists[l] < N - 3) {
        int kind = rand_r(&seed) % 4, n = lists[l];
        ostRow r = contactRow(rand_r(&seed) % 3, 3 + rand_r(&seed) % 2, (rand_r(&seed) % 5) * 0.5, 1);
        if (kind == 0) {
          r.type = OST_ROW_LIMIT;
        } else if (kind == 1) {
          r.type = OST_ROW_EQUALITY;
        }
        dst[l][n] = r;
        int fric = r.type == OST_ROW_CONTACT && rand_r(&seed) % 2;
        for (int f = 1; f <= 2 * fric; f++) {
          dst[l][n + f] = r;
          dst[l][n + f].type = OST_ROW_FRICTION;
          dst[l][n + f].normal = n;
        }
        lists[l] += 1 + 2 * fric;
        if (trial % 2 && rand_r(&seed) % 8 == 0) break;
      }
    }
    sorted += lists[0] > OST_MATCH_SORT_MIN;
    for (int j = 0; j < lists[0]; j++) plam[j] = j + 1;
    osti_matchRows(lam1, rows, lists[1], plam, prev, lists[0], used);
    osti_matchRowsSorted(lam2, rows, lists[1], plam, prev, lists[0], used, order);
    for (int i = 0; i < lists[1]; i++) {
      ck_assert_msg(lam1[i] == lam2[i], "trial %d row %d: %g vs %g", trial, i, lam1[i], lam2[i]);
    }
  }
  ck_assert_int_ge(sorted, 150);
}
END_TEST

int main(void) {
  Suite* s = suite_create("ost_constraint");
  TCase* tc = tcase_create("constraint");
  tcase_add_test(tc, test_fischerBurmeister);
  tcase_add_test(tc, test_projection);
  tcase_add_test(tc, test_matching);
  tcase_add_test(tc, test_matchingSorted);
  suite_add_tcase(s, tc);
  return ost_fixtureRun(s);
}
