// ost_cli_synth_terrain.h: the terrain scene of `ostrich synth` (--scene terrain), shared by its
// two files: ost_cli_synth_terrain.c (instances, terrain, rollouts, loss and gradients) and
// ost_cli_synth_terrain_run.c (the optimizer, the summary and the outputs). The task, the loss
// and the sources of the constants are described at the top of ost_cli_synth_terrain.c.
//
// Invariant: knots are laid out wheel-major, knots[i * TER_NKNOT + j], wheel i in kTerWheel
// order (v_left, v_right, v_rear), whatever the actuators' order in the model.
#ifndef OSTRICH_PLUGIN_CLI_OST_CLI_SYNTH_TERRAIN_H_
#define OSTRICH_PLUGIN_CLI_OST_CLI_SYNTH_TERRAIN_H_

#include <mujoco/mujoco.h>

#include "ost_cli_synth.h"
#include "ost_cli_util.h"
#include "ostrich.h"

#ifdef __cplusplus
extern "C" {
#endif

//---------------------------------- Task constants ------------------------------------------------

#define TER_NWHEEL     3          // wheels (actuators v_left, v_right, v_rear)
#define TER_NKNOT      10         // spline knots per wheel (K)
#define TER_NVAR       (TER_NWHEEL * TER_NKNOT)
#define TER_HORIZON    10.0       // s
#define TER_H          0.08       // s: Ostrich's step (T = 125)
#define TER_DT         0.08       // s: interval of the loss samples (S = 125)
#define TER_SPLIT      6          // at least this many halvings of a step whose Newton solve
                                  // fails (ostOptions.split_depth): at 3, a step of the guess's
                                  // rollout did not converge on 3 of seeds 1-50 (residual 7e-5
                                  // to 6e-4 m/s), ending those trials at once; with no bound on
                                  // the splits past 3 (deep_splits), as measured
#define TER_DEEP_SPLITS 1000

#define TER_NWAVE      4          // sinusoids of the surface (gen_terrain.py WAVES)
#define TER_NGRID      80         // samples per side (terrain_sinusoid.bin, .obj)
#define TER_HALF       12.0       // m: half extent (24 x 24 m)
#define TER_R0         1.2        // m: flat disc radius around the start
#define TER_R1         3.7        // m: end of the smoothstep blend
#define TER_ZLO        -0.139822  // m: elevation of data 0 (terrain_hfield.xml geom pos z)
#define TER_SPAN       0.28148    // m: elevation of data 1 minus ZLO (hfield size[2])
#define TER_AMP_MIN    0.5        // wave amplitude a_k ~ a0_k U(TER_AMP_MIN, 1)

#define TER_BASE_LO    1.0        // rad/s: target base knot b_j ~ U(LO, HI); 0.35 m wheels, so
#define TER_BASE_HI    3.0        //   0.35-1.05 m/s, at most 10.5 m in 10 s (the edge is at 12)
#define TER_TURN       0.5        // rad/s: target left/right half difference d_j ~ U(-., .)
#define TER_SIGMA      1.5        // rad/s: guess = target + N(0, SIGMA^2) per knot

#define TER_W_TRACK    1.0        // 1/m^2
#define TER_W_YAW      0.25       // m^2 per (2 - 2 cos dpsi)
#define TER_W_MAG      1e-5       // s^2/rad^2
#define TER_W_SMOOTH   1e-4       // s^2/rad^2
#define TER_W_SLIP     1e-2       // s^2/rad^2

#define TER_RMSE_OK    0.5        // m: success: best RMSE below
#define TER_RMSE_GOOD  0.2        // m: also counted: best RMSE below
#define TER_MAX_BAD    3          // failed iterates in a row that end a trial


//---------------------------------- Types ---------------------------------------------------------

typedef struct terTask_ {         // one instance, from one seed
  double wave[TER_NWAVE][4];      // amplitude (m), wavelength (m), direction (rad), phase (rad)
  double target[TER_NVAR];        // target knots (rad/s)
  double guess[TER_NVAR];         // initial knots (rad/s)
} terTask;

typedef struct terEval_ {         // what one rollout achieved
  double loss;                    // L
  double rmse;                    // xy tracking RMSE against the target path (m)
} terEval;

enum {                            // outcome of a rollout (and its gradient)
  TER_OK = 0,                     // finished
  TER_BAD,                        // this rollout failed (why in terEngine.why): a non-finite
                                  // state, MuJoCo reset a diverged one, an Ostrich step (e.g.
                                  // not converged) or the backward pass returned an error
  TER_FAILED                      // MuJoCo error (it sticks for the process) or out of memory
};

typedef struct terEngine_ {       // one engine on its scene
  // setup
  const char* name;               // "ostrich" or "mujoco"
  int         ostrich;            // 1: ost_tapeStep + adjoint; 0: mj_step + finite differences
  mjModel*    m;                  // scene (ostrich: mesh terrain; mujoco: height field)
  mjData*     d;                  // data
  int         act[TER_NWHEEL];    // actuator of each wheel (v_left, v_right, v_rear)
  int         geom;               // the terrain geom
  int*        vgrid;              // ostrich: grid sample of each mesh vertex          (nvert)
  float*      vert0;              // ostrich: the mesh's vertices as loaded (local) (nvert x 3)
  double      h;                  // step size (s)
  int         nsub;               // steps per loss sample (TER_DT / h)
  int         nsample;            // loss samples after the start (S)
  int         nstep;              // steps of a rollout (nsub S)
  double      lo, hi;             // knot bounds: v_left's ctrlrange, else +-inf
  int*        knot;               // step k: its interval j                           (nstep)
  double*     alpha;              // step k: its weight a                             (nstep)
  ostTape*    tape;               // rollout record (ostrich)
  int         truncate;           // backward pass: ostGradOptions.truncate (ostrich)
  int         central;            // finite differences: 1 central, 0 forward (mujoco)
  double      eps;                // finite-difference step (rad/s)

  // the instance
  double*     ref;                // target path: x, y (m), heading (rad) per sample ((S+1) x 3)

  // scratch
  mjtNum*     qs;                 // sample states: qpos                      ((S + 1) x nq)
  mjtNum*     vs;                 //                qvel                      ((S + 1) x nv)
  mjtNum*     qs_fd;              // the same for perturbed rollouts           ((S + 1) x nq)
  mjtNum*     vs_fd;              //                                           ((S + 1) x nv)
  mjtNum*     gqs;                // loss cotangents of the samples, tangent  ((S + 1) x nv)
  mjtNum*     gus;                //   (qvel: zero, the loss reads positions)  ((S + 1) x nv)
  mjtNum*     gq;                 // tape cotangents, per step            ((nstep + 1) x nv)
  mjtNum*     gu;                 //                                      ((nstep + 1) x nv)
  mjtNum*     gctrl;              // dL/dctrl                                   (nstep x nu)
  double*     var;                // perturbed knots                               (TER_NVAR)

  // outcomes
  char        why[CLI_MSG_SZ];    // why the last rollout was TER_BAD
  long        fd_fallback;        // perturbed rollouts that failed (other side used)
} terEngine;


//---------------------------------- ost_cli_synth_terrain.c ---------------------------------------

// The fixed surface's waves (gen_terrain.py, terrain_sinusoid.*) into task->wave.
void ter_fixedWaves(terTask* task);

// Draw instance `seed`: waves, target knots, guess knots (knots clipped to [lo, hi]).
void ter_task(unsigned long long seed, double lo, double hi, terTask* task);

// The task's surface as height-field data (TER_NGRID^2, row-major, rows along y), in [0, 1].
void ter_heights(const terTask* task, float* data);

// Give the engine's scene the surface `data` (mesh vertices, or height-field samples).
void ter_setTerrain(terEngine* e, const float* data);

// Load an engine's scene (path) and set it up; return 0, else print why (a usage error).
int ter_engineSetup(terEngine* e, const char* name, const char* path, const synthArgs* a);

// Free an engine.
void ter_engineFree(terEngine* e);

// Regularizers of the knots and, if gknot != NULL, their gradient (added).
double ter_regLoss(const double* knots, double* gknot);

// Loss of the sample states against e->ref, its qpos cotangents if gqs != NULL; *rmse (m).
double ter_stateLoss(const terEngine* e, const mjtNum* qs, mjtNum* gqs, double* rmse);

// Roll the knots out from rest at qpos0, sampling qs, vs; TER_OK, TER_BAD or TER_FAILED.
int ter_rollout(terEngine* e, const double* knots, mjtNum* qs, mjtNum* vs);

// Roll the target knots out into e->ref; TER_OK, TER_BAD or TER_FAILED.
int ter_setTarget(terEngine* e, const double* target);

// Ostrich: loss and its adjoint gradient over the knots; TER_OK, TER_BAD or TER_FAILED.
int ter_gradAdjoint(terEngine* e, const double* knots, terEval* ev, double* gknot);

// MuJoCo: loss and its finite-difference gradient over the knots; TER_OK, TER_BAD, TER_FAILED.
int ter_gradFD(terEngine* e, const double* knots, terEval* ev, double* gknot);

#ifdef __cplusplus
}
#endif

#endif  // OSTRICH_PLUGIN_CLI_OST_CLI_SYNTH_TERRAIN_H_
