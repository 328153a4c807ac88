// test_ost_envelope.c: the direct solves of a large island's Schur system. The envelope solve
// (core/ost_envelope.h) against GMRES on the matrix-free operator: symmetric (Cholesky) and with
// sliding couplings (LU), the factor kept for the next solve of the same operator and made again
// for a new one, and the sets it must leave to PCR (no room, no row cache); then MuJoCo's
// grid2pin, a tendon network under load, stepped with and without it: the same states, far fewer
// Krylov iterations. And the dense solve that a host world makes of an island above
// OST_DIRECT_MAX rows once a Krylov solve of it stopped short (osti_schurSolveSet), which a
// batch's world never makes.
#include "ost_solver.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>

#include "fixture.h"
#include "ost_internal.h"

enum { NV = 240, NCON = 50, N = 3 * NCON };  // 60 chains of 4 dofs; 150 rows (> OST_DIRECT_MAX)

typedef struct {
  ostWorld   w;
  ostEnvWork e;
  void*      buf;
  void*      dbuf;
  void*      ebuf;
  double*    yrow;
  int        parent[NV];
} envWorld;


// a world of NV dofs in chains of four (tree-factored M) and NCON contacts of three rows, each
// touching two chains (`shared`: every contact also touches chain 0, so all rows share a dof);
// every third contact sliding when `sliding` (its row along the slip fixed, c ~ 1e12 k_f)
// (`host`: with a host context's large-island dense arrays, ostu_denseLargeInit)
static void makeWorldFor(envWorld* ew, int shared, int sliding, int host) {
  ostWorld* w = &ew->w;
  double h = 0.1;
  ew->buf = aligned_alloc(64, ostu_worldSize(NV, NV, N));
  ostu_worldInit(w, ew->buf, NV, NV, N, h);
  ew->dbuf = host ? aligned_alloc(64, ostu_denseLargeSize(NV, N) + 64) : NULL;
  if (host) ostu_denseLargeInit(w, ew->dbuf, N);
  ew->ebuf = aligned_alloc(64, ostu_envSize(NV, NV, N) + 64);
  ostu_envInit(&ew->e, ew->ebuf, NV, NV, N);
  ew->yrow = (double*)calloc((size_t)N * NV, sizeof(double));
  for (int j = 0; j < NV; j++) ew->parent[j] = j % 4 == 0 ? -1 : j - 1;
  for (int i = 0; i < NV * NV; i++) w->M[i] = 0;
  for (int j = 0; j < NV; j++) {
    w->M[j * NV + j] = 1 + 0.01 * j;
    if (ew->parent[j] >= 0) w->M[j * NV + ew->parent[j]] = 0.3;
  }
  w->dof_parent = ew->parent;
  ck_assert_int_eq(osti_factorMass(w), 0);
  w->yrow = ew->yrow;
  w->env = &ew->e;
  w->nrow = N;
  unsigned seed = 5;
  for (int k = 0; k < NCON; k++) {
    int c1 = k % 60, c2 = (7 * k + 3) % 60;
    for (int r = 0; r < 3; r++) {
      double* row = osti_rowScratch(w, 3 * k) + (size_t)r * NV;
      for (int j = 0; j < NV; j++) {
        seed = seed * 1103515245u + 12345u;
        int chain = j / 4;
        int on = chain == c1 || chain == c2 || (shared && chain == 0);
        row[j] = on ? (double)(seed >> 8) / (1 << 24) - 0.5 : 0;
      }
    }
    ck_assert_int_eq(osti_rowStore(w, 3 * k, 3), 0);
  }
  ost_fixtureContactRows(w, NCON, h, sliding);  // fills the row cache, as an evaluation does
}


static void makeWorld(envWorld* ew, int shared, int sliding) {
  makeWorldFor(ew, shared, sliding, 0);
}


static void freeWorld(envWorld* ew) {
  free(ew->buf);
  free(ew->dbuf);
  free(ew->ebuf);
  free(ew->yrow);
}


// max |x - y| / max |y|
static double relDiff(const double* x, const double* y, int n) {
  double err = 0, scale = 0;
  for (int i = 0; i < n; i++) {
    err = fmax(err, fabs(x[i] - y[i]));
    scale = fmax(scale, fabs(y[i]));
  }
  return err / scale;
}


// the envelope solve equals GMRES run to 1e-14 on the same operator, with and without sliding
// couplings; a second right-hand side reuses the factor, a new operator makes it again
START_TEST(test_envelopeMatchesGmres) {
  for (int sliding = 0; sliding <= 1; sliding++) {
    envWorld ew;
    makeWorld(&ew, 0, sliding);
    ostWorld* w = &ew.w;
    ostRowSet set = osti_wholeSet(w);
    ck_assert_int_eq(osti_hasSlidingCouplingSet(w, &set), sliding);
    double b[N], x[N], xe[N];
    for (int pass = 0; pass < 3; pass++) {
      if (pass == 2) w->op_version++;  // a new evaluation: the kept factor is stale
      for (int i = 0; i < N; i++) b[i] = sin(1.0 + i + pass) * (w->c[i] > 1 ? 1e12 : 1);
      osti_gmres(w, x, b, 2000, 1e-14);
      ck_assert_int_eq(osti_envelopeSet(w, &set, xe, b, 1), 1);
      double err = relDiff(xe, x, N);
      printf("envelope (%s) vs GMRES, pass %d: %.3g relative; factors %d, solves %d, "
             "envelope %zu of %d doubles\n", sliding ? "LU" : "Cholesky", pass, err,
             ew.e.factors, ew.e.solves, ew.e.adr[N], N * (N + 1) / 2);
      // GMRES runs to a relative residual of 1e-14; 1e-9 leaves room for the conditioning
      ck_assert_double_lt(err, 1e-9);
      ck_assert_int_eq(ew.e.factors, pass < 2 ? 1 : 2);
      ck_assert_int_eq(ew.e.lu, sliding);
    }
    // the ordering keeps the factor sparse: rows touch 2 of 60 chains
    ck_assert_uint_lt(ew.e.adr[N], (size_t)N * (N + 1) / 4);
    freeWorld(&ew);
  }
}
END_TEST


// sets the envelope must leave to the Krylov solve: an envelope larger than the work holds (all
// rows on one shared dof make A dense), a world without the row cache (GPU and batch worlds);
// without factor = 1 it only answers from a kept factor
START_TEST(test_envelopeRefuses) {
  envWorld ew;
  makeWorld(&ew, 1, 0);
  ostWorld* w = &ew.w;
  ostRowSet set = osti_wholeSet(w);
  double b[N], x[N];
  for (int i = 0; i < N; i++) b[i] = cos(i);
  ck_assert_int_eq(osti_envelopeSet(w, &set, x, b, 1), 1);  // dense, but within room and cost
  ck_assert_uint_eq(ew.e.adr[N], (size_t)N * (N + 1) / 2);
  w->op_version++;
  ew.e.cap = (size_t)N * (N + 1) / 2 - 1;
  ck_assert_int_eq(osti_envelopeSet(w, &set, x, b, 1), 0);
  freeWorld(&ew);
  makeWorld(&ew, 0, 0);
  w = &ew.w;
  ck_assert_int_eq(osti_envelopeSet(w, &set, x, b, 0), 0);  // no kept factor, not asked to
  w->yrow = NULL;
  ck_assert_int_eq(osti_envelopeSet(w, &set, x, b, 1), 0);
  ck_assert_int_eq(ew.e.factors, 0);
  freeWorld(&ew);
}
END_TEST


// a Krylov solve cut at a budget it cannot meet (4 iterations, the sliding rows' c / h ~ 1e12
// times the others' diagonal) leaves a relative residual far above OST_DIRECT_FALLBACK: a host
// world (with large-island dense arrays) solves that island again directly, to GMRES's answer at
// 1e-14, and solves the loop's later large islands directly at once (direct_large, until
// osti_startStep); a batch's world (none, as on the GPU) keeps the Krylov answer
START_TEST(test_directAfterShortKrylov) {
  ostSolverOptions opt = {0};
  opt.pcr_iter = 4;
  opt.pcr_tol = 1e-12;
  for (int host = 0; host <= 1; host++) {
    envWorld ew;
    makeWorldFor(&ew, 0, 1, host);
    ostWorld* w = &ew.w;
    w->env = NULL;  // the envelope's own fallback is tested above
    ostRowSet set = osti_wholeSet(w);
    double b[N], x[N], xg[N];
    for (int i = 0; i < N; i++) b[i] = sin(1.0 + i) * (w->c[i] > 1 ? 1e12 : 1);
    osti_gmres(w, xg, b, 2000, 1e-14);
    for (int i = 0; i < N; i++) x[i] = 0;
    int it = osti_schurSolveSet(w, &set, x, b, &opt);
    double err = relDiff(x, xg, N);
    printf("a short Krylov solve of %d rows, %s world: %.3g relative to GMRES at 1e-14 (%d "
           "iterations), large-island dense rows %d, direct_large %d\n", N,
           host ? "host" : "batch", err, it, w->ndense_large, w->direct_large);
    if (host) {
      ck_assert_int_eq(w->ndense_large, N);
      ck_assert_int_eq(w->direct_large, 1);
      ck_assert_int_eq(it, opt.pcr_iter + 1);  // the Krylov budget, then one direct solve
      // GMRES runs to a relative residual of 1e-14; 1e-9 leaves room for the conditioning
      ck_assert_double_lt(err, 1e-9);
      // the next solve of the loop goes direct without Krylov iterations; a new loop does not
      for (int i = 0; i < N; i++) x[i] = 0;
      ck_assert_int_eq(osti_schurSolveSet(w, &set, x, b, &opt), 1);
      ck_assert_double_lt(relDiff(x, xg, N), 1e-9);
      double u[NV] = {0};
      osti_startStep(w, u, 0);
      ck_assert_int_eq(w->direct_large, 0);
    } else {
      ck_assert_int_eq(w->ndense_large, 0);
      ck_assert_int_eq(w->direct_large, 0);
      ck_assert_int_eq(it, opt.pcr_iter);
      ck_assert_double_gt(err, OST_DIRECT_FALLBACK);  // the truncated answer, as before
    }
    freeWorld(&ew);
  }
}
END_TEST


// MuJoCo's grid2pin (a 9 x 9 grid of particles joined by 144 tendon equalities, pinned at two
// corners, hanging), its contacts disabled: one island of 144+ rows whose loaded tendons engage
// the geometric term, stepped with and without the envelope solves. Both converge every step
// to the same states (within what the solver's tolerance leaves: 1e-10 m/s in the merit); with
// the envelope each of the term's nested Schur solves is one factor solve instead of up to
// 4 x pcr_iter PCR iterations, so the Krylov count must drop by far more than half. Six steps:
// from the seventh the merit stalls at rounding's floor, 1-3e-10 against tol 1e-10, and a step
// splits or not by chance in either run.
START_TEST(test_grid2pinWithAndWithout) {
  ost_fixtureSetup();
  char err[500];
  mjModel* m = mj_loadXML("/usr/share/mujoco/model/composite/grid2pin.xml", NULL, err,
                          sizeof(err));
  ck_assert_msg(m != NULL, "%s", err);
  // without its self-contacts: the step's solution is then unique (the contacts that a look-ahead
  // lists depend on q+, and the two runs converged to different, equally valid contact sets)
  m->opt.disableflags |= mjDSBL_CONTACT;
  mjData* d1 = mj_makeData(m);
  mjData* d2 = mj_makeData(m);
  ost_context(m, d2)->no_envelope = 1;
  long krylov1 = 0, krylov2 = 0, newton1 = 0, newton2 = 0;
  double worst = 0;
  int n = 6;
  for (int k = 0; k < n; k++) {
    ck_assert_int_eq(ost_step(m, d1), OST_OK);
    ck_assert_int_eq(ost_step(m, d2), OST_OK);
    krylov1 += ost_stats(d1)->pcr_iter;
    krylov2 += ost_stats(d2)->pcr_iter;
    newton1 += ost_stats(d1)->newton_iter;
    newton2 += ost_stats(d2)->newton_iter;
    for (int j = 0; j < m->nv; j++) worst = fmax(worst, fabs(d1->qvel[j] - d2->qvel[j]));
  }
  const ostEnvWork* e = &ost_context(m, d1)->env;
  printf("grid2pin, %d steps: Newton iterates %ld / %ld, Krylov iterations %ld / %ld with / "
         "without the envelope (%d factors, %d solves); max |qvel difference| %.3g m/s\n", n,
         newton1, newton2, krylov1, krylov2, e->factors, e->solves, worst);
  ck_assert_int_gt(e->factors, 0);
  ck_assert_int_lt(4 * krylov1, krylov2);
  // two converged answers of the same steps (measured 1e-11): each within tol (1e-10 m/s) of the
  // solution, so their velocities differ by about tol, not by a physical amount. Later steps of
  // this model stall at a merit of 1-3e-10, rounding's floor here, and split or not by chance
  ck_assert_double_lt(worst, 1e-8);
  mj_deleteData(d1);
  mj_deleteData(d2);
  mj_deleteModel(m);
}
END_TEST


int main(void) {
  Suite* s = suite_create("ost_envelope");
  TCase* tc = tcase_create("envelope");
  tcase_add_test(tc, test_envelopeMatchesGmres);
  tcase_add_test(tc, test_envelopeRefuses);
  tcase_add_test(tc, test_directAfterShortKrylov);
  tcase_add_test(tc, test_grid2pinWithAndWithout);
  tcase_set_timeout(tc, 120);
  suite_add_tcase(s, tc);
  return ost_fixtureRun(s);
}
