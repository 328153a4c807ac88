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

// Path of the trajectory CSV next to FILE.csv: FILE_traj.csv (written into buf).
void synth_trajPath(const char* csv, char* buf, size_t sz);

// `ostrich synth --scene terrain` (ost_cli_synth_terrain.c), on checked arguments; returns the
// exit status (CLI_OK, CLI_FAIL, CLI_USAGE).
int synth_terrainMain(const synthArgs* a);

#ifdef __cplusplus
}
#endif

#endif  // OSTRICH_PLUGIN_CLI_OST_CLI_SYNTH_H_
