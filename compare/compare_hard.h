// compare_hard.h: the case table of `ostrich compare hard` (compare_hard_cases.c), shared with
// its driver (compare_hard.c). A case is a model, a duration, optional controls, and a probe
// that turns the state after every step into one case-specific number (the metric) and an
// optional second one (aux), plus the bounds Ostrich is expected to meet. The driver measures
// everything that is the same for every case: status, penetration, energy, wall time.
//
// Invariant: a case's functions see only (mjModel, mjData, hardProbe) and never step, so each
// case is measured identically for both engines and every step size.
#ifndef OSTRICH_COMPARE_COMPARE_HARD_H_
#define OSTRICH_COMPARE_COMPARE_HARD_H_

#include <mujoco/mujoco.h>

#ifdef __cplusplus
extern "C" {
#endif

typedef struct hardProbe_ {       // a case's measurement state during one run
  double duration;                // simulated time of the run (s), set by the driver
  double h;                       // step size of the run (s), set by the driver
  int    qpos_adr[2];             // qpos addresses of the free bodies the case watches
  int    qvel_adr[2];             // qvel addresses of those bodies
  double ref[6];                  // values captured by start (initial positions, speed, ...)
  double work[2];                 // observer state (e.g. velocity and time at half-time)
  double metric;                  // case metric so far (hardCase.metric_name)
  double aux;                     // second number so far (hardCase.aux_name); NAN if none
} hardProbe;

typedef struct hardBounds_ {      // what Ostrich is expected to achieve (every run also has to
                                  // finish: no NaN, no divergence, no failed step)
  double h_max;                   // the bounds are expected for h <= h_max (s)
  double penetration;             // deepest contact penetration over the run (m)
  double energy_gain;             // max over the run of E(t) - E(0) (J); unchecked if actuated
  double metric;                  // largest metric
  double aux_min;                 // range of aux (-INFINITY, INFINITY: unchecked)
  double aux_max;
} hardBounds;

typedef struct hardCase_ {        // one hard case
  const char* name;               // --cases name
  const char* model;              // file in --models DIR; NULL: the humanoid (--humanoid)
  const char* summary;            // one line: the scene
  double      duration;           // simulated time at --duration-scale 1 (s)
  int         actuated;           // 1: controls do work, so energy gain is not measured
  const char* metric_name;        // name and unit of the metric
  const char* aux_name;           // name and unit of aux; NULL: none
  hardBounds  expect;             // Ostrich's expectation
  const char* why;                // why Ostrich should meet it (or where it cannot)

  // after mj_resetData (and keyframe 0, if the model has one): find what to watch, capture the
  // reference values; return 0, else print why (a model that lacks a named body) and return 1;
  // NULL: nothing to capture
  int (*start)(const mjModel* m, const mjData* d, hardProbe* p);

  // before each step: set d->ctrl for the step that ends at t_end; NULL: zero controls
  void (*control)(const mjModel* m, mjData* d, double t_end);

  // after each step: update p->metric and p->aux from the new state
  void (*observe)(const mjModel* m, const mjData* d, hardProbe* p);
} hardCase;

// The suite, in the order of the issue (compare_hard_cases.c).
extern const hardCase kHardCases[];
extern const int kHardNumCases;

#ifdef __cplusplus
}
#endif

#endif  // OSTRICH_COMPARE_COMPARE_HARD_H_
