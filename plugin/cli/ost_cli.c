// ost_cli.c: the `ostrich` command-line tool. Subcommands are dispatched from one table
// (kCommands); `sim` loads an MJCF model, steps it with Ostrich (ost_step) or stock MuJoCo
// (mj_step) from qpos0 or a keyframe (--key), optionally writes the trajectory as CSV (--csv),
// and prints a JSON summary; `check` runs sim's acceptance test, then compares native geometry with
// MuJoCo's. `synth` (ost_cli_synth.c) and `gradcheck` (ost_cli_gradcheck.c) live in their own
// files; the shared helpers in ost_cli_util.c.
// Mirrors MuJoCo's sample programs (testspeed.cc, basic.cc), without rendering.
//
// Invariant: stdout carries at most one JSON line per run and nothing else; every diagnostic
// and progress line goes to stderr and starts with "ostrich:" (MuJoCo warnings with
// "mujoco warning:"). Exit codes: 0 success, 1 the run failed (NaN, failed step, MuJoCo error,
// a check over tolerance), 2 bad usage or unusable input (options, model file, XML, model
// refused by Ostrich).
#define _POSIX_C_SOURCE 200809L

#include <errno.h>
#include <math.h>
#include <stddef.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <mujoco/mujoco.h>

#include "compare.h"
#include "ost_cli_util.h"
#include "ostrich.h"


//---------------------------------- sim: arguments ------------------------------------------------

typedef struct simArgs_ {         // arguments of `ostrich sim`
  const char* model;              // MJCF path (the positional argument)
  const char* engine;             // "ostrich" or "mujoco"
  double      h;                  // step size (s); 0: not given
  double      duration;           // simulated time (s); 0: not given
  long        steps;              // number of steps; -1: not given
  const char* ctrl;               // comma list of nu controls; NULL: not given
  long        newton;             // Newton budget; -1: not given
  long        pcr;                // PCR budget; -1: not given
  const char* csv;                // trajectory CSV path; NULL: none
  const char* geometry;           // "mujoco" or "native"; NULL: the model's option
  long        key;                // start keyframe; CLI_KEY_NONE: qpos0
  long        perturb;            // seed of the start's qvel perturbation; 0: none
  int         help;               // --help was given
} simArgs;

#define SIM_PERTURB 5e-7          // --perturb: each qvel moves by at most this (m/s or rad/s)

#define SIM_DEFAULT_DURATION 5.0  // simulated seconds when neither --duration nor --steps

static const cliOption kSimOptions[] = {
  {"--engine", CLI_ARG_STRING, offsetof(simArgs, engine), "ostrich|mujoco",
   "time stepper: ostrich (ost_step, the default) or mujoco (stock mj_step)"},
  {"--h", CLI_ARG_POSITIVE, offsetof(simArgs, h), "SEC",
   "step size (s); default: ostrich: the model's <custom> ostrich/timestep\n"
   "if present, else opt.timestep; mujoco: opt.timestep"},
  {"--duration", CLI_ARG_POSITIVE, offsetof(simArgs, duration), "SEC",
   "simulated time (s), steps = round(SEC / h) (default 5)"},
  {"--steps", CLI_ARG_COUNT, offsetof(simArgs, steps), "N",
   "number of steps, instead of --duration (giving both is an error)"},
  {"--ctrl", CLI_ARG_STRING, offsetof(simArgs, ctrl), "v1,v2,...",
   "exactly nu controls, set into d->ctrl before every step (default 0)"},
  {"--newton", CLI_ARG_COUNT, offsetof(simArgs, newton), "K",
   "Newton budget per step (ostrich/newton_iter); ignored by mujoco"},
  {"--pcr", CLI_ARG_COUNT, offsetof(simArgs, pcr), "K",
   "PCR budget per Newton iterate (ostrich/pcr_iter); ignored by mujoco"},
  {"--geometry", CLI_ARG_STRING, offsetof(simArgs, geometry), "mujoco|native",
   "Ostrich's geometry provider (ostrich/geometry): MuJoCo's kinematics\n"
   "and collision, or Ostrich's portable native geometry"},
  CLI_KEY_OPTION(simArgs),
  {"--perturb", CLI_ARG_COUNT, offsetof(simArgs, perturb), "SEED",
   "add a uniform perturbation of at most 5e-7 to every qvel of the start (seed\n"
   "SEED >= 1; 0: none, the default): runs of a model whose iterate counts are\n"
   "chaotic (composites lying in contact) are compared over several starts"},
  {"--csv", CLI_ARG_STRING, offsetof(simArgs, csv), "FILE.csv",
   "write the trajectory as CSV: header time,qpos_0..,qvel_0..(,act_0.. if na > 0); one row\n"
   "for the initial state, then one after each step (%.10g); written to\n"
   "FILE.csv.tmp<pid>, renamed at the end (a killed run leaves FILE whole)"},
};

static const int kSimNumOptions = (int)(sizeof(kSimOptions) / sizeof(kSimOptions[0]));


// Print the usage of `ostrich sim`.
static void sim_usage(FILE* f) {
  fprintf(f,
    "usage: ostrich sim MODEL.xml [options]\n"
    "\n"
    "Load an MJCF model, simulate it with Ostrich or stock MuJoCo 2.2.2, and print one JSON\n"
    "line on stdout: engine, model, h, steps, wall_s (seconds spent in the step calls),\n"
    "nan (a non-finite qpos/qvel was seen, or MuJoCo reset a diverged state; stepping stops\n"
    "there), max_penetration (m, deepest contact over all steps), mean_residual (ostrich: merit\n"
    "residual; mujoco: final solver gradient norm), mean_newton_iter (ostrich: Newton\n"
    "iterates; mujoco: solver iterations), cold_retries (ostrich: Newton solves redone from\n"
    "a cold start after failing from the warm one), geometric_retries (ostrich: Newton solves\n"
    "redone with the geometric terms after failing), key (the start keyframe, null: qpos0),\n"
    "perturb (--perturb's seed, 0: none) and final_qpos. Both engines start from the same\n"
    "state: qpos0 (mj_resetData), or keyframe K with --key K.\n"
    "\n"
    "options:\n");
  cli_printOptions(f, kSimOptions, kSimNumOptions);
  fprintf(f,
    "  %-26s print this help and exit\n"
    "\n"
    "Progress lines (ostrich: step k/N) go to stderr every second on runs longer than about\n"
    "2 s, unless OSTRICH_QUIET=1. Exit status: 0 success; 1 the simulation failed (NaN,\n"
    "failed step, MuJoCo error; the JSON line and the CSV still cover the steps taken); 2 bad\n"
    "usage, missing or malformed model, --key out of range, model refused by Ostrich (the\n"
    "message names every unsupported feature; `ostrich check` gives the same).\n",
    "-h, --help");
}


// Parse the arguments of `ostrich sim`; return 0 on success, else print why.
static int sim_parseArgs(int argc, char** argv, simArgs* a) {
  *a = (simArgs){.engine = "ostrich", .steps = -1, .newton = -1, .pcr = -1, .key = CLI_KEY_NONE};
  return cli_parseArgs("sim", argc, argv, kSimOptions, kSimNumOptions, a, &a->model, &a->help);
}


// Check the combination of parsed arguments; return 0 on success, else print why.
static int sim_checkArgs(const simArgs* a) {
  if (!a->model) {
    cli_error("sim: missing MODEL.xml (see ostrich sim --help)");
    return 1;
  }
  if (strcmp(a->engine, "ostrich") && strcmp(a->engine, "mujoco")) {
    cli_error("--engine: '%s' is not ostrich or mujoco", a->engine);
    return 1;
  }
  if (a->duration > 0 && a->steps >= 0) {
    cli_error("give either --duration or --steps, not both");
    return 1;
  }
  if (a->geometry && strcmp(a->geometry, "mujoco") && strcmp(a->geometry, "native")) {
    cli_error("--geometry: '%s' is not mujoco or native", a->geometry);
    return 1;
  }
  return a->csv && cli_checkOutput("--csv", a->csv);
}


//---------------------------------- sim: setup ----------------------------------------------------

typedef struct simRun_ {          // one simulation: inputs, state and results
  // setup
  mjModel* m;                     // model
  mjData*  d;                     // data
  int      ostrich;               // 1: ost_step, 0: mj_step
  double   h;                     // step size (s)
  long     nstep;                 // steps requested
  mjtNum*  ctrl;                  // controls set before every step (nu); NULL: none
  FILE*    csv;                   // trajectory output (its temporary file); NULL: none
  char     csv_tmp[CLI_PATH_SZ];  // name of that temporary file

  // results
  long     done;                  // steps completed
  double   wall;                  // seconds spent in the step calls
  int      nan;                   // a non-finite qpos/qvel was seen, or MuJoCo reset one
  double   max_penetration;       // max of ost_maxPenetration over steps (m)
  double   sum_residual;          // sum over steps of the solver residual
  double   sum_iter;              // sum over steps of the solver iterations
} simRun;


// Configure the engine, the step size and the step count; return 0 on success.
static int sim_setup(const simArgs* a, simRun* r) {
  r->ostrich = !strcmp(a->engine, "ostrich");
  if (r->ostrich) {
    if (cli_setupOstrich(r->m, r->d, a->h, a->newton, a->pcr, a->geometry, &r->h)) {
      return 1;
    }
  } else {
    r->h = a->h > 0 ? a->h : r->m->opt.timestep;
  }
  cli_resetStart(r->m, r->d, a->key);
  if (a->perturb > 0) {
    // uniform in [-SIM_PERTURB, SIM_PERTURB] from a 64-bit LCG (Knuth's MMIX constants), so a
    // seed gives the same start on every platform
    unsigned long long x = (unsigned long long)a->perturb;
    for (int j = 0; j < r->m->nv; j++) {
      x = x * 6364136223846793005ULL + 1442695040888963407ULL;
      r->d->qvel[j] += SIM_PERTURB * (2 * ((double)(x >> 11) / 9007199254740992.0) - 1);
    }
  }

  // keep the model consistent with the step size (stock stages read opt.timestep)
  r->m->opt.timestep = r->h;
  double duration = a->duration > 0 ? a->duration : SIM_DEFAULT_DURATION;
  r->nstep = a->steps >= 0 ? a->steps : lround(duration / r->h);

  // controls
  if (a->ctrl) {
    int nu = r->m->nu;
    r->ctrl = (mjtNum*)malloc(sizeof(mjtNum) * (nu > 0 ? nu : 1));
    if (!r->ctrl || cli_parseList("--ctrl", a->ctrl, r->ctrl, nu)) {
      return 1;
    }
  }

  // trajectory file, renamed over --csv by sim_free
  return a->csv && !(r->csv = cli_openOutput(a->csv, r->csv_tmp, sizeof(r->csv_tmp)));
}


//---------------------------------- sim: stepping ------------------------------------------------

// Write the CSV header.
static void sim_writeHeader(const simRun* r) {
  fprintf(r->csv, "time");
  for (int i = 0; i < r->m->nq; i++) {
    fprintf(r->csv, ",qpos_%d", i);
  }
  for (int i = 0; i < r->m->nv; i++) {
    fprintf(r->csv, ",qvel_%d", i);
  }
  for (int i = 0; i < r->m->na; i++) {
    fprintf(r->csv, ",act_%d", i);
  }
  fputc('\n', r->csv);
}


// Write the current state as one CSV row.
static void sim_writeRow(const simRun* r) {
  fprintf(r->csv, "%.10g", r->d->time);
  for (int i = 0; i < r->m->nq; i++) {
    fprintf(r->csv, ",%.10g", r->d->qpos[i]);
  }
  for (int i = 0; i < r->m->nv; i++) {
    fprintf(r->csv, ",%.10g", r->d->qvel[i]);
  }
  for (int i = 0; i < r->m->na; i++) {
    fprintf(r->csv, ",%.10g", r->d->act[i]);
  }
  fputc('\n', r->csv);
}


// Accumulate the solver statistics of the last step.
static void sim_accumulate(simRun* r) {
  const mjData* d = r->d;
  if (r->ostrich) {
    const ostStats* s = ost_stats(d);
    r->sum_residual += s ? s->residual : 0;
    r->sum_iter += s ? s->newton_iter : 0;
  } else {
    // the solver stores statistics of its first mjNSOLVER iterations only
    int last = (d->solver_iter < mjNSOLVER ? d->solver_iter : mjNSOLVER) - 1;
    r->sum_residual += last >= 0 ? d->solver[last].gradient : 0;
    r->sum_iter += d->solver_iter;
  }
  // Ostrich: its own contacts at q+ (native: including a terrain mesh, which MuJoCo collides as
  // its convex hull); MuJoCo: d->contact, with Ostrich's generators for its own pairs
  const ostStats* st = r->ostrich ? ost_stats(d) : NULL;
  double p = st ? st->max_penetration : ost_maxPenetration(r->m, d);
  if (p > r->max_penetration) {
    r->max_penetration = p;
  }
}


// Take step k (0-based) and time it; return 0 on success, else print why.
static int sim_stepOnce(simRun* r, long k) {
  if (r->ctrl) {
    mju_copy(r->d->ctrl, r->ctrl, r->m->nu);
  }
  double start = cli_now();
  int status = OST_OK;
  if (r->ostrich) {
    status = ost_step(r->m, r->d);
  } else {
    mj_step(r->m, r->d);
  }
  r->wall += cli_now() - start;

  if (status != OST_OK && !OST_IS_WARNING(status)) {
    cli_error("step %ld failed: %s", k + 1, ost_lastError(r->d));
    return 1;
  }
  if (cli_mujocoError()) {
    cli_error("step %ld failed: mujoco error: %s", k + 1, cli_mujocoError());
    return 1;
  }
  return 0;
}


// Write the CSV row of the state after step k (0-based) and check it; return 1 to stop at a
// non-finite state (a state that MuJoCo reset is not written), else 0.
static int sim_record(simRun* r, long k) {
  int bad = cli_hasNan(r->m, r->d);
  if (r->csv && bad != 2) {
    sim_writeRow(r);
  }
  if (!bad) {
    return 0;
  }
  r->nan = 1;
  if (bad == 1) {
    cli_error("step %ld: %s step left a non-finite qpos or qvel", k + 1,
              r->ostrich ? "Ostrich's" : "MuJoCo's");
  } else if (r->ostrich) {
    cli_error("step %ld: Ostrich's step diverged (a MuJoCo stage it calls found a bad "
              "qpos/qvel/qacc and reset the state)", k + 1);
  } else {
    cli_error("step %ld: MuJoCo's step diverged (mj_step found a bad qpos/qvel/qacc and reset "
              "the state)", k + 1);
  }
  return 1;
}


// Print a progress line every second on runs expected to take over 2 s; last: time of the last.
static void sim_progress(const simRun* r, double start, double* last) {
  double now = cli_now();
  double expected = (now - start) * (double)r->nstep / (double)r->done;
  if (now - *last >= 1.0 && expected > 2.0) {
    fprintf(stderr, "ostrich: step %ld/%ld\n", r->done, r->nstep);
    *last = now;
  }
}


// Run the stepping loop; return CLI_OK or CLI_FAIL.
static int sim_loop(simRun* r) {
  int progress = cli_progress();
  double start = cli_now(), last = start;

  if (r->csv) {
    sim_writeHeader(r);
    sim_writeRow(r);
  }
  // the start state's own penetration counts: a model that starts inside its floor says so
  mj_forward(r->m, r->d);
  r->max_penetration = ost_maxPenetration(r->m, r->d);
  for (long k = 0; k < r->nstep; k++) {
    if (sim_stepOnce(r, k)) {
      return CLI_FAIL;
    }
    r->done++;
    sim_accumulate(r);
    if (sim_record(r, k)) {
      return CLI_FAIL;
    }
    if (progress) {
      sim_progress(r, start, &last);
    }
  }
  return CLI_OK;
}


//---------------------------------- sim: report ---------------------------------------------------

// Print the one-line JSON summary on stdout.
static void sim_report(const simArgs* a, const simRun* r) {
  double n = r->done > 0 ? (double)r->done : 1.0;
  printf("{\"engine\":");
  cli_jsonString(stdout, a->engine);
  printf(",\"model\":");
  cli_jsonString(stdout, a->model);
  printf(",\"h\":");
  cli_jsonNumber(stdout, r->h);
  printf(",\"steps\":%ld,\"wall_s\":%.6f,\"nan\":%s,\"max_penetration\":", r->done, r->wall,
         r->nan ? "true" : "false");
  cli_jsonNumber(stdout, r->max_penetration);
  printf(",\"mean_residual\":");
  cli_jsonNumber(stdout, r->sum_residual / n);
  printf(",\"mean_newton_iter\":");
  cli_jsonNumber(stdout, r->sum_iter / n);
  // Ostrich's counts of steps not solved to tolerance and of bounded depenetration
  const ostTotals* t = r->ostrich ? ost_totals(r->d) : NULL;
  if (t) {
    printf(",\"unconverged_steps\":%ld,\"worst_residual\":", t->unconverged);
    cli_jsonNumber(stdout, t->worst_residual);
    printf(",\"depenetrated_steps\":%ld,\"worst_initial_violation\":", t->depenetrated);
    cli_jsonNumber(stdout, t->worst_initial_violation);
    printf(",\"cold_retries\":%ld,\"geometric_retries\":%ld", t->retries, t->geo_retries);
  } else {
    printf(",\"unconverged_steps\":null,\"worst_residual\":null,\"depenetrated_steps\":null,"
           "\"worst_initial_violation\":null,\"cold_retries\":null,\"geometric_retries\":null");
  }
  if (a->key == CLI_KEY_NONE) {
    printf(",\"key\":null");
  } else {
    printf(",\"key\":%ld", a->key);
  }
  printf(",\"perturb\":%ld", a->perturb);
  printf(",\"final_qpos\":[");
  for (int i = 0; i < r->m->nq; i++) {
    if (i) {
      putchar(',');
    }
    cli_jsonNumber(stdout, r->d->qpos[i]);
  }
  printf("]}\n");
  fflush(stdout);
}


// Close the CSV file (kept: rename it over csv_path; else remove it) and free the run; return
// CLI_FAIL if the CSV could not be written.
static int sim_free(simRun* r, const char* csv_path, int keep) {
  int status = CLI_OK;
  if (r->csv && keep) {
    status = cli_commitOutput(r->csv, r->csv_tmp, csv_path) ? CLI_FAIL : CLI_OK;
  } else if (r->csv) {
    cli_discardOutput(r->csv, r->csv_tmp);
  }
  if (r->d) {
    if (r->ostrich) {
      ost_deleteData(r->d);
    } else {
      mj_deleteData(r->d);
    }
  }
  if (r->m) {
    mj_deleteModel(r->m);
  }
  free(r->ctrl);
  return status;
}


//---------------------------------- sim -----------------------------------------------------------

// `ostrich sim MODEL.xml [options]`
int sim_main(int argc, char** argv) {
  simArgs a;
  if (sim_parseArgs(argc, argv, &a)) {
    return CLI_USAGE;
  }
  if (a.help) {
    sim_usage(stdout);
    return CLI_OK;
  }
  if (sim_checkArgs(&a)) {
    return CLI_USAGE;
  }

  // load, configure, step, report
  simRun r = {0};
  int status = CLI_USAGE;
  if (!cli_loadModel(a.model, &r.m, &r.d) && !cli_checkKey(r.m, a.key) && !sim_setup(&a, &r)) {
    status = sim_loop(&r);
    sim_report(&a, &r);
  }
  // the CSV of a failed simulation covers the steps taken, and is kept
  int freed = sim_free(&r, a.csv, status != CLI_USAGE);
  return status != CLI_OK ? status : freed;
}


//---------------------------------- check ---------------------------------------------------------

typedef struct checkArgs_ {       // arguments of `ostrich check`
  const char* model;              // MJCF path
  long        states;             // random configurations (default 100)
  long        seed;               // random seed (default 1)
  int         help;               // --help was given
} checkArgs;

static const cliOption kCheckOptions[] = {
  {"--states", CLI_ARG_COUNT, offsetof(checkArgs, states), "N",
   "random joint configurations, besides every keyframe (default 100)"},
  {"--seed", CLI_ARG_COUNT, offsetof(checkArgs, seed), "S", "random seed (default 1)"},
};

static const int kCheckNumOptions = (int)(sizeof(kCheckOptions) / sizeof(kCheckOptions[0]));


// Print the usage of `ostrich check`.
static void check_usage(FILE* f) {
  fprintf(f,
    "usage: ostrich check MODEL.xml [options]\n"
    "\n"
    "First the acceptance test of `ostrich sim MODEL.xml` (the model's features, its\n"
    "<custom> ostrich/* options and its geometry provider): a model that sim refuses is\n"
    "refused here with the same message, which names every unsupported feature and the\n"
    "elements that use it. Then compare Ostrich's native geometry (kinematics, mass matrix,\n"
    "bias forces, Jacobians, contacts) with MuJoCo's at every keyframe and at N random\n"
    "configurations (keyframes are only configurations to compare at here: check steps\n"
    "nothing, so it has no start state and no --key).\n"
    "\n"
    "Prints one JSON line: model, accepted (sim's verdict), native (whether the native\n"
    "provider can represent the model; null if not accepted), refusal (the message, or\n"
    "null), then states and the largest error of each quantity, and ok.\n"
    "Exit status: 0 ok; 1 an error over tolerance (1e-10 relative for kinematics and\n"
    "dynamics, 1e-9 for analytic contact pairs, 1e-6 for MPR pairs and height fields); 2 bad\n"
    "usage, a model that sim refuses, or one the native provider cannot represent.\n"
    "Progress lines (ostrich: check: ...) go to stderr before and after the comparison,\n"
    "unless OSTRICH_QUIET=1.\n"
    "\n"
    "options:\n");
  cli_printOptions(f, kCheckOptions, kCheckNumOptions);
  cli_printHelpOption(f);
}


// Print the JSON line of a refused model: accepted 0 (sim refuses it) or 1 (native cannot).
static void check_refused(const char* model, int accepted, const char* refusal) {
  printf("{\"model\": ");
  cli_jsonString(stdout, model);
  printf(", \"accepted\": %s, \"native\": %s, \"refusal\": ", accepted ? "true" : "false",
         accepted ? "false" : "null");
  cli_jsonString(stdout, refusal);
  printf(", \"ok\": false}\n");
  fflush(stdout);
}


// `ostrich check MODEL.xml [--states N] [--seed S]`
int check_main(int argc, char** argv) {
  checkArgs a = {.states = 100, .seed = 1};
  if (cli_parseArgs("check", argc, argv, kCheckOptions, kCheckNumOptions, &a, &a.model,
                    &a.help)) {
    return CLI_USAGE;
  }
  if (a.help) {
    check_usage(stdout);
    return CLI_OK;
  }
  if (!a.model) {
    cli_error("check: missing MODEL.xml (see ostrich check --help)");
    return CLI_USAGE;
  }
  simRun r = {0};
  if (cli_loadModel(a.model, &r.m, &r.d)) {
    sim_free(&r, NULL, 0);
    return CLI_USAGE;
  }

  // the acceptance test of `sim MODEL.xml` (cli_setupOstrich), with its message
  char err[CLI_MSG_SZ] = "";
  ostOptions opt;
  if (cli_ostrichOptions(r.m, 0, -1, -1, NULL, &opt, err, sizeof(err))) {
    cli_error("%s", err);
    check_refused(a.model, 0, err);
    sim_free(&r, NULL, 0);
    return CLI_USAGE;
  }
  // one library call compares every state: a line before it and one after it
  ostNativeReport rep;
  double start = cli_now();
  if (cli_progress()) {
    fprintf(stderr, "ostrich: check: %s accepted; comparing native geometry with MuJoCo's at "
            "%d keyframes and %ld random states ...\n", a.model, r.m->nkey, a.states);
  }
  int status = ost_compareNative(r.m, (int)a.states, (unsigned)a.seed, &rep, err, sizeof(err));
  if (cli_progress()) {
    fprintf(stderr, "ostrich: check: done in %.1f s\n", cli_now() - start);
  }
  if (status != OST_OK) {
    cli_error("%s", err);
    check_refused(a.model, 1, err);
    sim_free(&r, NULL, 0);
    return CLI_USAGE;
  }
  printf("{\"model\": ");
  cli_jsonString(stdout, a.model);
  printf(", \"accepted\": true, \"native\": true, \"refusal\": null, \"states\": %d, "
         "\"contacts\": %d, \"body_pos\": %.3g, "
         "\"body_rot\": %.3g, \"mass_matrix\": %.3g, \"bias\": %.3g, \"passive\": %.3g, "
         "\"actuator\": %.3g, \"jacobian\": %.3g, \"contact_count\": %d, "
         "\"contact_dist\": %.3g, \"contact_normal\": %.3g, \"contact_pos\": %.3g, "
         "\"mpr_dist\": %.3g, \"mpr_normal\": %.3g, \"mpr_pos\": %.3g, \"ok\": %s}\n",
         rep.nstate, rep.ncontact, rep.body_pos, rep.body_rot, rep.mass_matrix,
         rep.bias, rep.passive, rep.actuator, rep.jacobian, rep.contact_count,
         rep.contact_analytic[0], rep.contact_analytic[1], rep.contact_analytic[2],
         rep.contact_mpr[0], rep.contact_mpr[1], rep.contact_mpr[2], rep.ok ? "true" : "false");
  sim_free(&r, NULL, 0);
  return rep.ok ? CLI_OK : CLI_FAIL;
}


//---------------------------------- Dispatch ------------------------------------------------------

typedef struct cliCommand_ {      // one subcommand
  const char* name;               // word after `ostrich`
  const char* summary;            // one line for the top-level usage
  int (*run)(int argc, char** argv);  // entry point; argv excludes the subcommand name
} cliCommand;

static const cliCommand kCommands[] = {
  {"sim", "simulate a model with Ostrich or stock MuJoCo; print a JSON summary", sim_main},
  {"check", "compare native geometry with MuJoCo at random configurations", check_main},
  {"synth", "control synthesis on the wheeled robot: adjoint or finite differences", synth_main},
  {"gradcheck", "compare the adjoint gradient of a rollout with finite differences",
   gradcheck_main},
  {"compare", "A/B against stock MuJoCo: timestep sweeps, replay, identify, hard cases",
   compare_main},
  {"bench", "benchmarks: `bench scale`, world scaling of the batch (cpu, cuda); `bench models`,\n"
   "             ost_step against mj_step per model and against nv; `bench adjoint`, the\n"
   "             backward pass against the step and mjd_transitionFD", bench_main},
};

static const int kNumCommands = (int)(sizeof(kCommands) / sizeof(kCommands[0]));


// Print the top-level usage.
static void cli_usage(FILE* f) {
  fprintf(f,
    "usage: ostrich COMMAND [arguments]\n"
    "       ostrich COMMAND --help\n"
    "\n"
    "Ostrich: implicit hard-contact time stepping for MuJoCo %s models.\n"
    "\n"
    "commands:\n", mj_versionString());
  for (int i = 0; i < kNumCommands; i++) {
    fprintf(f, "  %-10s %s\n", kCommands[i].name, kCommands[i].summary);
  }
  fprintf(f,
    "\n"
    "one grammar for every command:\n"
    "  MODEL.xml          the model is a positional argument (synth, bench scale and\n"
    "                     compare gen-logs default to their robot scene)\n"
    "  --engine E[,E]     ostrich or mujoco; a comma list where a command runs both\n"
    "  --csv FILE.csv     the one CSV a command writes; --plot FILE.png its figure\n"
    "  --out DIR          a directory that receives several outputs (created if missing)\n"
    "  --repeat N         repetitions of a measurement; --key K the start keyframe\n"
    "Outputs are checked before any work and written to FILE.tmp<pid>, then renamed, so a\n"
    "killed run leaves the previous file whole. stdout carries one JSON line (null for a\n"
    "non-finite number) or a table; progress goes to stderr unless OSTRICH_QUIET=1. The\n"
    "previous release's spellings still work, with a note on stderr (see CHANGELOG.md).\n"
    "\n"
    "options:\n"
    "  -h, --help  print this help and exit\n");
}


int main(int argc, char** argv) {
  // before anything can reach MuJoCo's default handlers (which wait for Enter and exit)
  mju_user_error = cli_onMujocoError;
  mju_user_warning = cli_onMujocoWarning;

  if (argc < 2) {
    cli_usage(stderr);
    return CLI_USAGE;
  }
  if (!strcmp(argv[1], "--help") || !strcmp(argv[1], "-h")) {
    cli_usage(stdout);
    return CLI_OK;
  }
  for (int i = 0; i < kNumCommands; i++) {
    if (!strcmp(argv[1], kCommands[i].name)) {
      return kCommands[i].run(argc - 2, argv + 2);
    }
  }
  cli_error("unknown command '%s' (see ostrich --help)", argv[1]);
  return CLI_USAGE;
}
