// ost_cli_gradcheck.c: `ostrich gradcheck`, the adjoint gradient of a whole Ostrich rollout
// (ost_tapeStep + ost_tapeBackward) against central finite differences of the same rollout, for
// the start state, every control of every step, and the physical parameters theta. Mirrors
// MuJoCo's engine_derivative_test.cc (mjd_ against mjd_FD), at the scale of a whole rollout.
//
// The rollout: N steps of ost_step from x0 = (qpos0 or keyframe --key, qvel0 + seeded noise), with
// controls ctrl_k = --ctrl + seeded noise. The loss is a seeded linear-plus-quadratic function of
// every state along it, so that every step contributes:
//   L = sum_{k=0..N} (a_k . qpos_k + b_k . qvel_k) + 1/2 |qpos_N - q*|^2 + 1/2 |qvel_N - v*|^2.
// Its cotangent for the tape is a tangent vector: gq_k = G(qpos_k)^T dL/dqpos_k, where G is the
// derivative of qpos along mj_integratePos's tangent (identity for positions, hinges and slides;
// d(q * exp(delta / 2))/d delta_i = 1/2 q * (0, e_i) for ball and free rotations).
//
// Invariant: the finite differences perturb exactly what the adjoint differentiates: the start
// qpos along the same tangent (mj_integratePos), qvel, each ctrl entry of each step, and each
// theta entry in the mjModel field that ost_paramAddress's group names, restored afterwards.
#define _POSIX_C_SOURCE 200809L

#include <math.h>
#include <stddef.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <mujoco/mujoco.h>

#include "ost_cli_util.h"
#include "ostrich.h"


//---------------------------------- Arguments -----------------------------------------------------

typedef struct gradcheckArgs_ {   // arguments of `ostrich gradcheck`
  const char* model;              // MJCF path (the positional argument)
  long        steps;              // rollout length N (default 10)
  double      h;                  // step size (s); 0: the model's
  long        seed;               // seed of the loss, the qvel noise and the ctrl noise
  const char* wrt;                // qpos | qvel | ctrl | params | all
  double      eps;                // finite-difference step
  double      tol;                // largest relative error per group that passes
  const char* ctrl;               // comma list of nu controls; NULL: zeros
  long        newton;             // Newton budget; -1: the model's
  long        key;                // start keyframe; CLI_KEY_NONE: qpos0
  int         help;               // --help was given
} gradcheckArgs;

static const cliOption kGradcheckOptions[] = {
  {"--steps", CLI_ARG_COUNT, offsetof(gradcheckArgs, steps), "N",
   "rollout length in steps, >= 1 (default 10)"},
  {"--h", CLI_ARG_POSITIVE, offsetof(gradcheckArgs, h), "SEC",
   "step size (s); default: the model's ostrich/timestep if present,\n"
   "else opt.timestep"},
  {"--seed", CLI_ARG_COUNT, offsetof(gradcheckArgs, seed), "S",
   "seed of the loss weights and of the qvel and ctrl noise (default 1)"},
  {"--wrt", CLI_ARG_STRING, offsetof(gradcheckArgs, wrt), "GROUP",
   "gradient group to compare: qpos, qvel, ctrl, params or all (default)"},
  {"--eps", CLI_ARG_POSITIVE, offsetof(gradcheckArgs, eps), "E",
   "central difference step: E / 100 along the qpos tangent, E * max(1, |x|)\n"
   "for qvel, ctrl and each parameter (default 1e-4: smaller steps\n"
   "resolve the Newton tolerance's noise, e.g. 1e-6 gives 8e-3 on the\n"
   "servo arm's parameters where 1e-4 gives 5e-5)"},
  {"--tol", CLI_ARG_POSITIVE, offsetof(gradcheckArgs, tol), "T",
   "largest relative error per group that passes (default 1e-3)"},
  {"--newton", CLI_ARG_COUNT, offsetof(gradcheckArgs, newton), "K",
   "Newton budget per step (ostrich/newton_iter); finite differences need\n"
   "converged steps"},
  {"--ctrl", CLI_ARG_STRING, offsetof(gradcheckArgs, ctrl), "v1,v2,...",
   "exactly nu base controls; each step adds seeded noise U(-0.1, 0.1)\n"
   "(default 0)"},
  CLI_KEY_OPTION(gradcheckArgs),
};

static const int kGradcheckNumOptions =
    (int)(sizeof(kGradcheckOptions) / sizeof(kGradcheckOptions[0]));

enum {                            // gradient groups, in the order of the JSON line
  GC_QPOS = 0,                    // start qpos, tangent (nv)
  GC_QVEL,                        // start qvel (nv)
  GC_CTRL,                        // every control of every step (N x nu)
  GC_PARAMS,                      // theta (ost_nparam)
  GC_NGROUP
};

static const char* const kGroupNames[GC_NGROUP] = {"qpos", "qvel", "ctrl", "params"};

static const char* const kParamNames[OST_NPARAM] = {  // ostParam groups, as in the JSON line
  "friction", "mass", "damping", "gain", "biaspos", "biasvel"};


// Print the usage of `ostrich gradcheck`.
static void gradcheck_usage(FILE* f) {
  fprintf(f,
    "usage: ostrich gradcheck MODEL.xml [options]\n"
    "\n"
    "Compare the adjoint gradient of a whole Ostrich rollout (ost_tapeStep, ost_tapeBackward)\n"
    "with central finite differences of the same rollout. The rollout runs N steps from qpos0\n"
    "and zero velocity (or keyframe K's qpos, qvel and act with --key K; a model's keyframes\n"
    "are not used otherwise) with U(-0.1, 0.1) noise added to qvel and controls --ctrl +\n"
    "U(-0.1, 0.1) noise per step. The loss is a seeded linear-plus-quadratic function of\n"
    "every state:\n"
    "  L = sum_k (a_k . qpos_k + b_k . qvel_k) + 1/2 |qpos_N - q*|^2 + 1/2 |qvel_N - v*|^2.\n"
    "Groups: qpos (start qpos, perturbed along mj_integratePos's tangent: free and ball\n"
    "rotations in the local frame), qvel (start qvel), ctrl (each control of each step) and\n"
    "params (theta in ost_paramAddress order: geom_friction[3g], body_mass[b], dof_damping[j],\n"
    "actuator_gainprm[10i], actuator_biasprm[10i+1], actuator_biasprm[10i+2], each written into\n"
    "the mjModel and restored). Every parameter is compared, used or not; params_nonzero counts\n"
    "those with a nonzero finite-difference gradient. A parameter on the boundary of its domain\n"
    "(friction, mass, damping >= 0; a servo's bias feedback <= 0, e.g. a velocity servo's\n"
    "biaspos = 0) gets the one-sided second-order difference into the domain; params_one_sided\n"
    "counts them.\n"
    "\n"
    "The relative error of a group is normwise: max_k |g_adj - g_fd| / max(max_k |g_fd|,\n"
    "tiny), tiny = 1e-6 * the largest |g_fd| of all compared groups (a group a million times\n"
    "smaller than the gradient is zero to within finite differences). Prints one JSON line:\n"
    "model, steps, h, seed, eps, tol, loss, the error of each group (null if not compared),\n"
    "n_qpos, n_qvel, n_ctrl, n_params, params_nonzero, params_one_sided, params_unknown (the\n"
    "parameters whose adjoint is NaN, not differentiated: a muscle's curves), param_groups (the\n"
    "error of each theta group against its own scale), adjoint_s, fd_s, ok.\n"
    "\n"
    "Finite differences are only meaningful where the rollout is smooth: a contact that\n"
    "appears, or switches between sticking and sliding, within +-eps makes the two disagree.\n"
    "Where both geoms of a contact have the same friction (MuJoCo takes the maximum, which has\n"
    "a kink there), central differences give each geom half of the gradient.\n"
    "\n"
    "options:\n");
  cli_printOptions(f, kGradcheckOptions, kGradcheckNumOptions);
  cli_printHelpOption(f);
  fprintf(f,
    "\n"
    "Exit status: 0 every compared group within --tol; 1 a group over --tol, a non-finite\n"
    "gradient, or a failed step or backward pass; 2 bad usage, missing or malformed model,\n"
    "--key out of range, model refused by Ostrich or not representable by the native\n"
    "geometry (gradients need it). Progress lines (ostrich: gradcheck: ...) go to stderr\n"
    "after the adjoint and every second of finite differences, unless OSTRICH_QUIET=1.\n");
}


// Check the combination of parsed arguments and decode --wrt; return 0 on success.
static int gradcheck_checkArgs(const gradcheckArgs* a, int wrt[GC_NGROUP]) {
  if (!a->model) {
    cli_error("gradcheck: missing MODEL.xml (see ostrich gradcheck --help)");
    return 1;
  }
  if (a->steps < 1) {
    cli_error("--steps: need at least 1 step");
    return 1;
  }
  int all = !strcmp(a->wrt, "all");
  int any = all;
  for (int g = 0; g < GC_NGROUP; g++) {
    wrt[g] = all || !strcmp(a->wrt, kGroupNames[g]);
    any |= wrt[g];
  }
  if (!any) {
    cli_error("--wrt: '%s' is not qpos, qvel, ctrl, params or all", a->wrt);
    return 1;
  }
  return 0;
}


//---------------------------------- Problem -------------------------------------------------------

typedef struct gradcheckProblem_ {  // the rollout, its loss, and the gradients
  // setup
  mjModel* m;                     // model (parameters written during finite differences)
  mjData*  d;                     // data, configured for Ostrich
  double   h;                     // step size (s)
  int      n;                     // steps N
  int      nparam;                // length of theta
  long     key;                   // start keyframe; CLI_KEY_NONE: qpos0
  mjtNum*  qpos0;                 // start qpos                                         (nq)
  mjtNum*  qvel0;                 // start qvel                                         (nv)
  mjtNum*  act0;                  // start act (keyframe --key or zero)                 (na)
  mjtNum*  ctrl;                  // controls of each step                          (N x nu)

  // loss: linear weights per state, quadratic targets of the final state
  mjtNum*  wq;                    // a_k                                      ((N + 1) x nq)
  mjtNum*  wv;                    // b_k                                      ((N + 1) x nv)
  mjtNum*  qstar;                 // q*                                                 (nq)
  mjtNum*  vstar;                 // v*                                                 (nv)

  // gradients: adjoint and finite differences, one flat vector in group order
  int      adr[GC_NGROUP + 1];    // offset of each group in g_adj and g_fd
  mjtNum*  g_adj;                 // adjoint gradient                                (adr[4])
  mjtNum*  g_fd;                  // finite-difference gradient                      (adr[4])
  mjtNum*  gq;                    // tape cotangents dL/dq_k, tangent         ((N + 1) x nv)
  mjtNum*  gu;                    // tape cotangents dL/du_k                  ((N + 1) x nv)
} gradcheckProblem;


// Allocate n doubles, zeroed; record a failure in *bad.
static mjtNum* gradcheck_alloc(int n, int* bad) {
  mjtNum* p = (mjtNum*)calloc((size_t)(n > 0 ? n : 1), sizeof(mjtNum));
  if (!p) {
    *bad = 1;
  }
  return p;
}


// Free the problem's buffers and model.
static void gradcheck_free(gradcheckProblem* p) {
  mjtNum* bufs[] = {p->qpos0, p->qvel0, p->act0, p->ctrl, p->wq, p->wv, p->qstar, p->vstar,
                    p->g_adj, p->g_fd, p->gq, p->gu};
  for (size_t i = 0; i < sizeof(bufs) / sizeof(bufs[0]); i++) {
    free(bufs[i]);
  }
  if (p->d) {
    ost_deleteData(p->d);
  }
  if (p->m) {
    mj_deleteModel(p->m);
  }
}


// Allocate and draw the start state, the controls and the loss; return 0 on success.
static int gradcheck_setup(const gradcheckArgs* a, gradcheckProblem* p) {
  const mjModel* m = p->m;
  int nq = m->nq, nv = m->nv, nu = m->nu, na = m->na, n = (int)a->steps, bad = 0;
  p->n = n;
  p->nparam = ost_nparam(m);
  p->adr[GC_QPOS] = 0;
  p->adr[GC_QVEL] = nv;
  p->adr[GC_CTRL] = 2 * nv;
  p->adr[GC_PARAMS] = 2 * nv + n * nu;
  p->adr[GC_NGROUP] = 2 * nv + n * nu + p->nparam;
  p->qpos0 = gradcheck_alloc(nq, &bad);
  p->qvel0 = gradcheck_alloc(nv, &bad);
  p->act0 = gradcheck_alloc(na, &bad);
  p->ctrl = gradcheck_alloc(n * nu, &bad);
  p->wq = gradcheck_alloc((n + 1) * nq, &bad);
  p->wv = gradcheck_alloc((n + 1) * nv, &bad);
  p->qstar = gradcheck_alloc(nq, &bad);
  p->vstar = gradcheck_alloc(nv, &bad);
  p->g_adj = gradcheck_alloc(p->adr[GC_NGROUP], &bad);
  p->g_fd = gradcheck_alloc(p->adr[GC_NGROUP], &bad);
  p->gq = gradcheck_alloc((n + 1) * nv, &bad);
  p->gu = gradcheck_alloc((n + 1) * nv, &bad);
  if (bad) {
    cli_error("gradcheck: out of memory");
    return 1;
  }

  // base controls
  mjtNum* base = gradcheck_alloc(nu, &bad);
  if (bad || (a->ctrl && cli_parseList("--ctrl", a->ctrl, base, nu))) {
    free(base);
    return 1;
  }

  // start state: qpos0, or keyframe --key (cli_resetStart); qvel noise
  cliRng rng;
  cli_rngSeed(&rng, (unsigned long long)a->seed);
  p->key = a->key;
  cli_resetStart(m, p->d, p->key);
  mju_copy(p->qpos0, p->d->qpos, nq);
  mju_copy(p->qvel0, p->d->qvel, nv);
  mju_copy(p->act0, p->d->act, na);
  for (int i = 0; i < nv; i++) {
    p->qvel0[i] += cli_uniform(&rng, -0.1, 0.1);
  }

  // controls: base plus noise per step
  for (int k = 0; k < n; k++) {
    for (int i = 0; i < nu; i++) {
      p->ctrl[k * nu + i] = base[i] + cli_uniform(&rng, -0.1, 0.1);
    }
  }
  free(base);

  // loss: a_k, b_k ~ U(-1, 1); q* = qpos0 + U(-0.1, 0.1) (unnormalized is fine); v* ~ U(-1, 1)
  for (int i = 0; i < (n + 1) * nq; i++) {
    p->wq[i] = cli_uniform(&rng, -1, 1);
  }
  for (int i = 0; i < (n + 1) * nv; i++) {
    p->wv[i] = cli_uniform(&rng, -1, 1);
  }
  for (int i = 0; i < nq; i++) {
    p->qstar[i] = p->qpos0[i] + cli_uniform(&rng, -0.1, 0.1);
  }
  for (int i = 0; i < nv; i++) {
    p->vstar[i] = cli_uniform(&rng, -1, 1);
  }
  return 0;
}


//---------------------------------- Loss ----------------------------------------------------------

// Loss terms of state k (qpos, qvel); with gq, gu: add their cotangents (gq a tangent vector).
static double gradcheck_stateLoss(const gradcheckProblem* p, int k, const mjtNum* qpos,
                                  const mjtNum* qvel, mjtNum* gq, mjtNum* gu) {
  const mjModel* m = p->m;
  int nq = m->nq, nv = m->nv;
  const mjtNum* a = p->wq + k * nq;
  const mjtNum* b = p->wv + k * nv;
  double loss = mju_dot(a, qpos, nq) + mju_dot(b, qvel, nv);
  int last = (k == p->n);
  for (int i = 0; i < nq && last; i++) {
    loss += 0.5 * (qpos[i] - p->qstar[i]) * (qpos[i] - p->qstar[i]);
  }
  for (int i = 0; i < nv && last; i++) {
    loss += 0.5 * (qvel[i] - p->vstar[i]) * (qvel[i] - p->vstar[i]);
  }
  if (!gq) {
    return loss;
  }

  // dL/dqpos (nq), then its pull-back to the tangent: gq = G(qpos)^T dL/dqpos
  mjtNum* gpos = (mjtNum*)malloc(sizeof(mjtNum) * (size_t)nq);
  if (!gpos) {
    return NAN;
  }
  for (int i = 0; i < nq; i++) {
    gpos[i] = a[i] + (last ? qpos[i] - p->qstar[i] : 0);
  }
  for (int i = 0; i < nv; i++) {
    gu[i] += b[i] + (last ? qvel[i] - p->vstar[i] : 0);
  }
  for (int j = 0; j < m->njnt; j++) {
    int padr = m->jnt_qposadr[j], vadr = m->jnt_dofadr[j], type = m->jnt_type[j];
    if (type == mjJNT_FREE) {
      for (int i = 0; i < 3; i++) {
        gq[vadr + i] += gpos[padr + i];
      }
      padr += 3;
      vadr += 3;
    }
    if (type == mjJNT_FREE || type == mjJNT_BALL) {
      // q' = q * exp(delta / 2): dq'/d delta_i = 1/2 q * (0, e_i)
      for (int i = 0; i < 3; i++) {
        mjtNum e[4] = {0, 0, 0, 0}, dq[4];
        e[i + 1] = 0.5;
        mju_mulQuat(dq, qpos + padr, e);
        gq[vadr + i] += mju_dot(gpos + padr, dq, 4);
      }
    } else {
      gq[vadr] += gpos[padr];
    }
  }
  free(gpos);
  return loss;
}


//---------------------------------- Rollouts ------------------------------------------------------

// Reset d to the start state x0 (cli_resetStart, then x0's qpos, qvel, act) with qpos replaced
// by qpos (NULL: x0's).
static void gradcheck_reset(const gradcheckProblem* p, const mjtNum* qpos) {
  const mjModel* m = p->m;
  mjData* d = p->d;
  cli_resetStart(m, d, p->key);
  mju_copy(d->qpos, qpos ? qpos : p->qpos0, m->nq);
  mju_copy(d->qvel, p->qvel0, m->nv);
  mju_copy(d->act, p->act0, m->na);
}


// Run the rollout from d's state with controls ctrl (N x nu), recording on tape if not NULL;
// add the loss into *loss and, with the tape, fill the cotangents p->gq, p->gu. Return 0, or 1
// after printing why a step failed.
static int gradcheck_rollout(gradcheckProblem* p, ostTape* tape, const mjtNum* ctrl,
                             double* loss) {
  const mjModel* m = p->m;
  mjData* d = p->d;
  int nv = m->nv, nu = m->nu;
  mjtNum* gq = tape ? p->gq : NULL;
  mjtNum* gu = tape ? p->gu : NULL;
  if (tape) {
    ost_tapeClear(tape);
    mju_zero(p->gq, (p->n + 1) * nv);
    mju_zero(p->gu, (p->n + 1) * nv);
  }
  double sum = gradcheck_stateLoss(p, 0, d->qpos, d->qvel, gq, gu);
  for (int k = 0; k < p->n; k++) {
    mju_copy(d->ctrl, ctrl + k * nu, nu);
    int status = tape ? ost_tapeStep(tape, m, d) : ost_step(m, d);
    if (OST_IS_WARNING(status)) {
      // neither the adjoint nor the differences of an unsolved step mean anything
      cli_error("gradcheck: step %d did not converge (residual %.3g m/s above tol): refusing "
                "to compare the gradients of an unsolved rollout (raise --newton or lower --h)",
                k + 1, ost_stats(d)->residual);
      return 1;
    }
    if (status != OST_OK || cli_mujocoError()) {
      cli_error("gradcheck: step %d failed: %s", k + 1,
                status != OST_OK ? ost_lastError(d) : cli_mujocoError());
      return 1;
    }
    sum += gradcheck_stateLoss(p, k + 1, d->qpos, d->qvel, gq ? gq + (k + 1) * nv : NULL,
                               gu ? gu + (k + 1) * nv : NULL);
  }
  *loss = sum;
  return isfinite(sum) ? 0 : (cli_error("gradcheck: the loss is not finite"), 1);
}


// Recorded rollout and backward pass: fill p->g_adj; return 0, or 1 after printing why.
static int gradcheck_adjoint(gradcheckProblem* p, int params, double* loss) {
  const mjModel* m = p->m;
  int status = OST_OK;
  ostTape* tape = ost_tapeCreate(m, 0);
  if (!tape) {
    cli_error("gradcheck: cannot create a tape (out of memory)");
    return 1;
  }
  gradcheck_reset(p, NULL);
  if (gradcheck_rollout(p, tape, p->ctrl, loss)) {
    ost_tapeDelete(tape);
    return 1;
  }

  // dL/dctrl (N x nu), dL/dx0 (row 0 included), dL/dtheta (accumulated into zeros)
  ostGradOptions go;
  ost_defaultGradOptions(&go);
  go.params = params;
  mjtNum* g = p->g_adj;
  mju_zero(g, p->adr[GC_NGROUP]);
  status = ost_tapeBackward(tape, m, &go, p->gq, p->gu, g + p->adr[GC_CTRL], g + p->adr[GC_QPOS],
                            g + p->adr[GC_QVEL], params ? g + p->adr[GC_PARAMS] : NULL);
  if (status != OST_OK) {
    cli_error("gradcheck: backward pass failed (status %d): %s", status, ost_tapeError(tape));
  }
  ost_tapeDelete(tape);
  return status != OST_OK;
}


// Parameter i of theta: the mjModel entry that its ostParam group names.
static mjtNum* gradcheck_param(const gradcheckProblem* p, int i, int* group) {
  mjModel* m = p->m;
  int g = 0;
  while (g + 1 < OST_NPARAM && ost_paramAddress(m, g + 1) <= i) {
    g++;
  }
  int j = i - ost_paramAddress(m, g);
  *group = g;
  switch (g) {
    case OST_PARAM_FRICTION: return m->geom_friction + 3 * j;
    case OST_PARAM_MASS:     return m->body_mass + j;
    case OST_PARAM_DAMPING:  return m->dof_damping + j;
    case OST_PARAM_GAIN:     return m->actuator_gainprm + mjNGAIN * j;
    case OST_PARAM_BIASPOS:  return m->actuator_biasprm + mjNBIAS * j + 1;
    default:                 return m->actuator_biasprm + mjNBIAS * j + 2;
  }
}


// Loss of the rollout with entry c of the flat gradient vector moved by s * eps (tangent step
// for qpos, s * eps * max(1, |x|) otherwise); *step gets the step taken. Return 0 or 1.
static int gradcheck_perturbed(gradcheckProblem* p, mjtNum* ctrl, mjtNum* qpos, int c, double s,
                               double eps, double* step, double* loss) {
  const mjModel* m = p->m;
  int nv = m->nv;
  mjtNum* entry = NULL;
  int group;

  // qpos along the tangent; the rest in place, restored below
  if (c < p->adr[GC_QVEL]) {
    mjtNum* dq = (mjtNum*)calloc((size_t)nv, sizeof(mjtNum));
    if (!dq) {
      cli_error("gradcheck: out of memory");
      return 1;
    }
    // a position step far below what a body moves in one step (g h^2 = 4e-5 m at 2 ms), so
    // that both rollouts meet a resting contact alike: E / 100 (a step of 1e-4 m lifts a box
    // resting on its floor clear of it for several steps; the + and - rollouts then differ in
    // kind, not by a derivative)
    dq[c] = 1;
    mju_copy(qpos, p->qpos0, m->nq);
    mj_integratePos(m, qpos, dq, s * eps * 0.01);
    free(dq);
    *step = eps * 0.01;
  } else if (c < p->adr[GC_CTRL]) {
    entry = p->qvel0 + (c - p->adr[GC_QVEL]);
  } else if (c < p->adr[GC_PARAMS]) {
    entry = ctrl + (c - p->adr[GC_CTRL]);
  } else {
    entry = gradcheck_param(p, c - p->adr[GC_PARAMS], &group);
  }
  mjtNum saved = entry ? *entry : 0;
  if (entry) {
    *step = eps * mju_max(1, mju_abs(saved));
    *entry = saved + s * *step;
  }
  gradcheck_reset(p, entry ? NULL : qpos);
  int status = gradcheck_rollout(p, NULL, ctrl, loss);
  if (entry) {
    *entry = saved;
  }
  return status;
}


// Side to which entry c may not be moved by its finite-difference step: +1 if a larger value
// leaves the parameter's domain, -1 if a smaller one does, 0 if both are fine. Friction, mass
// and damping are >= 0; a servo's bias feedback is <= 0 (ost_checkModel refuses positive
// feedback), so a velocity servo's biaspos of 0 is on the boundary.
static int gradcheck_boundary(gradcheckProblem* p, int c, double eps) {
  if (c < p->adr[GC_PARAMS]) {
    return 0;
  }
  int group;
  mjtNum value = *gradcheck_param(p, c - p->adr[GC_PARAMS], &group);
  double step = eps * mju_max(1, mju_abs(value));
  if (group == OST_PARAM_BIASPOS || group == OST_PARAM_BIASVEL) {
    return value + step > 0 ? 1 : 0;
  }
  if (group != OST_PARAM_GAIN) {
    return value - step < 0 ? -1 : 0;
  }
  return 0;
}


// Finite differences of every entry of the compared groups: fill p->g_fd; *one_sided counts
// the entries next to a domain boundary. Central, (L(+s) - L(-s)) / 2s, except at a boundary:
// the one-sided second-order difference into the domain, (-3 L(0) + 4 L(s) - L(2s)) / 2s with
// s of the inward sign. Return 0 or 1.
static int gradcheck_fd(gradcheckProblem* p, const int wrt[GC_NGROUP], double eps,
                        int* one_sided) {
  const mjModel* m = p->m;
  int bad = 0;
  double l0 = NAN;
  *one_sided = 0;
  mjtNum* ctrl = gradcheck_alloc(p->n * m->nu, &bad);
  mjtNum* qpos = gradcheck_alloc(m->nq, &bad);
  if (bad) {
    free(ctrl);
    free(qpos);
    cli_error("gradcheck: out of memory");
    return 1;
  }
  mju_copy(ctrl, p->ctrl, p->n * m->nu);

  // progress: a line every second, on the entries done of those compared
  int progress = cli_progress(), ndone = 0, ntotal = 0;
  double last = cli_now();
  for (int g = 0; g < GC_NGROUP; g++) {
    ntotal += wrt[g] ? p->adr[g + 1] - p->adr[g] : 0;
  }
  for (int g = 0; g < GC_NGROUP && !bad; g++) {
    for (int c = p->adr[g]; c < p->adr[g + 1] && wrt[g] && !bad; c++) {
      double l1, l2, step;
      if (progress && cli_now() - last >= 1.0) {
        fprintf(stderr, "ostrich: gradcheck: finite differences %d/%d\n", ndone, ntotal);
        last = cli_now();
      }
      ndone++;
      int side = gradcheck_boundary(p, c, eps);
      if (!side) {
        bad = gradcheck_perturbed(p, ctrl, qpos, c, 1, eps, &step, &l1) ||
              gradcheck_perturbed(p, ctrl, qpos, c, -1, eps, &step, &l2);
        p->g_fd[c] = (l1 - l2) / (2 * step);
        continue;
      }

      // inward one-sided: the unperturbed loss once, from an untaped rollout like the others
      if (isnan(l0)) {
        gradcheck_reset(p, NULL);
        bad = gradcheck_rollout(p, NULL, ctrl, &l0);
      }
      bad = bad || gradcheck_perturbed(p, ctrl, qpos, c, -side, eps, &step, &l1) ||
            gradcheck_perturbed(p, ctrl, qpos, c, -2 * side, eps, &step, &l2);
      p->g_fd[c] = -side * (-3 * l0 + 4 * l1 - l2) / (2 * step);
      (*one_sided)++;
    }
  }
  free(ctrl);
  free(qpos);
  return bad;
}


//---------------------------------- Report --------------------------------------------------------

// Normwise relative error of entries [lo, hi): max |adj - fd| / max(max |fd|, tiny); NaN if
// any entry is not finite. With unknown (parameters only): an entry whose adjoint is NaN, a
// parameter the adjoint does not differentiate (ostParam: a muscle's curves), is left out and
// counted there.
static double gradcheck_error(const gradcheckProblem* p, int lo, int hi, double tiny,
                              int* unknown) {
  double diff = 0, scale = tiny;
  for (int c = lo; c < hi; c++) {
    if (unknown && isnan(p->g_adj[c])) {
      (*unknown)++;
      continue;
    }
    if (!isfinite(p->g_adj[c]) || !isfinite(p->g_fd[c])) {
      return NAN;
    }
    diff = mju_max(diff, mju_abs(p->g_adj[c] - p->g_fd[c]));
    scale = mju_max(scale, mju_abs(p->g_fd[c]));
  }
  return diff / scale;
}


// Print the worst entry of group g on stderr (for diagnosis).
static void gradcheck_printWorst(const gradcheckProblem* p, int g) {
  int worst = -1;
  double diff = -1;
  for (int c = p->adr[g]; c < p->adr[g + 1]; c++) {
    double e = mju_abs(p->g_adj[c] - p->g_fd[c]);
    if (!(e <= diff)) {
      diff = e;
      worst = c;
    }
  }
  if (worst < 0) {
    return;
  }
  int i = worst - p->adr[g];
  char where[64];
  if (g == GC_CTRL) {
    snprintf(where, sizeof(where), "step %d, ctrl %d", i / p->m->nu, i % p->m->nu);
  } else if (g == GC_PARAMS) {
    int group;
    gradcheck_param(p, i, &group);
    snprintf(where, sizeof(where), "%s %d", kParamNames[group],
             i - ost_paramAddress(p->m, group));
  } else {
    snprintf(where, sizeof(where), "dof %d", i);
  }
  fprintf(stderr, "ostrich: gradcheck %s: worst entry %s: adjoint %.10g, fd %.10g\n",
          kGroupNames[g], where, p->g_adj[worst], p->g_fd[worst]);
}


// Print the JSON line (errors null after a failed run); return 1 if the run did not fail and
// every compared group is within tol, else 0.
static int gradcheck_report(const gradcheckArgs* a, const gradcheckProblem* p, int failed,
                            const int wrt[GC_NGROUP], double loss, int one_sided, double t_adj,
                            double t_fd) {
  // tiny: relative to the largest finite-difference gradient of all compared groups
  double gmax = 1e-300;
  int nonzero = 0;
  for (int g = 0; g < GC_NGROUP; g++) {
    for (int c = p->adr[g]; c < p->adr[g + 1] && wrt[g]; c++) {
      gmax = mju_max(gmax, mju_abs(p->g_fd[c]));
    }
  }
  double tiny = 1e-6 * gmax;
  for (int c = p->adr[GC_PARAMS]; c < p->adr[GC_NGROUP] && wrt[GC_PARAMS]; c++) {
    nonzero += (mju_abs(p->g_fd[c]) > tiny);
  }

  printf("{\"model\":");
  cli_jsonString(stdout, a->model);
  printf(",\"steps\":%d,\"h\":", p->n);
  cli_jsonNumber(stdout, p->h);
  if (a->key == CLI_KEY_NONE) {
    printf(",\"key\":null");
  } else {
    printf(",\"key\":%ld", a->key);
  }
  printf(",\"seed\":%ld,\"wrt\":", a->seed);
  cli_jsonString(stdout, a->wrt);
  printf(",\"eps\":%g,\"tol\":%g,\"loss\":", a->eps, a->tol);
  cli_jsonNumber(stdout, loss);
  int ok = !failed, unknown = 0;
  for (int g = 0; g < GC_NGROUP; g++) {
    double e = wrt[g] ? gradcheck_error(p, p->adr[g], p->adr[g + 1], tiny,
                                        g == GC_PARAMS ? &unknown : NULL)
                      : NAN;
    printf(",\"%s\":", kGroupNames[g]);
    if (wrt[g] && !failed) {
      cli_jsonNumber(stdout, e);
      if (!(e <= a->tol)) {
        ok = 0;
        gradcheck_printWorst(p, g);
      }
    } else {
      printf("null");
    }
  }
  printf(",\"n_qpos\":%d,\"n_qvel\":%d,\"n_ctrl\":%d,\"n_params\":%d,\"params_nonzero\":",
         p->m->nv, p->m->nv, p->n * p->m->nu, p->nparam);
  if (wrt[GC_PARAMS] && !failed) {
    printf("%d,\"params_one_sided\":%d,\"params_unknown\":%d,\"param_groups\":{", nonzero,
           one_sided, unknown);
    for (int g = 0; g < OST_NPARAM; g++) {
      int lo = p->adr[GC_PARAMS] + ost_paramAddress(p->m, g);
      int hi = p->adr[GC_PARAMS] + ost_paramAddress(p->m, g + 1), skipped = 0;
      printf("%s\"%s\":", g ? "," : "", kParamNames[g]);
      cli_jsonNumber(stdout, hi > lo ? gradcheck_error(p, lo, hi, tiny, &skipped) : 0);
    }
    printf("}");
  } else {
    printf("null,\"params_one_sided\":null,\"params_unknown\":null,\"param_groups\":null");
  }
  printf(",\"adjoint_s\":%.6f,\"fd_s\":%.6f,\"ok\":%s}\n", t_adj, t_fd, ok ? "true" : "false");
  fflush(stdout);
  return ok;
}


//---------------------------------- gradcheck -----------------------------------------------------

// `ostrich gradcheck MODEL.xml [options]`
int gradcheck_main(int argc, char** argv) {
  gradcheckArgs a = {.steps = 10, .seed = 1, .wrt = "all", .eps = 1e-4, .tol = 1e-3,
                     .newton = -1, .key = CLI_KEY_NONE};
  int wrt[GC_NGROUP];
  if (cli_parseArgs("gradcheck", argc, argv, kGradcheckOptions, kGradcheckNumOptions, &a,
                    &a.model, &a.help)) {
    return CLI_USAGE;
  }
  if (a.help) {
    gradcheck_usage(stdout);
    return CLI_OK;
  }
  if (gradcheck_checkArgs(&a, wrt)) {
    return CLI_USAGE;
  }

  // load; Ostrich options; gradients need the native provider's model
  gradcheckProblem p = {0};
  char err[CLI_MSG_SZ] = "";
  if (cli_loadModel(a.model, &p.m, &p.d) || cli_checkKey(p.m, a.key) ||
      cli_setupOstrich(p.m, p.d, a.h, a.newton, -1, NULL, &p.h)) {
    gradcheck_free(&p);
    return CLI_USAGE;
  }
  if (ost_checkNative(p.m, err, sizeof(err)) != OST_OK) {
    cli_error("gradients need the native geometry: %s", err);
    gradcheck_free(&p);
    return CLI_USAGE;
  }
  p.m->opt.timestep = p.h;
  if (gradcheck_setup(&a, &p)) {
    gradcheck_free(&p);
    return CLI_USAGE;
  }

  // adjoint, then finite differences (which rewrite d and, briefly, the model)
  double loss = NAN;
  double t0 = cli_now();
  int failed = gradcheck_adjoint(&p, wrt[GC_PARAMS], &loss);
  double t1 = cli_now();
  if (cli_progress()) {
    fprintf(stderr, "ostrich: gradcheck: adjoint in %.2f s; finite differences ...\n", t1 - t0);
  }
  int one_sided = 0;
  failed = failed || gradcheck_fd(&p, wrt, a.eps, &one_sided);
  double t2 = cli_now();
  int ok = gradcheck_report(&a, &p, failed, wrt, loss, one_sided, t1 - t0, t2 - t1);
  gradcheck_free(&p);
  return ok ? CLI_OK : CLI_FAIL;
}
