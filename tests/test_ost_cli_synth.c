// test_ost_cli_synth.c: the loss of `ostrich synth` (plugin/cli/ost_cli_synth.c) against central
// differences (eps 1e-6, normwise relative error below 1e-6), on robot_box.xml:
//   heading  dpsi/ddelta along the local rotation tangent (synth_heading) at 50 random attitudes,
//            the differences taken through mj_integratePos
//   state    the cotangents of synth_stateLoss (every sample's qpos tangent and qvel) on a random
//            path
//   knots    W^T of a random control gradient (synth_pullback) plus the regularizers
//            (synth_regLoss), against differences of sum_k gctrl_k . (W kappa)_k + regularizers
// These were `ostrich synth --selftest` (the same draws: one stream, seed 1, in this order).
// The terrain scene (ost_cli_synth_terrain*.c, --scene terrain):
//   surface  the fixed waves give terrain_hfield.xml's samples (gen_terrain.py's surface); a
//            seed's surface lands on the mesh (world vertices) and on the height field alike,
//            and the fixed waves then give back the mesh as loaded; a seed's mesh is the same
//            bit for bit whatever seeds came before it
//   target   the target knots reproduce the target path (RMSE 0, loss = regularizers only) on
//            both engines, and perturbed knots cost more
//   gradient on a 2 s horizon (seed 5, mostly on the flat start disc), the complete adjoint of
//            the loss against central differences (eps 1e-4 rad/s; normwise 1e-6, measured
//            2e-9), and the truncated one's cosine with them above 0.999 (measured 0.999995)
// The files under test are included whole, so that their static functions can be called.
#include "ost_cli_synth.c"
#include "ost_cli_synth_terrain.c"
#include "ost_cli_synth_terrain_run.c"

#include "fixture.h"

// complete adjoint vs central differences on the 2 s terrain horizon, normwise (measured 2e-9)
#define TER_GRAD_TOL 1e-6


// Normwise relative error of a against b over n entries.
static double relErr(const double* a, const double* b, int n) {
  double diff = 0, scale = 1e-12;
  for (int i = 0; i < n; i++) {
    diff = fmax(diff, fabs(a[i] - b[i]));
    scale = fmax(scale, fabs(b[i]));
  }
  return diff / scale;
}


// A random unit quaternion: yaw up to +-pi, then a tilt of up to 0.5 rad about a random axis.
static void randomQuat(cliRng* rng, mjtNum q[4]) {
  mjtNum yaw[4], tilt[4], axis[3];
  mjtNum zaxis[3] = {0, 0, 1};
  mju_axisAngle2Quat(yaw, zaxis, cli_uniform(rng, -mjPI, mjPI));
  for (int i = 0; i < 3; i++) {
    axis[i] = cli_uniform(rng, -1, 1);
  }
  mju_normalize3(axis);
  mju_axisAngle2Quat(tilt, axis, cli_uniform(rng, -0.5, 0.5));
  mju_mulQuat(q, yaw, tilt);
}


// engine `name` on robot_box.xml with synth's default settings (complete adjoint, forward
// differences of 0.1 rad/s)
static void engineOnBox(synthEngine* e, const char* name) {
  ost_fixtureSetup();
  synthArgs a = {.trials = 10, .iters = 50, .seed = 1, .lr = 0.3, .engine = name,
                 .model = OST_MODEL_DIR "/robot_box.xml", .fd = "forward", .eps = 0.1,
                 .grad = "complete"};
  ck_assert_msg(!synth_engineSetup(e, name, &a), "cannot set up the %s engine on %s", name,
                a.model);
}


START_TEST(test_lossDerivatives) {
  synthEngine e;
  engineOnBox(&e, "mujoco");
  const mjModel* m = e.m;
  int nq = m->nq, nv = m->nv, S = e.nsample, ns = S + 1, bad = 0;
  double eps = 1e-6, err[3];
  cliRng rng;
  cli_rngSeed(&rng, 1);  // synth's default seed: the draws of the former --selftest
  mjtNum* q = (mjtNum*)synth_alloc((size_t)nq, sizeof(mjtNum), &bad);
  mjtNum* qp = (mjtNum*)synth_alloc((size_t)nq, sizeof(mjtNum), &bad);
  mjtNum* qm = (mjtNum*)synth_alloc((size_t)nq, sizeof(mjtNum), &bad);
  mjtNum* dq = (mjtNum*)synth_alloc((size_t)nv, sizeof(mjtNum), &bad);
  double* fd = (double*)synth_alloc((size_t)(2 * ns * nv + e.nvar), sizeof(double), &bad);
  double* an = (double*)synth_alloc((size_t)(2 * ns * nv + e.nvar), sizeof(double), &bad);
  double* gctrl = (double*)synth_alloc((size_t)(e.nstep * e.nu), sizeof(double), &bad);
  double* knots = (double*)synth_alloc((size_t)e.nvar, sizeof(double), &bad);
  ck_assert_msg(!bad, "out of memory");

  // 1. heading along the local rotation tangent, at 50 random attitudes (mj_integratePos)
  for (int trial = 0; trial < 50; trial++) {
    mjtNum dpsi[3];
    mju_zero(q, nq);
    randomQuat(&rng, q + 3);
    synth_heading(q + 3, dpsi);
    for (int i = 0; i < 3; i++) {
      mju_zero(dq, nv);
      dq[3 + i] = 1;
      mju_copy(qp, q, nq);
      mju_copy(qm, q, nq);
      mj_integratePos(m, qp, dq, eps);
      mj_integratePos(m, qm, dq, -eps);
      an[3 * trial + i] = dpsi[i];
      fd[3 * trial + i] = synth_wrap(synth_heading(qp + 3, NULL) - synth_heading(qm + 3, NULL)) /
                          (2 * eps);
    }
  }
  err[0] = relErr(an, fd, 150);

  // 2. state cotangents of a random path (every sample's qpos tangent and qvel)
  synthTask task = {{0.1, -0.1, 0.15}, {3, 0.2, -0.25}};
  for (int s = 0; s < ns; s++) {
    mjtNum* qs = e.qs + s * nq;
    for (int i = 0; i < nq; i++) {
      qs[i] = cli_uniform(&rng, -1, 1);
    }
    qs[0] = cli_uniform(&rng, -0.5, 4);
    randomQuat(&rng, qs + 3);
    for (int i = 0; i < nv; i++) {
      e.vs[s * nv + i] = cli_uniform(&rng, -1, 1);
    }
  }
  synthEval ev;
  synth_stateLoss(&e, &task, e.qs, e.vs, e.gqs, e.gus, &ev);
  mju_copy(an, e.gqs, ns * nv);
  mju_copy(an + ns * nv, e.gus, ns * nv);
  for (int s = 0; s < ns; s++) {
    for (int i = 0; i < 2 * nv; i++) {
      double l[2];
      for (int side = 0; side < 2; side++) {
        double h = side ? -eps : eps;
        mju_copy(q, e.qs + s * nq, nq);
        mjtNum v = e.vs[s * nv + i % nv];
        if (i < nv) {
          mju_zero(dq, nv);
          dq[i] = 1;
          mj_integratePos(m, e.qs + s * nq, dq, h);
        } else {
          e.vs[s * nv + i - nv] += h;
        }
        l[side] = synth_stateLoss(&e, &task, e.qs, e.vs, NULL, NULL, &ev);
        mju_copy(e.qs + s * nq, q, nq);
        e.vs[s * nv + i % nv] = v;
      }
      fd[(i < nv ? 0 : ns * nv) + s * nv + i % nv] = (l[0] - l[1]) / (2 * eps);
    }
  }
  err[1] = relErr(an, fd, 2 * ns * nv);

  // 3. knots: W^T of a random control gradient plus the regularizers, against differences of
  //    sum_k gctrl_k . (W kappa)_k + regularizers
  for (int c = 0; c < e.nvar; c++) {
    knots[c] = cli_uniform(&rng, -3, 3);
  }
  for (int k = 0; k < e.nstep * e.nu; k++) {
    gctrl[k] = cli_uniform(&rng, -1, 1);
  }
  mju_zero(an, e.nvar);
  synth_pullback(&e, gctrl, an);
  synth_regLoss(&e, knots, an);
  // capacity of the local control array below (u[64])
  ck_assert_int_le(e.nu, 64);
  for (int c = 0; c < e.nvar; c++) {
    double l[2];
    for (int side = 0; side < 2; side++) {
      double saved = knots[c];
      mjtNum u[64];
      knots[c] += side ? -eps : eps;
      l[side] = synth_regLoss(&e, knots, NULL);
      for (int k = 0; k < e.nstep; k++) {
        synth_ctrl(&e, knots, k, u);
        l[side] += mju_dot(gctrl + k * e.nu, u, e.nu);
      }
      knots[c] = saved;
    }
    fd[c] = (l[0] - l[1]) / (2 * eps);
  }
  err[2] = relErr(an, fd, e.nvar);

  free(q);
  free(qp);
  free(qm);
  free(dq);
  free(fd);
  free(an);
  free(gctrl);
  free(knots);
  synth_engineFree(&e);
  ck_assert_msg(err[0] < 1e-6, "heading: relative error %g", err[0]);
  ck_assert_msg(err[1] < 1e-6, "state cotangents: relative error %g", err[1]);
  ck_assert_msg(err[2] < 1e-6, "knot gradient: relative error %g", err[2]);
}
END_TEST


//---------------------------------- Terrain scene -------------------------------------------------

// Arguments of the terrain scene with engine `name`.
static synthArgs terrainArgs(void) {
  synthArgs a = {.trials = 1, .iters = 1, .seed = 1, .lr = 0.3, .engine = "ostrich",
                 .model = OST_MODEL_DIR "/terrain_mesh.xml", .fd = "central", .eps = 0.1,
                 .grad = "truncated", .scene = "terrain"};
  return a;
}


// World positions of the terrain mesh's vertices (3 x nvert, allocated).
static double* meshWorld(const terEngine* e) {
  const mjModel* m = e->m;
  int g = e->geom, id = m->geom_dataid[g], n = m->mesh_vertnum[id];
  double* w = (double*)malloc(sizeof(double) * 3 * (size_t)n);
  mjtNum R[9];
  mju_quat2Mat(R, m->geom_quat + 4 * g);
  for (int v = 0; v < n && w; v++) {
    const float* p = m->mesh_vert + 3 * (m->mesh_vertadr[id] + v);
    mjtNum local[3] = {p[0], p[1], p[2]};
    mju_mulMatVec(w + 3 * v, R, local, 3, 3);
    mju_addTo3(w + 3 * v, m->geom_pos + 3 * g);
  }
  return w;
}


// cli_resetState: an Ostrich rollout (tape and adjoint) from the state that the rollout of other
// knots left behind equals, bit for bit, the same rollout after mj_resetData (which clears MuJoCo's
// whole buffer): the sampled states and the knots' adjoint gradient
START_TEST(test_rolloutReset) {
  synthEngine e;
  engineOnBox(&e, "ostrich");
  const mjModel* m = e.m;
  int bad = 0, ns = e.nsample + 1;
  synthTask task = {{0.1, -0.1, 0.15}, {3, 0.2, -0.25}};
  double* knots = (double*)synth_alloc((size_t)e.nvar, sizeof(double), &bad);
  double* other = (double*)synth_alloc((size_t)e.nvar, sizeof(double), &bad);
  double* g[2];
  mjtNum* qs[2];
  for (int r = 0; r < 2; r++) {
    g[r] = (double*)synth_alloc((size_t)e.nvar, sizeof(double), &bad);
    qs[r] = (mjtNum*)synth_alloc((size_t)ns * (m->nq + m->nv), sizeof(mjtNum), &bad);
  }
  ck_assert_msg(!bad, "out of memory");
  for (int i = 0; i < e.nvar; i++) {
    knots[i] = i % 10 == 9 ? 0 : 1.5;  // over the box at 1.5 rad/s: the optimizer's start
    other[i] = i % 10 == 9 ? 0 : 1.0;
  }
  for (int r = 0; r < 2; r++) {
    // leave the data dirty: the other knots' rollout, a contact-rich state and MuJoCo arrays
    ck_assert_int_eq(synth_rollout(&e, &task, other, e.qs, e.vs), SYNTH_OK);
    if (r == 1) {
      mj_resetData(m, e.d);  // the reference: the whole buffer cleared (synth_start resets too)
    }
    synthEval ev;
    int status = synth_gradAdjoint(&e, &task, knots, &ev, g[r]);
    ck_assert_msg(status == SYNTH_OK, "rollout %d: %s", r, e.why);
    memcpy(qs[r], e.qs, (size_t)ns * m->nq * sizeof(mjtNum));
    memcpy(qs[r] + (size_t)ns * m->nq, e.vs, (size_t)ns * m->nv * sizeof(mjtNum));
  }
  ck_assert_msg(!memcmp(qs[0], qs[1], (size_t)ns * (m->nq + m->nv) * sizeof(mjtNum)),
                "the sampled states differ after cli_resetState");
  ck_assert_msg(!memcmp(g[0], g[1], (size_t)e.nvar * sizeof(double)),
                "the knot gradients differ after cli_resetState");
  for (int r = 0; r < 2; r++) {
    free(g[r]);
    free(qs[r]);
  }
  free(knots);
  free(other);
  synth_engineFree(&e);
}
END_TEST


START_TEST(test_terrainSurface) {
  ost_fixtureSetup();
  synthArgs a = terrainArgs();
  terEngine eo, em;
  ck_assert(!ter_engineSetup(&eo, "ostrich", a.model, &a));
  ck_assert(!ter_engineSetup(&em, "mujoco", OST_MODEL_DIR "/terrain_hfield.xml", &a));
  static float data[TER_NGRID * TER_NGRID];
  int nvert = eo.m->mesh_vertnum[eo.m->geom_dataid[eo.geom]];
  const float* hdata = em.m->hfield_data + em.m->hfield_adr[em.m->geom_dataid[em.geom]];

  // 1. the fixed waves: the height field as loaded (float data, so 1e-6)
  terTask task;
  ter_fixedWaves(&task);
  ter_heights(&task, data);
  double err_fixed = 0;
  for (int i = 0; i < TER_NGRID * TER_NGRID; i++) {
    err_fixed = fmax(err_fixed, fabs(data[i] - hdata[i]));
  }
  ck_assert_msg(err_fixed < 1e-6, "fixed waves vs terrain_sinusoid.bin: %g", err_fixed);

  // 2. seed 7's surface on both scenes: mesh vertex z = ZLO + SPAN data, x and y kept; the
  //    height field holds the same data
  double* w0 = meshWorld(&eo);
  ter_task(7, eo.lo, eo.hi, &task);
  ter_heights(&task, data);
  ter_setTerrain(&eo, data);
  ter_setTerrain(&em, data);
  double* w1 = meshWorld(&eo);
  double err_xy = 0, err_z = 0, moved = 0;
  for (int v = 0; v < nvert; v++) {
    err_xy = fmax(err_xy, fmax(fabs(w1[3 * v] - w0[3 * v]), fabs(w1[3 * v + 1] - w0[3 * v + 1])));
    err_z = fmax(err_z, fabs(w1[3 * v + 2] - (TER_ZLO + TER_SPAN * data[eo.vgrid[v]])));
    moved = fmax(moved, fabs(w1[3 * v + 2] - w0[3 * v + 2]));
  }
  ck_assert_msg(err_xy < 1e-5 && err_z < 1e-5, "seed 7 on the mesh: xy moved %g, z off %g",
                err_xy, err_z);
  ck_assert_msg(moved > 0.02, "seed 7's surface is the fixed one (vertices moved %g m)", moved);
  ck_assert(!memcmp(hdata, data, sizeof(data)));

  // 3. the fixed waves again give back the mesh as loaded
  ter_fixedWaves(&task);
  ter_heights(&task, data);
  ter_setTerrain(&eo, data);
  free(w1);
  w1 = meshWorld(&eo);
  double err_back = 0;
  for (int i = 0; i < 3 * nvert; i++) {
    err_back = fmax(err_back, fabs(w1[i] - w0[i]));
  }
  ck_assert_msg(err_back < 1e-5, "mesh after seed 7 then the fixed waves: %g m off", err_back);

  // 4. a seed's mesh does not depend on the seeds before it: seed 9 after seed 7 (and the fixed
  //    waves) is seed 9 from the loaded mesh, bit for bit
  int id = eo.m->geom_dataid[eo.geom];
  float* mesh = eo.m->mesh_vert + 3 * eo.m->mesh_vertadr[id];
  float* after = (float*)malloc(sizeof(float) * 3 * (size_t)nvert);
  ck_assert(after);
  ter_task(9, eo.lo, eo.hi, &task);
  ter_heights(&task, data);
  ter_setTerrain(&eo, data);
  memcpy(after, mesh, sizeof(float) * 3 * (size_t)nvert);
  memcpy(mesh, eo.vert0, sizeof(float) * 3 * (size_t)nvert);
  ter_setTerrain(&eo, data);
  ck_assert_msg(!memcmp(after, mesh, sizeof(float) * 3 * (size_t)nvert),
                "seed 9's mesh depends on the seeds applied before it");
  free(after);
  free(w0);
  free(w1);
  ter_engineFree(&eo);
  ter_engineFree(&em);
}
END_TEST


START_TEST(test_terrainTarget) {
  ost_fixtureSetup();
  synthArgs a = terrainArgs();
  const char* names[2] = {"ostrich", "mujoco"};
  const char* paths[2] = {OST_MODEL_DIR "/terrain_mesh.xml", OST_MODEL_DIR "/terrain_hfield.xml"};
  static float data[TER_NGRID * TER_NGRID];
  terTask task;
  cliRng rng;
  cli_rngSeed(&rng, 3);
  for (int k = 0; k < 2; k++) {
    terEngine e;
    ck_assert(!ter_engineSetup(&e, names[k], paths[k], &a));
    ter_task(3, e.lo, e.hi, &task);
    ter_heights(&task, data);
    ter_setTerrain(&e, data);
    ck_assert_int_eq(ter_setTarget(&e, task.target), TER_OK);

    // the robot went somewhere: the target path is at least 3 m long
    double* end = e.ref + 3 * e.nsample;
    ck_assert_msg(hypot(end[0], end[1]) > 3, "%s: target path ends at (%g, %g)", names[k],
                  end[0], end[1]);

    // the target knots: RMSE 0, the loss is the regularizers alone
    double rmse = -1, loss0;
    ck_assert_int_eq(ter_rollout(&e, task.target, e.qs, e.vs), TER_OK);
    loss0 = ter_stateLoss(&e, e.qs, NULL, &rmse) + ter_regLoss(task.target, NULL);
    ck_assert_msg(rmse == 0, "%s: RMSE of the target knots %g", names[k], rmse);
    ck_assert_double_eq_tol(loss0, ter_regLoss(task.target, NULL), 1e-15);

    // perturbed knots (0.3 rad/s per knot) cost more; the guess costs more still
    double knots[TER_NVAR], loss;
    for (int trial = 0; trial < 3; trial++) {
      for (int c = 0; c < TER_NVAR; c++) {
        knots[c] = task.target[c] + cli_uniform(&rng, -0.3, 0.3);
      }
      ck_assert_int_eq(ter_rollout(&e, knots, e.qs, e.vs), TER_OK);
      loss = ter_stateLoss(&e, e.qs, NULL, &rmse) + ter_regLoss(knots, NULL);
      ck_assert_msg(loss > loss0 && rmse > 1e-3, "%s: perturbed knots: loss %g (target %g), "
                    "RMSE %g", names[k], loss, loss0, rmse);
    }
    ter_engineFree(&e);
  }
}
END_TEST


START_TEST(test_terrainGradient) {
  ost_fixtureSetup();
  synthArgs a = terrainArgs();
  static float data[TER_NGRID * TER_NGRID];
  terEngine e;
  terTask task;
  terEval ev;
  ck_assert(!ter_engineSetup(&e, "ostrich", a.model, &a));
  ter_task(5, e.lo, e.hi, &task);
  ter_heights(&task, data);
  ter_setTerrain(&e, data);

  // a 2 s horizon (25 steps; the knots after 2 s have no influence, gradient 0)
  e.nsample = 25;
  e.nstep = 25;
  ck_assert_int_eq(ter_setTarget(&e, task.target), TER_OK);
  double an[2][TER_NVAR], fd[TER_NVAR], knots[TER_NVAR], eps = 1e-4;
  for (int tr = 0; tr < 2; tr++) {
    e.truncate = tr;
    ck_assert_int_eq(ter_gradAdjoint(&e, task.guess, &ev, an[tr]), TER_OK);
  }
  for (int c = 0; c < TER_NVAR; c++) {
    double l[2];
    for (int side = 0; side < 2; side++) {
      int status;
      memcpy(knots, task.guess, sizeof(knots));
      knots[c] += side ? -eps : eps;
      l[side] = ter_rolloutLoss(&e, knots, &status);
      ck_assert_int_eq(status, TER_OK);
    }
    fd[c] = (l[0] - l[1]) / (2 * eps);
  }
  double err = relErr(an[0], fd, TER_NVAR), dot = 0, n0 = 0, n1 = 0;
  for (int c = 0; c < TER_NVAR; c++) {
    dot += an[1][c] * fd[c];
    n0 += fd[c] * fd[c];
    n1 += an[1][c] * an[1][c];
  }
  double cosine = dot / sqrt(n0 * n1);
  ter_engineFree(&e);
  ck_assert_msg(n0 > 1e-6, "the loss does not depend on the knots (|grad| %g)", sqrt(n0));
  ck_assert_msg(err < TER_GRAD_TOL, "complete adjoint vs central differences: %g", err);
  ck_assert_msg(cosine > 0.999, "truncated adjoint vs central differences: cosine %g", cosine);
}
END_TEST


static Suite* suite(void) {
  Suite* s = suite_create("ost_cli_synth");
  TCase* tc = tcase_create("loss");
  tcase_add_test(tc, test_lossDerivatives);
  tcase_add_test(tc, test_rolloutReset);
  suite_add_tcase(s, tc);
  TCase* tt = tcase_create("terrain");
  tcase_set_timeout(tt, 60);
  tcase_add_test(tt, test_terrainSurface);
  tcase_add_test(tt, test_terrainTarget);
  tcase_add_test(tt, test_terrainGradient);
  suite_add_tcase(s, tt);
  return s;
}


int main(void) {
  return ost_fixtureRun(suite());
}
