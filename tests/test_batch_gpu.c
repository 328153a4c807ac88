// test_batch_gpu.c: the CUDA batch equals the CPU batch (ctest label `gpu`; the CPU half runs in
// CI as `--device cpu:1` against `cpu`). A mixed batch of one model: every world starts from
// its own perturbation of qpos0 (and of the activations, for a model with activation dynamics)
// and gets its own random controls each step; every 7th world
// gets a NaN control at step T/3, and with --nconmax K a small contact capacity makes some
// worlds overflow. Both devices run the same rollout and its backward pass (random cotangents
// at every step, segment checkpoints every S steps; with --keep the device under test takes
// them from its rollout, ost_batchKeepCheckpoints, while the CPU replays); it passes if every
// state and every gradient (controls, start state, parameters) is the same bit for bit (NaN
// where the other is NaN: the failed worlds) and every world's outcome bits are equal: a batch
// world steps as the same code on every device and thread count, so any difference is a bug
// (an unzeroed array read on the GPU once made robot_box's gradients differ by 2.8e-10). Prints one JSON line per model with the
// times of both devices (world-steps per second forward, world-iterations per second forward
// and backward).
//   usage: test_batch_gpu MODEL.xml... [--worlds N] [--steps T] [--nconmax K] [--device D]
//                                      [--checkpoint S] [--keep]
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


typedef struct runOut_ {           // one device's rollout and gradients
  mjtNum *qpos, *qvel;            // T x nworld x nq, nv
  mjtNum *act;                    // nworld x na: the activations after the rollout
  mjtNum *gctrl, *g0;             // T x nworld x nu; gq0 then gu0 (nworld x nv each)
  mjtNum *gth;                    // nworld x nparam: the parameters' gradients
  int*    status;                 // after the backward pass
  double  fwd_s, bwd_s;           // seconds
} runOut;


// run the batch on device forward and backward; returns 0 or -1
static int run(const mjModel* m, const char* device, int nworld, int T, int checkpoint, int keep,
               const mjtNum* q0, const mjtNum* act0, const mjtNum* ctrl, const mjtNum* gq,
               const mjtNum* gu, runOut* o) {
  char err[1000];
  ostBatch* b = ost_batchCreate(m, nworld, device, err, sizeof(err));
  if (!b) {
    fprintf(stderr, "test_batch_gpu: %s: %s\n", device, err);
    return -1;
  }
  double t0 = now();
  int rc = ost_batchKeepCheckpoints(b, keep ? checkpoint : 0) || ost_batchSetState(b, q0, NULL)
           || (m->na && ost_batchSetAct(b, act0)) || ost_batchRollout(b, T, ctrl, o->qpos, o->qvel)
           || (m->na && ost_batchGetAct(b, o->act));
  double t1 = now();
  ostGradOptions go;
  ost_defaultGradOptions(&go);
  go.params = 1;
  rc = rc || ost_batchBackwardParams(b, &go, checkpoint, gq, gu, o->gctrl, o->g0,
                                     o->g0 + (size_t)nworld * m->nv, o->gth);
  o->fwd_s = t1 - t0;
  o->bwd_s = now() - t1;
  rc = rc || ost_batchStatus(b, o->status);
  if (rc) {
    fprintf(stderr, "test_batch_gpu: %s: %s\n", device, ost_batchError(b));
  }
  ost_batchDelete(b);
  return rc ? -1 : 0;
}


static runOut allocOut(size_t nqs, size_t nvs, size_t nas, size_t ncs, size_t ng0, size_t nth,
                       int nworld) {
  runOut o = {malloc(sizeof(mjtNum) * nqs), malloc(sizeof(mjtNum) * nvs),
              malloc(sizeof(mjtNum) * (nas + 1)),
              malloc(sizeof(mjtNum) * (ncs + 1)), malloc(sizeof(mjtNum) * ng0),
              malloc(sizeof(mjtNum) * (nth + 1)), malloc(sizeof(int) * nworld), 0, 0};
  return o;
}


static void freeOut(runOut* o) {
  free(o->qpos);
  free(o->qvel);
  free(o->act);
  free(o->gctrl);
  free(o->g0);
  free(o->gth);
  free(o->status);
}


// largest |a - b| over n numbers, relative to max(1, |b|); a NaN on one side only counts as
// infinite, NaN on both as agreement
static double arrayDiff(const mjtNum* a, const mjtNum* b, size_t n) {
  double e = 0;
  for (size_t i = 0; i < n; i++) {
    if (isnan(a[i]) || isnan(b[i])) {
      e = isnan(a[i]) && isnan(b[i]) ? e : INFINITY;
    } else {
      e = fmax(e, fabs(a[i] - b[i]) / fmax(1, fabs(b[i])));
    }
  }
  return e;
}


static int runModel(const char* path, int nworld, int T, int nconmax, int checkpoint, int keep,
                    const char* device) {
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
  // activations at the start: within actrange where limited, else in [-0.5, 0.5]
  mjtNum* act0 = (mjtNum*)malloc(sizeof(mjtNum) * (nworld * m->na + 1));
  for (int w = 0; w < nworld; w++) {
    for (int a = m->nu - m->na; a < m->nu; a++) {
      const mjtNum* r = m->actuator_actrange + 2 * a;
      int lim = m->actuator_actlimited[a];
      act0[w * m->na + a - (m->nu - m->na)] = uniform(&seed, lim ? r[0] : -0.5, lim ? r[1] : 0.5);
    }
  }
  // cotangents of the state after every step
  size_t nseq = (size_t)(T + 1) * nworld * nv;
  mjtNum *gq = malloc(sizeof(mjtNum) * nseq), *gu = malloc(sizeof(mjtNum) * nseq);
  for (size_t i = 0; i < nseq; i++) {
    gq[i] = uniform(&seed, -1, 1);
    gu[i] = uniform(&seed, -0.1, 0.1);
  }
  size_t nqs = (size_t)T * nworld * nq, nvs = (size_t)T * nworld * nv;
  size_t ncs = (size_t)T * nworld * nu, ng0 = 2 * (size_t)nworld * nv;
  size_t nth = (size_t)nworld * ost_nparam(m);
  size_t nas = (size_t)nworld * m->na;
  runOut a = allocOut(nqs, nvs, nas, ncs, ng0, nth, nworld);
  runOut c = allocOut(nqs, nvs, nas, ncs, ng0, nth, nworld);
  int ok = !run(m, device, nworld, T, checkpoint, keep, q0, act0, ctrl, gq, gu, &a)
           && !run(m, "cpu", nworld, T, checkpoint, 0, q0, act0, ctrl, gq, gu, &c);
  int nstatus = 0, nfail = 0, nnan = 0, nover = 0;
  double worst = 0, gworst = 0, pworst = 0;
  if (ok) {  // (NaN in one of them is a difference: fmax would skip it)
    worst = fmax(arrayDiff(a.qpos, c.qpos, nqs), arrayDiff(a.qvel, c.qvel, nvs));
    worst = fmax(worst, arrayDiff(a.act, c.act, nas));
    gworst = fmax(arrayDiff(a.gctrl, c.gctrl, ncs), arrayDiff(a.g0, c.g0, ng0));
    pworst = arrayDiff(a.gth, c.gth, nth);
  }
  for (int w = 0; ok && w < nworld; w++) {
    nstatus += a.status[w] != c.status[w];
    nfail += (a.status[w] & (OST_OVERFLOW | OST_NAN | OST_CHOL_FAIL)) != 0;
    nnan += (a.status[w] & OST_NAN) != 0;
    nover += (a.status[w] & OST_OVERFLOW) != 0;
  }
  ok = ok && worst == 0 && gworst == 0 && pworst == 0 && nstatus == 0;
  printf("{\"model\": \"%s\", \"device\": \"%s\", \"worlds\": %d, \"steps\": %d, "
         "\"checkpoint\": %d, \"max_state_diff\": %.3g, \"max_grad_diff\": %.3g, "
         "\"max_param_grad_diff\": %.3g, "
         "\"status_mismatch\": %d, \"failed_worlds\": %d, \"nan_worlds\": %d, "
         "\"overflow_worlds\": %d, \"%s_fwd_s\": %.4f, \"cpu_fwd_s\": %.4f, "
         "\"%s_bwd_s\": %.4f, \"cpu_bwd_s\": %.4f, \"%s_world_iters_per_s\": %.1f, "
         "\"cpu_world_iters_per_s\": %.1f, \"ok\": %s}\n",
         path, device, nworld, T, checkpoint, worst, gworst, pworst, nstatus, nfail, nnan, nover, device,
         a.fwd_s, c.fwd_s, device, a.bwd_s, c.bwd_s, device, nworld / (a.fwd_s + a.bwd_s),
         nworld / (c.fwd_s + c.bwd_s), ok ? "true" : "false");
  free(q0);
  free(act0);
  free(ctrl);
  free(gq);
  free(gu);
  freeOut(&a);
  freeOut(&c);
  mj_deleteModel(m);
  return ok ? 0 : 1;
}


int main(int argc, char** argv) {
  int nworld = 256, T = 30, nconmax = 0, checkpoint = 10, keep = 0, status = 0, nmodel = 0;
  const char* device = "cuda";
  for (int i = 1; i < argc; i++) {
    if (i + 1 < argc && !strcmp(argv[i], "--worlds")) nworld = atoi(argv[++i]);
    else if (i + 1 < argc && !strcmp(argv[i], "--steps")) T = atoi(argv[++i]);
    else if (i + 1 < argc && !strcmp(argv[i], "--nconmax")) nconmax = atoi(argv[++i]);
    else if (i + 1 < argc && !strcmp(argv[i], "--device")) device = argv[++i];
    else if (i + 1 < argc && !strcmp(argv[i], "--checkpoint")) checkpoint = atoi(argv[++i]);
    else if (!strcmp(argv[i], "--keep")) keep = 1;
  }
  for (int i = 1; i < argc; i++) {
    if (argv[i][0] == '-' && argv[i][1] == '-') {
      i += strcmp(argv[i], "--keep") != 0;  // skip the option's value
      continue;
    }
    status |= runModel(argv[i], nworld, T, nconmax, checkpoint, keep, device);
    nmodel++;
  }
  return nmodel ? status : 2;
}
