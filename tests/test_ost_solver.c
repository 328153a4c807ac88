// test_ost_solver.c: the per-world Newton step on hand-made problems with closed-form answers:
// PCR solves the Schur system exactly, GMRES the non-symmetric one of sliding friction, the direct
// solve of an island equals GMRES, a point mass lands on a hard floor, a velocity servo; a
// Newton loop that diverged returns its first iterate; a row stored from its known columns equals
// the column scan.
#include "ost_solver.h"
#include "ost_step.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>

#include "fixture.h"

static ostSolverOptions options(void) {
  ostSolverOptions o = {16, 50, 1, 0, 1e-12, 1e-14, 1e-12, 0, 0};
  return o;
}

static void* makeWorld(ostWorld* w, int nv, int nrow_max, double h) {
  void* buf = aligned_alloc(64, ostu_worldSize(nv, nv, nrow_max));
  ostu_worldInit(w, buf, nv, nv, nrow_max, h);
  return buf;
}


// the world's dofs in chains of four (parent: nv entries, kept by the world), with a mass matrix
// of diagonal 1 + j and 0.3 between a dof and its parent, factored
static void chainsOfFour(ostWorld* w, int* parent) {
  int nv = w->nv;
  for (int j = 0; j < nv; j++) parent[j] = j % 4 == 0 ? -1 : j - 1;
  for (int i = 0; i < nv * nv; i++) w->M[i] = 0;
  for (int j = 0; j < nv; j++) {
    w->M[j * nv + j] = 1 + j;
    if (parent[j] >= 0) w->M[j * nv + parent[j]] = 0.3;
  }
  w->dof_parent = parent;
  ck_assert_int_eq(osti_factorMass(w), 0);
}


// store the dense rows J (n x nv) as the world's rows 0..n-1, as a geometry provider does
static void setRows(ostWorld* w, const double* J, int n) {
  for (int i = 0; i < n; i++) {
    double* row = osti_rowScratch(w, i);
    for (int j = 0; j < w->nv; j++) row[j] = J[i * w->nv + j];
    ck_assert_int_eq(osti_rowStore(w, i, 1), 0);
  }
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
  setRows(&w, (double[]){1}, 1);
  w.lambda[0] = 0;
  double merit = 1;
  for (int k = 0; k < 20 && merit > 1e-12; k++) {
    // the gap at q+ = q- + h u is linear in u: the geometry provider of this problem
    w.rows[0].pos = gap + h * w.qvel[0];
    merit = sqrt(osti_evaluate(&w, &o));
    if (merit > 1e-12) osti_newtonUpdate(&w, &o);
  }
  // the Newton loop runs to 1e-12; the landing is then exact up to rounding, and the force
  // error is the velocity error times m / h = 20
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
  setRows(&w, (double[]){1}, 1);
  w.lambda[0] = 0;
  for (int k = 0; k < 3; k++) {
    osti_evaluate(&w, &o);
    osti_newtonUpdate(&w, &o);
  }
  // a linear problem: Newton solves it to rounding
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
  setRows(&w, J, 3);
  for (int i = 0; i < 3; i++) {
    w.c[i] = c[i];
    diag[i] = ostu_cholNormSqr(w.tmp + 2, w.M, J + 2 * i, 2);
    w.diag[i] = diag[i];
  }
  double b[3] = {1, -1, 0.5}, x[3], y[3];
  int it = osti_pcr(&w, x, b, 10, 1e-15);
  // PCR on a 3 x 3 system is exact after n = 3 iterations in exact arithmetic; 4 allows rounding
  ck_assert_int_le(it, 4);
  osti_schurApply(&w, y, x);
  for (int i = 0; i < 3; i++) ck_assert_double_eq_tol(y[i], b[i], 1e-12);
  free(buf);
}
END_TEST

// GMRES solves the non-symmetric Newton system of sliding contacts (osti_newtonApply: the row
// along the slip gets -(c/h) mu in its normal column, with c ~ 1e12 k_f) to the direct solution:
// nv = 40, 45 rows (15 contacts, 5 of them sliding), enough that it restarts (OST_KRYLOV = 32)
START_TEST(test_gmresSliding) {
  enum { nv = 40, ncon = 15, n = 3 * ncon };
  ostWorld w;
  void* buf = makeWorld(&w, nv, n, 0.1);
  double h = 0.1;
  unsigned seed = 7;
  for (int i = 0; i < nv * nv; i++) w.M[i] = 0;
  for (int j = 0; j < nv; j++) w.M[j * nv + j] = 1 + j;
  w.M[1] = w.M[nv] = 0.3;
  ck_assert_int_eq(osti_factorMass(&w), 0);
  w.nrow = n;
  static double Jd[n * nv];
  for (int i = 0; i < n * nv; i++) {
    seed = seed * 1103515245u + 12345u;
    Jd[i] = (double)(seed >> 8) / (1 << 24) - 0.5;
  }
  setRows(&w, Jd, n);
  ost_fixtureContactRows(&w, ncon, h, 1);
  double b[n], x[n], y[n], A[n * n], e[n], xd[n];
  int piv[n];
  for (int i = 0; i < n; i++) b[i] = sin(1.0 + i) * (w.c[i] > 1 ? 1e12 : 1);
  int it = osti_gmres(&w, x, b, 400, 1e-14);
  ck_assert_int_gt(it, OST_KRYLOV);
  // the direct solution of the same operator
  for (int j = 0; j < n; j++) {
    for (int i = 0; i < n; i++) e[i] = i == j;
    osti_newtonApply(&w, y, e);
    for (int i = 0; i < n; i++) A[i * n + j] = y[i];
  }
  ck_assert_int_eq(ostu_luFactor(A, piv, n), 0);
  ostu_luSolve(xd, A, piv, b, n);
  double err = 0, scale = 0;
  for (int i = 0; i < n; i++) {
    err = fmax(err, fabs(x[i] - xd[i]));
    scale = fmax(scale, fabs(xd[i]));
  }
  // GMRES runs to a relative residual of 1e-14; 1e-9 leaves room for the system's conditioning
  ck_assert_double_lt(err / scale, 1e-9);
  // the coupling matters: the sliding rows follow mu dlambda_n, which PCR's symmetric A omits
  ck_assert_double_eq_tol(x[1] - 0.8 * x[0], xd[1] - 0.8 * xd[0], 1e-9 * scale);
  free(buf);
}
END_TEST

// the direct solve of an island (osti_directSet: the Schur matrix from the rows' half-solves on
// their patterns, an LU factor) equals GMRES on the matrix-free operator, sliding couplings
// included: the system of test_gmresSliding on a tree-factored mass matrix
START_TEST(test_directMatchesGmres) {
  enum { nv = 40, ncon = 15, n = 3 * ncon };
  ostWorld w;
  void* buf = makeWorld(&w, nv, n, 0.1);
  double h = 0.1;
  unsigned seed = 11;
  static int parent[nv];
  chainsOfFour(&w, parent);
  w.nrow = n;
  static double Jd[n * nv];
  for (int i = 0; i < n * nv; i++) {
    seed = seed * 1103515245u + 12345u;
    // each contact touches two of the chains, as a contact touches its two bodies' chains
    int k = i / nv / 3, j = i % nv;
    Jd[i] = (j / 4 == k % 10 || j / 4 == (3 * k + 1) % 10) ? (double)(seed >> 8) / (1 << 24) - 0.5
                                                           : 0;
  }
  setRows(&w, Jd, n);
  ost_fixtureContactRows(&w, ncon, h, 1);
  double b[n], x[n], xd[n];
  for (int i = 0; i < n; i++) b[i] = sin(1.0 + i) * (w.c[i] > 1 ? 1e12 : 1);
  osti_gmres(&w, x, b, 400, 1e-14);
  ostRowSet set = osti_wholeSet(&w);
  ck_assert_int_eq(osti_directSet(&w, &set, xd, b), 1);
  double err = 0, scale = 0;
  for (int i = 0; i < n; i++) {
    err = fmax(err, fabs(x[i] - xd[i]));
    scale = fmax(scale, fabs(xd[i]));
  }
  printf("direct vs GMRES: max |difference| %.3g of %.3g\n", err, scale);
  // GMRES runs to a relative residual of 1e-14; 1e-9 leaves room for the conditioning
  ck_assert_double_lt(err / scale, 1e-9);
  free(buf);
}
END_TEST


// A geometry provider whose Jacobian has the wrong sign: the contact's gap at q+ = q- + h u is
// g0 - s h u, but the row says +1, so every Newton direction deepens the penetration and every
// iterate after the first is worse than it (the Newton model is wrong, as when conflicting
// constraints or a geometry's discontinuity mislead it). With s = 1000 the first trial is 1000
// times worse: the loop diverged and must return its first iterate, evaluated again (the same
// merit bit for bit), reported as the best; before, it returned the least bad later iterate,
// deeper and faster than the start. With s = 1 the later iterates are only a little worse
// (a stall): the loop keeps its best later iterate, which moves on.
typedef struct { ostWorld* w; double g0, s; } wrongSign;

static int wrongSignGeometry(void* ctx, const ostNum* u) {
  wrongSign* p = (wrongSign*)ctx;
  ostWorld* w = p->w;
  w->nrow = 1;
  w->rows[0] = (ostRow){0};
  w->rows[0].type = OST_ROW_CONTACT;
  w->rows[0].normal = -1;
  w->rows[0].pos = p->g0 - p->s * w->h * u[0];
  osti_rowScratch(w, 0)[0] = 1;
  return osti_rowStore(w, 0, 1);
}

START_TEST(test_divergedReturnsFirst) {
  for (int c = 0; c < 4; c++) {
    int tree = c & 1, diverge = c < 2;  // one system, then islands (a tree factor)
    ostWorld w;
    void* buf = makeWorld(&w, 1, 4, 0.1);
    static const int parent[1] = {-1};
    ostSolverOptions o = options();
    o.newton_iter = 8;
    w.dof_parent = tree ? parent : NULL;
    w.M[0] = 2;
    ck_assert_int_eq(osti_factorMass(&w), 0);
    w.qvel_prev[0] = 0;
    w.qfrc_explicit[0] = 0;
    wrongSign p = {&w, -0.01, diverge ? 1000 : 1};  // 1 cm deep at u = 0
    osti_startStep(&w, (double[]){0}, 0);
    ostNewtonStats st;
    ostNum merit_k[9];
    ck_assert_int_eq(osti_newton(&w, &o, 4, wrongSignGeometry, &p, merit_k, NULL, 9, &st), 0);
    printf("wrong-sign provider x%g (%s): first merit %.6g, iterates 1..%d from %.6g to %.6g, "
           "returned iterate %d with %.6g, u = %g\n", p.s, tree ? "islands" : "one system",
           st.first, st.iterates - 1, merit_k[1], merit_k[st.iterates - 1], st.best,
           st.best_merit, w.qvel[0]);
    ck_assert_int_eq(st.iterates, 9);
    ck_assert_int_eq(tree ? w.nisland : 0, tree);
    for (int k = 1; k < st.iterates; k++) {
      ck_assert_double_gt(merit_k[k], (diverge ? OST_DIVERGED : 1) * st.first);
    }
    if (diverge) {
      ck_assert_int_eq(st.best, 0);
      ck_assert(st.best_merit == st.first);
      ck_assert(w.qvel[0] == 0);
      ck_assert(w.rows[0].pos == -0.01);
    } else {
      ck_assert_int_eq(st.best, 1);
      ck_assert(st.best_merit == merit_k[1]);
      ck_assert_double_gt(w.qvel[0], 0);
    }
    free(buf);
  }
}
END_TEST

// osti_rowStoreCols (a row with known candidate columns) stores exactly what osti_rowStore
// (a scan of every column) stores: the same pattern in the same order, the same values, the
// same refusal of a pattern wider than ncol; over random trees (and no tree), rows with 1 to 12
// candidate columns of which some are exactly zero (MuJoCo's sparse rows keep such entries),
// on random trees and on one chain, so patterns up to the whole tree (past OST_STORE_SORT_MAX), and ncol of 8 or nv
START_TEST(test_rowStoreCols) {
  enum { NV = 60 };
  unsigned seed = 7;
  int parent[NV], cols[NV], checked = 0, refused = 0, wide = 0;
  for (int trial = 0; trial < 400; trial++) {
    int tree = trial % 4 != 3, ncol = trial % 5 == 4 ? 8 : NV;
    for (int j = 0; j < NV; j++) {
      seed = seed * 1103515245u + 12345u;
      parent[j] = trial % 3 == 0 ? j - 1  // one chain: deep patterns
                                 : j > 0 && (seed >> 8) % 8 ? (int)((seed >> 12) % j) : -1;
    }
    ostWorld a, b;
    void* ba = aligned_alloc(64, ostu_worldSize(NV, ncol, 1));
    void* bb = aligned_alloc(64, ostu_worldSize(NV, ncol, 1));
    ostu_worldInit(&a, ba, NV, ncol, 1, 0.01);
    ostu_worldInit(&b, bb, NV, ncol, 1, 0.01);
    a.dof_parent = b.dof_parent = tree ? parent : NULL;
    seed = seed * 1103515245u + 12345u;
    int k = 1 + (int)((seed >> 8) % 12);
    double* ra = osti_rowScratch(&a, 0);
    double* rb = osti_rowScratch(&b, 0);
    for (int j = 0; j < NV; j++) ra[j] = rb[j] = 0;
    for (int l = 0; l < k; l++) {
      seed = seed * 1103515245u + 12345u;
      cols[l] = (int)((seed >> 8) % NV);  // repeats allowed
      double v = (seed >> 20) % 4 ? ((seed >> 4) % 1000) / 999.0 - 0.5 : 0;  // some exact zeros
      ra[cols[l]] = rb[cols[l]] = v;
    }
    int sa = osti_rowStore(&a, 0, 1), sb = osti_rowStoreCols(&b, 0, cols, k);
    ck_assert_int_eq(sa, sb);
    if (sa == 0) {
      ck_assert_int_eq(a.Jnnz[0], b.Jnnz[0]);
      for (int l = 0; l < a.Jnnz[0]; l++) {
        ck_assert_int_eq(a.Jind[l], b.Jind[l]);
        ck_assert(a.J[l] == b.J[l]);
      }
      wide += a.Jnnz[0] > OST_STORE_SORT_MAX;
      checked++;
    } else {
      refused++;
    }
    for (int j = 0; j < NV; j++) {
      ck_assert_int_eq(a.colmark[j], 0);  // the scratch is left clear
      ck_assert_int_eq(b.colmark[j], 0);
    }
    free(ba);
    free(bb);
  }
  printf("rowStoreCols: %d rows equal to the column scan (%d wider than %d), %d refused by both\n",
         checked, wide, OST_STORE_SORT_MAX, refused);
  ck_assert_int_ge(checked, 200);
  ck_assert_int_ge(refused, 10);
  ck_assert_int_ge(wide, 5);
}
END_TEST


int main(void) {
  Suite* s = suite_create("ost_solver");
  TCase* tc = tcase_create("solver");
  tcase_add_test(tc, test_landing);
  tcase_add_test(tc, test_velocityServo);
  tcase_add_test(tc, test_pcr);
  tcase_add_test(tc, test_rowStoreCols);
  tcase_add_test(tc, test_gmresSliding);
  tcase_add_test(tc, test_directMatchesGmres);
  tcase_add_test(tc, test_divergedReturnsFirst);
  suite_add_tcase(s, tc);
  return ost_fixtureRun(s);
}
