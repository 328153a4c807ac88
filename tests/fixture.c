// fixture.c: see fixture.h.
#include "fixture.h"

#include "ostrich.h"
#include "ost_solver.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

static int allow_warnings = 0;
static int nwarnings = 0;

static void onError(const char* msg) {
  ck_abort_msg("MuJoCo error: %s", msg);
}


static void onWarning(const char* msg) {
  nwarnings++;
  if (!allow_warnings) {
    ck_abort_msg("MuJoCo warning: %s", msg);
  }
}


void ost_fixtureSetup(void) {
  mju_user_error = onError;
  mju_user_warning = onWarning;
  allow_warnings = 0;
  nwarnings = 0;
}


int ost_fixtureAllowWarnings(int allow) {
  allow_warnings = allow;
  return nwarnings;
}


mjModel* ost_fixtureLoadModel(const char* name) {
  char path[1024], err[1000] = "";
  snprintf(path, sizeof(path), "%s/%s", OST_MODEL_DIR, name);
  mjModel* m = mj_loadXML(path, NULL, err, sizeof(err));
  ck_assert_msg(m != NULL, "cannot load %s: %s", path, err);
  return m;
}


mjModel* ost_fixtureTryLoadString(const char* xml, char* err, int err_sz) {
  char path[] = "/tmp/ostrich_test_XXXXXX.xml";
  int fd = mkstemps(path, 4);
  ck_assert_int_ge(fd, 0);
  FILE* f = fdopen(fd, "w");
  fputs(xml, f);
  fclose(f);
  mjModel* m = mj_loadXML(path, NULL, err, err_sz);
  unlink(path);
  return m;
}


mjModel* ost_fixtureLoadString(const char* xml) {
  char err[1000] = "";
  mjModel* m = ost_fixtureTryLoadString(xml, err, sizeof(err));
  ck_assert_msg(m != NULL, "cannot load XML: %s", err);
  return m;
}


int ost_fixtureRun(Suite* s) {
  SRunner* sr = srunner_create(s);
  srunner_run_all(sr, CK_NORMAL);
  int nfailed = srunner_ntests_failed(sr);
  srunner_free(sr);
  return nfailed == 0 ? EXIT_SUCCESS : EXIT_FAILURE;
}


void ost_fixtureSetTimestep(const mjModel* m, mjData* d, double h) {
  ostOptions opt;
  ck_assert_int_eq(ost_readOptions(m, &opt, NULL, 0), OST_OK);
  opt.timestep = h;
  ck_assert_int_eq(ost_setOptions(m, d, &opt), OST_OK);
}


void ost_fixtureSetProvider(const mjModel* m, mjData* d, double h, int geometry) {
  ostOptions opt;
  ck_assert_int_eq(ost_readOptions(m, &opt, NULL, 0), OST_OK);
  opt.timestep = h;
  opt.geometry = geometry;
  ck_assert_int_eq(ost_setOptions(m, d, &opt), OST_OK);
}


void ost_fixtureTransitionFD(const mjModel* m, mjData* d, double eps, double* A, double* B) {
  int nq = m->nq, nv = m->nv, na = m->na, nu = m->nu, nx = 2 * nv + na;
  // the start state (q0, v0, a0, u0), the two perturbed results x (2 nx), a tangent dq (nv)
  // and the unperturbed step's qpos (qbase, nq), in one block
  double* s0 = (double*)malloc((2 * nq + 2 * nv + na + nu + 2 * nx) * sizeof(double));
  double *q0 = s0, *v0 = q0 + nq, *a0 = v0 + nv, *u0 = a0 + na, *x = u0 + nu;
  double *dq = x + 2 * nx, *qbase = dq + nv;
  double t0 = d->time;
  memcpy(q0, d->qpos, nq * sizeof(double));
  memcpy(v0, d->qvel, nv * sizeof(double));
  memcpy(a0, d->act, na * sizeof(double));
  memcpy(u0, d->ctrl, nu * sizeof(double));
  ck_assert_int_eq(ost_step(m, d), OST_OK);  // the unperturbed step: the tangent's base point
  memcpy(qbase, d->qpos, nq * sizeof(double));
  for (int j = 0; j < nx + nu; j++) {
    for (int side = 0; side < 2; side++) {
      double e = side ? -eps : eps;
      memcpy(d->qpos, q0, nq * sizeof(double));
      memcpy(d->qvel, v0, nv * sizeof(double));
      memcpy(d->act, a0, na * sizeof(double));
      memcpy(d->ctrl, u0, nu * sizeof(double));
      d->time = t0;
      if (j < nv) {
        for (int i = 0; i < nv; i++) dq[i] = i == j ? e : 0;
        mj_integratePos(m, d->qpos, dq, 1);
      } else if (j < 2 * nv) {
        d->qvel[j - nv] += e;
      } else if (j < nx) {
        d->act[j - 2 * nv] += e;
      } else {
        d->ctrl[j - nx] += e;
      }
      mj_forward(m, d);
      ck_assert_int_eq(ost_step(m, d), OST_OK);
      double* xs = x + side * nx;
      mj_differentiatePos(m, xs, 1, qbase, d->qpos);
      memcpy(xs + nv, d->qvel, nv * sizeof(double));
      memcpy(xs + 2 * nv, d->act, na * sizeof(double));
    }
    for (int i = 0; i < nx; i++) {
      double fd = (x[i] - x[nx + i]) / (2 * eps);
      if (j < nx) {
        A[i * nx + j] = fd;
      } else {
        B[i * nu + j - nx] = fd;
      }
    }
  }
  memcpy(d->qpos, q0, nq * sizeof(double));
  memcpy(d->qvel, v0, nv * sizeof(double));
  memcpy(d->act, a0, na * sizeof(double));
  memcpy(d->ctrl, u0, nu * sizeof(double));
  d->time = t0;
  mj_forward(m, d);
  free(s0);
}


void ost_fixtureSetState(const mjModel* m, mjData* d, const double* q, const double* v,
                         const double* a, const double* u) {
  memcpy(d->qpos, q, m->nq * sizeof(double));
  memcpy(d->qvel, v, m->nv * sizeof(double));
  memcpy(d->act, a, m->na * sizeof(double));
  memcpy(d->ctrl, u, m->nu * sizeof(double));
  d->time = 0;
  mj_forward(m, d);
}


void ost_fixtureCopyState(const mjModel* m, mjData* dst, const mjData* src) {
  dst->time = src->time;
  memcpy(dst->qpos, src->qpos, m->nq * sizeof(mjtNum));
  memcpy(dst->qvel, src->qvel, m->nv * sizeof(mjtNum));
  memcpy(dst->ctrl, src->ctrl, m->nu * sizeof(mjtNum));
  mju_zero(dst->qacc_warmstart, m->nv);
}


double ost_fixtureMaxDiff(const double* a, const double* b, int n, double* scale) {
  double e = 0;
  for (int i = 0; i < n; i++) {
    e = fabs(a[i] - b[i]) > e ? fabs(a[i] - b[i]) : e;
    *scale = fabs(a[i]) > *scale ? fabs(a[i]) : *scale;
  }
  return e;
}


void ost_fixtureTransitionCheck(const mjModel* m, mjData* d, const char* label, double* A,
                                double* B, double* worst_a, double* worst_b, double* scale) {
  int nx = 2 * m->nv + m->na, nu = m->nu;
  for (int i = 0; i < nx * nx; i++) A[i] = NAN;
  for (int i = 0; i < nx * nu; i++) B[i] = NAN;
  ck_assert_int_eq(ost_transition(m, d, A, B), OST_OK);
  double* fd = (double*)malloc((size_t)nx * (nx + nu) * sizeof(double));
  ost_fixtureTransitionFD(m, d, 1e-6, fd, fd + (size_t)nx * nx);
  *scale = 0;
  *worst_a = ost_fixtureMaxDiff(A, fd, nx * nx, scale);
  *worst_b = ost_fixtureMaxDiff(B, fd + (size_t)nx * nx, nx * nu, scale);
  printf("%s (nx = %d): max |A - FD| %.2g, max |B - FD| %.2g, max |entry| %.3g\n", label, nx,
         *worst_a, *worst_b, *scale);
  free(fd);
}


void ost_fixtureContactRows(struct ostWorld_* w, int ncon, double h, int sliding) {
  for (int k = 0; k < ncon; k++) {
    int i = 3 * k, slide = sliding && k % 3 == 0;
    w->rows[i] = (ostRow){0};
    w->rows[i].type = OST_ROW_CONTACT;
    w->rows[i].normal = -1;
    w->rows[i].mu = 0.8;
    for (int f = 1; f <= 2; f++) {
      w->rows[i + f] = (ostRow){0};
      w->rows[i + f].type = OST_ROW_FRICTION;
      w->rows[i + f].normal = i;
    }
    w->lambda[i] = 10;
    w->W[i] = slide;
    for (int r = 0; r < 3; r++) {
      osti_rowDiag(w, i + r);
      w->c[i + r] = 0.5 * h * w->diag[i + r];
    }
    if (slide) w->c[i + 1] = 1e12 * h * w->diag[i + 1];  // force along the slip fixed
  }
}
