// ost_cli_synth.c: `ostrich synth`, control synthesis on the wheeled robot (the Ostrich paper,
// section IV-B). From a random start the robot must drive over the box of robot_box.xml to a
// random target and stop there. The controls are a wheel-velocity spline, optimized by Adam with
// the gradient of the whole rollout's loss: Ostrich's adjoint (ost_tapeStep, ost_tapeBackward)
// at h = 0.1 s, or, as a stock MuJoCo 2.2 user would, finite differences of mj_step rollouts at
// the model's opt.timestep (2 ms). Mirrors MuJoCo's sample programs; no rendering (gnuplot).
// This file parses the arguments of every scene and runs the box scene (the default); --scene
// terrain runs ost_cli_synth_terrain*.c with the helpers ost_cli_synth.h declares.
//
// Task (one seeded random stream for all trials; both engines get the same trials):
//   start   x, y ~ U(-0.2, 0.2) m, yaw ~ U(-0.2, 0.2) rad, at rest (free joint qpos)
//   target  x = 3 m, y ~ U(-0.3, 0.3) m, heading ~ U(-0.3, 0.3) rad; horizon T = 6 s
//   success final position error < 0.2 m and final speed < 0.3 m/s, at the best-loss iterate
// Controls: K = 10 knots per actuator at t_j = j T / (K - 1); the control of a step is the
// piecewise-linear spline at the step's midpoint, u_k = (1 - a_k) kappa_j + a_k kappa_{j+1}, a
// fixed linear map W of the knots, so a control gradient pulls back as W^T.
// Loss, from the chassis state at the sample times t_s = 0.1 s * s, s = 0..S (S = 60; every
// Ostrich step at h = 0.1 s, every 50th MuJoCo step at 2 ms: the same function for both):
//   L = W_POS |p_S - p*|^2                    final xy position error          (10 / m^2)
//     + W_HEAD wrap(psi_S - psi*)^2           final heading error              (2 / rad^2)
//     + W_VEL |v_S|^2 + W_YAW w_S^2           final chassis linear velocity and yaw rate
//                                             (qvel 0..2 and 5)                (5 s^2/m^2, 1)
//     + W_TRACK dt sum_{s=1..S} dist(p_s, seg)^2  distance from the start-target segment
//                                             (2 / (m^2 s))
//     + W_MAG sum kappa^2 + W_SMOOTH sum (kappa_{j+1} - kappa_j)^2   per actuator
//                                             (1e-3, 1e-2 s^2/rad^2)
// The weights make the final position dominate (0.2 m error costs 0.4), the final velocity
// next, and keep the regularizers two orders below them for knots of a few rad/s.
// Gradients: ostrich: the tape's backward pass, complete by default (on robot_box.xml with its
// tyre creep, 25 of 25 trials succeed against 14 of 25 with --grad truncated, which holds each
// step's contact geometry fixed; measured, seed 1). mujoco: forward differences (1 + 30
// rollouts per iteration), eps = 0.1 rad/s: MuJoCo's loss jumps by 0.05 to 0.3 under knot changes of
// 1e-5 rad/s at the box edge, so smaller steps measure that noise (a line search along the
// difference direction lowered the loss on 5 of 6 tasks at eps 0.1, on 1 to 3 of 6 at 1e-2 to
// 1e-6). Optimizer: Adam (lr 0.3 decaying to 0.03 by a cosine, betas 0.9, 0.999) on the knots,
// starting from 1.5 rad/s with the last knot 0 (a stop), projected onto ctrlrange; an
// iterate whose rollout fails is retried from the last good one at half the step.
//
// Cotangents for ost_tapeBackward are tangent vectors: for the free joint, entries 0-2 are the
// world position, entries 3-5 the rotation in the local frame (q' = q * exp(delta / 2), as
// mj_integratePos). With R' = R (I + [delta]x) the heading psi = atan2(R10, R00) moves by
//   dpsi/ddelta = (0, R10 R02 - R00 R12, R00 R11 - R10 R01) / (R00^2 + R10^2);
// tests/test_ost_cli_synth.c checks it, the loss's other cotangents and W^T against finite
// differences.
//
// Invariant: both engines optimize the same function of the same variables from the same
// start; only the simulator and the gradient differ, and every time compared is from this run.
#define _POSIX_C_SOURCE 200809L

#include <errno.h>
#include <math.h>
#include <stddef.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/wait.h>

#include <mujoco/mujoco.h>

#include "ost_cli_synth.h"
#include "ost_cli_util.h"
#include "ostrich.h"


//---------------------------------- Task constants ------------------------------------------------

#define SYNTH_NKNOT        10     // spline knots per actuator
#define SYNTH_HORIZON      6.0    // s
#define SYNTH_DT           0.1    // s: interval of the loss samples
#define SYNTH_TARGET_X     3.0    // m
#define SYNTH_START_XY     0.2    // m: start x, y ~ U(-., .)
#define SYNTH_START_YAW    0.2    // rad
#define SYNTH_TARGET_Y     0.3    // m
#define SYNTH_TARGET_HEAD  0.3    // rad
#define SYNTH_INIT_KNOT    1.5    // rad/s: initial knots, the last 0 (a stop: r T/(K-1) (K-1.5)
                                  // 1.5 = 2.98 m in 6 s)
#define SYNTH_POS_OK       0.2    // m: success: final position error below
#define SYNTH_SPEED_OK     0.3    // m/s: success: final speed below

#define SYNTH_W_POS        10.0   // 1/m^2
#define SYNTH_W_HEAD       2.0    // 1/rad^2
#define SYNTH_W_VEL        5.0    // s^2/m^2
#define SYNTH_W_YAW        1.0    // s^2/rad^2
#define SYNTH_W_TRACK      2.0    // 1/(m^2 s)
#define SYNTH_W_MAG        1e-3   // s^2/rad^2
#define SYNTH_W_SMOOTH     1e-2   // s^2/rad^2

#define SYNTH_LR_FLOOR     0.1    // the step size decays (cosine) to this fraction of --lr
#define SYNTH_ADAM_B1      0.9    // Adam's first-moment decay
#define SYNTH_ADAM_B2      0.999  // Adam's second-moment decay
#define SYNTH_ADAM_EPS     1e-8   // Adam's denominator guard
#define SYNTH_MAX_BAD      3      // failed iterates in a row that end a trial


//---------------------------------- Arguments -----------------------------------------------------

static const cliOption kSynthOptions[] = {
  {"--scene", CLI_ARG_STRING, offsetof(synthArgs, scene), "box|terrain",
   "the task: box (the default: over the box to a target) or terrain\n"
   "(recover a random target spline's path over a procedural mesh\n"
   "terrain, one seed per trial; see below)"},
  {"--trials", CLI_ARG_COUNT, offsetof(synthArgs, trials), "N",
   "random tasks, >= 1 (default: box 10, terrain 50)"},
  {"--iters", CLI_ARG_COUNT, offsetof(synthArgs, iters), "K",
   "Adam iterations (rollouts with a gradient) per trial (default: box\n"
   "50, terrain 100)"},
  {"--seed", CLI_ARG_COUNT, offsetof(synthArgs, seed), "S",
   "seed of the one random stream of all tasks (default 1)"},
  {"--lr", CLI_ARG_POSITIVE, offsetof(synthArgs, lr), "LR",
   "Adam's initial step size in rad/s (default 0.3, the paper's; it\n"
   "decays to a tenth by a cosine over the iterations)"},
  {"--engine", CLI_ARG_STRING, offsetof(synthArgs, engine), "ostrich,mujoco",
   "ostrich (adjoint, h = the model's ostrich/timestep, 0.1 s), mujoco\n"
   "(mj_step at opt.timestep, 2 ms, finite differences), or both as\n"
   "ostrich,mujoco or both (the same tasks on each; default ostrich)"},
  {"--grad", CLI_ARG_STRING, offsetof(synthArgs, grad), "truncated|complete",
   "ostrich's backward pass (ostGradOptions.truncate): truncated holds\n"
   "each step's contact geometry fixed, complete pulls it back too\n"
   "(default: box complete: 25 of 25 tasks succeed, truncated 14 of 25;\n"
   "terrain truncated: the complete adjoint grows over its 125 steps)"},
  {"--fd", CLI_ARG_STRING, offsetof(synthArgs, fd), "forward|central",
   "finite differences of the mujoco engine: forward (1 + 30 rollouts per\n"
   "iteration, the default) or central (1 + 60)"},
  {"--eps", CLI_ARG_POSITIVE, offsetof(synthArgs, eps), "E",
   "finite-difference step of a knot, rad/s (default 0.1: MuJoCo's loss\n"
   "jumps by 0.05-0.3 for knot changes of 1e-5 rad/s at the box edges,\n"
   "so smaller steps measure that noise)"},
  {"--csv", CLI_ARG_STRING, offsetof(synthArgs, csv), "FILE.csv",
   "write one row per iteration: engine,trial,iter,loss,pos_err,speed,\n"
   "heading_err,time_ms,x,y (final chassis x, y); and FILE_traj.csv:\n"
   "engine,trial,iter,t,x,y (the chassis every 0.1 s of every iteration)"},
  {"--plot", CLI_ARG_STRING, offsetof(synthArgs, plot), "FILE.png",
   "draw the chassis xy paths of every iteration, coloured by iteration,\n"
   "with the obstacle's footprint, starts and targets (gnuplot)\n"
   "Both outputs are checked before the trials, written to temporary\n"
   "names and renamed at the end."},
};

static const int kSynthNumOptions = (int)(sizeof(kSynthOptions) / sizeof(kSynthOptions[0]));


// Print the usage of `ostrich synth`.
static void synth_usage(FILE* f) {
  fprintf(f,
    "usage: ostrich synth [MODEL.xml] [options]\n"
    "\n"
    "MODEL.xml: the scene, a free-jointed robot (joint 0) with nu wheel actuators (default\n"
    "mjcf_models/robot_box.xml, relative to the working directory).\n"
    "\n"
    "Control synthesis on the wheeled robot (Ostrich paper, section IV-B). From a random start\n"
    "(x, y ~ U(-0.2, 0.2) m, yaw ~ U(-0.2, 0.2) rad, at rest) the robot drives over the box to a\n"
    "random target (x = 3 m, y ~ U(-0.3, 0.3) m, heading ~ U(-0.3, 0.3) rad) and stops within\n"
    "6 s. Variables: 10 spline knots of wheel velocity per actuator (rad/s, piecewise linear,\n"
    "start 1.5 rad/s with the last knot 0), optimized by Adam, the step decaying from --lr to a\n"
    "tenth of it by a cosine. Loss, from the chassis every 0.1 s:\n"
    "  10 |p - p*|^2 + 2 (psi - psi*)^2 + 5 |v|^2 + 1 yawrate^2   (final state)\n"
    "  + 2 * 0.1 s * sum_s dist(p_s, start-target segment)^2     (every sample)\n"
    "  + 1e-3 sum knot^2 + 1e-2 sum (knot_{j+1} - knot_j)^2        (per actuator)\n"
    "Gradients: ostrich: the adjoint of the recorded rollout (ost_tapeStep, ost_tapeBackward);\n"
    "mujoco: finite differences of whole mj_step rollouts over the knots (forward by default).\n"
    "A trial succeeds if, at its best-loss iterate, the final position error is below 0.2 m and\n"
    "the final speed below 0.3 m/s. An iterate whose rollout fails (diverges, a step or the\n"
    "backward pass returns an error) counts as an iteration with a NaN loss; the next iterate\n"
    "is the last good one's step at half the step size (kept for the rest of the trial). A\n"
    "trial ends early if its first iterate fails or 3 fail in a row.\n"
    "\n"
    "Prints one JSON line: engine, model, trials, iters, seed, lr, h, steps, gradient, successes,\n"
    "success_rate, successes_last (at the last good iterate), median_final_error,\n"
    "median_final_speed (best-loss iterates), median_warm_iter_ms (median over iterations except\n"
    "each trial's first), failed_trials (ended early), bad_rollouts, fd_fallbacks (mujoco:\n"
    "perturbed rollouts that failed, the other side used), total_s; with --engine both: one\n"
    "such object per engine under \"ostrich\" and \"mujoco\", and warm_iter_ratio = mujoco /\n"
    "ostrich median warm iteration time, both measured in this run. One progress line per\n"
    "iteration goes to stderr, unless OSTRICH_QUIET=1.\n"
    "\n"
    "--scene terrain (the paper's terrain traversal; MODEL.xml default\n"
    "mjcf_models/terrain_mesh.xml, and the mujoco engine loads terrain_hfield.xml from the same\n"
    "folder: the same surface as a height field, since MuJoCo 2.2.2 collides meshes as convex\n"
    "hulls). Trial t derives from the one seed S + t - 1 (--seed S): a sum of 4 sinusoids on the\n"
    "24 x 24 m, 80 x 80-sample grid (12,482 triangles; gen_terrain.py's wavelengths, amplitudes\n"
    "0.5-1 times its, random directions and phases, flat within 1.2 m of the start), written\n"
    "into the mesh (then ost_modelChanged) and the height field, so every seed has its own\n"
    "terrain on both engines; a target spline (10 knots per wheel, left/right = b +- d,\n"
    "rear = b, b ~ U(1, 3), d ~ U(-0.5, 0.5) rad/s); and a guess, the target plus N(0, 1.5^2)\n"
    "rad/s per knot. Each engine rolls the target out on its own scene and, from the guess,\n"
    "recovers that path over 10 s (ostrich: h = 0.08 s, 125 steps; mujoco: 5,000 steps of 2 ms;\n"
    "the loss sampled every 0.08 s):\n"
    "  1 / S sum_s |p_s - p*_s|^2 + 0.25 / S sum_s 2 (1 - cos(psi_s - psi*_s))\n"
    "  + 1e-5 sum knot^2 + 1e-4 sum (knot_{j+1} - knot_j)^2\n"
    "  + 1e-2 sum_j (rear_j - (left_j + right_j) / 2)^2\n"
    "A trial succeeds if its best RMSE (tracking error of the xy path) over the iterates is below\n"
    "0.5 m. Defaults: 50 trials, 100 iterations, --grad truncated. Prints one JSON line with\n"
    "scene \"terrain\": successes, below_0.2m, median/mean/std_best_rmse, median_initial_rmse\n"
    "(the guesses), median_last_rmse, median_warm_iter_ms, failed_trials (a failed target\n"
    "rollout also ends its trial), bad_rollouts, and, with --engine both, warm_iter_ratio.\n"
    "--csv: engine,trial,iter,loss,rmse,time_ms and FILE_traj.csv (iter 0: the target path);\n"
    "--plot: trial 1's paths over its terrain and the RMSE over the iterations of all trials.\n"
    "\n"
    "options:\n");
  cli_printOptions(f, kSynthOptions, kSynthNumOptions);
  cli_printHelpOption(f);
  fprintf(f,
    "\n"
    "Exit status: 0 success (whether or not the trials reach their targets); 1 a trial ended\n"
    "early, a MuJoCo error, or an output could not be written; 2 bad usage, missing or\n"
    "malformed model, model refused by Ostrich or not representable by the native geometry.\n");
}


// Check the combination of parsed arguments and the outputs; return 0 on success, else print why.
static int synth_checkArgs(const synthArgs* a) {
  if (a->trials < 1 || a->iters < 1) {
    cli_error("%s: need at least 1", a->trials < 1 ? "--trials" : "--iters");
    return 1;
  }
  if (strcmp(a->engine, "ostrich") && strcmp(a->engine, "mujoco") && strcmp(a->engine, "both")) {
    cli_error("--engine: '%s' is not ostrich, mujoco or both", a->engine);
    return 1;
  }
  if (strcmp(a->grad, "truncated") && strcmp(a->grad, "complete")) {
    cli_error("--grad: '%s' is not truncated or complete", a->grad);
    return 1;
  }
  if (strcmp(a->fd, "forward") && strcmp(a->fd, "central")) {
    cli_error("--fd: '%s' is not forward or central", a->fd);
    return 1;
  }

  // the outputs, before any trial: FILE.csv, FILE_traj.csv next to it, FILE.png
  char traj[CLI_PATH_SZ];
  if (a->csv) {
    synth_trajPath(a->csv, traj, sizeof(traj));
  }
  return (a->csv && (cli_checkOutput("--csv", a->csv) || cli_checkOutput("--csv", traj))) ||
         (a->plot && cli_checkOutput("--plot", a->plot));
}


//---------------------------------- Engine --------------------------------------------------------

typedef struct synthTask_ {       // one trial
  double start[3];                // x, y (m), yaw (rad)
  double target[3];               // x, y (m), heading (rad)
} synthTask;

typedef struct synthEval_ {       // what one rollout achieved
  double loss;                    // L
  double pos_err;                 // final |p - p*| (m)
  double speed;                   // final |v| of the chassis (m/s)
  double heading_err;             // final wrap(psi - psi*) (rad)
  double x, y;                    // final chassis position (m)
} synthEval;

typedef struct synthEngine_ {     // one engine: its model, rollout and gradient
  // setup
  const char* name;               // "ostrich" or "mujoco"
  int         ostrich;            // 1: ost_tapeStep + adjoint; 0: mj_step + finite differences
  mjModel*    m;                  // model (opt.timestep = h)
  mjData*     d;                  // data
  double      h;                  // step size (s)
  int         nsub;               // steps per loss sample (SYNTH_DT / h)
  int         nsample;            // loss samples after the start (S)
  int         nstep;              // steps of a rollout (nsub S)
  int         nu;                 // actuators
  int         nvar;               // knots (nu x K)
  double      lo, hi;             // knot bounds: the first actuator's ctrlrange, else +-inf
  int*        knot;               // step k: its interval j, u = (1 - a) kappa_j + a kappa_j+1
  double*     alpha;              // step k: its weight a                               (nstep)
  ostTape*    tape;               // rollout record (ostrich)
  int         truncate;           // backward pass: ostGradOptions.truncate (ostrich)
  int         central;            // finite differences: 1 central, 0 forward (mujoco)
  double      eps;                // finite-difference step (rad/s)

  // scratch
  mjtNum*     qs;                 // sample states: qpos                      ((S + 1) x nq)
  mjtNum*     vs;                 //                qvel                      ((S + 1) x nv)
  mjtNum*     qs_fd;              // the same for perturbed rollouts           ((S + 1) x nq)
  mjtNum*     vs_fd;              //                                           ((S + 1) x nv)
  mjtNum*     gqs;                // loss cotangents of the samples, tangent  ((S + 1) x nv)
  mjtNum*     gus;                //                                           ((S + 1) x nv)
  mjtNum*     gq;                 // tape cotangents, per step            ((nstep + 1) x nv)
  mjtNum*     gu;                 //                                      ((nstep + 1) x nv)
  mjtNum*     gctrl;              // dL/dctrl                                   (nstep x nu)
  double*     var;                // perturbed knots                                 (nvar)

  // outcomes
  char        why[CLI_MSG_SZ];    // why the last rollout was SYNTH_BAD
  long        fd_fallback;        // perturbed rollouts that failed (other side used)
} synthEngine;

enum {                            // outcome of a rollout (and its gradient)
  SYNTH_OK = 0,                   // finished
  SYNTH_BAD,                      // this rollout failed (why in synthEngine.why): a non-finite
                                  // state, MuJoCo reset a diverged one, an Ostrich step or the
                                  // backward pass returned an error; the optimizer backtracks
  SYNTH_FAILED                    // MuJoCo error (it sticks for the process) or out of memory
};


// Allocate n zeroed elements of size sz; record a failure in *bad.
void* synth_alloc(size_t n, size_t sz, int* bad) {
  void* p = calloc(n > 0 ? n : 1, sz);
  if (!p) {
    *bad = 1;
  }
  return p;
}


int synth_stepGrid(const char* engine, double h, double dt, double horizon, int nknot,
                   int* nsub, int* nsample, int* nstep, int** knot, double** alpha) {
  *nsub = (int)lround(dt / h);
  if (*nsub < 1 || fabs(*nsub * h - dt) > 1e-9) {
    cli_error("synth: the %s step size %g s does not divide the loss interval %g s", engine, h,
              dt);
    return 1;
  }
  *nsample = (int)lround(horizon / dt);
  *nstep = *nsub * *nsample;
  int bad = 0;
  *knot = (int*)synth_alloc((size_t)*nstep, sizeof(int), &bad);
  *alpha = (double*)synth_alloc((size_t)*nstep, sizeof(double), &bad);
  if (bad) {
    cli_error("synth: out of memory");
    return 1;
  }
  double spacing = horizon / (nknot - 1);
  for (int k = 0; k < *nstep; k++) {
    double t = ((double)k + 0.5) * h / spacing;
    int j = (int)floor(t);
    j = j < 0 ? 0 : (j > nknot - 2 ? nknot - 2 : j);
    (*knot)[k] = j;
    (*alpha)[k] = t - j;
  }
  return 0;
}


int synth_gradientTape(const mjModel* m, ostTape** tape) {
  char err[CLI_MSG_SZ] = "";
  if (ost_checkNative(m, err, sizeof(err)) != OST_OK) {
    cli_error("synth: gradients need the native geometry: %s", err);
    return 1;
  }
  if (!(*tape = ost_tapeCreate(m, 0))) {
    cli_error("synth: cannot create a tape (out of memory)");
    return 1;
  }
  return 0;
}


int synth_fdGradient(int nvar, const double* x, double* var, double lo, double hi, double eps,
                     int central, double l0, double (*loss)(void* ctx, const double* x,
                                                            int* fatal),
                     void* ctx, double* g, long* fallback) {
  mju_copy(var, x, nvar);
  for (int c = 0; c < nvar; c++) {
    double lp = NAN, lm = NAN;
    int fatal = 0;
    if (x[c] + eps <= hi) {
      var[c] = x[c] + eps;
      lp = loss(ctx, var, &fatal);
    }
    if ((central || !isfinite(lp)) && !fatal && x[c] - eps >= lo) {
      var[c] = x[c] - eps;
      lm = loss(ctx, var, &fatal);
    }
    var[c] = x[c];
    if (fatal) {
      return 1;
    }
    if (isfinite(lp) && isfinite(lm)) {
      g[c] = (lp - lm) / (2 * eps);
    } else if (isfinite(lp)) {
      g[c] = (lp - l0) / eps;
      *fallback += central;
    } else if (isfinite(lm)) {
      g[c] = (l0 - lm) / eps;
      (*fallback)++;
    } else {
      g[c] = 0;
      (*fallback)++;
    }
  }
  return 0;
}


// Free an engine.
static void synth_engineFree(synthEngine* e) {
  void* bufs[] = {e->knot, e->alpha, e->qs, e->vs, e->qs_fd, e->vs_fd, e->gqs, e->gus, e->gq,
                  e->gu, e->gctrl, e->var};
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


// Check that the model is a free-jointed robot with actuators; return 0, else print why.
static int synth_checkModel(const char* path, const mjModel* m) {
  if (m->njnt < 1 || m->jnt_type[0] != mjJNT_FREE || m->jnt_qposadr[0] || m->jnt_dofadr[0]) {
    cli_error("synth: '%s' needs a free joint as its first joint (the robot's chassis)", path);
    return 1;
  }
  if (m->nu < 1 || m->na > 0) {
    cli_error("synth: '%s' needs actuators without activation (the wheels)", path);
    return 1;
  }
  return 0;
}


// Load the model and set an engine up; return 0, else print why (a usage error).
static int synth_engineSetup(synthEngine* e, const char* name, const synthArgs* a) {
  memset(e, 0, sizeof(*e));
  e->name = name;
  e->ostrich = !strcmp(name, "ostrich");
  if (cli_loadModel(a->model, &e->m, &e->d) || synth_checkModel(a->model, e->m)) {
    return 1;
  }
  mjModel* m = e->m;

  // step size: Ostrich's from the model's <custom>, MuJoCo's opt.timestep
  if (e->ostrich) {
    if (cli_setupOstrich(m, e->d, 0, -1, -1, NULL, &e->h) || synth_gradientTape(m, &e->tape)) {
      return 1;
    }
  } else {
    e->h = m->opt.timestep;
  }
  m->opt.timestep = e->h;
  if (synth_stepGrid(name, e->h, SYNTH_DT, SYNTH_HORIZON, SYNTH_NKNOT, &e->nsub, &e->nsample,
                     &e->nstep, &e->knot, &e->alpha)) {
    return 1;
  }
  e->nu = m->nu;
  e->nvar = m->nu * SYNTH_NKNOT;
  e->lo = -mjMAXVAL;
  e->hi = mjMAXVAL;
  if (m->actuator_ctrllimited[0]) {
    e->lo = m->actuator_ctrlrange[0];
    e->hi = m->actuator_ctrlrange[1];
  }
  e->truncate = !strcmp(a->grad, "truncated");
  e->central = !strcmp(a->fd, "central");
  e->eps = a->eps;

  // the knot map: step k takes the spline at its midpoint
  int bad = 0, ns = e->nsample + 1, nv = m->nv;
  e->qs = (mjtNum*)synth_alloc((size_t)(ns * m->nq), sizeof(mjtNum), &bad);
  e->vs = (mjtNum*)synth_alloc((size_t)(ns * nv), sizeof(mjtNum), &bad);
  e->qs_fd = (mjtNum*)synth_alloc((size_t)(ns * m->nq), sizeof(mjtNum), &bad);
  e->vs_fd = (mjtNum*)synth_alloc((size_t)(ns * nv), sizeof(mjtNum), &bad);
  e->gqs = (mjtNum*)synth_alloc((size_t)(ns * nv), sizeof(mjtNum), &bad);
  e->gus = (mjtNum*)synth_alloc((size_t)(ns * nv), sizeof(mjtNum), &bad);
  e->gq = (mjtNum*)synth_alloc((size_t)((e->nstep + 1) * nv), sizeof(mjtNum), &bad);
  e->gu = (mjtNum*)synth_alloc((size_t)((e->nstep + 1) * nv), sizeof(mjtNum), &bad);
  e->gctrl = (mjtNum*)synth_alloc((size_t)(e->nstep * e->nu), sizeof(mjtNum), &bad);
  e->var = (double*)synth_alloc((size_t)e->nvar, sizeof(double), &bad);
  if (bad) {
    cli_error("synth: out of memory");
    return 1;
  }
  return 0;
}


//---------------------------------- Controls ------------------------------------------------------

// Controls of step k from the knots (nu x K): ctrl = W_k kappa.
static void synth_ctrl(const synthEngine* e, const double* knots, int k, mjtNum* ctrl) {
  int j = e->knot[k];
  double a = e->alpha[k];
  for (int i = 0; i < e->nu; i++) {
    ctrl[i] = (1 - a) * knots[i * SYNTH_NKNOT + j] + a * knots[i * SYNTH_NKNOT + j + 1];
  }
}


// Pull a control gradient (nstep x nu) back to the knots: gknot += W^T gctrl.
static void synth_pullback(const synthEngine* e, const mjtNum* gctrl, double* gknot) {
  for (int k = 0; k < e->nstep; k++) {
    int j = e->knot[k];
    double a = e->alpha[k];
    for (int i = 0; i < e->nu; i++) {
      gknot[i * SYNTH_NKNOT + j] += (1 - a) * gctrl[k * e->nu + i];
      gknot[i * SYNTH_NKNOT + j + 1] += a * gctrl[k * e->nu + i];
    }
  }
}


//---------------------------------- Loss ----------------------------------------------------------

// Heading psi = atan2(R10, R00) of a unit quaternion, and, if dpsi != NULL, its derivative along
// the local rotation tangent delta (q' = q * exp(delta / 2), mj_integratePos): with
// R' = R (I + [delta]x), d R[:,0] = R[:,1] delta_z - R[:,2] delta_y, so
//   dpsi/ddelta = (0, R10 R02 - R00 R12, R00 R11 - R10 R01) / (R00^2 + R10^2).
double synth_heading(const mjtNum quat[4], mjtNum dpsi[3]) {
  mjtNum R[9];
  mju_quat2Mat(R, quat);
  double c = R[0], s = R[3], n2 = c * c + s * s;
  if (dpsi) {
    dpsi[0] = 0;
    dpsi[1] = (s * R[2] - c * R[5]) / n2;
    dpsi[2] = (c * R[4] - s * R[1]) / n2;
  }
  return atan2(s, c);
}


// Angle wrapped to (-pi, pi].
static double synth_wrap(double a) {
  a = fmod(a + mjPI, 2 * mjPI);
  return (a <= 0 ? a + 2 * mjPI : a) - mjPI;
}


// Squared distance of p from the segment [a, b], and its gradient 2 (p - c), c the closest point
// (the gradient holds also where c moves along the segment: p - c is then normal to it).
static double synth_segmentDist2(const double p[2], const double a[2], const double b[2],
                                 double grad[2]) {
  double d[2] = {b[0] - a[0], b[1] - a[1]};
  double len2 = d[0] * d[0] + d[1] * d[1];
  double t = len2 > 0 ? ((p[0] - a[0]) * d[0] + (p[1] - a[1]) * d[1]) / len2 : 0;
  t = t < 0 ? 0 : (t > 1 ? 1 : t);
  double r[2] = {p[0] - a[0] - t * d[0], p[1] - a[1] - t * d[1]};
  grad[0] = 2 * r[0];
  grad[1] = 2 * r[1];
  return r[0] * r[0] + r[1] * r[1];
}


// Loss of the regularizers and, if gknot != NULL, their gradient (added).
static double synth_regLoss(const synthEngine* e, const double* knots, double* gknot) {
  double loss = 0;
  for (int i = 0; i < e->nu; i++) {
    const double* kp = knots + i * SYNTH_NKNOT;
    double* g = gknot ? gknot + i * SYNTH_NKNOT : NULL;
    for (int j = 0; j < SYNTH_NKNOT; j++) {
      loss += SYNTH_W_MAG * kp[j] * kp[j];
      if (g) {
        g[j] += 2 * SYNTH_W_MAG * kp[j];
      }
    }
    for (int j = 0; j + 1 < SYNTH_NKNOT; j++) {
      double dk = kp[j + 1] - kp[j];
      loss += SYNTH_W_SMOOTH * dk * dk;
      if (g) {
        g[j + 1] += 2 * SYNTH_W_SMOOTH * dk;
        g[j] -= 2 * SYNTH_W_SMOOTH * dk;
      }
    }
  }
  return loss;
}


// Loss of the sample states qs, vs ((S + 1) x nq, nv) and, if gqs != NULL, its cotangents gqs,
// gus ((S + 1) x nv, tangent; overwritten). Fills ev except ev->loss.
static double synth_stateLoss(const synthEngine* e, const synthTask* task, const mjtNum* qs,
                              const mjtNum* vs, mjtNum* gqs, mjtNum* gus, synthEval* ev) {
  int nq = e->m->nq, nv = e->m->nv, S = e->nsample;
  const double* p0 = task->start;
  const double* pt = task->target;
  double loss = 0, grad[2];
  if (gqs) {
    mju_zero(gqs, (S + 1) * nv);
    mju_zero(gus, (S + 1) * nv);
  }

  // tracking: every sample after the start
  for (int s = 1; s <= S; s++) {
    loss += SYNTH_W_TRACK * SYNTH_DT * synth_segmentDist2(qs + s * nq, p0, pt, grad);
    if (gqs) {
      gqs[s * nv + 0] += SYNTH_W_TRACK * SYNTH_DT * grad[0];
      gqs[s * nv + 1] += SYNTH_W_TRACK * SYNTH_DT * grad[1];
    }
  }

  // final position, heading, velocity and yaw rate
  const mjtNum* q = qs + S * nq;
  const mjtNum* v = vs + S * nv;
  mjtNum dpsi[3];
  double ex = q[0] - pt[0], ey = q[1] - pt[1];
  double eh = synth_wrap(synth_heading(q + 3, dpsi) - pt[2]);
  loss += SYNTH_W_POS * (ex * ex + ey * ey) + SYNTH_W_HEAD * eh * eh;
  loss += SYNTH_W_VEL * (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]) + SYNTH_W_YAW * v[5] * v[5];
  if (gqs) {
    mjtNum* gq = gqs + S * nv;
    mjtNum* gu = gus + S * nv;
    gq[0] += 2 * SYNTH_W_POS * ex;
    gq[1] += 2 * SYNTH_W_POS * ey;
    for (int i = 0; i < 3; i++) {
      gq[3 + i] += 2 * SYNTH_W_HEAD * eh * dpsi[i];
      gu[i] += 2 * SYNTH_W_VEL * v[i];
    }
    gu[5] += 2 * SYNTH_W_YAW * v[5];
  }
  ev->pos_err = sqrt(ex * ex + ey * ey);
  ev->speed = sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]);
  ev->heading_err = eh;
  ev->x = q[0];
  ev->y = q[1];
  return loss;
}


//---------------------------------- Rollouts ------------------------------------------------------

// Set d to the task's start: chassis at (x, y, qpos0 z) with yaw, every joint and velocity 0.
static void synth_start(const synthEngine* e, const synthTask* task) {
  mjData* d = e->d;
  cli_resetState(e->m, d);
  d->qpos[0] = task->start[0];
  d->qpos[1] = task->start[1];
  d->qpos[3] = cos(0.5 * task->start[2]);
  d->qpos[4] = 0;
  d->qpos[5] = 0;
  d->qpos[6] = sin(0.5 * task->start[2]);
}


// Roll the task out with the knots (recorded on the tape for ostrich); sample states into qs, vs.
// Return SYNTH_OK, SYNTH_BAD (e->why says why) or SYNTH_FAILED (printed).
static int synth_rollout(synthEngine* e, const synthTask* task, const double* knots, mjtNum* qs,
                         mjtNum* vs) {
  const mjModel* m = e->m;
  mjData* d = e->d;
  synth_start(e, task);
  if (e->ostrich) {
    ost_tapeClear(e->tape);
  }
  mju_copy(qs, d->qpos, m->nq);
  mju_copy(vs, d->qvel, m->nv);
  for (int k = 0; k < e->nstep; k++) {
    synth_ctrl(e, knots, k, d->ctrl);
    int status = e->ostrich ? ost_tapeStep(e->tape, m, d) : (mj_step(m, d), OST_OK);
    if (cli_mujocoError()) {
      cli_error("synth: %s step %d: mujoco error: %s", e->name, k + 1, cli_mujocoError());
      return SYNTH_FAILED;
    }
    if (status != OST_OK) {
      snprintf(e->why, sizeof(e->why), "step %d failed: %s", k + 1, ost_lastError(d));
      return SYNTH_BAD;
    }
    if ((k + 1) % e->nsub == 0) {
      int s = (k + 1) / e->nsub;
      if (cli_hasNan(m, d)) {
        snprintf(e->why, sizeof(e->why), "the rollout diverged by t = %g s", s * SYNTH_DT);
        return SYNTH_BAD;
      }
      mju_copy(qs + s * m->nq, d->qpos, m->nq);
      mju_copy(vs + s * m->nv, d->qvel, m->nv);
    }
  }
  return SYNTH_OK;
}


// Loss of one rollout with the knots (no gradient); NaN if it failed, *status its outcome.
static double synth_rolloutLoss(synthEngine* e, const synthTask* task, const double* knots,
                                int* status) {
  synthEval ev;
  *status = synth_rollout(e, task, knots, e->qs_fd, e->vs_fd);
  if (*status != SYNTH_OK) {
    return NAN;
  }
  return synth_stateLoss(e, task, e->qs_fd, e->vs_fd, NULL, NULL, &ev) +
         synth_regLoss(e, knots, NULL);
}


// Ostrich: recorded rollout, loss, backward pass, pull-back to the knots. Fills ev, gknot.
static int synth_gradAdjoint(synthEngine* e, const synthTask* task, const double* knots,
                             synthEval* ev, double* gknot) {
  const mjModel* m = e->m;
  int nv = m->nv;
  int status = synth_rollout(e, task, knots, e->qs, e->vs);
  if (status != SYNTH_OK) {
    return status;
  }

  // sample cotangents, placed on the steps that end at a sample (row 0: the start)
  mju_zero(gknot, e->nvar);
  ev->loss = synth_stateLoss(e, task, e->qs, e->vs, e->gqs, e->gus, ev) +
             synth_regLoss(e, knots, gknot);
  mju_zero(e->gq, (e->nstep + 1) * nv);
  mju_zero(e->gu, (e->nstep + 1) * nv);
  for (int s = 0; s <= e->nsample; s++) {
    mju_copy(e->gq + s * e->nsub * nv, e->gqs + s * nv, nv);
    mju_copy(e->gu + s * e->nsub * nv, e->gus + s * nv, nv);
  }

  // dL/dctrl by the adjoint, then W^T
  ostGradOptions go;
  ost_defaultGradOptions(&go);
  go.truncate = e->truncate;
  int rc = ost_tapeBackward(e->tape, m, &go, e->gq, e->gu, e->gctrl, NULL, NULL, NULL);
  if (rc != OST_OK) {
    snprintf(e->why, sizeof(e->why), "backward pass failed (status %d): %s", rc,
             ost_tapeError(e->tape));
    return SYNTH_BAD;
  }
  synth_pullback(e, e->gctrl, gknot);
  return SYNTH_OK;
}


typedef struct synthFdCtx_ {      // synth_fdGradient's context in the box scene
  synthEngine*     e;
  const synthTask* task;
} synthFdCtx;

// The loss of a rollout with knots x; *fatal on an error that ends the run.
static double synth_fdLoss(void* ctx, const double* x, int* fatal) {
  synthFdCtx* c = (synthFdCtx*)ctx;
  int status;
  double loss = synth_rolloutLoss(c->e, c->task, x, &status);
  *fatal = status == SYNTH_FAILED;
  return loss;
}


// MuJoCo: base rollout, then finite differences of the whole loss over every knot. Forward:
// g = (L(kappa + eps e_c) - L) / eps; central: (L(+eps) - L(-eps)) / 2 eps. A perturbed rollout
// that fails, or a step that would leave the control range, is replaced by the other side.
static int synth_gradFD(synthEngine* e, const synthTask* task, const double* knots,
                        synthEval* ev, double* gknot) {
  int status = synth_rollout(e, task, knots, e->qs, e->vs);
  if (status != SYNTH_OK) {
    return status;
  }
  double l0 = synth_stateLoss(e, task, e->qs, e->vs, NULL, NULL, ev) +
              synth_regLoss(e, knots, NULL);
  ev->loss = l0;
  synthFdCtx ctx = {e, task};
  return synth_fdGradient(e->nvar, knots, e->var, e->lo, e->hi, e->eps, e->central, l0,
                          synth_fdLoss, &ctx, gknot, &e->fd_fallback) ? SYNTH_FAILED
                                                                      : SYNTH_OK;
}


//---------------------------------- Optimization --------------------------------------------------

typedef struct synthIter_ {       // one iteration of one trial
  synthEval ev;                   // the rollout of the iterate
  double    ms;                   // wall time of the iteration (rollouts, gradient, update)
} synthIter;

typedef struct synthResult_ {     // one engine's results over all trials
  int        trials, iters;       // sizes
  int        nsample;             // loss samples per rollout (S)
  synthIter* it;                  // iterations                            (trials x iters)
  float*     path;                // chassis xy at the samples   (trials x iters x (S+1) x 2)
  int*       done;                // iterations run per trial, failed ones included (trials)
  int*       failed;              // the trial ended early                          (trials)
  int        bad_rollouts;        // iterations whose rollout or gradient failed (loss NaN)
  double     total_s;             // wall time of all trials (s)
  long       fd_fallback;         // finite differences taken one-sided after a failure
} synthResult;


// Allocate a result; return 0, else print why.
static int synth_resultAlloc(synthResult* r, int trials, int iters, int nsample) {
  int bad = 0;
  size_t n = (size_t)trials * (size_t)iters;
  memset(r, 0, sizeof(*r));
  r->trials = trials;
  r->iters = iters;
  r->nsample = nsample;
  r->it = (synthIter*)synth_alloc(n, sizeof(synthIter), &bad);
  r->path = (float*)synth_alloc(n * (size_t)(nsample + 1) * 2, sizeof(float), &bad);
  r->done = (int*)synth_alloc((size_t)trials, sizeof(int), &bad);
  r->failed = (int*)synth_alloc((size_t)trials, sizeof(int), &bad);
  if (bad) {
    cli_error("synth: out of memory");
  }
  return bad;
}


// Free a result.
static void synth_resultFree(synthResult* r) {
  free(r->it);
  free(r->path);
  free(r->done);
  free(r->failed);
}


// Adam direction from gradient g (t: 1-based count of gradients): the moments are updated and
// dir = mhat / (sqrt(vhat) + eps); the step is kappa - lr dir.
void synth_adam(int nvar, int t, const double* g, double* mom, double* var2, double* dir) {
  double c1 = 1 - pow(SYNTH_ADAM_B1, t), c2 = 1 - pow(SYNTH_ADAM_B2, t);
  for (int c = 0; c < nvar; c++) {
    mom[c] = SYNTH_ADAM_B1 * mom[c] + (1 - SYNTH_ADAM_B1) * g[c];
    var2[c] = SYNTH_ADAM_B2 * var2[c] + (1 - SYNTH_ADAM_B2) * g[c] * g[c];
    dir[c] = (mom[c] / c1) / (sqrt(var2[c] / c2) + SYNTH_ADAM_EPS);
  }
}


// kappa = prev - lr dir, projected onto the control range.
static void synth_step(const synthEngine* e, const double* prev, double lr, const double* dir,
                       double* knots) {
  for (int c = 0; c < e->nvar; c++) {
    double k = prev[c] - lr * dir[c];
    knots[c] = k < e->lo ? e->lo : (k > e->hi ? e->hi : k);
  }
}


// Step-size factor of iteration i of n: cosine decay from 1 to SYNTH_LR_FLOOR, so that late
// iterates settle instead of orbiting the minimum at the full step (measured, 25 trials: the
// same 17 successes at the best iterate, 10 instead of 7 at the last one)
double synth_decay(int i, int n) {
  double f = n > 1 ? (double)i / (n - 1) : 0;
  return SYNTH_LR_FLOOR + (1 - SYNTH_LR_FLOOR) * 0.5 * (1 + cos(3.14159265358979323846 * f));
}


// Optimize one trial: iters rollouts with gradients and Adam steps; record into r. An iterate
// whose rollout or gradient fails (SYNTH_BAD) is recorded with a NaN loss and replaced by the
// last good iterate's step at half the step size (the rest of the trial keeps the smaller step);
// the trial ends at a failure of its first iterate, after SYNTH_MAX_BAD failures in a row, or
// at SYNTH_FAILED. Return 0, or 1 if the trial ended early.
static int synth_trial(synthEngine* e, const synthArgs* a, const synthTask* task, int trial,
                       synthResult* r) {
  int bad = 0, nvar = e->nvar, S = e->nsample, progress = cli_progress();
  double* knots = (double*)synth_alloc((size_t)nvar, sizeof(double), &bad);
  double* prev = (double*)synth_alloc((size_t)nvar, sizeof(double), &bad);
  double* grad = (double*)synth_alloc((size_t)nvar, sizeof(double), &bad);
  double* dir = (double*)synth_alloc((size_t)nvar, sizeof(double), &bad);
  double* mom = (double*)synth_alloc((size_t)nvar, sizeof(double), &bad);
  double* var2 = (double*)synth_alloc((size_t)nvar, sizeof(double), &bad);
  int status = bad ? SYNTH_FAILED : SYNTH_OK, ngood = 0, nbad = 0;
  double lr = a->lr;
  if (bad) {
    cli_error("synth: out of memory");
  }
  for (int c = 0; c < nvar && !bad; c++) {
    knots[c] = c % SYNTH_NKNOT == SYNTH_NKNOT - 1 ? 0 : SYNTH_INIT_KNOT;
  }
  for (int i = 0; i < r->iters && status != SYNTH_FAILED; i++) {
    synthIter* it = r->it + trial * r->iters + i;
    double start = cli_now();
    status = e->ostrich ? synth_gradAdjoint(e, task, knots, &it->ev, grad)
                        : synth_gradFD(e, task, knots, &it->ev, grad);
    if (status == SYNTH_OK) {
      // a good iterate: Adam step from it
      synth_adam(nvar, ++ngood, grad, mom, var2, dir);
      mju_copy(prev, knots, nvar);
      synth_step(e, prev, lr * synth_decay(i, r->iters), dir, knots);
      nbad = 0;
    } else if (status == SYNTH_BAD && ngood > 0) {
      // a failed iterate: half the last step from the last good iterate
      lr *= 0.5;
      synth_step(e, prev, lr * synth_decay(i, r->iters), dir, knots);
      nbad++;
    }
    it->ms = 1e3 * (cli_now() - start);
    r->done[trial] = i + 1;

    // record and report
    if (status != SYNTH_OK) {
      it->ev = (synthEval){NAN, NAN, NAN, NAN, NAN, NAN};
      r->bad_rollouts += (status == SYNTH_BAD);
      int end = (status == SYNTH_FAILED || ngood == 0 || nbad >= SYNTH_MAX_BAD);
      if (status == SYNTH_BAD) {
        cli_error("synth: %s trial %d iteration %d: %s; %s", e->name, trial + 1, i + 1, e->why,
                  end ? "trial ended" : "retrying the last step at half the step size");
      }
      if (end) {
        status = SYNTH_FAILED;
      }
      continue;
    }
    float* path = r->path + ((size_t)(trial * r->iters + i)) * (size_t)(S + 1) * 2;
    for (int s = 0; s <= S; s++) {
      path[2 * s] = (float)e->qs[s * e->m->nq];
      path[2 * s + 1] = (float)e->qs[s * e->m->nq + 1];
    }
    if (progress) {
      fprintf(stderr, "ostrich: synth %s trial %d/%d iter %d/%d loss %.5g pos_err %.4f m "
              "speed %.4f m/s heading_err %.4f rad %.1f ms\n", e->name, trial + 1, r->trials,
              i + 1, r->iters, it->ev.loss, it->ev.pos_err, it->ev.speed, it->ev.heading_err,
              it->ms);
    }
  }
  r->failed[trial] = (status == SYNTH_FAILED);
  free(knots);
  free(prev);
  free(grad);
  free(dir);
  free(mom);
  free(var2);
  return r->failed[trial];
}


// Run every trial on one engine; return the number of trials that ended early.
static int synth_run(synthEngine* e, const synthArgs* a, const synthTask* tasks,
                     synthResult* r) {
  int nfailed = 0;
  double start = cli_now();
  for (int t = 0; t < r->trials; t++) {
    if (cli_progress()) {
      fprintf(stderr, "ostrich: synth %s trial %d/%d: start (%.3f, %.3f) m yaw %.3f rad, "
              "target (%.3f, %.3f) m heading %.3f rad\n", e->name, t + 1, r->trials,
              tasks[t].start[0], tasks[t].start[1], tasks[t].start[2], tasks[t].target[0],
              tasks[t].target[1], tasks[t].target[2]);
    }
    nfailed += synth_trial(e, a, tasks + t, t, r);
  }
  r->total_s = cli_now() - start;
  r->fd_fallback = e->fd_fallback;
  return nfailed;
}


//---------------------------------- Summary -------------------------------------------------------

typedef struct synthSummary_ {    // one engine's summary
  int    successes;               // at the best-loss iterate
  int    successes_last;          // at the last iterate
  int    failed;                  // trials that ended early
  double median_error;            // final position error at the best-loss iterates (m)
  double median_speed;            // final speed at the best-loss iterates (m/s)
  double median_warm_ms;          // median iteration time, each trial's first excluded (ms)
} synthSummary;


// Ascending order of doubles (qsort).
static int synth_compare(const void* a, const void* b) {
  double x = *(const double*)a, y = *(const double*)b;
  return (x > y) - (x < y);
}


// Median of n values (sorted in place); NaN if n = 0.
double synth_median(double* x, int n) {
  if (n <= 0) {
    return NAN;
  }
  qsort(x, (size_t)n, sizeof(double), synth_compare);
  return n % 2 ? x[n / 2] : 0.5 * (x[n / 2 - 1] + x[n / 2]);
}


// Index of the best-loss iteration of a trial, -1 if it has none.
static int synth_best(const synthResult* r, int t) {
  int best = -1;
  for (int i = 0; i < r->done[t]; i++) {
    const synthIter* it = r->it + t * r->iters + i;
    if (isfinite(it->ev.loss) && (best < 0 || it->ev.loss < r->it[t * r->iters + best].ev.loss)) {
      best = i;
    }
  }
  return best;
}


// Success of an iterate.
static int synth_success(const synthEval* ev) {
  return ev->pos_err < SYNTH_POS_OK && ev->speed < SYNTH_SPEED_OK;
}


// Summarize one engine's result; return 0, else print why (out of memory).
static int synth_summarize(const synthResult* r, synthSummary* sum) {
  int bad = 0, nerr = 0, nwarm = 0;
  double* err = (double*)synth_alloc((size_t)r->trials, sizeof(double), &bad);
  double* speed = (double*)synth_alloc((size_t)r->trials, sizeof(double), &bad);
  double* warm = (double*)synth_alloc((size_t)r->trials * (size_t)r->iters, sizeof(double), &bad);
  memset(sum, 0, sizeof(*sum));
  for (int t = 0; t < r->trials && !bad; t++) {
    int best = synth_best(r, t);
    sum->failed += r->failed[t];
    int last = r->done[t] - 1;
    while (last >= 0 && !isfinite(r->it[t * r->iters + last].ev.loss)) {
      last--;
    }
    if (best >= 0) {
      const synthEval* ev = &r->it[t * r->iters + best].ev;
      sum->successes += synth_success(ev);
      sum->successes_last += synth_success(&r->it[t * r->iters + last].ev);
      err[nerr] = ev->pos_err;
      speed[nerr++] = ev->speed;
    }
    for (int i = 1; i < r->done[t]; i++) {
      warm[nwarm++] = r->it[t * r->iters + i].ms;
    }
  }
  if (!bad) {
    sum->median_error = synth_median(err, nerr);
    sum->median_speed = synth_median(speed, nerr);
    sum->median_warm_ms = synth_median(warm, nwarm);
  } else {
    cli_error("synth: out of memory");
  }
  free(err);
  free(speed);
  free(warm);
  return bad;
}


// Print one engine's summary as JSON members (no braces); with_time: its total_s too.
static void synth_printSummary(const synthEngine* e, const synthResult* r,
                               const synthSummary* s, int with_time) {
  printf("\"engine\":\"%s\",\"h\":", e->name);
  cli_jsonNumber(stdout, e->h);
  printf(",\"steps\":%d,\"gradient\":", e->nstep);
  if (e->ostrich) {
    printf("\"adjoint, %s\"", e->truncate ? "truncated" : "complete");
  } else {
    printf("\"%s differences, eps %g rad/s, %d rollouts per iteration\"",
           e->central ? "central" : "forward", e->eps, 1 + (e->central ? 2 : 1) * e->nvar);
  }
  printf(",\"trials\":%d,\"successes\":%d,\"success_rate\":", r->trials, s->successes);
  cli_jsonNumber(stdout, (double)s->successes / r->trials);
  printf(",\"successes_last\":%d,\"median_final_error\":", s->successes_last);
  cli_jsonNumber(stdout, s->median_error);
  printf(",\"median_final_speed\":");
  cli_jsonNumber(stdout, s->median_speed);
  printf(",\"median_warm_iter_ms\":");
  cli_jsonNumber(stdout, s->median_warm_ms);
  printf(",\"failed_trials\":%d,\"bad_rollouts\":%d", s->failed, r->bad_rollouts);
  if (!e->ostrich) {
    printf(",\"fd_fallbacks\":%ld", r->fd_fallback);
  }
  if (with_time) {
    printf(",\"total_s\":%.3f", r->total_s);
  }
}


//---------------------------------- Output files --------------------------------------------------

// Path of the trajectory CSV next to FILE.csv: FILE_traj.csv (written into buf).
void synth_trajPath(const char* csv, char* buf, size_t sz) {
  size_t n = strlen(csv);
  int ext = n >= 4 && !strcmp(csv + n - 4, ".csv");
  snprintf(buf, sz, "%.*s_traj.csv", (int)(ext ? n - 4 : n), csv);
}


// Write the iteration CSV and the trajectory CSV (each atomically); return 0, else print why.
static int synth_writeCsv(const char* path, const synthEngine* engines, const synthResult* res,
                          int nengine) {
  char traj[CLI_PATH_SZ], tmp_f[CLI_PATH_SZ], tmp_g[CLI_PATH_SZ];
  synth_trajPath(path, traj, sizeof(traj));
  FILE* f = cli_openOutput(path, tmp_f, sizeof(tmp_f));
  FILE* g = f ? cli_openOutput(traj, tmp_g, sizeof(tmp_g)) : NULL;
  if (!f || !g) {
    if (f) {
      cli_discardOutput(f, tmp_f);
    }
    return 1;
  }
  fprintf(f, "engine,trial,iter,loss,pos_err,speed,heading_err,time_ms,x,y\n");
  fprintf(g, "engine,trial,iter,t,x,y\n");
  for (int k = 0; k < nengine; k++) {
    const synthResult* r = res + k;
    for (int t = 0; t < r->trials; t++) {
      for (int i = 0; i < r->done[t]; i++) {
        const synthIter* it = r->it + t * r->iters + i;
        fprintf(f, "%s,%d,%d,%.10g,%.6g,%.6g,%.6g,%.3f,%.6g,%.6g\n", engines[k].name, t + 1,
                i + 1, it->ev.loss, it->ev.pos_err, it->ev.speed, it->ev.heading_err, it->ms,
                it->ev.x, it->ev.y);
        const float* p = r->path + ((size_t)(t * r->iters + i)) * (size_t)(r->nsample + 1) * 2;
        for (int s = 0; s <= r->nsample && isfinite(it->ev.loss); s++) {
          fprintf(g, "%s,%d,%d,%.3f,%.6g,%.6g\n", engines[k].name, t + 1, i + 1, s * SYNTH_DT,
                  p[2 * s], p[2 * s + 1]);
        }
      }
    }
  }
  if (cli_commitOutput(f, tmp_f, path) | cli_commitOutput(g, tmp_g, traj)) {
    return 1;
  }
  fprintf(stderr, "ostrich: wrote %s and %s\n", path, traj);
  return 0;
}


// Write the gnuplot commands that draw the obstacles' footprints: every box of the world body
// as its rotated rectangle, any other non-plane world geom as a circle of its bounding radius.
static void synth_plotObstacles(FILE* p, const mjModel* m) {
  int id = 1;
  for (int g = 0; g < m->ngeom; g++) {
    int type = m->geom_type[g];
    if (m->geom_bodyid[g] != 0 || type == mjGEOM_PLANE || type == mjGEOM_HFIELD) {
      continue;
    }
    const mjtNum* pos = m->geom_pos + 3 * g;
    if (type == mjGEOM_BOX) {
      mjtNum R[9];
      mju_quat2Mat(R, m->geom_quat + 4 * g);
      const mjtNum* sz = m->geom_size + 3 * g;
      const int corner[5][2] = {{1, 1}, {-1, 1}, {-1, -1}, {1, -1}, {1, 1}};
      fprintf(p, "set object %d polygon", id++);
      for (int c = 0; c < 5; c++) {
        double lx = corner[c][0] * sz[0], ly = corner[c][1] * sz[1];
        fprintf(p, " %s %.4f,%.4f", c ? "to" : "from", pos[0] + R[0] * lx + R[1] * ly,
                pos[1] + R[3] * lx + R[4] * ly);
      }
    } else {
      fprintf(p, "set object %d circle at %.4f,%.4f size %.4f", id++, pos[0], pos[1],
              m->geom_rbound[g]);
    }
    fprintf(p, " behind fillcolor rgb '#c8a070' fillstyle solid 0.6 border lc rgb '#805020'\n");
  }
}


// Write the gnuplot script of the PNG (terminal: pngcairo or png).
static void synth_plotScript(FILE* p, const char* terminal, const char* png,
                             const synthEngine* engines, const synthResult* res, int nengine,
                             const synthTask* tasks) {
  fprintf(p, "set terminal %s size %d,600\n", terminal, nengine > 1 ? 1600 : 900);
  fprintf(p, "set output '");
  for (const char* c = png; *c; c++) {
    fputs(*c == '\'' ? "''" : (char[2]){*c, 0}, p);
  }
  fprintf(p, "'\n");

  // data: per engine, one block of paths (x y iteration; a blank line between paths) and one
  // of best-loss paths; starts and targets
  for (int k = 0; k < nengine; k++) {
    const synthResult* r = res + k;
    for (int best = 0; best < 2; best++) {
      fprintf(p, "$%s%d << EOD\n", best ? "B" : "P", k);
      for (int t = 0; t < r->trials; t++) {
        int b = synth_best(r, t);
        for (int i = best ? b : 0; i >= 0 && i < (best ? b + 1 : r->done[t]); i++) {
          if (!isfinite(r->it[t * r->iters + i].ev.loss)) {
            continue;
          }
          const float* q = r->path + ((size_t)(t * r->iters + i)) * (size_t)(r->nsample + 1) * 2;
          for (int s = 0; s <= r->nsample; s++) {
            fprintf(p, "%.4f %.4f %d\n", q[2 * s], q[2 * s + 1], i + 1);
          }
          fprintf(p, "\n");
        }
      }
      fprintf(p, "EOD\n");
    }
  }
  fprintf(p, "$S << EOD\n");
  for (int t = 0; t < res[0].trials; t++) {
    fprintf(p, "%.4f %.4f %.4f %.4f\n", tasks[t].start[0], tasks[t].start[1], tasks[t].target[0],
            tasks[t].target[1]);
  }
  fprintf(p, "EOD\n");

  // panels
  if (nengine > 1) {
    fprintf(p, "set multiplot layout 1,%d\n", nengine);
  }
  fprintf(p, "set size ratio -1\nset xrange [-0.6:3.8]\nset yrange [-1.2:1.2]\n"
             "set xlabel 'x (m)'\nset ylabel 'y (m)'\nset cblabel 'iteration'\n"
             "set cbrange [1:%d]\nset palette rgbformulae 33,13,10\nset grid\n"
             "set key top left box opaque\n", res[0].iters > 1 ? res[0].iters : 2);
  synth_plotObstacles(p, engines[0].m);
  for (int k = 0; k < nengine; k++) {
    synthSummary s;
    synth_summarize(res + k, &s);
    fprintf(p, "set title '%s (%s, h = %g s): %d/%d trials reached the target' noenhanced\n",
            engines[k].name, engines[k].ostrich ? "adjoint" : "finite differences", engines[k].h,
            s.successes, res[k].trials);
    fprintf(p, "plot $P%d using 1:2:3 with lines lc palette lw 1 notitle, "
               "$B%d using 1:2 with lines lc rgb 'black' lw 2 title 'best-loss iterate', "
               "$S using 1:2 with points pt 7 ps 1.2 lc rgb 'black' title 'start', "
               "$S using 3:4 with points pt 6 ps 2.5 lw 2 lc rgb 'black' title 'target'\n",
            k, k);
  }
  if (nengine > 1) {
    fprintf(p, "unset multiplot\n");
  }
}


// Draw the PNG with gnuplot (stdout sent to stderr); pngcairo, else the libgd png terminal.
// Return 0, else print why.
static int synth_writePlot(const char* png, const synthEngine* engines, const synthResult* res,
                           int nengine, const synthTask* tasks) {
  const char* terminals[] = {"pngcairo", "png"};
  char tmp[CLI_PATH_SZ];
  if (cli_outputTemp(png, tmp, sizeof(tmp))) {
    return 1;
  }
  for (int i = 0; i < 2; i++) {
    fflush(stdout);
    FILE* p = popen("gnuplot 1>&2", "w");
    if (!p) {
      cli_error("cannot run gnuplot: %s", strerror(errno));
      return 1;
    }
    synth_plotScript(p, terminals[i], tmp, engines, res, nengine, tasks);
    int status = pclose(p);
    if (status != -1 && WIFEXITED(status) && WEXITSTATUS(status) == 0) {
      if (cli_commitOutput(NULL, tmp, png)) {
        return 1;
      }
      fprintf(stderr, "ostrich: wrote %s (gnuplot, %s terminal)\n", png, terminals[i]);
      return 0;
    }
    if (status != -1 && WIFEXITED(status) && WEXITSTATUS(status) == 127) {
      cli_error("cannot run gnuplot (is it installed? Debian: gnuplot-nox)");
      cli_discardOutput(NULL, tmp);
      return 1;
    }
  }
  cli_error("gnuplot could not draw '%s' with the pngcairo or png terminal", png);
  cli_discardOutput(NULL, tmp);
  return 1;
}


//---------------------------------- synth ---------------------------------------------------------

// Draw the trials' tasks from one stream.
static void synth_tasks(long seed, synthTask* tasks, int n) {
  cliRng rng;
  cli_rngSeed(&rng, (unsigned long long)seed);
  for (int t = 0; t < n; t++) {
    tasks[t].start[0] = cli_uniform(&rng, -SYNTH_START_XY, SYNTH_START_XY);
    tasks[t].start[1] = cli_uniform(&rng, -SYNTH_START_XY, SYNTH_START_XY);
    tasks[t].start[2] = cli_uniform(&rng, -SYNTH_START_YAW, SYNTH_START_YAW);
    tasks[t].target[0] = SYNTH_TARGET_X;
    tasks[t].target[1] = cli_uniform(&rng, -SYNTH_TARGET_Y, SYNTH_TARGET_Y);
    tasks[t].target[2] = cli_uniform(&rng, -SYNTH_TARGET_HEAD, SYNTH_TARGET_HEAD);
  }
}


// Print the JSON line.
static void synth_report(const synthArgs* a, const synthEngine* engines, const synthResult* res,
                         const synthSummary* sums, int nengine, double total) {
  printf("{");
  if (nengine == 1) {
    synth_printSummary(engines, res, sums, 0);
    printf(",");
  } else {
    printf("\"engine\":\"both\",\"trials\":%ld,", a->trials);
  }
  printf("\"model\":");
  cli_jsonString(stdout, a->model);
  printf(",\"iters\":%ld,\"seed\":%ld,\"lr\":", a->iters, a->seed);
  cli_jsonNumber(stdout, a->lr);
  if (nengine > 1) {
    for (int k = 0; k < nengine; k++) {
      printf(",\"%s\":{", engines[k].name);
      synth_printSummary(engines + k, res + k, sums + k, 1);
      printf("}");
    }
    printf(",\"warm_iter_ratio\":");
    cli_jsonNumber(stdout, sums[1].median_warm_ms / sums[0].median_warm_ms);
  }
  printf(",\"total_s\":%.3f}\n", total);
  fflush(stdout);
}


// `ostrich synth [MODEL.xml] [options]`
int synth_main(int argc, char** argv) {
  // trials, iters and grad: -1 and NULL until the scene's defaults fill them
  synthArgs a = {.trials = -1, .iters = -1, .seed = 1, .lr = 0.3, .engine = "ostrich",
                 .fd = "forward", .eps = 0.1, .grad = NULL, .scene = "box"};
  if (cli_parseArgs("synth", argc, argv, kSynthOptions, kSynthNumOptions, &a, &a.model,
                    &a.help)) {
    return CLI_USAGE;
  }
  int terrain = !strcmp(a.scene, "terrain");
  if (!terrain && strcmp(a.scene, "box")) {
    cli_error("--scene: '%s' is not box or terrain", a.scene);
    return CLI_USAGE;
  }
  if (!a.model) {
    a.model = terrain ? "mjcf_models/terrain_mesh.xml" : "mjcf_models/robot_box.xml";
  }
  if (a.trials < 0) {
    a.trials = terrain ? 50 : 10;
  }
  if (a.iters < 0) {
    a.iters = terrain ? 100 : 50;
  }
  if (!a.grad) {
    a.grad = terrain ? "truncated" : "complete";
  }
  if (!strcmp(a.engine, "ostrich,mujoco") || !strcmp(a.engine, "mujoco,ostrich")) {
    a.engine = "both";  // the comma list of the other commands
  }
  if (a.help) {
    synth_usage(stdout);
    return CLI_OK;
  }
  if (synth_checkArgs(&a)) {
    return CLI_USAGE;
  }
  if (terrain) {
    return synth_terrainMain(&a);
  }

  // engines: ostrich first when both; the same tasks for each
  double start = cli_now();
  int both = !strcmp(a.engine, "both");
  int nengine = both ? 2 : 1;
  const char* names[2] = {both ? "ostrich" : a.engine, "mujoco"};
  synthEngine engines[2];
  synthResult res[2];
  synthSummary sums[2];
  memset(engines, 0, sizeof(engines));
  memset(res, 0, sizeof(res));
  synthTask* tasks = (synthTask*)calloc((size_t)a.trials, sizeof(synthTask));
  int status = tasks ? CLI_OK : CLI_USAGE;
  for (int k = 0; k < nengine && status == CLI_OK; k++) {
    if (synth_engineSetup(engines + k, names[k], &a) ||
        synth_resultAlloc(res + k, (int)a.trials, (int)a.iters, engines[k].nsample)) {
      status = CLI_USAGE;
    }
  }
  if (status == CLI_OK) {
    synth_tasks(a.seed, tasks, (int)a.trials);
    for (int k = 0; k < nengine; k++) {
      int ended = synth_run(engines + k, &a, tasks, res + k);
      if (synth_summarize(res + k, sums + k) || ended || cli_mujocoError()) {
        status = CLI_FAIL;
      }
    }

    // outputs, then the summary
    if (a.csv && synth_writeCsv(a.csv, engines, res, nengine)) {
      status = CLI_FAIL;
    }
    if (a.plot && synth_writePlot(a.plot, engines, res, nengine, tasks)) {
      status = CLI_FAIL;
    }
    synth_report(&a, engines, res, sums, nengine, cli_now() - start);
  } else if (!tasks) {
    cli_error("synth: out of memory");
  }
  for (int k = 0; k < nengine; k++) {
    synth_resultFree(res + k);
    synth_engineFree(engines + k);
  }
  free(tasks);
  return status;
}
