// test_batch_gpu.c: the CUDA batch equals the CPU batch (ctest label `gpu`; the CPU half runs in
// CI as `--device cpu:1` against `cpu`). A mixed batch of one model: every world starts from
// its own perturbation of qpos0 and gets its own random controls each step; every 7th world
// gets a NaN control at step T/3, and with --nconmax K a small contact capacity makes some
// worlds overflow. Both devices run the same rollout; it passes if every state agrees to 1e-9
// and every world's outcome bits are equal. Prints one JSON line per model with the rollout
// times of both devices (world-steps per second).
//   usage: test_batch_gpu MODEL.xml... [--worlds N] [--steps T] [--nconmax K] [--device D]
#define _POSIX_C_SOURCE 200809L

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "ostrich.h"

static double now(void) {
  struct timespec t;
  clock_gettime(CLOCK_MONOTONIC, &t);
  return t.tv_sec + 1e-9 * t.tv_nsec;
}


// uniform in [lo, hi] from a linear congruential stream
static double uniform(unsigned* seed, double lo, double hi) {
  *seed = *seed * 1103515245u + 12345u;
  return lo + (hi - lo) * ((*seed >> 8) & 0xffffff) / (double)0xffffff;
}


// run the batch on device; fills qpos/qvel (T x nworld x n) and status; returns seconds or -1
static double run(const mjModel* m, const char* device, int nworld, int T, const mjtNum* q0,
                  const mjtNum* ctrl, mjtNum* qpos, mjtNum* qvel, int* status) {
  char err[1000];
  ostBatch* b = ost_batchCreate(m, nworld, device, err, sizeof(err));
  if (!b) {
    fprintf(stderr, "test_batch_gpu: %s: %s\n", device, err);
    return -1;
  }
  double t0 = now();
  int rc = ost_batchSetState(b, q0, NULL) || ost_batchRollout(b, T, ctrl, qpos, qvel)
           || ost_batchStatus(b, status);
  double t = now() - t0;
  if (rc) {
    fprintf(stderr, "test_batch_gpu: %s: %s\n", device, ost_batchError(b));
  }
  ost_batchDelete(b);
  return rc ? -1 : t;
}


static int runModel(const char* path, int nworld, int T, int nconmax, const char* device) {
  char err[1000] = "";
  mjModel* m = mj_loadXML(path, NULL, err, sizeof(err));
  if (!m) {
    fprintf(stderr, "cannot load %s: %s\n", path, err);
    return 2;
  }
  if (nconmax > 0) {
    m->nconmax = nconmax;
  }
  int nq = m->nq, nv = m->nv, nu = m->nu;
  unsigned seed = 7;
  mjtNum* q0 = (mjtNum*)malloc(sizeof(mjtNum) * nworld * nq);
  mjtNum* ctrl = (mjtNum*)malloc(sizeof(mjtNum) * T * nworld * (nu > 0 ? nu : 1));
  for (int w = 0; w < nworld; w++) {
    mjtNum* q = q0 + (size_t)w * nq;
    for (int i = 0; i < nq; i++) q[i] = m->qpos0[i];
    for (int j = 0; j < m->njnt; j++) {
      int t = m->jnt_type[j], a = m->jnt_qposadr[j];
      if (t == mjJNT_FREE) {
        q[a] += uniform(&seed, -0.3, 0.3);
        q[a + 1] += uniform(&seed, -0.3, 0.3);
        mjtNum yaw = uniform(&seed, -0.5, 0.5);
        q[a + 3] = cos(yaw / 2);
        q[a + 6] = sin(yaw / 2);
      } else if (t == mjJNT_HINGE || t == mjJNT_SLIDE) {
        q[a] += uniform(&seed, -0.1, 0.1);
      }
    }
  }
  for (int t = 0; t < T; t++) {
    for (int w = 0; w < nworld; w++) {
      for (int a = 0; a < nu; a++) {
        const mjtNum* r = m->actuator_ctrlrange + 2 * a;
        mjtNum lo = m->actuator_ctrllimited[a] ? r[0] : -1, hi = m->actuator_ctrllimited[a] ? r[1] : 1;
        mjtNum* u = ctrl + ((size_t)t * nworld + w) * nu + a;
        *u = uniform(&seed, lo > -4 ? lo : -4, hi < 4 ? hi : 4);
        if (w % 7 == 3 && t == T / 3 && a == 0) *u = NAN;
      }
    }
  }
  size_t nqs = (size_t)T * nworld * nq, nvs = (size_t)T * nworld * nv;
  mjtNum *qa = malloc(sizeof(mjtNum) * nqs), *va = malloc(sizeof(mjtNum) * nvs);
  mjtNum *qb = malloc(sizeof(mjtNum) * nqs), *vb = malloc(sizeof(mjtNum) * nvs);
  int *sa = malloc(sizeof(int) * nworld), *sb = malloc(sizeof(int) * nworld);
  double ta = run(m, device, nworld, T, q0, ctrl, qa, va, sa);
  double tb = run(m, "cpu", nworld, T, q0, ctrl, qb, vb, sb);
  int ok = ta >= 0 && tb >= 0, nstatus = 0, nfail = 0, nnan = 0, nover = 0;
  double worst = 0;
  for (size_t i = 0; ok && i < nqs; i++) worst = fmax(worst, fabs(qa[i] - qb[i]));
  for (size_t i = 0; ok && i < nvs; i++) worst = fmax(worst, fabs(va[i] - vb[i]));
  for (int w = 0; ok && w < nworld; w++) {
    nstatus += sa[w] != sb[w];
    nfail += (sa[w] & (OST_OVERFLOW | OST_NAN | OST_CHOL_FAIL)) != 0;
    nnan += (sa[w] & OST_NAN) != 0;
    nover += (sa[w] & OST_OVERFLOW) != 0;
  }
  ok = ok && worst <= 1e-9 && nstatus == 0 && !isnan(worst);
  printf("{\"model\": \"%s\", \"device\": \"%s\", \"worlds\": %d, \"steps\": %d, "
         "\"max_state_diff\": %.3g, \"status_mismatch\": %d, \"failed_worlds\": %d, "
         "\"nan_worlds\": %d, \"overflow_worlds\": %d, \"%s_s\": %.4f, \"cpu_s\": %.4f, "
         "\"%s_world_steps_per_s\": %.1f, \"cpu_world_steps_per_s\": %.1f, \"ok\": %s}\n",
         path, device, nworld, T, worst, nstatus, nfail, nnan, nover, device, ta, tb, device,
         nworld * (double)T / ta, nworld * (double)T / tb, ok ? "true" : "false");
  free(q0);
  free(ctrl);
  free(qa);
  free(va);
  free(qb);
  free(vb);
  free(sa);
  free(sb);
  mj_deleteModel(m);
  return ok ? 0 : 1;
}


int main(int argc, char** argv) {
  int nworld = 256, T = 30, nconmax = 0, status = 0, nmodel = 0;
  const char* device = "cuda";
  for (int i = 1; i < argc; i++) {
    if (i + 1 < argc && !strcmp(argv[i], "--worlds")) nworld = atoi(argv[++i]);
    else if (i + 1 < argc && !strcmp(argv[i], "--steps")) T = atoi(argv[++i]);
    else if (i + 1 < argc && !strcmp(argv[i], "--nconmax")) nconmax = atoi(argv[++i]);
    else if (i + 1 < argc && !strcmp(argv[i], "--device")) device = argv[++i];
  }
  for (int i = 1; i < argc; i++) {
    if (argv[i][0] == '-' && argv[i][1] == '-') {
      i++;
      continue;
    }
    status |= runModel(argv[i], nworld, T, nconmax, device);
    nmodel++;
  }
  return nmodel ? status : 2;
}
