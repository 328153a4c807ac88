// test_build_types.c: the library built as the project builds it (-O3 outside Debug, no
// floating-point contraction) against the same sources at -O0 (libostrich_O0.so), both loaded
// into this process with dlopen (RTLD_LOCAL: each keeps its own symbols and contexts). Rollouts
// and their gradients must agree bit for bit: optimization may reorder instructions, not
// arithmetic, so any difference means the build changes the physics (contraction into fused
// multiply-adds, reassociation, excess precision). Checked through the public API: a recorded
// rollout and its backward pass with parameters (the step, the tape, the adjoint's dual code),
// and a CPU batch rollout and its backward pass (core's batch code).
#include <check.h>
#include <dlfcn.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <mujoco/mujoco.h>

#include "ostrich.h"

typedef struct lib_ {             // one build of the library
  void* h;
  int (*readOptions)(const mjModel*, ostOptions*, char*, int);
  int (*setOptions)(const mjModel*, mjData*, const ostOptions*);
  ostTape* (*tapeCreate)(const mjModel*, int);
  int (*tapeStep)(ostTape*, const mjModel*, mjData*);
  int (*tapeBackward)(ostTape*, const mjModel*, const ostGradOptions*, const mjtNum*,
                      const mjtNum*, mjtNum*, mjtNum*, mjtNum*, mjtNum*);
  const char* (*tapeError)(const ostTape*);
  void (*tapeDelete)(ostTape*);
  void (*deleteData)(mjData*);
  int (*nparam)(const mjModel*);
  ostBatch* (*batchCreate)(const mjModel*, int, const char*, char*, int);
  int (*batchSetState)(ostBatch*, const mjtNum*, const mjtNum*);
  int (*batchRollout)(ostBatch*, int, const mjtNum*, mjtNum*, mjtNum*);
  int (*batchBackward)(ostBatch*, const ostGradOptions*, int, const mjtNum*, const mjtNum*,
                       mjtNum*, mjtNum*, mjtNum*);
  void (*batchDelete)(ostBatch*);
  int (*batchStatus)(const ostBatch*, int*);
} lib;


static void* sym(void* h, const char* name) {
  void* f = dlsym(h, name);
  ck_assert_msg(f != NULL, "dlsym %s: %s", name, dlerror());
  return f;
}


static void load(lib* L, const char* path) {
  L->h = dlopen(path, RTLD_NOW | RTLD_LOCAL);
  ck_assert_msg(L->h != NULL, "dlopen %s: %s", path, dlerror());
  *(void**)&L->readOptions = sym(L->h, "ost_readOptions");
  *(void**)&L->setOptions = sym(L->h, "ost_setOptions");
  *(void**)&L->tapeCreate = sym(L->h, "ost_tapeCreate");
  *(void**)&L->tapeStep = sym(L->h, "ost_tapeStep");
  *(void**)&L->tapeBackward = sym(L->h, "ost_tapeBackward");
  *(void**)&L->tapeError = sym(L->h, "ost_tapeError");
  *(void**)&L->tapeDelete = sym(L->h, "ost_tapeDelete");
  *(void**)&L->deleteData = sym(L->h, "ost_deleteData");
  *(void**)&L->nparam = sym(L->h, "ost_nparam");
  *(void**)&L->batchCreate = sym(L->h, "ost_batchCreate");
  *(void**)&L->batchSetState = sym(L->h, "ost_batchSetState");
  *(void**)&L->batchRollout = sym(L->h, "ost_batchRollout");
  *(void**)&L->batchBackward = sym(L->h, "ost_batchBackward");
  *(void**)&L->batchDelete = sym(L->h, "ost_batchDelete");
  *(void**)&L->batchStatus = sym(L->h, "ost_batchStatus");
}


// a recorded rollout of n steps at h (native geometry) and its backward pass with parameters:
// out = the states after every step, then gctrl, gq0, gu0, gtheta
static void tapeRun(const lib* L, const mjModel* m, double h, int n, double* out) {
  mjData* d = mj_makeData(m);
  ostOptions o;
  ck_assert_int_eq(L->readOptions(m, &o, NULL, 0), OST_OK);
  o.timestep = h;
  o.geometry = OST_GEOMETRY_NATIVE;
  ck_assert_int_eq(L->setOptions(m, d, &o), OST_OK);
  ostTape* t = L->tapeCreate(m, 0);
  int nv = m->nv, nu = m->nu;
  double* p = out;
  for (int k = 0; k < n; k++) {
    for (int i = 0; i < nu; i++) d->ctrl[i] = 0.5 * sin(0.3 * k + i);
    int s = L->tapeStep(t, m, d);
    ck_assert_msg(s == OST_OK, "step %d: status %d", k, s);
    memcpy(p, d->qpos, m->nq * sizeof(double));
    memcpy(p + m->nq, d->qvel, nv * sizeof(double));
    p += m->nq + nv;
  }
  double* gq = (double*)calloc((size_t)(n + 1) * nv, sizeof(double));
  double* gu = (double*)calloc((size_t)(n + 1) * nv, sizeof(double));
  for (int i = 0; i < (n + 1) * nv; i++) {
    gq[i] = sin(0.7 * i);
    gu[i] = cos(0.4 * i);
  }
  ostGradOptions go = {0, 1, 0};  // the reverse sweep (default) too must keep its bits
  memset(p, 0, ((size_t)n * nu + 2 * nv + L->nparam(m)) * sizeof(double));
  int s = L->tapeBackward(t, m, &go, gq, gu, p, p + n * nu, p + n * nu + nv, p + n * nu + 2 * nv);
  ck_assert_msg(s == OST_OK, "backward: %s", L->tapeError(t));
  free(gq);
  free(gu);
  L->tapeDelete(t);
  L->deleteData(d);
}


// a CPU batch of 3 worlds, one thread: rollout of n steps and its backward pass; out = the
// states after every step, then gctrl, gq0, gu0
static void batchRun(const lib* L, const mjModel* m, int n, double* out) {
  char err[512];
  int W = 3, nq = m->nq, nv = m->nv, nu = m->nu;
  ostBatch* b = L->batchCreate(m, W, "cpu:1", err, sizeof(err));
  ck_assert_msg(b != NULL, "%s", err);
  double* ctrl = (double*)malloc((size_t)n * W * nu * sizeof(double) + 8);
  for (int i = 0; i < n * W * nu; i++) ctrl[i] = 0.4 * sin(0.2 * i);
  double* q0 = (double*)malloc((size_t)W * nq * sizeof(double));
  for (int w = 0; w < W; w++) memcpy(q0 + w * nq, m->qpos0, nq * sizeof(double));
  double* v0 = (double*)calloc((size_t)W * nv, sizeof(double));
  ck_assert_int_eq(L->batchSetState(b, q0, v0), OST_OK);
  double* qs = out;
  double* vs = qs + (size_t)n * W * nq;
  ck_assert_int_eq(L->batchRollout(b, n, ctrl, qs, vs), OST_OK);
  int status[3];
  ck_assert_int_eq(L->batchStatus(b, status), OST_OK);
  for (int w = 0; w < W; w++) {
    ck_assert_msg(status[w] == 0, "world %d: status bits %d", w, status[w]);
  }
  double* g = vs + (size_t)n * W * nv;
  double* gq = (double*)calloc((size_t)(n + 1) * W * nv, sizeof(double));
  for (int i = 0; i < (n + 1) * W * nv; i++) gq[i] = sin(0.9 * i);
  ck_assert_int_eq(L->batchBackward(b, NULL, 4, gq, NULL, g, g + (size_t)n * W * nu,
                                    g + (size_t)n * W * nu + W * nv), OST_OK);
  free(ctrl); free(q0); free(v0); free(gq);
  L->batchDelete(b);
}


static lib lib_opt, lib_O0;

static void compare(const char* what, const double* a, const double* b, size_t n) {
  size_t diff = 0;
  double worst = 0;
  for (size_t i = 0; i < n; i++) {
    if (memcmp(a + i, b + i, sizeof(double))) {
      diff++;
      worst = fmax(worst, fabs(a[i] - b[i]));
    }
  }
  printf("%-40s %zu numbers, %zu differ (largest %.3g)\n", what, n, diff, worst);
  fflush(stdout);
  ck_assert_msg(diff == 0, "%s: %zu of %zu numbers differ between -O3 and -O0", what, diff, n);
  for (size_t i = 0; i < n; i++) {  // every step converged: no NaN gradient hides a difference
    ck_assert_msg(isfinite(a[i]), "%s: number %zu is not finite", what, i);
  }
}


static void checkModel(const char* name, const char* path, double h, int n, int batch) {
  char err[512];
  mjModel* m = mj_loadXML(path, NULL, err, sizeof(err));
  ck_assert_msg(m != NULL, "%s: %s", path, err);
  size_t nt = (size_t)n * (m->nq + m->nv) + (size_t)n * m->nu + 2 * m->nv + lib_opt.nparam(m);
  double* a = (double*)calloc(nt, sizeof(double));
  double* b = (double*)calloc(nt, sizeof(double));
  tapeRun(&lib_opt, m, h, n, a);
  tapeRun(&lib_O0, m, h, n, b);
  char what[128];
  snprintf(what, sizeof(what), "%s: tape states and gradients", name);
  compare(what, a, b, nt);
  free(a); free(b);
  if (batch) {
    size_t nb = 3 * ((size_t)n * (m->nq + m->nv) + (size_t)n * m->nu + 2 * m->nv);
    a = (double*)calloc(nb, sizeof(double));
    b = (double*)calloc(nb, sizeof(double));
    batchRun(&lib_opt, m, n, a);
    batchRun(&lib_O0, m, n, b);
    snprintf(what, sizeof(what), "%s: batch states and gradients", name);
    compare(what, a, b, nb);
    free(a); free(b);
  }
  mj_deleteModel(m);
}


START_TEST(test_sameBits) {
  load(&lib_opt, OST_LIB_OPT);
  load(&lib_O0, OST_LIB_O0);
  checkModel("robot over the box (h 0.1)", OST_MODEL_DIR "/robot_box.xml", 0.1, 30, 1);
  checkModel("pallet (h 0.05)", OST_MODEL_DIR "/robot_pallet.xml", 0.05, 30, 1);
  checkModel("condim 4/6, frictionloss (h 0.01)", OST_MODEL_DIR "/../tests/models/friction_rows.xml",
             0.01, 30, 1);
  checkModel("humanoid (h 0.01)", OST_HUMANOID, 0.01, 40, 0);
}
END_TEST


int main(void) {
  Suite* s = suite_create("build_types");
  TCase* tc = tcase_create("bits");
  tcase_set_timeout(tc, 600);
  tcase_add_test(tc, test_sameBits);
  suite_add_tcase(s, tc);
  SRunner* sr = srunner_create(s);
  srunner_run_all(sr, CK_NORMAL);
  int failed = srunner_ntests_failed(sr);
  srunner_free(sr);
  return failed ? EXIT_FAILURE : EXIT_SUCCESS;
}
