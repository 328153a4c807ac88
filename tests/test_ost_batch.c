// test_ost_batch.c: the batched API (plugin/ost_batch.c, core/ost_batch.h) on the CPU:
// a batch world steps as ost_step with the native provider does; a mixed batch (different
// states and controls, a world with a NaN control, a world that overflows its contact capacity)
// gives every world the result it gets alone, for any number of threads, and failed worlds keep
// their state; bad arguments and devices are refused with a message.
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "fixture.h"
#include "ost_batch.h"
#include "ostrich.h"

// largest |a - b| over n numbers
static double maxDiff(const mjtNum* a, const mjtNum* b, int n) {
  double e = 0;
  for (int i = 0; i < n; i++) {
    e = fmax(e, fabs(a[i] - b[i]));
  }
  return e;
}


// new data of m whose ost_step takes the native provider, as a batch does
static mjData* nativeData(const mjModel* m) {
  mjData* d = mj_makeData(m);
  ostOptions o;
  ck_assert_int_eq(ost_readOptions(m, &o, NULL, 0), OST_OK);
  o.geometry = OST_GEOMETRY_NATIVE;
  ck_assert_int_eq(ost_setOptions(m, d, &o), OST_OK);
  return d;
}


// the mixed batch: world i starts at qpos0 shifted by (0.15 i, 0.05 i) m and yawed by 0.03 i
// rad; worlds 0 and 1 rest (controls 0), world i >= 2 drives at 0.6 (i - 1) rad/s with a
// differential of 0.2 i; world `nan_world` gets a NaN control at step `nan_step`
static void mixedStart(const mjModel* m, int nworld, mjtNum* qpos, mjtNum* ctrl, int nstep,
                       int nan_world, int nan_step) {
  for (int i = 0; i < nworld; i++) {
    mjtNum* q = qpos + i * m->nq;
    memcpy(q, m->qpos0, m->nq * sizeof(mjtNum));
    q[0] += 0.15 * i;
    q[1] += 0.05 * i;
    mjtNum yaw = 0.03 * i;
    q[3] = cos(yaw / 2);
    q[6] = sin(yaw / 2);
    for (int t = 0; t < nstep; t++) {
      mjtNum* u = ctrl + (t * nworld + i) * m->nu;
      for (int a = 0; a < m->nu; a++) {
        u[a] = i < 2 ? 0 : 0.6 * (i - 1) + (a == 0 ? -0.1 : 0.1) * i;
      }
      if (i == nan_world && t == nan_step) u[0] = NAN;
    }
  }
}


// a batch world equals ost_step with the native provider bitwise, step by step (the robot climbs
// the box and splits steps)
START_TEST(test_batchEqualsStep) {
  ost_fixtureSetup();
  mjModel* m = ost_fixtureLoadModel("robot_box.xml");
  mjData* d = nativeData(m);
  char err[1000];
  ostBatch* b = ost_batchCreate(m, 1, "cpu:1", err, sizeof(err));
  ck_assert_msg(b != NULL, "%s", err);
  mjtNum qpos[64], qvel[64], ctrl[3] = {3, 3.2, 3};
  for (int a = 0; a < m->nu; a++) d->ctrl[a] = ctrl[a];
  ck_assert_int_eq(ost_batchSetCtrl(b, ctrl), OST_OK);
  double worst = 0;
  int nstep = 40;  // 4 s at h = 0.1 s: on the box at x = 1 m and over it
  for (int k = 0; k < nstep; k++) {
    ck_assert_int_eq(ost_step(m, d), OST_OK);
    ck_assert_int_eq(ost_batchStep(b), OST_OK);
    ck_assert_int_eq(ost_batchGetState(b, qpos, qvel), OST_OK);
    worst = fmax(worst, fmax(maxDiff(qpos, d->qpos, m->nq), maxDiff(qvel, d->qvel, m->nv)));
  }
  int status;
  ck_assert_int_eq(ost_batchStatus(b, &status), OST_OK);
  printf("batch vs ost_step (native), robot_box 40 steps: max |diff| %.3g, x %.3f m, status %d\n",
         worst, d->qpos[0], status);
  ck_assert_double_gt(d->qpos[0], 2.0);  // it crossed the box
  ck_assert_int_eq(status & ~OST_NOT_CONVERGED, 0);
  // the same functions in the same order: the same bits
  ck_assert_double_eq(worst, 0);
  ost_batchDelete(b);
  ost_deleteData(d);
  mj_deleteModel(m);
}
END_TEST


// run the mixed batch of nworld worlds on device for nstep steps; outputs as ost_batchRollout
static void runMixed(const mjModel* m, const char* device, int nworld, int nstep,
                     const mjtNum* qpos0, const mjtNum* ctrl, mjtNum* qpos, mjtNum* qvel,
                     int* status) {
  char err[1000];
  ostBatch* b = ost_batchCreate(m, nworld, device, err, sizeof(err));
  ck_assert_msg(b != NULL, "%s", err);
  ck_assert_int_eq(ost_batchSetState(b, qpos0, NULL), OST_OK);
  ck_assert_int_eq(ost_batchRollout(b, nstep, ctrl, qpos, qvel), OST_OK);
  ck_assert_int_eq(ost_batchStatus(b, status), OST_OK);
  ost_batchDelete(b);
}


// mixed batch: each world's trajectory equals its own single-world run bitwise, for 1, 2 and 3
// threads; the NaN world stops with OST_NAN and keeps its state; a capacity of 4 contacts
// overflows for the worlds that reach the box edge and only for them
START_TEST(test_batchMixed) {
  ost_fixtureSetup();
  mjModel* m = ost_fixtureLoadModel("robot_box.xml");
  m->nconmax = 7;  // 6 on flat ground (two per wheel); a wheel on the box edge adds more
  int nworld = 7, nstep = 30, nan_world = 1, nan_step = 10, nq = m->nq, nv = m->nv;
  mjtNum* q0 = (mjtNum*)calloc(nworld * nq, sizeof(mjtNum));
  mjtNum* ctrl = (mjtNum*)calloc(nstep * nworld * m->nu, sizeof(mjtNum));
  mjtNum* qpos[3];
  mjtNum* qvel[3];
  int status[3][8];
  mixedStart(m, nworld, q0, ctrl, nstep, nan_world, nan_step);
  const char* devices[3] = {"cpu:1", "cpu:2", "cpu:3"};
  for (int r = 0; r < 3; r++) {
    qpos[r] = (mjtNum*)calloc(nstep * nworld * nq, sizeof(mjtNum));
    qvel[r] = (mjtNum*)calloc(nstep * nworld * nv, sizeof(mjtNum));
    runMixed(m, devices[r], nworld, nstep, q0, ctrl, qpos[r], qvel[r], status[r]);
  }

  // thread counts agree bitwise
  for (int r = 1; r < 3; r++) {
    ck_assert_int_eq(memcmp(qpos[0], qpos[r], nstep * nworld * nq * sizeof(mjtNum)), 0);
    ck_assert_int_eq(memcmp(qvel[0], qvel[r], nstep * nworld * nv * sizeof(mjtNum)), 0);
    ck_assert_int_eq(memcmp(status[0], status[r], nworld * sizeof(int)), 0);
  }

  // each world alone gives the same trajectory
  mjtNum* q1 = (mjtNum*)calloc(nstep * nq, sizeof(mjtNum));
  mjtNum* v1 = (mjtNum*)calloc(nstep * nv, sizeof(mjtNum));
  mjtNum* c1 = (mjtNum*)calloc(nstep * m->nu, sizeof(mjtNum));
  int overflowed = 0, clean = 0;
  for (int i = 0; i < nworld; i++) {
    int s1;
    for (int t = 0; t < nstep; t++) {
      memcpy(c1 + t * m->nu, ctrl + (t * nworld + i) * m->nu, m->nu * sizeof(mjtNum));
    }
    runMixed(m, "cpu:1", 1, nstep, q0 + i * nq, c1, q1, v1, &s1);
    for (int t = 0; t < nstep; t++) {
      ck_assert_int_eq(memcmp(q1 + t * nq, qpos[0] + (t * nworld + i) * nq, nq * sizeof(mjtNum)),
                       0);
      ck_assert_int_eq(memcmp(v1 + t * nv, qvel[0] + (t * nworld + i) * nv, nv * sizeof(mjtNum)),
                       0);
    }
    ck_assert_int_eq(s1, status[0][i]);
    overflowed += (status[0][i] & OST_OVERFLOW) != 0;
    clean += (status[0][i] & ~OST_NOT_CONVERGED) == 0;
    printf("mixed world %d: status %d, x %.3f m at the end\n", i, status[0][i],
           qpos[0][((nstep - 1) * nworld + i) * nq]);
  }

  // the NaN world: OST_NAN from step nan_step on, its state frozen at the step before
  ck_assert_int_eq(status[0][nan_world], OST_NAN);
  for (int t = nan_step; t < nstep; t++) {
    ck_assert_int_eq(memcmp(qpos[0] + (t * nworld + nan_world) * nq,
                            qpos[0] + ((nan_step - 1) * nworld + nan_world) * nq,
                            nq * sizeof(mjtNum)), 0);
  }
  ck_assert_int_gt(overflowed, 0);
  ck_assert_int_gt(clean, 0);
  for (int r = 0; r < 3; r++) {
    free(qpos[r]);
    free(qvel[r]);
  }
  free(q0);
  free(ctrl);
  free(q1);
  free(v1);
  free(c1);
  mj_deleteModel(m);
}
END_TEST



// loss of each world: x + 0.3 y + 0.5 vx of its state after the last step (qpos (nworld x nq))
static void worldLoss(const mjModel* m, int nworld, const mjtNum* qpos, const mjtNum* qvel,
                      mjtNum* L) {
  for (int i = 0; i < nworld; i++) {
    L[i] = qpos[i * m->nq] + 0.3 * qpos[i * m->nq + 1] + 0.5 * qvel[i * m->nv];
  }
}


// the batch's backward pass equals central differences of its own rollouts (robot on the floor
// short of the box, four worlds with their own starts and per-step controls, 15 steps at h = 0.1 s); a world with
// a NaN control gets NaN gradients and OST_NAN; a rollout that did not start from a set state
// has no backward pass
START_TEST(test_batchBackward) {
  ost_fixtureSetup();
  mjModel* m = ost_fixtureLoadModel("robot_box.xml");
  int nw = 4, T = 15, nq = m->nq, nv = m->nv, nu = m->nu;
  char err[1000];
  ostBatch* b = ost_batchCreate(m, nw, "cpu:2", err, sizeof(err));
  ck_assert_msg(b != NULL, "%s", err);
  mjtNum* q0 = calloc(nw * nq, sizeof(mjtNum));
  mjtNum* ctrl = calloc(T * nw * nu, sizeof(mjtNum));
  mjtNum *qpos = calloc(nw * nq, sizeof(mjtNum)), *qvel = calloc(nw * nv, sizeof(mjtNum));
  mjtNum *gq = calloc((T + 1) * nw * nv, sizeof(mjtNum)), *gu = calloc((T + 1) * nw * nv, 8);
  mjtNum* gctrl = calloc(T * nw * nu, sizeof(mjtNum));
  for (int i = 0; i < nw; i++) {
    memcpy(q0 + i * nq, m->qpos0, nq * sizeof(mjtNum));
    q0[i * nq] = -1;  // 2 m before the box: flat ground for the whole rollout
    q0[i * nq + 1] = 0.1 * i;
    q0[i * nq + 3] = cos(0.05 * i);
    q0[i * nq + 6] = sin(0.05 * i);
    for (int t = 0; t < T; t++) {
      for (int a = 0; a < nu; a++) {
        ctrl[(t * nw + i) * nu + a] = 1 + 0.5 * sin(0.7 * t + a + i);
      }
    }
    gq[(T * nw + i) * nv + 0] = 1;
    gq[(T * nw + i) * nv + 1] = 0.3;
    gu[(T * nw + i) * nv + 0] = 0.5;
  }
  ctrl[(5 * nw + 3) * nu] = NAN;  // world 3 fails at step 5

  ck_assert_int_eq(ost_batchSetState(b, q0, NULL), OST_OK);
  ck_assert_int_eq(ost_batchRollout(b, T, ctrl, NULL, NULL), OST_OK);
  ck_assert_int_eq(ost_batchBackward(b, NULL, 0, gq, gu, gctrl, NULL, NULL), OST_OK);
  int status[4];
  ck_assert_int_eq(ost_batchStatus(b, status), OST_OK);
  ck_assert_int_eq(status[3] & OST_NAN, OST_NAN);

  // central differences of the loss over single controls
  const int probes[4][2] = {{2, 0}, {7, 1}, {11, 2}, {14, 0}};
  double worst = 0, eps = 1e-6;
  for (int p = 0; p < 4; p++) {
    mjtNum Lp[4], Lm[4];
    for (int sgn = 0; sgn < 2; sgn++) {
      for (int i = 0; i < 3; i++) ctrl[(probes[p][0] * nw + i) * nu + probes[p][1]] += sgn ? -2 * eps : eps;
      ck_assert_int_eq(ost_batchSetState(b, q0, NULL), OST_OK);
      ck_assert_int_eq(ost_batchRollout(b, T, ctrl, NULL, NULL), OST_OK);
      ck_assert_int_eq(ost_batchGetState(b, qpos, qvel), OST_OK);
      worldLoss(m, nw, qpos, qvel, sgn ? Lm : Lp);
    }
    for (int i = 0; i < 3; i++) ctrl[(probes[p][0] * nw + i) * nu + probes[p][1]] += eps;
    for (int i = 0; i < 3; i++) {
      double fd = (Lp[i] - Lm[i]) / (2 * eps), g = gctrl[(probes[p][0] * nw + i) * nu + probes[p][1]];
      // each step is converged to tol = 1e-10 m/s only, so the central differences carry an
      // absolute error of order 1e-6 (tol over eps, times the steps' gain); small gradients
      // are compared in absolute terms below 1e-2 (largest gradients here about 0.06)
      double e = fabs(g - fd) / fmax(1e-2, fabs(fd));
      worst = fmax(worst, e);
      printf("backward world %d ctrl[t=%d, a=%d]: adjoint %.8g, central differences %.8g\n", i,
             probes[p][0], probes[p][1], g, fd);
    }
    ck_assert(isnan(gctrl[(probes[p][0] * nw + 3) * nu + probes[p][1]]));
  }
  printf("batch backward vs central differences: max relative error %.3g\n", worst);
  // the 1e-6 absolute error of the differences over the 1e-2 floor above (measured: 5.5e-5)
  ck_assert_double_lt(worst, 1e-4);

  // a rollout that continues the last one has no record
  ck_assert_int_eq(ost_batchRollout(b, 2, NULL, NULL, NULL), OST_OK);
  ck_assert_int_eq(ost_batchBackward(b, NULL, 0, gq, gu, gctrl, NULL, NULL), OST_ERR_INPUT);
  ck_assert_ptr_nonnull(strstr(ost_batchError(b), "no rollout recorded"));
  ost_batchDelete(b);
  free(q0);
  free(ctrl);
  free(qpos);
  free(qvel);
  free(gq);
  free(gu);
  free(gctrl);
  mj_deleteModel(m);
}
END_TEST


// the batch's backward pass (core/ost_batch_adjoint.h: replay from segment checkpoints) gives
// the gradients of the plugin's tape (ost_tapeStep with the native provider, then
// ost_tapeBackward) for every world: three robots climbing the box (splits, contact changes),
// 30 steps, cotangents at every step; with no checkpoints and with segments of 4 and 7 steps;
// the parameters' gradients (friction, masses, damping, servo gains) too
START_TEST(test_batchBackwardEqualsTape) {
  ost_fixtureSetup();
  mjModel* m = ost_fixtureLoadModel("robot_box.xml");
  int nw = 3, T = 30, nq = m->nq, nv = m->nv, nu = m->nu, np = ost_nparam(m);
  ostGradOptions go;
  ost_defaultGradOptions(&go);
  go.params = 1;
  go.forward_only = 1;  // the tape takes the batch's path, so the bits must agree
  mjtNum *tth = calloc(nw * np, 8), *gth = calloc(nw * np, 8);
  mjtNum* q0 = calloc(nw * nq, sizeof(mjtNum));
  mjtNum* ctrl = calloc(T * nw * nu, sizeof(mjtNum));
  mjtNum *gq = calloc((T + 1) * nw * nv, 8), *gu = calloc((T + 1) * nw * nv, 8);
  mjtNum *gctrl = calloc(T * nw * nu, 8), *gq0 = calloc(nw * nv, 8), *gu0 = calloc(nw * nv, 8);
  for (int i = 0; i < nw; i++) {
    memcpy(q0 + i * nq, m->qpos0, nq * sizeof(mjtNum));
    q0[i * nq] = -0.2 - 0.15 * i;
    q0[i * nq + 3] = cos(0.04 * i);
    q0[i * nq + 6] = sin(0.04 * i);
    for (int t = 0; t < T; t++) {
      for (int a = 0; a < nu; a++) ctrl[(t * nw + i) * nu + a] = 3 + 0.4 * sin(0.5 * t + a + i);
    }
    for (int t = 0; t <= T; t++) {
      for (int j = 0; j < nv; j++) {
        gq[(t * nw + i) * nv + j] = sin(1.3 * t + j + 2 * i);
        gu[(t * nw + i) * nv + j] = 0.1 * cos(0.7 * t + j - i);
      }
    }
  }

  // the oracle: each world through a tape
  mjtNum *tq = calloc((T + 1) * nv, 8), *tu = calloc((T + 1) * nv, 8);
  mjtNum *tc = calloc(nw * T * nu, 8), *tq0 = calloc(nw * nv, 8), *tu0 = calloc(nw * nv, 8);
  mjData* d = nativeData(m);
  ostTape* tape = ost_tapeCreate(m, 0);
  for (int i = 0; i < nw; i++) {
    mj_resetData(m, d);
    memcpy(d->qpos, q0 + i * nq, nq * sizeof(mjtNum));
    ost_tapeClear(tape);
    for (int t = 0; t < T; t++) {
      memcpy(d->ctrl, ctrl + (t * nw + i) * nu, nu * sizeof(mjtNum));
      ck_assert_int_eq(ost_tapeStep(tape, m, d), OST_OK);
    }
    for (int t = 0; t <= T; t++) {
      memcpy(tq + t * nv, gq + (t * nw + i) * nv, nv * sizeof(mjtNum));
      memcpy(tu + t * nv, gu + (t * nw + i) * nv, nv * sizeof(mjtNum));
    }
    ck_assert_int_eq(ost_tapeBackward(tape, m, &go, tq, tu, tc + i * T * nu, tq0 + i * nv,
                                      tu0 + i * nv, tth + i * np), OST_OK);
    printf("tape world %d: x %.3f m after %d steps\n", i, d->qpos[0], T);
    ck_assert_double_gt(d->qpos[0], 0.45);  // on the box's edge or over it
  }

  char err[1000];
  ostBatch* b = ost_batchCreate(m, nw, "cpu:2", err, sizeof(err));
  ck_assert_msg(b != NULL, "%s", err);
  // checkpoint intervals, and the interval the rollout keeps (0: none; 4 with checkpoint 7:
  // kept but not used; 100 >= T: the start only, one segment)
  const int checkpoints[6] = {0, 4, 7, 4, 7, 0}, keep[6] = {0, 0, 0, 4, 4, 100};
  mjtNum* gctrl4 = calloc(T * nw * nu, 8);
  for (int c = 0; c < 6; c++) {
    ck_assert_int_eq(ost_batchKeepCheckpoints(b, keep[c]), OST_OK);
    ck_assert_int_eq(ost_batchSetState(b, q0, NULL), OST_OK);
    size_t bytes0 = ost_batchBytes(b);
    ck_assert_int_eq(ost_batchRollout(b, T, ctrl, NULL, NULL), OST_OK);
    if (c == 3) {  // ceil(30 / 4) = 8 copies of the worlds, counted in the batch's memory
      ck_assert_uint_gt(ost_batchBytes(b), bytes0);
    }
    if (c < 5) {
      ck_assert_int_eq(ost_batchBackward(b, NULL, checkpoints[c], gq, gu, gctrl, gq0, gu0),
                       OST_OK);
    } else {
      ck_assert_int_eq(ost_batchBackwardParams(b, &go, checkpoints[c], gq, gu, gctrl, gq0, gu0,
                                               gth), OST_OK);
      double wth = 0, sth = 0;
      for (int i = 0; i < nw * np; i++) {
        wth = fmax(wth, fabs(gth[i] - tth[i]));
        sth = fmax(sth, fabs(tth[i]));
      }
      printf("batch parameter gradients vs tape: max |diff| %.3g (largest %.3g)\n", wth, sth);
      ck_assert_double_gt(sth, 0);
      ck_assert_double_le(wth, 1e-9 * sth);  // the same regression baseline as below
    }
    if (c == 1) {
      memcpy(gctrl4, gctrl, T * nw * nu * sizeof(mjtNum));
    }
    if (c == 3) {  // the rollout's checkpoints are the replay's, bit for bit
      ck_assert_int_eq(memcmp(gctrl4, gctrl, T * nw * nu * sizeof(mjtNum)), 0);
    }
    double worst = 0, scale = 0;
    for (int i = 0; i < nw; i++) {
      for (int t = 0; t < T; t++) {
        for (int a = 0; a < nu; a++) {
          double x = gctrl[(t * nw + i) * nu + a], y = tc[(i * T + t) * nu + a];
          worst = fmax(worst, fabs(x - y));
          scale = fmax(scale, fabs(y));
        }
      }
      worst = fmax(worst, fmax(maxDiff(gq0 + i * nv, tq0 + i * nv, nv),
                               maxDiff(gu0 + i * nv, tu0 + i * nv, nv)));
    }
    printf("batch backward (checkpoint %d, kept %d) vs tape: max |diff| %.3g (largest gradient "
           "%.3g)\n", checkpoints[c], keep[c], worst, scale);
    // regression baseline (measured: 0, bit for bit, at the time of writing): the same replayed
    // steps; 1e-9 relative is kept so a summation-order change alone does not fail it
    ck_assert_double_le(worst, 1e-9 * scale);
  }
  int status[3];
  ck_assert_int_eq(ost_batchStatus(b, status), OST_OK);
  for (int i = 0; i < nw; i++) ck_assert_int_eq(status[i] & (OST_OVERFLOW | OST_NAN | OST_CHOL_FAIL), 0);
  ost_batchDelete(b);
  ost_tapeDelete(tape);
  ost_deleteData(d);
  free(q0); free(ctrl); free(gq); free(gu); free(gctrl); free(gq0); free(gu0); free(gctrl4);
  free(tq); free(tu); free(tc); free(tq0); free(tu0); free(tth); free(gth);
  mj_deleteModel(m);
}
END_TEST


// robot_box.xml with `add` (custom numerics) at the start of its <custom>, loaded from the
// fixture's folder (its include made relative to the models)
static mjModel* robotBoxWith(const char* add) {
  char path[1024], *xml = NULL;
  snprintf(path, sizeof(path), "%s/robot_box.xml", OST_MODEL_DIR);
  FILE* f = fopen(path, "rb");
  ck_assert_ptr_nonnull(f);
  fseek(f, 0, SEEK_END);
  long n = ftell(f);
  fseek(f, 0, SEEK_SET);
  xml = calloc(n + strlen(add) + 1200, 1);
  ck_assert_int_eq((long)fread(xml, 1, n, f), n);
  fclose(f);
  char* at = strstr(xml, "<custom>") + strlen("<custom>");
  memmove(at + strlen(add), at, strlen(at) + 1);
  memcpy(at, add, strlen(add));
  at = strstr(xml, "file=\"") + strlen("file=\"");  // the include, from the fixture's /tmp
  char dir[1100];
  snprintf(dir, sizeof(dir), "..%s/", OST_MODEL_DIR);
  memmove(at + strlen(dir), at, strlen(at) + 1);
  memcpy(at, dir, strlen(dir));
  mjModel* m = ost_fixtureLoadString(xml);
  free(xml);
  return m;
}


// a batch splits a step past 3 levels only where the model sets ostrich/deep_splits: with
// split_tol 0 every step splits as far as allowed; without the numeric the batch equals
// ost_step at deep_splits 0 bit for bit (8 substeps, where ost_step's default takes 14), with
// it ost_step at its value
START_TEST(test_batchDeepSplits) {
  ost_fixtureSetup();
  const char* adds[2] = {"<numeric name=\"ostrich/split_tol\" data=\"0\"/>",
                         "<numeric name=\"ostrich/split_tol\" data=\"0\"/>"
                         "<numeric name=\"ostrich/deep_splits\" data=\"2\"/>"};
  for (int c = 0; c < 2; c++) {
    mjModel* m = robotBoxWith(adds[c]);
    char err[1000];
    ostBatch* b = ost_batchCreate(m, 1, "cpu:1", err, sizeof(err));
    ck_assert_msg(b != NULL, "%s", err);
    mjtNum ctrl[3] = {3, 3.2, 3}, qpos[64], qvel[64];
    ck_assert_int_eq(ost_batchSetCtrl(b, ctrl), OST_OK);
    for (int deep = 0; deep <= 6; deep += 2) {
      mjData* d = mj_makeData(m);
      ostOptions o;
      ck_assert_int_eq(ost_readOptions(m, &o, NULL, 0), OST_OK);
      o.geometry = OST_GEOMETRY_NATIVE;
      o.deep_splits = deep;
      ck_assert_int_eq(ost_setOptions(m, d, &o), OST_OK);
      for (int a = 0; a < m->nu; a++) d->ctrl[a] = ctrl[a];
      ost_step(m, d);
      ck_assert_int_eq(ost_stats(d)->substeps, 8 + deep);
      ck_assert_int_eq(ost_batchSetState(b, NULL, NULL), OST_OK);
      ck_assert_int_eq(ost_batchStep(b), OST_OK);
      ck_assert_int_eq(ost_batchGetState(b, qpos, qvel), OST_OK);
      double diff = fmax(maxDiff(qpos, d->qpos, m->nq), maxDiff(qvel, d->qvel, m->nv));
      int same = deep == (c ? 2 : 0);
      ck_assert_msg(same ? diff == 0 : diff > 0, "model %d, ost_step at deep_splits %d: %g", c,
                    deep, diff);
      ost_deleteData(d);
    }
    ost_batchDelete(b);
    mj_deleteModel(m);
  }
}
END_TEST


// the backward pass records at most 2 S + 8 + deep_splits substeps per segment of S steps:
// with split_tol 0 every step splits to split_depth (3 here: 8 substeps); with deep_splits 0
// segments of one step hold them and give the tape's gradients, segments of two steps (16 > 12)
// overflow and say so (NaN gradients, OST_OVERFLOW), and the forward rollout is the same either
// way
START_TEST(test_batchBackwardRecordCapacity) {
  ost_fixtureSetup();
  mjModel* m = robotBoxWith("<numeric name=\"ostrich/split_tol\" data=\"0\"/>"
                             "<numeric name=\"ostrich/split_depth\" data=\"3\"/>"
                             "<numeric name=\"ostrich/deep_splits\" data=\"0\"/>");
  int T = 4, nv = m->nv, nu = m->nu;
  mjtNum ctrl[4 * 3], gq[5 * 9] = {0}, gctrl[4 * 3], gq0[9], gu0[9], tc[4 * 3], tq0[9], tu0[9];
  for (int i = 0; i < T * nu; i++) ctrl[i] = 2;
  gq[T * nv] = 1;

  // the oracle: the tape (no capacity)
  mjData* d = mj_makeData(m);
  ostOptions o;
  ck_assert_int_eq(ost_readOptions(m, &o, NULL, 0), OST_OK);
  ck_assert_double_eq(o.split_tol, 0);
  o.geometry = OST_GEOMETRY_NATIVE;
  ck_assert_int_eq(ost_setOptions(m, d, &o), OST_OK);
  ostTape* tape = ost_tapeCreate(m, 0);
  for (int t = 0; t < T; t++) {
    memcpy(d->ctrl, ctrl + t * nu, nu * sizeof(mjtNum));
    ck_assert_int_eq(ost_tapeStep(tape, m, d), OST_OK);
  }
  ostGradOptions fwd;
  ost_defaultGradOptions(&fwd);
  fwd.forward_only = 1;  // the batch's path, so the bits must agree
  ck_assert_int_eq(ost_tapeBackward(tape, m, &fwd, gq, NULL, tc, tq0, tu0, NULL), OST_OK);

  char err[1000];
  ostBatch* b = ost_batchCreate(m, 1, "cpu:1", err, sizeof(err));
  ck_assert_msg(b != NULL, "%s", err);
  for (int checkpoint = 1; checkpoint <= 2; checkpoint++) {
    int status;
    ck_assert_int_eq(ost_batchSetState(b, NULL, NULL), OST_OK);
    ck_assert_int_eq(ost_batchRollout(b, T, ctrl, NULL, NULL), OST_OK);
    ck_assert_int_eq(ost_batchStatus(b, &status), OST_OK);
    ck_assert_int_eq(status & OST_OVERFLOW, 0);
    ostGradOptions go;
    ost_defaultGradOptions(&go);
    go.params = 1;
    mjtNum gth[64];
    ck_assert_int_le(ost_nparam(m), 64);
    ck_assert_int_eq(ost_batchBackwardParams(b, &go, checkpoint, gq, NULL, gctrl, gq0, gu0, gth),
                     OST_OK);
    ck_assert_int_eq(ost_batchStatus(b, &status), OST_OK);
    printf("split every step, checkpoint %d: status %d, dL/dctrl[0] %.6g (tape %.6g)\n",
           checkpoint, status, gctrl[0], tc[0]);
    for (int i = 0; i < ost_nparam(m); i++) {
      ck_assert(checkpoint == 1 ? isfinite(gth[i]) : isnan(gth[i]));  // NaN for a failed world
    }
    if (checkpoint == 1) {
      ck_assert_double_eq(maxDiff(gctrl, tc, T * nu), 0);
      ck_assert_double_eq(maxDiff(gq0, tq0, nv) + maxDiff(gu0, tu0, nv), 0);
      ck_assert_int_eq(status & OST_OVERFLOW, 0);
    } else {
      ck_assert(isnan(gctrl[0]) && isnan(gq0[0]));
      ck_assert_int_eq(status & OST_OVERFLOW, OST_OVERFLOW);
    }
  }
  ost_batchDelete(b);
  ost_tapeDelete(tape);
  ost_deleteData(d);
  mj_deleteModel(m);
}
END_TEST


// refused: bad arguments, unknown devices, cuda without a CUDA build, models native cannot do
START_TEST(test_batchErrors) {
  ost_fixtureSetup();
  mjModel* m = ost_fixtureLoadModel("robot_box.xml");
  char err[1000];
  ck_assert_ptr_null(ost_batchCreate(NULL, 4, "cpu", err, sizeof(err)));
  ck_assert_ptr_nonnull(strstr(err, "no model"));
  ck_assert_ptr_null(ost_batchCreate(m, 0, "cpu", err, sizeof(err)));
  ck_assert_ptr_nonnull(strstr(err, "nworld"));
  ck_assert_ptr_null(ost_batchCreate(m, 4, "tpu", err, sizeof(err)));
  ck_assert_ptr_nonnull(strstr(err, "unknown device 'tpu'"));
  ck_assert_ptr_null(ost_batchCreate(m, 4, "cpu:0", err, sizeof(err)));
  ostBatch* b = ost_batchCreate(m, 4, "cuda", err, sizeof(err));
  if (!b) {
    printf("cuda: %s\n", err);
    ck_assert_msg(strstr(err, "without CUDA") || strstr(err, "cuda") || strstr(err, "CUDA"),
                  "%s", err);
  }
  ost_batchDelete(b);
  ck_assert_int_eq(ost_batchStep(NULL), -1);
  ck_assert_int_eq(ost_batchSetState(NULL, NULL, NULL), -1);
  b = ost_batchCreate(m, 2, "cpu", err, sizeof(err));
  ck_assert_ptr_nonnull(b);
  ck_assert_int_eq(ost_batchRollout(b, -1, NULL, NULL, NULL), -2);
  ck_assert_int_eq(ost_batchSetCtrl(b, NULL), -2);
  ck_assert_int_eq(ost_batchStatus(b, NULL), -2);
  ost_batchDelete(b);
  mj_deleteModel(m);

  // a model the native provider cannot represent names the reason
  mjModel* e = ost_fixtureLoadString(
      "<mujoco><worldbody><body mocap=\"true\"><geom type=\"box\" size=\"0.1 0.1 0.1\"/>"
      "</body><body pos=\"1 0 0\"><freejoint/><geom type=\"sphere\" size=\"0.1\"/>"
      "</body></worldbody></mujoco>");
  ck_assert_ptr_null(ost_batchCreate(e, 2, "cpu", err, sizeof(err)));
  printf("refused: %s\n", err);
  ck_assert_ptr_nonnull(strstr(err, "mocap"));
  mj_deleteModel(e);
}
END_TEST


// a world of a model with activation dynamics (tests/models/activation_pusher.xml: a filter,
// an integrator and a muscle beside a plain motor; the arm pushes a box) steps as ost_step with
// the native provider, activations included, bit for bit, from activations set away from 0;
// ost_batchSetState zeroes them; and the batch's backward pass gives the tape's gradients,
// the controls' path through the activations included
START_TEST(test_batchActivations) {
  ost_fixtureSetup();
  mjModel* m = ost_fixtureLoadModel("../tests/models/activation_pusher.xml");
  int nq = m->nq, nv = m->nv, nu = m->nu, na = m->na, T = 100;
  ck_assert_int_eq(na, 3);
  mjtNum act0[3] = {0.2, -0.3, 0.4}, qvel[32];
  mjtNum* ctrl = calloc(T * 2 * nu, sizeof(mjtNum));
  for (int t = 0; t < T; t++) {
    for (int i = 0; i < 2; i++) {  // world 1 pushes the box over, world 0 touches it
      mjtNum* u = ctrl + (t * 2 + i) * nu;
      u[0] = 0.5 * sin(0.2 * t + i);
      u[1] = -0.3 + 0.05 * cos(0.1 * t);
      u[2] = 1 + i;
      u[3] = 0.5 + 0.4 * sin(0.3 * t - i);
    }
  }
  mjData* d = nativeData(m);
  char err[1000];
  ostBatch* b = ost_batchCreate(m, 2, "cpu:2", err, sizeof(err));
  ck_assert_msg(b != NULL, "%s", err);
  mjtNum act2[6] = {9, 9, 9, 9, 9, 9};
  ck_assert_int_eq(ost_batchSetAct(b, act2), OST_OK);
  ck_assert_int_eq(ost_batchSetState(b, NULL, NULL), OST_OK);
  ck_assert_int_eq(ost_batchGetAct(b, act2), OST_OK);
  for (int j = 0; j < 6; j++) ck_assert_double_eq(act2[j], 0);  // reset with the state
  ck_assert_int_eq(ost_batchSetAct(b, NULL), -2);
  for (int j = 0; j < 6; j++) act2[j] = act0[j % 3];
  ck_assert_int_eq(ost_batchSetAct(b, act2), OST_OK);

  // forward: world 1 against ost_step, step by step
  memcpy(d->act, act0, sizeof(act0));
  double worst = 0, moved = 0;
  mjtNum* qs = calloc(T * 2 * nq, sizeof(mjtNum));
  for (int t = 0; t < T; t++) {
    memcpy(d->ctrl, ctrl + (t * 2 + 1) * nu, nu * sizeof(mjtNum));
    ck_assert_int_eq(ost_step(m, d), OST_OK);
    ck_assert_int_eq(ost_batchRolloutAct(b, 1, ctrl + t * 2 * nu, qs + t * 2 * nq, NULL, act2),
                     OST_OK);
    ck_assert_int_eq(ost_batchGetState(b, NULL, qvel), OST_OK);
    worst = fmax(worst, fmax(maxDiff(qs + (t * 2 + 1) * nq, d->qpos, nq),
                             maxDiff(qvel + nv, d->qvel, nv)));
    worst = fmax(worst, maxDiff(act2 + na, d->act, na));
    mjtNum act_now[6];
    ck_assert_int_eq(ost_batchGetAct(b, act_now), OST_OK);
    worst = fmax(worst, maxDiff(act_now, act2, 2 * na));
    for (int j = 0; j < na; j++) moved = fmax(moved, fabs(d->act[j] - act0[j]));
  }
  printf("batch vs ost_step (native) with activations, %d steps: max |diff| %.3g, act moved "
         "%.3g, box x %.3f m\n", T, worst, moved, d->qpos[3]);
  ck_assert_double_eq(worst, 0);  // the same functions in the same order
  ck_assert_double_gt(moved, 0.3);  // the activations did move
  ck_assert_double_gt(d->qpos[3], 0.55);  // world 1 pushed the box from x = 0.5 m

  // backward: both worlds against their tapes (forward_only: the batch's path, the same bits)
  ostGradOptions go;
  ost_defaultGradOptions(&go);
  go.forward_only = 1;
  mjtNum *gq = calloc((T + 1) * 2 * nv, 8), *gu = calloc((T + 1) * 2 * nv, 8);
  for (int i = 0; i < (T + 1) * 2 * nv; i++) {
    gq[i] = sin(1.3 * i);
    gu[i] = 0.1 * cos(0.7 * i);
  }
  mjtNum *gctrl = calloc(T * 2 * nu, 8), *g0 = calloc(4 * nv, 8);
  ck_assert_int_eq(ost_batchSetState(b, NULL, NULL), OST_OK);
  ck_assert_int_eq(ost_batchSetAct(b, act2), OST_OK);  // (act0 in both worlds: act2 rows)
  for (int j = 0; j < 6; j++) act2[j] = act0[j % 3];
  ck_assert_int_eq(ost_batchSetAct(b, act2), OST_OK);
  ck_assert_int_eq(ost_batchRollout(b, T, ctrl, NULL, NULL), OST_OK);
  ck_assert_int_eq(ost_batchBackward(b, &go, 7, gq, gu, gctrl, g0, g0 + 2 * nv), OST_OK);
  ostTape* tape = ost_tapeCreate(m, 0);
  mjtNum *tq = calloc((T + 1) * nv, 8), *tu = calloc((T + 1) * nv, 8), *tc = calloc(T * nu, 8);
  mjtNum tq0[16], tu0[16];
  double gworst = 0, scale = 0, through_act = 0;
  for (int i = 0; i < 2; i++) {
    mj_resetData(m, d);
    memcpy(d->act, act0, sizeof(act0));
    ost_tapeClear(tape);
    for (int t = 0; t < T; t++) {
      memcpy(d->ctrl, ctrl + (t * 2 + i) * nu, nu * sizeof(mjtNum));
      ck_assert_int_eq(ost_tapeStep(tape, m, d), OST_OK);
    }
    for (int t = 0; t <= T; t++) {
      memcpy(tq + t * nv, gq + (t * 2 + i) * nv, nv * sizeof(mjtNum));
      memcpy(tu + t * nv, gu + (t * 2 + i) * nv, nv * sizeof(mjtNum));
    }
    ck_assert_int_eq(ost_tapeBackward(tape, m, &go, tq, tu, tc, tq0, tu0, NULL), OST_OK);
    for (int t = 0; t < T; t++) {
      for (int a = 0; a < nu; a++) {
        double y = tc[t * nu + a];
        gworst = fmax(gworst, fabs(gctrl[(t * 2 + i) * nu + a] - y));
        scale = fmax(scale, fabs(y));
        if (a > 0 && t < T - 1) through_act = fmax(through_act, fabs(y));
      }
    }
    gworst = fmax(gworst, fmax(maxDiff(g0 + i * nv, tq0, nv), maxDiff(g0 + (2 + i) * nv, tu0, nv)));
  }
  printf("batch backward with activations vs tape: max |diff| %.3g (largest gradient %.3g)\n",
         gworst, scale);
  ck_assert_double_gt(through_act, 0);  // the stateful actuators' controls act through act+
  ck_assert_double_eq(gworst, 0);  // the same records and the same Jacobians: the same bits
  ost_tapeDelete(tape);
  ost_batchDelete(b);
  ost_deleteData(d);
  free(ctrl); free(qs); free(gq); free(gu); free(gctrl); free(g0); free(tq); free(tu); free(tc);
  mj_deleteModel(m);
}
END_TEST


static Suite* suite(void) {
  Suite* s = suite_create("ost_batch");
  TCase* tc = tcase_create("batch");
  tcase_set_timeout(tc, 600);
  tcase_add_test(tc, test_batchEqualsStep);
  tcase_add_test(tc, test_batchMixed);
  tcase_add_test(tc, test_batchBackward);
  tcase_add_test(tc, test_batchBackwardEqualsTape);
  tcase_add_test(tc, test_batchBackwardRecordCapacity);
  tcase_add_test(tc, test_batchDeepSplits);
  tcase_add_test(tc, test_batchErrors);
  tcase_add_test(tc, test_batchActivations);
  suite_add_tcase(s, tc);
  return s;
}


int main(void) {
  return ost_fixtureRun(suite());
}
