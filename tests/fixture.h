// fixture.h: shared helpers for the Check suites: MuJoCo error and warning handlers that fail the
// running test (fixture.cc pattern), and model loading from mjcf_models/ or from an XML string.
#ifndef OSTRICH_TESTS_FIXTURE_H_
#define OSTRICH_TESTS_FIXTURE_H_

#include <check.h>
#include <mujoco/mujoco.h>

// install handlers: mju_error always fails the test; mju_warning fails it unless allowed
void ost_fixtureSetup(void);

// allow (1) or forbid (0) MuJoCo warnings; returns the number of warnings seen since setup
int ost_fixtureAllowWarnings(int allow);

// load mjcf_models/NAME; fails the test on error
mjModel* ost_fixtureLoadModel(const char* name);

// load a model from an XML string; fails the test on error
mjModel* ost_fixtureLoadString(const char* xml);

// load a model from an XML string; returns NULL and the message in err on error
mjModel* ost_fixtureTryLoadString(const char* xml, char* err, int err_sz);

// make Ostrich step d with timestep h (the model's other ostrich/* options kept)
void ost_fixtureSetTimestep(const mjModel* m, mjData* d, double h);

// make Ostrich step d with timestep h and geometry provider geometry (ostGeometry)
void ost_fixtureSetProvider(const mjModel* m, mjData* d, double h, int geometry);

// central differences of one ost_step from d's state (qpos along the tangent, qvel, act; ctrl),
// each column perturbed by +-eps, in mjd_transitionFD's layout: A (nx x nx, nx = 2 nv + na),
// B (nx x nu). Every perturbed step must return OST_OK; d's state is left as it was.
void ost_fixtureTransitionFD(const mjModel* m, mjData* d, double eps, double* A, double* B);

// d's state: qpos (nq), qvel (nv), act (na) and ctrl (nu) from the arrays, time 0, mj_forward
void ost_fixtureSetState(const mjModel* m, mjData* d, const double* q, const double* v,
                         const double* a, const double* u);

// src's time, qpos, qvel and ctrl into dst (sizes from m) and dst's qacc_warmstart zeroed: an
// Ostrich step from dst repeats a step from a restored state, started cold
void ost_fixtureCopyState(const mjModel* m, mjData* dst, const mjData* src);

// max |a - b| over n entries; *scale becomes the larger of itself and max |a|
double ost_fixtureMaxDiff(const double* a, const double* b, int n, double* scale);

// ost_transition from d's state into A (nx x nx) and B (nx x nu), poisoned with NaN first so
// that every entry must be written, then central differences (ost_fixtureTransitionFD, eps
// 1e-6): *worst_a, *worst_b get max |A - FD|, max |B - FD| and *scale the largest entry of A and
// B; prints them with label. Fails the test unless ost_transition returns OST_OK.
void ost_fixtureTransitionCheck(const mjModel* m, mjData* d, const char* label, double* A,
                                double* B, double* worst_a, double* worst_b, double* scale);

// run a suite and return the process exit status
int ost_fixtureRun(Suite* s);

// rows 0 .. 3 ncon - 1 of a world (J already stored, ost_solver.h's ostWorld) as ncon contacts of
// mu = 0.8 with two friction rows each, normal force 10, compliance h diag / 2; with sliding,
// every third one slides: its row along the slip fixed (c ~ 1e12 k_f). Each row's diagonal is
// made by osti_rowDiag (which fills the world's row cache when it has one)
struct ostWorld_;
void ost_fixtureContactRows(struct ostWorld_* w, int ncon, double h, int sliding);

#endif  // OSTRICH_TESTS_FIXTURE_H_
