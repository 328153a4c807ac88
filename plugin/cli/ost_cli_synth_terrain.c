// ost_cli_synth_terrain.c: `ostrich synth --scene terrain`, trajectory recovery of the wheeled
// robot over a procedural triangle-mesh terrain (the Ostrich paper, "Beyond Primitives: Terrain
// Traversal"). Shares arguments and optimizer helpers with ost_cli_synth.c (ost_cli_synth.h);
// the optimizer and its outputs (summary, CSV, PNG) are in ost_cli_synth_terrain_run.c.
//
// Instance t (1-based) of a run derives from the one seed --seed + t - 1 (so `--seed S+t-1
// --trials 1` reproduces it), drawn in this order:
//   terrain  h(x, y) = w(r) sum_k a_k sin(2 pi / lambda_k (cos th_k x + sin th_k y) + phi_k),
//            the 4 waves of compare/gen_terrain.py with a_k ~ a0_k U(0.5, 1), th_k ~ U(0, pi),
//            phi_k ~ U(0, 2 pi) (wavelengths kept, 3.5-7 m), w(r) its smoothstep (flat within
//            1.2 m of the origin, where the robot starts). Sampled on the 80 x 80 grid of
//            terrain_sinusoid.bin (24 x 24 m, 12,482 triangles) and quantized as that file is
//            (float data in [0, 1] over the file's elevation range), then written into the
//            Ostrich scene's mesh_vert (followed by ost_modelChanged) and the MuJoCo scene's
//            hfield_data: both engines collide the same surface.
//   target   K = 10 knots per wheel: base b_j ~ U(1, 3) rad/s, turn d_j ~ U(-0.5, 0.5) rad/s;
//            left = b + d, right = b - d, rear = b (correlated left/right velocities).
//   guess    target + N(0, 1.5^2) rad/s per knot, projected onto ctrlrange.
// Each engine rolls the target out on its own scene (its own simulator), and optimizes from the
// guess to recover that path, so a perfect optimizer reaches RMSE 0 on either.
// Horizon 10 s; Ostrich h = 80 ms (T = 125 steps), MuJoCo at opt.timestep (2 ms, 5,000 steps);
// loss samples every 80 ms (s = 1..S, S = 125; the box scene's spline map, K knots over 10 s).
// Loss (psi the chassis heading, p its xy position, * the target rollout's):
//   L = W_TRACK / S sum_s |p_s - p*_s|^2                  position tracking         (1 / m^2)
//     + W_YAW / S sum_s 2 (1 - cos(psi_s - psi*_s))       yaw alignment (~ dpsi^2)  (0.25 m^2)
//     + W_MAG sum kappa^2 + W_SMOOTH sum (kappa_{j+1} - kappa_j)^2  control regularization
//     + W_SLIP sum_j (rear_j - (left_j + right_j) / 2)^2             wheel agreement
// The tracking term is RMSE^2, RMSE = sqrt(1/S sum_s |p_s - p*_s|^2); W_YAW makes a 1 rad heading
// error cost as much as 0.5 m of RMSE. W_MAG and W_SMOOTH are 3 to 4 orders below both at knots
// of a few rad/s. The agreement term is zero for every spline whose rear wheel rolls at the
// front wheels' mean speed (no wheel drags another; the targets are such splines): without it
// Adam drove rear knots to -5 rad/s against the front wheels, where the truncated gradient has
// no descent direction left (cosine -0.05 with central differences, measured on a seed outside
// 1-50); with W_SLIP 1e-2 (1e-3 and 1e-1 did worse on seeds 101-110) 10 of 10 reach 0.5 m.
// So the target spline stays (numerically) the minimum.
// A trial succeeds if its best RMSE over the iterates is below 0.5 m.
// Gradients: ostrich: the tape's backward pass, truncated by default (contact geometry held fixed
// within each step; the complete pull-back grows along the 125 steps); mujoco: forward (or
// central) differences of whole rollouts, as in the box scene.
//
// Invariant: every loss, RMSE and time compared comes from this run; both engines see the same
// instances (terrain, target knots, guess).
#define _POSIX_C_SOURCE 200809L

#include "ost_cli_synth_terrain.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <mujoco/mujoco.h>

#include "ost_cli_synth.h"
#include "ost_cli_util.h"
#include "ostrich.h"


// the waves of compare/gen_terrain.py (WAVES): amplitude (m), wavelength (m), direction (rad),
// phase (rad); the fixed surface of terrain_sinusoid.bin / .obj
static const double kTerWave0[TER_NWAVE][4] = {
  {0.050, 7.0, 0.00, 0.3}, {0.040, 5.0, 1.57, 1.1}, {0.030, 3.5, 0.79, 2.0}, {0.025, 4.3, 2.40, 0.7}
};

static const char* kTerWheel[TER_NWHEEL] = {"v_left", "v_right", "v_rear"};


//---------------------------------- Instances -----------------------------------------------------

// A standard normal draw (Box-Muller on two uniform draws).
static double ter_normal(cliRng* rng) {
  double u1 = cli_uniform(rng, 0, 1), u2 = cli_uniform(rng, 0, 1);
  return sqrt(-2 * log(1 - u1)) * cos(2 * mjPI * u2);
}


// The fixed surface's waves (gen_terrain.py) into a task.
void ter_fixedWaves(terTask* task) {
  memcpy(task->wave, kTerWave0, sizeof(kTerWave0));
}


// Draw instance `seed`: waves, target knots, guess knots (knots clipped to [lo, hi]).
void ter_task(unsigned long long seed, double lo, double hi, terTask* task) {
  cliRng rng;
  cli_rngSeed(&rng, seed);
  for (int k = 0; k < TER_NWAVE; k++) {
    task->wave[k][0] = kTerWave0[k][0] * cli_uniform(&rng, TER_AMP_MIN, 1);
    task->wave[k][1] = kTerWave0[k][1];
    task->wave[k][2] = cli_uniform(&rng, 0, mjPI);
    task->wave[k][3] = cli_uniform(&rng, 0, 2 * mjPI);
  }
  for (int j = 0; j < TER_NKNOT; j++) {
    double b = cli_uniform(&rng, TER_BASE_LO, TER_BASE_HI);
    double d = cli_uniform(&rng, -TER_TURN, TER_TURN);
    task->target[0 * TER_NKNOT + j] = b + d;
    task->target[1 * TER_NKNOT + j] = b - d;
    task->target[2 * TER_NKNOT + j] = b;
  }
  for (int c = 0; c < TER_NVAR; c++) {
    double g = task->target[c] + TER_SIGMA * ter_normal(&rng);
    task->guess[c] = g < lo ? lo : (g > hi ? hi : g);
  }
}


// Height of the task's surface at (x, y) (gen_terrain.py's height()).
static double ter_height(const terTask* task, double x, double y) {
  double s = 0;
  for (int k = 0; k < TER_NWAVE; k++) {
    const double* w = task->wave[k];
    double kw = 2 * mjPI / w[1];
    s += w[0] * sin(kw * (cos(w[2]) * x + sin(w[2]) * y) + w[3]);
  }
  double t = (sqrt(x * x + y * y) - TER_R0) / (TER_R1 - TER_R0);
  t = t < 0 ? 0 : (t > 1 ? 1 : t);
  return s * t * t * (3 - 2 * t);
}


// The task's surface as height-field data (TER_NGRID^2, row r at y = -HALF + 2 HALF r / (n-1),
// column c at x likewise, row-major): float (z - ZLO) / SPAN clamped to [0, 1], as
// gen_terrain.py quantizes (the elevation is then ZLO + data SPAN on both engines).
void ter_heights(const terTask* task, float* data) {
  for (int r = 0; r < TER_NGRID; r++) {
    for (int c = 0; c < TER_NGRID; c++) {
      double x = -TER_HALF + 2 * TER_HALF * c / (TER_NGRID - 1);
      double y = -TER_HALF + 2 * TER_HALF * r / (TER_NGRID - 1);
      float v = (float)((ter_height(task, x, y) - TER_ZLO) / TER_SPAN);
      data[r * TER_NGRID + c] = v < 0 ? 0 : (v > 1 ? 1 : v);
    }
  }
}


// Grid index of a world xy position, -1 unless it is a grid sample (within 1e-3 m).
static int ter_gridIndex(double x, double y) {
  double fc = (x + TER_HALF) * (TER_NGRID - 1) / (2 * TER_HALF);
  double fr = (y + TER_HALF) * (TER_NGRID - 1) / (2 * TER_HALF);
  long c = lround(fc), r = lround(fr);
  double step = 2 * TER_HALF / (TER_NGRID - 1);
  if (c < 0 || r < 0 || c >= TER_NGRID || r >= TER_NGRID || fabs(fc - c) * step > 1e-3 ||
      fabs(fr - r) * step > 1e-3) {
    return -1;
  }
  return (int)(r * TER_NGRID + c);
}


// Find the scene's terrain and check that it is the 80 x 80 grid of terrain_sinusoid: the
// ostrich/terrain mesh (each vertex on a grid sample: e->vgrid) or the height field (size
// 12 x 12 m, elevation ZLO + data SPAN). Return 0, else print why.
static int ter_findTerrain(terEngine* e, const char* path) {
  const mjModel* m = e->m;
  e->geom = -1;
  for (int g = 0; g < m->ngeom && e->geom < 0; g++) {
    if (m->geom_bodyid[g] == 0 && (e->ostrich ? m->geom_type[g] == mjGEOM_MESH
                                              : m->geom_type[g] == mjGEOM_HFIELD)) {
      e->geom = g;
    }
  }
  if (e->geom < 0) {
    cli_error("synth: '%s' has no terrain %s in its worldbody", path,
              e->ostrich ? "mesh" : "height field");
    return 1;
  }
  int g = e->geom, id = m->geom_dataid[g];
  if (!e->ostrich) {
    const mjtNum* sz = m->hfield_size + 4 * id;
    if (m->hfield_nrow[id] != TER_NGRID || m->hfield_ncol[id] != TER_NGRID ||
        fabs(sz[0] - TER_HALF) > 1e-9 || fabs(sz[1] - TER_HALF) > 1e-9 ||
        fabs(sz[2] - TER_SPAN) > 1e-9 || fabs(m->geom_pos[3 * g + 2] - TER_ZLO) > 1e-9 ||
        m->geom_quat[4 * g] != 1) {
      cli_error("synth: '%s': the height field is not the %d x %d, 24 x 24 m grid of "
                "terrain_hfield.xml", path, TER_NGRID, TER_NGRID);
      return 1;
    }
    return 0;
  }
  int nvert = m->mesh_vertnum[id], bad = 0;
  e->vgrid = (int*)synth_alloc((size_t)nvert, sizeof(int), &bad);
  e->vert0 = (float*)synth_alloc((size_t)(3 * nvert), sizeof(float), &bad);
  if (bad) {
    cli_error("synth: out of memory");
    return 1;
  }
  mjtNum R[9];
  mju_quat2Mat(R, m->geom_quat + 4 * g);
  memcpy(e->vert0, m->mesh_vert + 3 * m->mesh_vertadr[id], sizeof(float) * 3 * (size_t)nvert);
  for (int v = 0; v < nvert; v++) {
    const float* p = m->mesh_vert + 3 * (m->mesh_vertadr[id] + v);
    mjtNum local[3] = {p[0], p[1], p[2]}, w[3];
    mju_mulMatVec(w, R, local, 3, 3);
    mju_addTo3(w, m->geom_pos + 3 * g);
    if ((e->vgrid[v] = ter_gridIndex(w[0], w[1])) < 0) {
      cli_error("synth: '%s': mesh vertex %d at (%g, %g) m is not on the %d x %d grid of "
                "terrain_mesh.xml", path, v, w[0], w[1], TER_NGRID, TER_NGRID);
      return 1;
    }
  }
  return 0;
}


// Give the engine's scene the surface `data` (ter_heights): the mesh's vertices as loaded
// (e->vert0) moved vertically in the world (local = vert0 + R^T (0, 0, dz), as the geom maps
// them; from the loaded vertices every time, so that a seed's mesh does not depend on the seeds
// before it through float rounding) then ost_modelChanged, or the height field's samples (read
// by MuJoCo at every collision).
void ter_setTerrain(terEngine* e, const float* data) {
  mjModel* m = e->m;
  int g = e->geom, id = m->geom_dataid[g];
  if (!e->ostrich) {
    memcpy(m->hfield_data + m->hfield_adr[id], data, sizeof(float) * TER_NGRID * TER_NGRID);
    return;
  }
  mjtNum R[9];
  mju_quat2Mat(R, m->geom_quat + 4 * g);
  for (int v = 0; v < m->mesh_vertnum[id]; v++) {
    float* p = m->mesh_vert + 3 * (m->mesh_vertadr[id] + v);
    const float* p0 = e->vert0 + 3 * v;
    mjtNum local[3] = {p0[0], p0[1], p0[2]}, w[3];
    mju_mulMatVec(w, R, local, 3, 3);
    double dz = TER_ZLO + TER_SPAN * (double)data[e->vgrid[v]] - (w[2] + m->geom_pos[3 * g + 2]);
    for (int i = 0; i < 3; i++) {
      p[i] = (float)(local[i] + R[6 + i] * dz);  // R^T e_z: the third row of R
    }
  }
  ost_modelChanged(m);
}


//---------------------------------- Engine --------------------------------------------------------

// Free an engine.
void ter_engineFree(terEngine* e) {
  void* bufs[] = {e->knot, e->alpha, e->vgrid, e->vert0, e->qs, e->vs, e->qs_fd, e->vs_fd, e->gqs, e->gus,
                  e->gq, e->gu, e->gctrl, e->var, e->ref};
  for (size_t i = 0; i < sizeof(bufs) / sizeof(bufs[0]); i++) {
    free(bufs[i]);
  }
  ost_tapeDelete(e->tape);
  if (e->d) {
    if (e->ostrich) {
      ost_deleteData(e->d);
    } else {
      mj_deleteData(e->d);
    }
  }
  if (e->m) {
    mj_deleteModel(e->m);
  }
  memset(e, 0, sizeof(*e));
}


// Load an engine's scene (path) and set it up; return 0, else print why (a usage error).
int ter_engineSetup(terEngine* e, const char* name, const char* path, const synthArgs* a) {
  memset(e, 0, sizeof(*e));
  e->name = name;
  e->ostrich = !strcmp(name, "ostrich");
  if (cli_loadModel(path, &e->m, &e->d)) {
    return 1;
  }
  mjModel* m = e->m;
  if (m->njnt < 1 || m->jnt_type[0] != mjJNT_FREE || m->jnt_qposadr[0] || m->jnt_dofadr[0] ||
      m->na > 0) {
    cli_error("synth: '%s' needs the robot's free joint first and no activations", path);
    return 1;
  }
  for (int i = 0; i < TER_NWHEEL; i++) {
    e->act[i] = mj_name2id(m, mjOBJ_ACTUATOR, kTerWheel[i]);
    if (e->act[i] < 0) {
      cli_error("synth: '%s' has no actuator '%s' (the wheels: v_left, v_right, v_rear)", path,
                kTerWheel[i]);
      return 1;
    }
  }
  if (ter_findTerrain(e, path)) {
    return 1;
  }

  // step size: Ostrich at TER_H (the model's ostrich/* options otherwise), MuJoCo opt.timestep
  if (e->ostrich) {
    char err[CLI_MSG_SZ] = "";
    // the model's options at h = TER_H, with at least TER_SPLIT halvings of a step whose Newton
    // solve fails (a split step is recorded on the tape as its substeps)
    ostOptions opt;
    if (cli_ostrichOptions(m, TER_H, -1, -1, NULL, &opt, err, sizeof(err))) {
      cli_error("synth: '%s': %s", path, err);
      return 1;
    }
    opt.split_depth = opt.split_depth > TER_SPLIT ? opt.split_depth : TER_SPLIT;
    opt.deep_splits = opt.deep_splits > TER_DEEP_SPLITS ? opt.deep_splits : TER_DEEP_SPLITS;
    if (ost_setOptions(m, e->d, &opt) != OST_OK) {
      cli_error("synth: '%s': options refused: %s", path, ost_lastError(e->d));
      return 1;
    }
    e->h = opt.timestep;
    if (synth_gradientTape(m, &e->tape)) {
      return 1;
    }
  } else {
    e->h = m->opt.timestep;
  }
  m->opt.timestep = e->h;
  if (synth_stepGrid(name, e->h, TER_DT, TER_HORIZON, TER_NKNOT, &e->nsub, &e->nsample,
                     &e->nstep, &e->knot, &e->alpha)) {
    return 1;
  }
  e->lo = -mjMAXVAL;
  e->hi = mjMAXVAL;
  if (m->actuator_ctrllimited[e->act[0]]) {
    e->lo = m->actuator_ctrlrange[2 * e->act[0]];
    e->hi = m->actuator_ctrlrange[2 * e->act[0] + 1];
  }
  e->truncate = !strcmp(a->grad, "truncated");
  e->central = !strcmp(a->fd, "central");
  e->eps = a->eps;

  // the knot map: step k takes the spline at its midpoint (as the box scene)
  int bad = 0, ns = e->nsample + 1, nv = m->nv;
  e->qs = (mjtNum*)synth_alloc((size_t)(ns * m->nq), sizeof(mjtNum), &bad);
  e->vs = (mjtNum*)synth_alloc((size_t)(ns * nv), sizeof(mjtNum), &bad);
  e->qs_fd = (mjtNum*)synth_alloc((size_t)(ns * m->nq), sizeof(mjtNum), &bad);
  e->vs_fd = (mjtNum*)synth_alloc((size_t)(ns * nv), sizeof(mjtNum), &bad);
  e->gqs = (mjtNum*)synth_alloc((size_t)(ns * nv), sizeof(mjtNum), &bad);
  e->gus = (mjtNum*)synth_alloc((size_t)(ns * nv), sizeof(mjtNum), &bad);
  e->gq = (mjtNum*)synth_alloc((size_t)((e->nstep + 1) * nv), sizeof(mjtNum), &bad);
  e->gu = (mjtNum*)synth_alloc((size_t)((e->nstep + 1) * nv), sizeof(mjtNum), &bad);
  e->gctrl = (mjtNum*)synth_alloc((size_t)(e->nstep * m->nu), sizeof(mjtNum), &bad);
  e->var = (double*)synth_alloc(TER_NVAR, sizeof(double), &bad);
  e->ref = (double*)synth_alloc((size_t)(3 * ns), sizeof(double), &bad);
  if (bad) {
    cli_error("synth: out of memory");
    return 1;
  }
  return 0;
}


//---------------------------------- Loss ----------------------------------------------------------

// Regularizers and, if gknot != NULL, their gradient (added).
double ter_regLoss(const double* knots, double* gknot) {
  double loss = 0;

  // wheel agreement: the rear wheel rolls at the front wheels' mean speed when nothing slips
  for (int j = 0; j < TER_NKNOT; j++) {
    double r = knots[2 * TER_NKNOT + j] - 0.5 * (knots[j] + knots[TER_NKNOT + j]);
    loss += TER_W_SLIP * r * r;
    if (gknot) {
      gknot[2 * TER_NKNOT + j] += 2 * TER_W_SLIP * r;
      gknot[j] -= TER_W_SLIP * r;
      gknot[TER_NKNOT + j] -= TER_W_SLIP * r;
    }
  }
  for (int i = 0; i < TER_NWHEEL; i++) {
    const double* kp = knots + i * TER_NKNOT;
    for (int j = 0; j < TER_NKNOT; j++) {
      loss += TER_W_MAG * kp[j] * kp[j];
      if (gknot) {
        gknot[i * TER_NKNOT + j] += 2 * TER_W_MAG * kp[j];
      }
      if (j + 1 < TER_NKNOT) {
        double dk = kp[j + 1] - kp[j];
        loss += TER_W_SMOOTH * dk * dk;
        if (gknot) {
          gknot[i * TER_NKNOT + j + 1] += 2 * TER_W_SMOOTH * dk;
          gknot[i * TER_NKNOT + j] -= 2 * TER_W_SMOOTH * dk;
        }
      }
    }
  }
  return loss;
}


// Loss of the sample states qs ((S + 1) x nq) against the target path e->ref and, if gqs != NULL,
// its qpos cotangents ((S + 1) x nv, tangent: 0-2 world position, 3-5 local rotation;
// overwritten). Sets *rmse (xy, m).
double ter_stateLoss(const terEngine* e, const mjtNum* qs, mjtNum* gqs, double* rmse) {
  int nq = e->m->nq, nv = e->m->nv, S = e->nsample;
  double loss = 0, sq = 0;
  if (gqs) {
    mju_zero(gqs, (S + 1) * nv);
  }
  for (int s = 1; s <= S; s++) {
    const mjtNum* q = qs + s * nq;
    const double* ref = e->ref + 3 * s;
    mjtNum dpsi[3];
    double ex = q[0] - ref[0], ey = q[1] - ref[1];
    double dh = synth_heading(q + 3, dpsi) - ref[2];
    sq += ex * ex + ey * ey;
    loss += TER_W_TRACK / S * (ex * ex + ey * ey) + TER_W_YAW / S * 2 * (1 - cos(dh));
    if (gqs) {
      mjtNum* g = gqs + s * nv;
      g[0] = 2 * TER_W_TRACK / S * ex;
      g[1] = 2 * TER_W_TRACK / S * ey;
      for (int i = 0; i < 3; i++) {
        g[3 + i] = TER_W_YAW / S * 2 * sin(dh) * dpsi[i];  // d(2 - 2 cos dh) = 2 sin dh dpsi
      }
    }
  }
  *rmse = sqrt(sq / S);
  return loss;
}


//---------------------------------- Rollouts ------------------------------------------------------

// Roll the knots out from the start (qpos0 at rest; recorded on the tape for ostrich); sample
// states into qs, vs. Return TER_OK, TER_BAD (e->why says why) or TER_FAILED (printed).
int ter_rollout(terEngine* e, const double* knots, mjtNum* qs, mjtNum* vs) {
  const mjModel* m = e->m;
  mjData* d = e->d;
  cli_resetState(m, d);
  if (e->ostrich) {
    ost_tapeClear(e->tape);
  }
  mju_copy(qs, d->qpos, m->nq);
  mju_copy(vs, d->qvel, m->nv);
  for (int k = 0; k < e->nstep; k++) {
    // controls: the spline at the step's midpoint, u = (1 - a) kappa_j + a kappa_j+1
    int j = e->knot[k];
    double al = e->alpha[k];
    for (int i = 0; i < TER_NWHEEL; i++) {
      d->ctrl[e->act[i]] = (1 - al) * knots[i * TER_NKNOT + j] + al * knots[i * TER_NKNOT + j + 1];
    }
    int status = e->ostrich ? ost_tapeStep(e->tape, m, d) : (mj_step(m, d), OST_OK);
    if (cli_mujocoError()) {
      cli_error("synth: %s step %d: mujoco error: %s", e->name, k + 1, cli_mujocoError());
      return TER_FAILED;
    }
    if (status == OST_WARN_NOT_CONVERGED) {
      snprintf(e->why, sizeof(e->why), "step %d did not converge (residual %.3g m/s)", k + 1,
               ost_stats(d)->residual);
      return TER_BAD;
    }
    if (status != OST_OK) {
      snprintf(e->why, sizeof(e->why), "step %d failed: %s", k + 1, ost_lastError(d));
      return TER_BAD;
    }
    if ((k + 1) % e->nsub == 0) {
      int s = (k + 1) / e->nsub;
      if (cli_hasNan(m, d)) {
        snprintf(e->why, sizeof(e->why), "the rollout diverged by t = %g s", s * TER_DT);
        return TER_BAD;
      }
      mju_copy(qs + s * m->nq, d->qpos, m->nq);
      mju_copy(vs + s * m->nv, d->qvel, m->nv);
    }
  }
  return TER_OK;
}


// Roll the target knots out and keep their path (x, y, heading per sample) in e->ref.
int ter_setTarget(terEngine* e, const double* target) {
  int status = ter_rollout(e, target, e->qs, e->vs);
  for (int s = 0; s <= e->nsample && status == TER_OK; s++) {
    const mjtNum* q = e->qs + s * e->m->nq;
    e->ref[3 * s] = q[0];
    e->ref[3 * s + 1] = q[1];
    e->ref[3 * s + 2] = synth_heading(q + 3, NULL);
  }
  return status;
}


// Loss of one rollout with the knots (no gradient); NaN if it failed, *status its outcome.
static double ter_rolloutLoss(terEngine* e, const double* knots, int* status) {
  double rmse;
  *status = ter_rollout(e, knots, e->qs_fd, e->vs_fd);
  if (*status != TER_OK) {
    return NAN;
  }
  return ter_stateLoss(e, e->qs_fd, NULL, &rmse) + ter_regLoss(knots, NULL);
}


// Ostrich: recorded rollout, loss, backward pass, pull-back to the knots (W^T). Fills ev, gknot.
int ter_gradAdjoint(terEngine* e, const double* knots, terEval* ev, double* gknot) {
  const mjModel* m = e->m;
  int nv = m->nv;
  int status = ter_rollout(e, knots, e->qs, e->vs);
  if (status != TER_OK) {
    return status;
  }

  // sample cotangents, placed on the steps that end at a sample (row 0: the start)
  mju_zero(gknot, TER_NVAR);
  ev->loss = ter_stateLoss(e, e->qs, e->gqs, &ev->rmse) + ter_regLoss(knots, gknot);
  mju_zero(e->gq, (e->nstep + 1) * nv);
  mju_zero(e->gu, (e->nstep + 1) * nv);
  for (int s = 0; s <= e->nsample; s++) {
    mju_copy(e->gq + s * e->nsub * nv, e->gqs + s * nv, nv);
  }

  // dL/dctrl by the adjoint, then W^T
  ostGradOptions go;
  ost_defaultGradOptions(&go);
  go.truncate = e->truncate;
  int rc = ost_tapeBackward(e->tape, m, &go, e->gq, e->gu, e->gctrl, NULL, NULL, NULL);
  if (rc != OST_OK) {
    snprintf(e->why, sizeof(e->why), "backward pass failed (status %d): %s", rc,
             ost_tapeError(e->tape));
    return TER_BAD;
  }
  for (int k = 0; k < e->nstep; k++) {
    int j = e->knot[k];
    double al = e->alpha[k];
    for (int i = 0; i < TER_NWHEEL; i++) {
      double g = e->gctrl[k * m->nu + e->act[i]];
      if (!isfinite(g)) {
        snprintf(e->why, sizeof(e->why), "non-finite control gradient at step %d", k + 1);
        return TER_BAD;
      }
      gknot[i * TER_NKNOT + j] += (1 - al) * g;
      gknot[i * TER_NKNOT + j + 1] += al * g;
    }
  }
  return TER_OK;
}


// The loss of a rollout with knots x; *fatal on an error that ends the run.
static double ter_fdLoss(void* ctx, const double* x, int* fatal) {
  int status;
  double loss = ter_rolloutLoss((terEngine*)ctx, x, &status);
  *fatal = status == TER_FAILED;
  return loss;
}


// MuJoCo: base rollout, then finite differences of the whole loss over every knot (forward, or
// central with --fd central); a perturbed rollout that fails, or a step that would leave the
// control range, is replaced by the other side (counted in e->fd_fallback).
int ter_gradFD(terEngine* e, const double* knots, terEval* ev, double* gknot) {
  int status = ter_rollout(e, knots, e->qs, e->vs);
  if (status != TER_OK) {
    return status;
  }
  double l0 = ter_stateLoss(e, e->qs, NULL, &ev->rmse) + ter_regLoss(knots, NULL);
  ev->loss = l0;
  return synth_fdGradient(TER_NVAR, knots, e->var, e->lo, e->hi, e->eps, e->central, l0,
                          ter_fdLoss, e, gknot, &e->fd_fallback) ? TER_FAILED : TER_OK;
}
