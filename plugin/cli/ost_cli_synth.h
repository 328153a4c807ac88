// ost_cli_synth.h: what the scenes of `ostrich synth` share. ost_cli_synth.c parses the
// arguments, runs the box scene and defines the optimizer's small helpers below;
// ost_cli_synth_terrain.c runs the terrain scene (--scene terrain) with them.
//
// Invariant: both scenes read one synthArgs, checked (outputs included) by ost_cli_synth.c
// before either scene starts work.
#ifndef OSTRICH_PLUGIN_CLI_OST_CLI_SYNTH_H_
#define OSTRICH_PLUGIN_CLI_OST_CLI_SYNTH_H_

#include <stddef.h>

#include <mujoco/mujoco.h>

#include "ostrich.h"

#ifdef __cplusplus
extern "C" {
#endif

typedef struct synthArgs_ {       // arguments of `ostrich synth`
  long        trials;             // random tasks (default: box 10, terrain 50)
  long        iters;              // Adam iterations per trial (default: box 50, terrain 100)
  long        seed;               // seed of the task stream (default 1)
  double      lr;                 // Adam step (rad/s, default 0.3)
  const char* engine;             // ostrich | mujoco | both
  const char* plot;               // PNG path; NULL: none
  const char* csv;                // CSV path; NULL: none
  const char* model;              // MJCF path
  const char* fd;                 // forward | central (mujoco)
  double      eps;                // finite-difference step (rad/s, mujoco)
  const char* grad;               // complete | truncated (ostrich; default: box complete,
                                  // terrain truncated)
  const char* scene;              // box | terrain
  int         help;               // --help was given
} synthArgs;

// Allocate n zeroed elements of size sz; record a failure in *bad.
void* synth_alloc(size_t n, size_t sz, int* bad);

// Heading psi = atan2(R10, R00) of a unit quaternion, and, if dpsi != NULL, its derivative along
// the local rotation tangent (q' = q * exp(delta / 2), mj_integratePos).
double synth_heading(const mjtNum quat[4], mjtNum dpsi[3]);

// Median of n values (sorted in place); NaN if n = 0.
double synth_median(double* x, int n);

// Step-size factor of iteration i of n: cosine decay from 1 to a tenth.
double synth_decay(int i, int n);

// Adam direction over nvar variables from gradient g (t: 1-based count of gradients): the
// moments mom, var2 are updated and dir = mhat / (sqrt(vhat) + eps).
void synth_adam(int nvar, int t, const double* g, double* mom, double* var2, double* dir);

// The steps of a rollout at step size h with the loss sampled every dt over horizon seconds, and
// each step's place on a piecewise-linear spline of nknot knots spanning the horizon (taken at
// the step's midpoint: u_k = (1 - alpha_k) kappa_knot_k + alpha_k kappa_knot_k+1). Sets *nsub
// (steps per sample), *nsample, *nstep = nsub nsample and allocates *knot, *alpha (nstep each,
// the caller frees them). Returns 0, else prints why (engine names the engine) and returns 1.
int synth_stepGrid(const char* engine, double h, double dt, double horizon, int nknot,
                   int* nsub, int* nsample, int* nstep, int** knot, double** alpha);

// A gradient engine's tape for model m, after checking that the native geometry takes m.
// Returns 0, else prints why and returns 1.
int synth_gradientTape(const mjModel* m, ostTape** tape);

// Finite-difference gradient g (nvar) of loss at x (nvar; l0 = its loss there), x_c + eps then,
// when central or that side failed, x_c - eps; a side outside [lo, hi] or whose loss is not
// finite is replaced by the other (each replacement counted in *fallback), a column with
// neither gets 0. var (nvar) is scratch. loss(ctx, x, &fatal) sets fatal on an error that must
// end the run; then this returns 1 at once, else 0.
int synth_fdGradient(int nvar, const double* x, double* var, double lo, double hi, double eps,
                     int central, double l0, double (*loss)(void* ctx, const double* x,
                                                            int* fatal),
                     void* ctx, double* g, long* fallback);

// Path of the trajectory CSV next to FILE.csv: FILE_traj.csv (written into buf).
void synth_trajPath(const char* csv, char* buf, size_t sz);

// `ostrich synth --scene terrain` (ost_cli_synth_terrain.c), on checked arguments; returns the
// exit status (CLI_OK, CLI_FAIL, CLI_USAGE).
int synth_terrainMain(const synthArgs* a);

#ifdef __cplusplus
}
#endif

#endif  // OSTRICH_PLUGIN_CLI_OST_CLI_SYNTH_H_
