// ost_cli_bench_adjoint.c: `ostrich bench adjoint`, the cost of exact gradients on one core. Per
// model, in one run: Ostrich's forward step (ost_step), the same rollout recorded on a tape
// (ost_tapeStep) and its backward pass (ost_tapeBackward, cotangents on every state), and stock
// MuJoCo's step (mj_step at opt.timestep) and its finite-difference transition Jacobians
// (mjd_transitionFD, centred, eps 1e-6) from the same states: what a MuJoCo user pays for one
// step's derivatives today. A table on stderr, one JSON line on stdout; --csv writes the rows.
// Ratios: backward / forward (Ostrich); mjd_transitionFD / backward per step and per simulated
// second (Ostrich's h against MuJoCo's opt.timestep).
//
// Invariant: every timing is of work done in this run, on this machine, with the same controls.
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "ost_cli_util.h"

typedef struct adjArgs_ {
  long steps;                     // steps per rollout
  long repeat;                    // rollouts timed (the median is kept)
  double h;                       // Ostrich's step (0: the model's)
  const char* csv;
  long key;
} adjArgs;

static const cliOption kOptions[] = {
  {"--steps", CLI_ARG_COUNT, offsetof(adjArgs, steps), "N", "steps per rollout (default 200)"},
  {"--repeat", CLI_ARG_COUNT, offsetof(adjArgs, repeat), "R",
   "rollouts timed per measurement; the median is reported (default 3)"},
  {"--h", CLI_ARG_POSITIVE, offsetof(adjArgs, h), "H",
   "Ostrich's step size in s (default: the model's ostrich/timestep)"},
  {"--csv", CLI_ARG_STRING, offsetof(adjArgs, csv), "FILE.csv", "write the rows"},
  CLI_KEY_OPTION(adjArgs),
};
#define NOPTION ((int)(sizeof(kOptions) / sizeof(kOptions[0])))
#define MAXMODEL 32

typedef struct adjRow_ {          // one model's measurements (microseconds per step)
  const char* path;
  int nv, nu;
  double h, mj_h;                 // Ostrich's step and MuJoCo's opt.timestep (s)
  double fwd_us, tape_us, bwd_us, mj_us, fd_us;
  double bytes_per_step;
  long unconverged;               // Ostrich steps that returned a warning
  long mj_warnings;               // MuJoCo's warnings in its runs (mjData.warning, e.g. an
                                  // unstable simulation reset): its timings are then of that run
  char msg[CLI_MSG_SZ];           // why the backward pass failed ("" if it did not)
} adjRow;


static int cmpDouble(const void* a, const void* b) {
  double x = *(const double*)a, y = *(const double*)b;
  return (x > y) - (x < y);
}


// the controls of step k: a slow sine per actuator within its control range (or +-0.3)
static void setCtrl(const mjModel* m, mjData* d, long k) {
  for (int i = 0; i < m->nu; i++) {
    double mid = 0, half = 0.3;
    if (m->actuator_ctrllimited[i]) {
      mid = 0.5 * (m->actuator_ctrlrange[2 * i] + m->actuator_ctrlrange[2 * i + 1]);
      half = 0.3 * (m->actuator_ctrlrange[2 * i + 1] - m->actuator_ctrlrange[2 * i]);
    }
    d->ctrl[i] = mid + half * sin(0.05 * k + 1.3 * i);
  }
}


// one measurement of the model: each timing the median of a.repeat rollouts of a.steps steps
static int measure(const char* path, const adjArgs* a, adjRow* r) {
  mjModel* m = NULL;
  mjData* d = NULL;
  memset(r, 0, sizeof(*r));
  r->path = path;
  if (cli_loadModel(path, &m, &d)) {
    return CLI_USAGE;
  }
  r->nv = m->nv;
  r->nu = m->nu;
  r->mj_h = m->opt.timestep;
  if (cli_setupOstrich(m, d, a->h, -1, -1, NULL, &r->h)) {
    mj_deleteModel(m);
    ost_deleteData(d);
    return CLI_USAGE;
  }
  long n = a->steps, R = a->repeat;
  int nv = m->nv;
  double* t = (double*)calloc(5 * R, sizeof(double));
  double* gq = (double*)calloc((size_t)(n + 1) * nv, sizeof(double));
  double* gu = (double*)calloc((size_t)(n + 1) * nv, sizeof(double));
  double* gctrl = (double*)calloc((size_t)n * m->nu + 1, sizeof(double));
  int nx = 2 * nv + m->na;
  double* A = (double*)malloc((size_t)nx * nx * sizeof(double));
  double* B = (double*)malloc((size_t)nx * (m->nu + 1) * sizeof(double));
  ostTape* tape = ost_tapeCreate(m, 0);
  mjData* dm = mj_makeData(m);
  if (!t || !gq || !gu || !gctrl || !A || !B || !tape || !dm) {
    cli_error("bench adjoint: out of memory");
    return CLI_FAIL;
  }
  for (long i = 0; i < (n + 1) * nv; i++) {  // a loss on every state: fixed pseudo-random weights
    gq[i] = sin(0.7 * i);
    gu[i] = 0.1 * cos(0.3 * i);
  }
  // warm-up, untimed: the context, the packed model and the adjoint's dual work are made once
  cli_resetStart(m, d, a->key);
  ost_tapeClear(tape);
  for (long k = 0; k < 2; k++) {
    setCtrl(m, d, k);
    ost_tapeStep(tape, m, d);
  }
  ost_tapeBackward(tape, m, NULL, gq, gu, gctrl, NULL, NULL, NULL);
  int status = CLI_OK;
  for (long rep = 0; rep < R && status == CLI_OK; rep++) {
    // Ostrich forward, plain
    cli_resetStart(m, d, a->key);
    double t0 = cli_now();
    for (long k = 0; k < n; k++) {
      setCtrl(m, d, k);
      int s = ost_step(m, d);
      if (s && !OST_IS_WARNING(s)) {
        snprintf(r->msg, sizeof(r->msg), "step %ld: %s", k, ost_lastError(d));
        status = CLI_FAIL;
        break;
      }
    }
    t[rep] = (cli_now() - t0) / n;
    // recorded, then backward
    cli_resetStart(m, d, a->key);
    ost_tapeClear(tape);
    r->unconverged = 0;
    t0 = cli_now();
    for (long k = 0; k < n && status == CLI_OK; k++) {
      setCtrl(m, d, k);
      int s = ost_tapeStep(tape, m, d);
      r->unconverged += OST_IS_WARNING(s) ? 1 : 0;
    }
    t[R + rep] = (cli_now() - t0) / n;
    r->bytes_per_step = (double)ost_tapeBytes(tape) / n;
    t0 = cli_now();
    int s = ost_tapeBackward(tape, m, NULL, gq, gu, gctrl, NULL, NULL, NULL);
    t[2 * R + rep] = (cli_now() - t0) / n;
    if (s) {
      snprintf(r->msg, sizeof(r->msg), "backward: %s", ost_tapeError(tape));
      t[2 * R + rep] = NAN;
    }
    // stock MuJoCo: mj_step at its own timestep, and mjd_transitionFD at the same states
    cli_resetStart(m, dm, a->key);
    t0 = cli_now();
    for (long k = 0; k < n; k++) {
      setCtrl(m, dm, k);
      mj_step(m, dm);
    }
    t[3 * R + rep] = (cli_now() - t0) / n;
    long mj_step_warnings = 0;
    for (int w = 0; w < mjNWARNING; w++) {
      mj_step_warnings += dm->warning[w].number;
    }
    cli_resetStart(m, dm, a->key);
    long nfd = n < 50 ? n : 50;  // the Jacobians cost 2 nx + 2 nu steps each: fewer of them
    t0 = cli_now();
    for (long k = 0; k < nfd; k++) {
      setCtrl(m, dm, k);
      mjd_transitionFD(m, dm, 1e-6, 1, A, B, NULL, NULL);
      mj_step(m, dm);
    }
    t[4 * R + rep] = (cli_now() - t0) / nfd - t[3 * R + rep];
    r->mj_warnings = mj_step_warnings;
    for (int w = 0; w < mjNWARNING; w++) {
      r->mj_warnings += dm->warning[w].number;
    }
    if (cli_progress()) {
      fprintf(stderr, "bench adjoint: %s rollout %ld of %ld\n", path, rep + 1, R);
    }
  }
  double* out[5] = {&r->fwd_us, &r->tape_us, &r->bwd_us, &r->mj_us, &r->fd_us};
  for (int q = 0; q < 5; q++) {
    qsort(t + q * R, R, sizeof(double), cmpDouble);
    *out[q] = 1e6 * t[q * R + R / 2];
  }
  free(t); free(gq); free(gu); free(gctrl); free(A); free(B);
  ost_tapeDelete(tape);
  mj_deleteData(dm);
  ost_deleteData(d);
  mj_deleteModel(m);
  return status;
}


// MuJoCo's finite-difference derivatives per simulated second over Ostrich's backward pass
static double simRatio(const adjRow* r) {
  return (r->fd_us / r->mj_h) / (r->bwd_us / r->h);
}


static void usage(void) {
  printf("usage: ostrich bench adjoint MODEL.xml ... [options]\n\n"
         "The cost of exact gradients on one core, per model in one run: Ostrich's step\n"
         "(ost_step), the recorded step (ost_tapeStep) and the backward pass of the rollout\n"
         "(ost_tapeBackward, a loss on every state), against stock MuJoCo's mj_step at its\n"
         "opt.timestep and its finite-difference Jacobians mjd_transitionFD (centred) at the\n"
         "same states. All in microseconds per step, medians of --repeat rollouts. Controls: a\n"
         "slow sine per actuator within its range. A table goes to stderr (unless\n"
         "OSTRICH_QUIET=1) and one JSON line to stdout: steps, repeat and per model\n"
         "(\"models\") model, nv, nu, h, mj_timestep, fwd_us, tape_us, bwd_us, bwd_over_fwd,\n"
         "mj_step_us,\n"
         "transitionFD_us, fd_over_bwd (per step), fd_over_bwd_sim (per simulated second:\n"
         "transitionFD_us / mj_timestep over bwd_us / h), tape_bytes_per_step, unconverged,\n"
         "mujoco_warnings (MuJoCo's warnings in its runs of the last repetition, e.g. an\n"
         "unstable simulation it reset: its timings are then of that run), error.\n\noptions:\n");
  cli_printOptions(stdout, kOptions, NOPTION);
  cli_printHelpOption(stdout);
}


int bench_adjoint_main(int argc, char** argv) {
  adjArgs a = {200, 3, 0, NULL, CLI_KEY_NONE};
  const char* paths[MAXMODEL];
  int npath = 0, help = 0;
  if (cli_parseArgsList("bench adjoint", argc, argv, kOptions, NOPTION, &a, paths, MAXMODEL,
                        &npath, &help)) {
    return CLI_USAGE;
  }
  if (help) {
    usage();
    return CLI_OK;
  }
  if (npath == 0 || a.steps < 1 || a.repeat < 1) {
    cli_error("bench adjoint: give at least one MODEL.xml, --steps >= 1 and --repeat >= 1");
    return CLI_USAGE;
  }
  if (a.csv && cli_checkOutput("--csv", a.csv)) {
    return CLI_USAGE;
  }
  adjRow rows[MAXMODEL];
  int status = CLI_OK;
  for (int i = 0; i < npath; i++) {
    int s = measure(paths[i], &a, rows + i);
    if (s == CLI_USAGE) {
      return s;
    }
    status = s ? s : status;
  }
  // the table on stderr (unless OSTRICH_QUIET), one JSON line on stdout
  if (cli_progress()) {
    fprintf(stderr, "%-36s %4s %7s %9s %9s %9s %7s %9s %9s %7s %9s %9s\n", "model", "nv", "h",
            "fwd_us", "tape_us", "bwd_us", "bwd/fwd", "mj_us", "fd_us", "fd/bwd", "per sim-s",
            "bytes/st");
    for (int i = 0; i < npath; i++) {
      adjRow* r = rows + i;
      fprintf(stderr,
              "%-36s %4d %7.4f %9.1f %9.1f %9.1f %7.2f %9.1f %9.1f %7.2f %9.1f %9.0f %s%s\n",
              r->path, r->nv, r->h, r->fwd_us, r->tape_us, r->bwd_us, r->bwd_us / r->fwd_us,
              r->mj_us, r->fd_us, r->fd_us / r->bwd_us, simRatio(r), r->bytes_per_step, r->msg,
              r->mj_warnings ? " (MuJoCo warned: unstable or reset, its timings are of that run)"
                             : "");
    }
  }
  printf("{\"steps\":%ld,\"repeat\":%ld,\"models\":[", a.steps, a.repeat);
  for (int i = 0; i < npath; i++) {
    adjRow* r = rows + i;
    printf("%s{\"model\":", i ? "," : "");
    cli_jsonString(stdout, r->path);
    printf(",\"nv\":%d,\"nu\":%d,\"h\":", r->nv, r->nu);
    cli_jsonNumber(stdout, r->h);
    double v[] = {r->mj_h, r->fwd_us, r->tape_us, r->bwd_us, r->bwd_us / r->fwd_us, r->mj_us,
                  r->fd_us, r->fd_us / r->bwd_us, simRatio(r), r->bytes_per_step};
    const char* k[] = {"mj_timestep", "fwd_us", "tape_us", "bwd_us", "bwd_over_fwd",
                       "mj_step_us", "transitionFD_us", "fd_over_bwd", "fd_over_bwd_sim",
                       "tape_bytes_per_step"};
    for (int q = 0; q < 10; q++) {
      printf(",\"%s\":", k[q]);
      cli_jsonNumber(stdout, v[q]);
    }
    printf(",\"unconverged\":%ld,\"mujoco_warnings\":%ld,\"error\":", r->unconverged,
           r->mj_warnings);
    cli_jsonString(stdout, r->msg);
    printf("}");
  }
  printf("]}\n");
  if (a.csv) {
    char tmp[CLI_PATH_SZ];
    FILE* f = cli_openOutput(a.csv, tmp, sizeof(tmp));
    if (!f) {
      return CLI_FAIL;
    }
    fprintf(f, "model,nv,nu,h,mj_timestep,fwd_us,tape_us,bwd_us,bwd_over_fwd,mj_step_us,"
               "transitionFD_us,fd_over_bwd,fd_over_bwd_sim,tape_bytes_per_step,unconverged,"
               "mujoco_warnings\n");
    for (int i = 0; i < npath; i++) {
      adjRow* r = rows + i;
      fprintf(f, "%s,%d,%d,%.6g,%.6g,%.6g,%.6g,%.6g,%.6g,%.6g,%.6g,%.6g,%.6g,%.6g,%ld,%ld\n",
              r->path, r->nv, r->nu, r->h, r->mj_h, r->fwd_us, r->tape_us, r->bwd_us,
              r->bwd_us / r->fwd_us, r->mj_us, r->fd_us, r->fd_us / r->bwd_us, simRatio(r),
              r->bytes_per_step, r->unconverged, r->mj_warnings);
    }
    if (cli_commitOutput(f, tmp, a.csv)) {
      return CLI_FAIL;
    }
  }
  return status;
}
