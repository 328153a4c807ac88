// ostrich.h: the public API of Ostrich, an implicit hard-contact, non-smooth Newton time stepper
// for MuJoCo 2.2.2 models. This is the only public header; it mirrors mujoco.h's mj_step family.
//
// Conventions: functions return an ostStatus (0 = OK, > 0 runtime failure, < 0 = minus the
// 1-based index of a bad argument, the LAPACK convention). Library code never exits, aborts or
// calls MuJoCo's default error handler; the message of the last failure on an mjData is kept and
// returned by ost_lastError.
//
// Names (as MuJoCo's mj_/mju_/mjd_; functions visible outside their file follow this table):
//   ost_    functions of this header (each marked OSTAPI) and the host pipeline behind them in
//           plugin/ and cuda/ (ost_packModel, ost_batchRollout_gpu); in cuda/, the suffix _gpu
//           marks a host launcher and _kernel a __global__ kernel
//   osti_   per-world math in core/ headers, inline for host and device (OST_HD): no
//           allocation, no globals, no MuJoCo calls (osti_evaluate, osti_stepDriven)
//   ostu_   self-contained utilities in core/ headers: dense and tree factorizations, math
//           kernels, the sizes, layouts and views of packed blocks, the terrain grid
//           (ostu_cholFactor, ostu_modelSize)
//   ostd_   derivatives: the C entry points of the dual-number code in plugin/ost_adjoint_dual.cc
//           (C++), declared in plugin/ost_adjoint_dual.h, called by the adjoint and the CPU batch's
//           backward pass (ostd_stepJacobian); ostdStep (core/ost_adjoint.h) is the recorded
//           substep they differentiate
//   ostx_   core/ code that compiles only where ostNum is a dual number (C++, OST_NUM_TYPE =
//           ostDual<N>): seeding and reading duals and the dual model (core/ost_dual.h), the
//           forward-mode Jacobian of a step's residual, OSTX_CHUNK directions per pass
//           (core/ost_adjoint_jacobian.h); used by plugin/ost_adjoint_dual.cc,
//           cuda/ost_batch_adjoint.cu and tests/test_ost_dual.cc
//   OST_    macros (OST_HD, OST_OK); OSTAPI marks exports; OSTU_ and OSTX_ macros belong to the
//           ostu_ and ostx_ code; OSTRICH_ names include guards (OSTRICH_<DIR>_<FILE>_H_), build
//           options (OSTRICH_CUDA) and the environment variable OSTRICH_QUIET
//   ostX    types: structs (ostModel, ostStats), this header's enums (ostStatus), the scalar
//           ostNum (float, double or a dual number); osttX are core's enums numbered as
//           MuJoCo's mjtX (osttJoint, osttGeom, osttRow)
//   cli_    the `ostrich` program's shared helpers (plugin/cli/); each subcommand's entry point
//           and own functions take its name (synth_main); cmp_ is the shared code of its
//           `compare` subcommands (compare/). mj_ names in plugin/ost_preload.c are MuJoCo's
//           own, replaced by the preload shim
#ifndef OSTRICH_PLUGIN_OSTRICH_H_
#define OSTRICH_PLUGIN_OSTRICH_H_

#include <mujoco/mujoco.h>

#ifdef __cplusplus
extern "C" {
#endif

#if mjVERSION_HEADER != 222
#error "Ostrich requires the MuJoCo 2.2.2 headers (mjVERSION_HEADER == 222)"
#endif


//---------------------------------- Export --------------------------------------------------------

// OSTAPI marks every public function. libostrich.so is compiled with hidden visibility, so only
// declarations that carry it are exported; a new public function needs it too.
#if defined(__GNUC__) || defined(__clang__)
  #define OSTAPI __attribute__((visibility("default")))
#else
  #define OSTAPI
#endif


//---------------------------------- Status --------------------------------------------------------

typedef enum ostStatus_ {         // result of a host call
  OST_OK            = 0,          // success
  OST_ERR_MODEL     = 1,          // model uses a feature Ostrich does not model (named in message)
  OST_ERR_INPUT     = 2,          // non-finite state, control or applied force (named in message)
  OST_ERR_OVERFLOW  = 3,          // contact or constraint capacity exceeded (nconmax / njmax)
  OST_ERR_NUMERIC   = 4,          // mass matrix not positive definite or non-finite solve
  OST_ERR_VERSION   = 5,          // MuJoCo library is not version 2.2.2
  OST_ERR_MEMORY    = 6,          // allocation failed
  OST_ERR_NOT_CONVERGED = 7,      // a gradient was asked of a step that did not converge or
                                  // kept part of an initial violation (named in message)

  // warnings (>= OST_WARN_FIRST): the step WAS taken and the state advanced, as MuJoCo goes on
  // after a warning; the answer is not to tolerance. Counted in ostTotals (ost_totals).
  OST_WARN_FIRST          = 100,
  OST_WARN_NOT_CONVERGED  = 100   // a committed (sub)step's best residual is above opt.tol
} ostStatus;

// 1 if status is a warning: the step was taken but is not to tolerance (see ostStats)
#define OST_IS_WARNING(status) ((status) >= OST_WARN_FIRST)

typedef enum ostStatusBit_ {      // per-step outcome bits (ostStats.status), same on CPU and GPU
  OST_NOT_CONVERGED = 1,          // best residual above tolerance after the Newton budget
  OST_OVERFLOW      = 2,          // a capacity was exceeded: a failure in a batch world or
                                  // beyond Ostrich's growth; with a step that succeeded, the
                                  // user's contact buffer could not list every contact at q+
  OST_NAN           = 4,          // a non-finite value appeared
  OST_CHOL_FAIL     = 8,          // M + h*D was not positive definite
  OST_DEPENETRATED  = 16          // an initial violation (penetration, joint limit, equality)
                                  // deeper than h * depenetration_speed was removed at that
                                  // bounded speed only (ostStats.initial_violation)
} ostStatusBit;


//---------------------------------- Options -------------------------------------------------------

// Solver options. Each field can be set in MJCF as <custom><numeric name="ostrich/FIELD"
// data="..."/></custom>, so that a model configured for Ostrich still loads in stock MuJoCo.
typedef struct ostOptions_ {
  int    newton_iter;             // Newton budget per step                          (64)
  int    pcr_iter;                // PCR budget per Newton iterate                   (32)
  int    k_min;                   // earliest Newton iterate that may be returned     (1)
  int    linesearch;              // max step halvings per Newton iterate, 0 = none   (1)
  int    warmstart;               // 1: start from the last step's forces if continuing (1)
  double tol;                     // merit residual (m/s) at which Newton stops early (1e-10)
  double pcr_tol;                 // relative PCR residual at which PCR stops early   (1e-12)
  double timestep;                // step size; 0 = use opt.timestep                  (0)
  double margin;                  // contact look-ahead distance (m) added to margins (0.01)
  double fb_eps;                  // Fischer-Burmeister smoothing (m, m/s)            (1e-9)
  double eq_compliance;           // equality-constraint compliance E (m/N)           (0)
  int    split_depth;             // max halvings of a step whose Newton fails        (6)
  int    deep_splits;             // splits per step past 3 halvings                 (6)
  double split_tol;               // best residual (m/s) above which a step is split (1e-10)
  double regularization;          // relative compliance of contacts and sticking     (1e-6)
  double friction_creep;          // sticking friction's slip velocity per newton of friction
                                  // force (s/kg), the same at every h                  (0)
  int    geometry;                // geometry provider: OST_GEOMETRY_MUJOCO or _NATIVE (0)
  double depenetration_speed;     // largest speed (m/s, rad/s for angular limits and
                                  // equalities) at which a violation present at the start of
                                  // a step is removed; 0 = at once                    (1)
  int    geometric_newton;        // the Newton model's geometric terms (core/README.md
                                  // "Geometric term"): 0 off; how J' lambda of loaded
                                  // equalities turns with q (tendons, strings, cloth): 1 from
                                  // the first iterate whose merit falls by less than half,
                                  // 2 every iterate; 3 every iterate, the turning of every
                                  // loaded row (contacts too) and of the slip J(q) u that
                                  // friction reads. Steps with the mujoco geometry provider
                                  // only: the native provider and the batches keep the
                                  // fixed-J model, bitwise as on the GPU             (1)
  int    cold_retry;              // 1: a Newton loop that fails from its warm start is
                                  // redone once from a cold start (u-, no carried forces)
                                  // before its step is split; 0: split at once       (1)
  int    convex_distance;         // 1: contacts of MuJoCo's general convex collision (MPR:
                                  // meshes, ellipsoids, most cylinder pairs) carry their
                                  // true distance inside the look-ahead, found by bisection
                                  // (mujoco provider; core/README.md section 4); 0: MuJoCo's
                                  // distance of the shapes inflated by the look-ahead  (0)
  int    geometric_retry;         // 1: a Newton loop that runs out of budget while still
                                  // improving (and whose cold retry, if any, failed too) is
                                  // redone once from a cold start with the geometric terms
                                  // of geometric_newton 3, before its step is split (mujoco
                                  // provider only; ostStats.geo_retries)               (0)
  int    decouple_open;           // 1: the open contacts of an island above 96 rows (rows of
                                  // the look-ahead whose gap stays open, and their friction)
                                  // are solved alone, out of its Krylov solve (mujoco
                                  // provider; core/README.md section 1, "Open contacts
                                  // solved alone"): nets whose neighbours sit inside the
                                  // look-ahead; a cloth lying on a sphere converges less
                                  // often with it                                      (0)
} ostOptions;

typedef enum ostGeometry_ {       // geometry providers (option `geometry`)
  OST_GEOMETRY_MUJOCO = 0,        // MuJoCo's kinematics and collision at every iterate
  OST_GEOMETRY_NATIVE = 1         // Ostrich's portable core/ geometry (CPU and GPU)
} ostGeometry;

// Set default options.
OSTAPI void ost_defaultOptions(ostOptions* opt);

// Read options from the model's <custom> numerics named "ostrich/*"; unknown names are an error.
OSTAPI int ost_readOptions(const mjModel* m, ostOptions* opt, char* err, int err_sz);

// Override the options used for steps of this mjData (after ost_readOptions of the model).
OSTAPI int ost_setOptions(const mjModel* m, mjData* d, const ostOptions* opt);

// Say that m was edited in arrays that steps do not compare. Every step compares the arrays it
// reads with their values at the last step and follows edits of them at once (body_mass,
// geom_friction, dof_damping, actuator gains, height-field data, opt, ...); only edits of mesh
// arrays (mesh_*), which are read when the model is packed, need this call before the next step
// of any mjData of m.
OSTAPI void ost_modelChanged(const mjModel* m);


//---------------------------------- Model check ---------------------------------------------------

// Refusal messages name every unsupported feature, one "; "-separated entry per feature with
// the elements that use it: "unsupported by Ostrich (2 features): joint 'hinge': frictionloss
// (dry joint friction); 3 actuators ('a', 'b', 'c'): activation dynamics (dyntype filter)";
// entries that do not fit in err_sz end the message as "; ... and K more".

#define OST_REFUSAL_NAMES 3       // element names an ostRefusal keeps

typedef struct ostRefusal_ {      // one unsupported feature and the elements that use it
  char what[24];                  // element kind ("joint", "geom pair", ...); "" for the model
  char feature[256];              // the feature, and what to use instead where there is a choice
  int  count;                     // elements that use it
  char name[OST_REFUSAL_NAMES][64];  // the first min(count, 3) of them ("#id" when unnamed)
} ostRefusal;

// Return OST_OK if Ostrich models every feature of m, else OST_ERR_MODEL and name every
// unsupported feature with its elements.
OSTAPI int ost_checkModel(const mjModel* m, char* err, int err_sz);

// Every feature of m that Ostrich does not model into out[0 .. nout); return how many there are
// (0: none; beyond nout they are counted, not stored), -1 for a bad argument.
OSTAPI int ost_checkModelList(const mjModel* m, ostRefusal* out, int nout);

// Return OST_OK if the native geometry provider can represent m, else OST_ERR_MODEL and name
// every geom pair, joint or feature it cannot do.
OSTAPI int ost_checkNative(const mjModel* m, char* err, int err_sz);

// ost_checkNative's refusals as a list, like ost_checkModelList.
OSTAPI int ost_checkNativeList(const mjModel* m, ostRefusal* out, int nout);

// Return OST_OK if ost_step accepts m with options opt, else OST_ERR_MODEL and one message that
// names every refusal: ost_checkModel's, then those of opt's geometry provider (native:
// ost_checkNative's; mujoco: no ostrich/terrain mesh, height fields only with margin 0).
OSTAPI int ost_checkStep(const mjModel* m, const ostOptions* opt, char* err, int err_sz);

// Geom id of the mesh that <custom><text name="ostrich/terrain" data="GEOM"/> marks as a
// non-convex terrain surface (native provider only), or -1 if none.
OSTAPI int ost_terrainGeom(const mjModel* m);

// Largest disagreements of the native provider with MuJoCo (ost_compareNative).
typedef struct ostNativeReport_ {
  int    nstate;                  // configurations compared (keyframes + random)
  int    ncontact;                // MuJoCo contacts seen, all configurations
  int    contact_count;           // worst per-configuration count of unmatched contacts
  int    ok;                      // 1 if every quantity is within tolerance
  double body_pos;                // body and geom positions (relative)
  double body_rot;                // body and geom rotation matrices
  double mass_matrix;             // joint-space inertia (relative)
  double bias;                    // gravity + Coriolis forces (relative)
  double passive;                 // spring and damping forces (relative)
  double actuator;                // actuator lengths and moments (relative)
  double jacobian;                // translational and rotational Jacobians at body coms
  double contact_analytic[3];     // analytic pairs: distance, normal, position (abs, m)
  double contact_mpr[3];          // MPR pairs (convex, height field): distance, normal, position
} ostNativeReport;

// Compare native geometry with MuJoCo at every keyframe and nstate random configurations
// (seeded): tolerances 1e-10 relative (kinematics, dynamics), 1e-9 (analytic contacts) and
// 1e-6 (MPR contacts); r->ok says whether all hold.
OSTAPI int ost_compareNative(const mjModel* m, int nstate, unsigned seed, ostNativeReport* r,
                             char* err, int err_sz);


//---------------------------------- Stepping ------------------------------------------------------

// Per-step statistics of the last step on an mjData.
typedef struct ostStats_ {
  int    status;                  // ostStatusBit flags
  int    newton_iter;             // Newton iterates evaluated
  int    best_iter;               // index of the returned (best) iterate: 0 (below k_min)
                                  // when the loop diverged, every later iterate above tol and
                                  // 10 times the first's merit (core/README.md, "Best iterate")
  int    pcr_iter;                // PCR iterations summed over the step
  int    substeps;                // committed substeps (1 unless the step was split)
  int    geometry_evals;          // iterates whose geometry was evaluated (line search incl.)
  int    ncon;                    // contacts in the returned iterate (incl. look-ahead)
  int    nrow;                    // constraint rows in the returned iterate
  double residual;                // merit residual of the returned iterate (m/s): its worst
                                  // island's when it has several (islands below)
  double residual_first;          // merit residual of the first iterate (m/s)
  double max_penetration;         // deepest contact penetration at q+ (m)
  double initial_violation;       // deepest violation at q- that was removed at the bounded
                                  // depenetration speed (m or rad; 0 if none, OST_DEPENETRATED)
  int    islands;                 // independent Newton systems (constraint islands) of the
                                  // returned iterate, most of any substep; residual is the
                                  // worst island's (core/README.md section 1, "Islands")
  int    ncon_capacity;           // contacts the iterates had room for: the model's nconmax,
                                  // doubled each time the look-ahead overflowed it
  int    retries;                 // Newton loops redone from a cold start after failing from
                                  // the warm one (option cold_retry; core/README.md "Cold
                                  // retry"): 0 unless a loop failed
  int    geo_retries;             // Newton loops redone with the geometric terms over all rows
                                  // after failing (core/README.md "Geometric retry")
} ostStats;

// Counts since d was first stepped by Ostrich (or ost_resetTotals), like mjData.warning[].number:
// every step is counted, so a warning that recurs is never reported only once.
typedef struct ostTotals_ {
  long   steps;                   // ost_step2 calls
  long   failed;                  // steps refused or failed (state left unchanged)
  long   unconverged;             // steps that returned OST_WARN_NOT_CONVERGED
  long   depenetrated;            // steps with OST_DEPENETRATED
  long   retries;                 // Newton loops redone from a cold start (ostStats.retries)
  long   geo_retries;             // and with the geometric terms (ostStats.geo_retries)
  long   overflow;                // steps with OST_OVERFLOW (capacity exceeded)
  double worst_residual;          // largest committed residual (m/s)
  double worst_initial_violation; // largest initial_violation (m or rad)
  int    last_failure;            // ostStatus of the last failed step (0 if none)
  long   model_packs;             // times the private model was checked and packed again
                                  // because the model or the options changed (1 if never)
  long   stages_reused;           // ost_step1 calls that reused the position and velocity
                                  // stages the last step published at the same state, instead
                                  // of running them again (bitwise the same result)
} ostTotals;

// Advance one step with Ostrich (mj_step semantics, mjcb_control included). Returns OST_OK,
// a warning (OST_IS_WARNING: the state advanced, but not to tolerance) or an error (the state
// is left as it was).
OSTAPI int ost_step(const mjModel* m, mjData* d);

// First half: stock position and velocity stages at (q-, u-), then mjcb_control (= mj_step1).
OSTAPI int ost_step1(const mjModel* m, mjData* d);

// Second half: Ostrich solve, commit (q+, u+), and publish mjData at q+ (core/README.md
// section 4).
OSTAPI int ost_step2(const mjModel* m, mjData* d);

// Statistics of the last step on d (NULL if d was never stepped by Ostrich).
OSTAPI const ostStats* ost_stats(const mjData* d);

// Counts of d's steps and warnings (NULL if d was never stepped by Ostrich).
OSTAPI const ostTotals* ost_totals(const mjData* d);

// Zero d's counts.
OSTAPI void ost_resetTotals(const mjData* d);

// Message of the last failed call on d, or of the warning the last step returned
// (OST_WARN_NOT_CONVERGED: its residual); "" if none.
OSTAPI const char* ost_lastError(const mjData* d);

// Deepest penetration (m) at d's kinematics: MuJoCo's contacts in d->contact, except that
// cylinder-box and height field-cylinder pairs are measured with Ostrich's own generators (as
// both providers collide them).
OSTAPI double ost_maxPenetration(const mjModel* m, const mjData* d);

// Release Ostrich's per-mjData state (buffers, options). Safe on unknown d.
OSTAPI void ost_detach(const mjData* d);

// Release Ostrich's per-mjData state and delete d (= mj_deleteData).
OSTAPI void ost_deleteData(mjData* d);


//---------------------------------- Gradients -----------------------------------------------------
// Exact gradients of Ostrich steps by the implicit function theorem at each step's solution
// (core/README.md section 2). Conventions, as mjd_transitionFD: a qpos cotangent or perturbation is
// a tangent vector of nv entries (mj_integratePos / mj_differentiatePos: ball and free rotations in
// the local frame), qvel and ctrl are plain vectors. Gradients need a model that the native
// geometry provider can represent (ost_checkNative): the derivatives of kinematics, dynamics and
// contact geometry come from core's native code in forward-mode dual numbers, whichever provider
// ran the forward step.

// Physical parameters theta, one flat vector in this group order (offsets: ost_paramAddress):
typedef enum ostParam_ {
  OST_PARAM_FRICTION = 0,         // geom_friction[g][0], sliding friction           (ngeom)
  OST_PARAM_MASS,                 // body_mass[b] (inertia held fixed)               (nbody)
  OST_PARAM_DAMPING,              // dof_damping[j]                                  (nv)
  OST_PARAM_GAIN,                 // actuator_gainprm[i][0]: kp or kv (fixed gain only) (nu)
  OST_PARAM_BIASPOS,              // actuator_biasprm[i][1] (= -kp of a position servo) (nu)
  OST_PARAM_BIASVEL,              // actuator_biasprm[i][2] (= -kv of a servo)       (nu)
  // (a gain or bias entry MuJoCo does not read, as a motor's biasprm, has gradient 0; a
  // muscle's gainprm[0], biasprm[1] and [2], which shape its curves and are not
  // differentiated, get NaN)
  OST_NPARAM                      // number of groups
} ostParam;

// Length of theta.
OSTAPI int ost_nparam(const mjModel* m);

// Offset of group g (ostParam) in theta; ost_paramAddress(m, OST_NPARAM) == ost_nparam(m).
OSTAPI int ost_paramAddress(const mjModel* m, int g);

typedef struct ostGradOptions_ {  // what a backward pass computes
  int truncate;                   // 1: contact geometry held fixed within a step (no position
                                  //    pull-back of points, normals, distances), for long
                                  //    chaotic horizons; 0: complete (default)
  int params;                     // 1: also accumulate dL/dtheta (costs more)
  int forward_only;               // 1: every input's derivatives by forward-mode passes (the
                                  //    bits of a batch's backward pass); 0: those of the step's
                                  //    start (q-, u-, act-, ctrl) by one reverse sweep (default,
                                  //    faster; the same gradients to rounding)
} ostGradOptions;

// Default gradient options (complete pull-back, no parameters).
OSTAPI void ost_defaultGradOptions(ostGradOptions* go);

// Vector-Jacobian product of the last ost_step on d (all its substeps): given gq = dL/dq+
// (nv, tangent) and gu = dL/du+ (nv), return dL/dq- (nv, tangent), dL/du- (nv), dL/dctrl (nu)
// and, if go->params and gtheta != NULL, dL/dtheta (ost_nparam, accumulated: += ). Outputs may
// be NULL. The step must have been taken by ost_step / ost_step2 on (m, d), and d's state not
// changed since. With activations (na > 0) L is a function of (q+, u+) and the controls'
// gradient includes their path through act+; dL/dact- is a row of ost_transition's A.
OSTAPI int ost_adjoint(const mjModel* m, const mjData* d, const ostGradOptions* go,
                       const mjtNum* gq, const mjtNum* gu, mjtNum* gq_prev, mjtNum* gu_prev,
                       mjtNum* gctrl, mjtNum* gtheta);

// Dense transition Jacobians of one Ostrich step from d's state, in mjd_transitionFD's layout:
// A = d x+/d x ((2nv + na) x (2nv + na)), B = d x+/d ctrl ((2nv + na) x nu), x = (qpos tangent,
// qvel, act); either may be NULL. d is left as it was (state, activations, controls, time).
OSTAPI int ost_transition(const mjModel* m, mjData* d, mjtNum* A, mjtNum* B);

// A tape records a rollout for its backward pass: per step only the state, controls and the
// converged forces (no Newton or PCR iterates), so the bytes per recorded step do not depend on
// the iteration budgets. With checkpoint = S > 0 it keeps every S-th step's record only and
// recomputes a segment's steps during the backward pass (memory / S, compute about x2).
typedef struct ostTape_ ostTape;

// New empty tape for model m (NULL if allocation fails).
OSTAPI ostTape* ost_tapeCreate(const mjModel* m, int checkpoint);

// Release a tape (NULL is ignored).
OSTAPI void ost_tapeDelete(ostTape* t);

// Forget the recorded rollout; keep the allocations.
OSTAPI void ost_tapeClear(ostTape* t);

// ost_step(m, d) and record the step; returns ost_step's status. A step that returns a warning
// (OST_IS_WARNING) is recorded, but ost_tapeBackward then refuses the rollout with
// OST_ERR_NOT_CONVERGED naming the step. The first step after ost_tapeClear fixes the start state.
OSTAPI int ost_tapeStep(ostTape* t, const mjModel* m, mjData* d);

// Steps recorded since the last ost_tapeClear.
OSTAPI int ost_tapeSteps(const ostTape* t);

// Bytes the tape holds now (records, checkpoints, scratch).
OSTAPI size_t ost_tapeBytes(const ostTape* t);

// Backward pass over the recorded rollout of n steps. gq, gu: ((n + 1) x nv) cotangents of the
// loss with respect to the state after each step, row 0 the start state (NULL = zero). Returns
// gctrl (n x nu), the gradient of the start state gq0, gu0 (nv each, row 0 of gq, gu included)
// and, with go->params, gtheta (accumulated). Outputs may be NULL. The error message of a
// failure is in ost_tapeError. With activations (na > 0) the loss is a function of (q, u); the
// controls' gradient includes their path through the activations (carried between steps).
OSTAPI int ost_tapeBackward(ostTape* t, const mjModel* m, const ostGradOptions* go,
                            const mjtNum* gq, const mjtNum* gu, mjtNum* gctrl, mjtNum* gq0,
                            mjtNum* gu0, mjtNum* gtheta);

// Message of the tape's last failure ("" if none).
OSTAPI const char* ost_tapeError(const ostTape* t);


//---------------------------------- Batches -------------------------------------------------------

// Many worlds of one model stepped together on core's native geometry: every world has its own
// state, controls and warm start, and its own outcome bits (ostStatusBit); a world that fails
// (OST_OVERFLOW, OST_NAN, OST_CHOL_FAIL) keeps the state it had before that step and is not
// stepped again until its state is set, and it never disturbs its neighbours. The `cpu` and
// `cuda` devices run the same per-world code (core/ost_batch.h) and give the same results.
// Options come from the model (ost_readOptions), except that a batch splits a step past 3
// levels only where the model sets ostrich/deep_splits (else 0: on the GPU a world that keeps
// failing holds its warp); the model must pass ost_checkNative.
typedef struct ostBatch_ ostBatch;

// Create nworld worlds of m at qpos0, at rest, controls 0, on device "cpu" (all cores),
// "cpu:N" (N threads) or "cuda" (the current GPU; needs a build with -DOSTRICH_CUDA=ON).
// Returns NULL on failure with the reason in err.
OSTAPI ostBatch* ost_batchCreate(const mjModel* m, int nworld, const char* device, char* err,
                                 int err_sz);

// Free a batch (NULL is ignored).
OSTAPI void ost_batchDelete(ostBatch* b);

// Number of worlds.
OSTAPI int ost_batchWorlds(const ostBatch* b);

// Set every world's state: qpos (nworld x nq) and qvel (nworld x nv); NULL = qpos0 / rest. The
// activations (models with activation dynamics, na > 0) are reset to 0, as mj_resetData does;
// time, warm start and outcome bits are reset.
OSTAPI int ost_batchSetState(ostBatch* b, const mjtNum* qpos, const mjtNum* qvel);

// Copy every world's state out: qpos (nworld x nq), qvel (nworld x nv); either may be NULL.
OSTAPI int ost_batchGetState(const ostBatch* b, mjtNum* qpos, mjtNum* qvel);

// Set every world's activations act (nworld x na), the rest of the state of a model with
// activation dynamics; they advance implicitly with each step, as ost_step's. Call it after
// ost_batchSetState (which zeroes them) and before the rollout to be differentiated: the
// backward pass starts from them. Drops the warm start, like any change of state.
OSTAPI int ost_batchSetAct(ostBatch* b, const mjtNum* act);

// Copy every world's activations out (nworld x na).
OSTAPI int ost_batchGetAct(const ostBatch* b, mjtNum* act);

// Set every world's controls (nworld x nu), used by the following steps.
OSTAPI int ost_batchSetCtrl(ostBatch* b, const mjtNum* ctrl);

// Advance every world by one step.
OSTAPI int ost_batchStep(ostBatch* b);

// Advance every world by nstep steps. ctrl (nstep x nworld x nu) gives the controls of each
// step (NULL: keep the worlds' controls); qpos (nstep x nworld x nq) and qvel (nstep x nworld x
// nv) receive the state after each step (NULL: not kept).
OSTAPI int ost_batchRollout(ostBatch* b, int nstep, const mjtNum* ctrl, mjtNum* qpos, mjtNum* qvel);

// ost_batchRollout, and act (nstep x nworld x na, or NULL) receives the activations after each
// step, the rest of the state of a model with activation dynamics.
OSTAPI int ost_batchRolloutAct(ostBatch* b, int nstep, const mjtNum* ctrl, mjtNum* qpos,
                               mjtNum* qvel, mjtNum* act);

// Let the following rollouts from a set state keep every world's state every `every` steps (0,
// the default: keep none), so that ost_batchBackward with checkpoint `every` starts from them
// instead of replaying the rollout to make them: one replay fewer per backward pass, for
// ceil(nstep / every) x ost_batchBytes' world memory more (host for cpu, device for cuda).
OSTAPI int ost_batchKeepCheckpoints(ostBatch* b, int every);

// Gradients of a loss of the last rollout, which must have started right after
// ost_batchSetState (cpu and cuda alike, same bits). gq, gu ((nstep + 1) x nworld x nv,
// step-major; NULL = zero): the loss's cotangents with respect to each world's state after each
// step, row 0 the start (qpos as a tangent vector, see ost_tapeBackward); with activations
// (na > 0) the loss is a function of (q, u), and the controls' gradient includes their path
// through the activations, as ost_tapeBackward's. Returns gctrl
// (nstep x nworld x nu) and gq0, gu0 (nworld x nv); any may be NULL. Each world's rollout is
// replayed from its start with a checkpoint every `checkpoint` steps (0 = one segment; no replay
// if the rollout kept them, ost_batchKeepCheckpoints), then segment by segment backward: the
// segment is replayed once more recording its substeps, and each substep's exact Jacobian (dual
// numbers; on cuda its columns spread over several threads) gives the implicit-function-theorem
// update (core/ost_batch_adjoint.h). Memory per lane: the checkpoints and one segment's records; a
// segment of S steps records at most 2 S + 8 + deep_splits substeps. A world whose rollout failed, whose
// segment records more substeps (OST_OVERFLOW), whose Jacobian is singular (OST_NAN) or whose
// rollout has a step that did not converge (OST_NOT_CONVERGED) or kept part of an initial
// violation (OST_DEPENETRATED) gets NaN gradients and that bit: the implicit function theorem
// holds only at a solved step. go->truncate is honoured; go->params needs
// ost_batchBackwardParams (refused here, where there is no gtheta).
OSTAPI int ost_batchBackward(ostBatch* b, const ostGradOptions* go, int checkpoint,
                             const mjtNum* gq, const mjtNum* gu, mjtNum* gctrl, mjtNum* gq0,
                             mjtNum* gu0);

// ost_batchBackward, and with go->params the gradient of the loss with respect to each world's
// physical parameters theta (ostParam, as ost_tapeBackward's) into gtheta (nworld x
// ost_nparam(m), world-major; overwritten, NaN for a failed world). Every world is stepped with
// the same model, so the batch's gradient with respect to a parameter shared by all worlds is
// the sum of its rows. Same bits on cpu and cuda, and as a tape of the same world.
OSTAPI int ost_batchBackwardParams(ostBatch* b, const ostGradOptions* go, int checkpoint,
                                   const mjtNum* gq, const mjtNum* gu, mjtNum* gctrl,
                                   mjtNum* gq0, mjtNum* gu0, mjtNum* gtheta);

// Outcome bits of every world's last step (nworld ints, ostStatusBit). OST_NOT_CONVERGED and
// OST_DEPENETRATED are warnings: the world stepped on.
OSTAPI int ost_batchStatus(const ostBatch* b, int* status);

// Steps of every world, since its state was last set, whose answer did not reach opt.tol
// (OST_NOT_CONVERGED; nworld ints).
OSTAPI int ost_batchUnconverged(const ostBatch* b, int* count);

// Bytes of the batch's world memory (host for cpu, device for cuda; the model not included).
OSTAPI size_t ost_batchBytes(const ostBatch* b);

// Memory of the batch's device: for cuda, the bytes in use on the GPU by every process
// (cudaMemGetInfo: total - free) and the GPU's total; for cpu, the batch's bytes (model and
// worlds) and 0.
OSTAPI int ost_batchMemory(const ostBatch* b, size_t* used, size_t* total);

// Message of the batch's last failure ("" if none).
OSTAPI const char* ost_batchError(const ostBatch* b);


#ifdef __cplusplus
}
#endif

#endif  // OSTRICH_PLUGIN_OSTRICH_H_
