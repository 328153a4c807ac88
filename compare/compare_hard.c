// compare_hard.c: `ostrich compare hard`, the hard-case suite of the A/B harness.
// Every case of compare_hard_cases.c runs at every step size of --h-grid with each engine:
// Ostrich (ost_step with the timestep overridden to h) and stock MuJoCo 2.2.2 (mj_step with
// opt.timestep = h, everything else as the model says). After every step the driver measures,
// from the state alone and identically for both engines:
//   - status: finished, nan (a non-finite qpos/qvel, or MuJoCo found NaN/Inf/huge values and
//     reset the state), diverged (|qvel| > HARD_VEL_MAX or a free body farther than
//     HARD_POS_MAX from the origin) or failed (ost_step returned an error, or a MuJoCo error);
//     a run stops at the first step that is not fine;
//   - the deepest penetration, from a fresh mj_collision at the state after the step;
//   - the energy gained, max over t of E(t) - E(0), E = kinetic + potential (gravity and
//     springs) by mj_energyPos / mj_energyVel (not for actuated cases);
//   - the case's own metric and aux (the probe).
// Ostrich's runs at h <= the case's h_max are checked against the case's bounds; MuJoCo's are
// measured against the same bounds for comparison only. Table on stderr, CSV, one JSON line.
//
// Invariant: every measurement reads the state only (qpos, qvel, time, and ctrl for the servo
// probe): energy and penetration on a scratch mjData, never from the engine's own solver
// output, so the two engines cannot be measured differently. Exit 0: every
// expected Ostrich run met its bounds; 1: one did not (or the CSV failed); 2: bad usage.
#define _POSIX_C_SOURCE 200809L

#include <errno.h>
#include <math.h>
#include <stddef.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <mujoco/mujoco.h>

#include "compare.h"
#include "compare_hard.h"
#include "ost_cli_util.h"
#include "ostrich.h"

#define HARD_MAX_H     16         // most step sizes in --h-grid
#define HARD_MAX_CASES 32         // most cases in the table (kHardNumCases)
#define HARD_VEL_MAX   1e3        // |qvel| (m/s, rad/s) above which a run has diverged
#define HARD_POS_MAX   100.0      // m: a free body this far from the origin left every scene
#define HARD_DEFAULT_HUMANOID "/usr/share/mujoco/model/humanoid/humanoid.xml"


//---------------------------------- Arguments -----------------------------------------------------

typedef struct hardArgs_ {        // arguments of `ostrich compare hard`
  const char* h_grid;             // comma list of step sizes (s)
  const char* cases;              // comma list of case names; NULL: all
  const char* engine;             // comma list of ostrich, mujoco
  const char* csv;                // CSV path; NULL: none
  double      duration_scale;     // multiplies every case's duration
  const char* models;             // directory of the mjcf_models files
  const char* humanoid;           // path of MuJoCo's humanoid.xml
  int         help;               // --help was given
} hardArgs;

static const cliOption kHardOptions[] = {
  {"--h-grid", CLI_ARG_STRING, offsetof(hardArgs, h_grid), "H1,H2,...",
   "step sizes (s), at most 16 (default 0.001,0.01,0.05,0.1)"},
  {"--cases", CLI_ARG_STRING, offsetof(hardArgs, cases), "NAME,...",
   "cases to run (default all; the names are listed below)"},
  {"--engine", CLI_ARG_STRING, offsetof(hardArgs, engine), "ostrich,mujoco",
   "ostrich and/or mujoco (default ostrich,mujoco)"},
  {"--csv", CLI_ARG_STRING, offsetof(hardArgs, csv), "FILE.csv",
   "write one row per case, h and engine (checked before the runs,\n"
   "written to a temporary name, then renamed)"},
  {"--duration-scale", CLI_ARG_POSITIVE, offsetof(hardArgs, duration_scale), "X",
   "multiply every case's simulated time by X (default 1)"},
  {"--models", CLI_ARG_STRING, offsetof(hardArgs, models), "DIR",
   "directory of the models (default mjcf_models, relative to the\n"
   "working directory)"},
  {"--humanoid", CLI_ARG_STRING, offsetof(hardArgs, humanoid), "FILE",
   "MuJoCo's humanoid (default\n" HARD_DEFAULT_HUMANOID ")"},
};

static const int kHardNumOptions = (int)(sizeof(kHardOptions) / sizeof(kHardOptions[0]));

typedef struct hardPlan_ {        // what to run, from the arguments
  int    nh;                      // step sizes
  double h[HARD_MAX_H];
  int    ncase;                   // selected cases, in table order
  int    cases[HARD_MAX_CASES];   // indices into kHardCases
  int    nengine;                 // engines, in the order given
  int    ostrich[2];              // 1: Ostrich, 0: MuJoCo
} hardPlan;


// Print the usage of `ostrich compare hard`.
static void hard_usage(FILE* f) {
  fprintf(f,
    "usage: ostrich compare hard [options]\n"
    "\n"
    "Run the hard cases at every step size with Ostrich (ost_step) and stock MuJoCo (mj_step,\n"
    "opt.timestep = h). Per case, h and engine: status (finished | nan | diverged | failed),\n"
    "deepest penetration, energy gained (max E(t) - E(0), unactuated cases), the case's metric\n"
    "and aux, wall time. Ostrich is checked against each case's bounds; MuJoCo is measured\n"
    "against the same bounds for comparison only. A table on stderr, one JSON line on stdout.\n"
    "\n"
    "options:\n");
  cli_printOptions(f, kHardOptions, kHardNumOptions);
  cli_printHelpOption(f);
  fprintf(f, "\ncases:\n");
  for (int i = 0; i < kHardNumCases; i++) {
    fprintf(f, "  %-14s %s\n", kHardCases[i].name, kHardCases[i].summary);
  }
  fprintf(f,
    "\nExit status: 0 every expected Ostrich run met its bounds; 1 one did not, or the CSV\n"
    "could not be written; 2 bad usage, or a model that cannot be loaded or is refused.\n");
}


// Parse the comma list `text` of --h-grid into plan->h; return 0, else print why.
static int hard_parseGrid(const char* text, hardPlan* plan) {
  int n = 1;
  for (const char* c = text; *c; c++) {
    n += (*c == ',');
  }
  if (!*text || n > HARD_MAX_H) {
    cli_error("--h-grid: give 1 to %d step sizes, got '%s'", HARD_MAX_H, text);
    return 1;
  }
  if (cli_parseList("--h-grid", text, plan->h, n)) {
    return 1;
  }
  for (int i = 0; i < n; i++) {
    if (plan->h[i] <= 0) {
      cli_error("--h-grid: %g is not a positive step size", plan->h[i]);
      return 1;
    }
  }
  plan->nh = n;
  return 0;
}


// Next item of a comma list: copy it into item and advance *s; return 0 at the end.
static int hard_nextItem(const char** s, char* item, int item_sz) {
  if (!*s) {
    return 0;
  }
  int len = (int)strcspn(*s, ",");
  snprintf(item, item_sz, "%.*s", len, *s);
  *s = (*s)[len] ? *s + len + 1 : NULL;
  return 1;
}


// Parse --cases (NULL: all) into plan->cases, in table order; return 0, else print why.
static int hard_parseCases(const char* text, hardPlan* plan) {
  int selected[HARD_MAX_CASES] = {0}, ncase = kHardNumCases;
  if (ncase > HARD_MAX_CASES) {
    cli_error("compare hard: %d cases, raise HARD_MAX_CASES (%d)", ncase, HARD_MAX_CASES);
    return 1;
  }
  char item[64];
  const char* s = text;
  while (hard_nextItem(&s, item, sizeof(item))) {
    int found = -1;
    for (int i = 0; i < ncase; i++) {
      if (!strcmp(item, kHardCases[i].name)) {
        found = i;
      }
    }
    if (found < 0) {
      cli_error("--cases: unknown case '%s' (see ostrich compare hard --help)", item);
      return 1;
    }
    selected[found] = 1;
  }
  plan->ncase = 0;
  for (int i = 0; i < ncase; i++) {
    if (!text || selected[i]) {
      plan->cases[plan->ncase++] = i;
    }
  }
  return 0;
}


// Parse --engine into plan->ostrich; return 0, else print why.
static int hard_parseEngines(const char* text, hardPlan* plan) {
  char item[64];
  const char* s = text;
  plan->nengine = 0;
  while (hard_nextItem(&s, item, sizeof(item))) {
    int ostrich = !strcmp(item, "ostrich");
    if ((!ostrich && strcmp(item, "mujoco")) || plan->nengine == 2 ||
        (plan->nengine == 1 && plan->ostrich[0] == ostrich)) {
      cli_error("--engine: '%s' is not one of ostrich, mujoco (each once)", item);
      return 1;
    }
    plan->ostrich[plan->nengine++] = ostrich;
  }
  return 0;
}


//---------------------------------- One run -------------------------------------------------------

typedef enum hardStatus_ {        // how a run ended
  HARD_FINISHED = 0,              // every step taken, state fine
  HARD_NAN,                       // non-finite state, or MuJoCo reset a NaN/Inf/huge one
  HARD_DIVERGED,                  // |qvel| > HARD_VEL_MAX or a free body beyond HARD_POS_MAX
  HARD_FAILED                     // ost_step returned an error, or a MuJoCo error
} hardStatus;

static const char* kHardStatusNames[] = {"finished", "nan", "diverged", "failed"};

enum {                            // checks a run can fail (bits of hardRun.failed)
  HARD_CHECK_STATUS  = 1,
  HARD_CHECK_PEN     = 2,
  HARD_CHECK_ENERGY  = 4,
  HARD_CHECK_METRIC  = 8,
  HARD_CHECK_AUX     = 16,
  HARD_NCHECK        = 5
};

static const char* kHardCheckNames[HARD_NCHECK] = {"status", "penetration", "energy",
                                                   "metric", "aux"};

typedef struct hardRun_ {         // one case at one h with one engine
  int         icase;              // index into kHardCases
  int         ostrich;            // 1: Ostrich, 0: MuJoCo
  double      h;                  // step size (s)
  long        nstep;              // steps requested
  long        steps;              // steps taken
  hardStatus  status;
  double      wall;               // seconds in the step calls
  double      max_penetration;    // m
  double      energy_gain;        // J; NAN for actuated cases
  double      metric;             // case metric (NAN: not measured)
  double      aux;                // case aux (NAN: none)
  int         unconverged;        // Ostrich steps whose Newton solve did not converge
  int         expected;           // 1: Ostrich at h <= h_max, so the bounds are checked
  int         failed;             // HARD_CHECK_* bits against the case's bounds
} hardRun;


// Energy (J) of the state of d, and its deepest penetration (m), computed on scratch s.
static double hard_measure(mjModel* m, const mjData* d, mjData* s, double* penetration) {
  mju_copy(s->qpos, d->qpos, m->nq);
  mju_copy(s->qvel, d->qvel, m->nv);
  s->time = d->time;

  // the position stages that energy and collision read: poses, com inertias, tendons, qM
  mj_kinematics(m, s);
  mj_comPos(m, s);
  mj_tendon(m, s);
  mj_crb(m, s);
  mj_collision(m, s);
  *penetration = ost_maxPenetration(m, s);

  // potential: -sum m g.x_com + springs; kinetic: 1/2 qvel' M qvel. Both return 0 unless
  // mjENBL_ENERGY is set, which is set here only, so the engines step the model as it is.
  int flags = m->opt.enableflags;
  m->opt.enableflags |= mjENBL_ENERGY;
  mj_energyPos(m, s);
  mj_energyVel(m, s);
  m->opt.enableflags = flags;
  return s->energy[0] + s->energy[1];
}


// Print why run r stopped at step `step` (1-based): "ostrich: CASE h=H ENGINE: step N: why".
static void hard_stopped(const hardRun* r, long step, const char* why) {
  cli_error("%s h=%g %s: step %ld: %s", kHardCases[r->icase].name, r->h,
            r->ostrich ? "ostrich" : "mujoco", step, why);
}


// How the state after step r->steps is: HARD_FINISHED if fine; else print why.
static hardStatus hard_stateStatus(const mjModel* m, const mjData* d, const hardRun* r) {
  char why[CLI_MSG_SZ];
  int bad = cli_hasNan(m, d);
  if (bad) {
    hard_stopped(r, r->steps, bad == 1 ? "non-finite qpos or qvel" : r->ostrich ?
                 "Ostrich's step diverged (a MuJoCo stage it calls found a NaN, Inf or huge "
                 "value and reset the state)" :
                 "mj_step found a NaN, Inf or huge value and reset the state");
    return HARD_NAN;
  }
  double vmax = 0;
  for (int j = 0; j < m->nv; j++) {
    vmax = fmax(vmax, fabs(d->qvel[j]));
  }
  if (vmax > HARD_VEL_MAX) {
    snprintf(why, sizeof(why), "diverged, |qvel| = %.3g > %g", vmax, HARD_VEL_MAX);
    hard_stopped(r, r->steps, why);
    return HARD_DIVERGED;
  }
  for (int j = 0; j < m->njnt; j++) {
    const mjtNum* x = d->qpos + m->jnt_qposadr[j];
    if (m->jnt_type[j] == mjJNT_FREE && mju_norm3(x) > HARD_POS_MAX) {
      snprintf(why, sizeof(why), "diverged, a free body is %.3g m from the origin",
               mju_norm3(x));
      hard_stopped(r, r->steps, why);
      return HARD_DIVERGED;
    }
  }
  return HARD_FINISHED;
}


// Take one step of r's engine; return HARD_FINISHED, else print why and return HARD_FAILED.
static hardStatus hard_step(const mjModel* m, mjData* d, hardRun* r) {
  char why[CLI_MSG_SZ];
  const char* earlier_error = cli_mujocoError();  // the first error of the process is kept
  double start = cli_now();
  int status = OST_OK;
  if (r->ostrich) {
    status = ost_step(m, d);
  } else {
    mj_step(m, d);
  }
  r->wall += cli_now() - start;
  // a warning (OST_WARN_NOT_CONVERGED) is a step taken; it is counted below as unconverged
  if (status != OST_OK && !OST_IS_WARNING(status)) {
    snprintf(why, sizeof(why), "ost_step failed: %s", ost_lastError(d));
    hard_stopped(r, r->steps + 1, why);
    return HARD_FAILED;
  }
  if (!earlier_error && cli_mujocoError()) {
    snprintf(why, sizeof(why), "mujoco error: %s", cli_mujocoError());
    hard_stopped(r, r->steps + 1, why);
    return HARD_FAILED;
  }
  if (r->ostrich && ost_stats(d) && (ost_stats(d)->status & OST_NOT_CONVERGED)) {
    r->unconverged++;
  }
  return HARD_FINISHED;
}


// Simulate case c on (m, d) with r's engine and step size, measuring on scratch; fill r.
static void hard_simulate(const hardCase* c, mjModel* m, mjData* d, mjData* scratch,
                          double duration, hardRun* r) {
  hardProbe probe = {.duration = duration, .h = r->h, .metric = 0, .aux = NAN};

  // start state: qpos0, or keyframe 0 (a thrown ball, a sliding one)
  mj_resetData(m, d);
  if (m->nkey > 0) {
    mj_resetDataKeyframe(m, d, 0);
  }
  m->opt.timestep = r->h;
  double h_used;
  if (r->ostrich && cli_setupOstrich(m, d, r->h, -1, -1, NULL, &h_used)) {
    return;
  }
  if (c->start && c->start(m, d, &probe)) {
    return;
  }
  double e0 = hard_measure(m, d, scratch, &r->max_penetration);
  if (!c->actuated) {
    r->energy_gain = 0;
  }

  // step, check, measure, until the end or the first step that is not fine
  r->status = HARD_FINISHED;
  while (r->steps < r->nstep && r->status == HARD_FINISHED) {
    if (c->control) {
      c->control(m, d, d->time + r->h);
    }
    r->status = hard_step(m, d, r);
    if (r->status == HARD_FINISHED) {
      r->steps++;
      r->status = hard_stateStatus(m, d, r);
    }
    if (r->status == HARD_FINISHED) {
      double penetration, e = hard_measure(m, d, scratch, &penetration);
      r->max_penetration = fmax(r->max_penetration, penetration);
      if (!c->actuated) {
        r->energy_gain = fmax(r->energy_gain, e - e0);
      }
      c->observe(m, d, &probe);
    }
  }
  r->metric = probe.metric;
  r->aux = probe.aux;
}


// Run case c on model m with r's engine and h for its (scaled) duration; fill r.
static void hard_run(const hardCase* c, mjModel* m, double duration, hardRun* r) {
  long nstep = lround(duration / r->h);
  r->nstep = nstep > 0 ? nstep : 1;
  r->status = HARD_FAILED;
  r->max_penetration = r->metric = r->aux = r->energy_gain = NAN;
  mjData* d = mj_makeData(m);
  mjData* scratch = mj_makeData(m);
  if (d && scratch) {
    hard_simulate(c, m, d, scratch, duration, r);
  } else {
    cli_error("%s: cannot allocate mjData", c->name);
  }
  if (d && r->ostrich) {
    ost_deleteData(d);
  } else if (d) {
    mj_deleteData(d);
  }
  if (scratch) {
    mj_deleteData(scratch);
  }
}


// Check r against its case's bounds: set r->failed (HARD_CHECK_* bits) and r->expected.
static void hard_check(const hardCase* c, hardRun* r) {
  const hardBounds* b = &c->expect;
  r->expected = r->ostrich && r->h <= b->h_max * (1 + 1e-12);
  r->failed = 0;
  if (r->status != HARD_FINISHED) {
    r->failed |= HARD_CHECK_STATUS;
  }
  if (!(r->max_penetration <= b->penetration)) {
    r->failed |= HARD_CHECK_PEN;
  }
  if (!c->actuated && !(r->energy_gain <= b->energy_gain)) {
    r->failed |= HARD_CHECK_ENERGY;
  }
  if (!(r->metric <= b->metric)) {
    r->failed |= HARD_CHECK_METRIC;
  }
  if (c->aux_name && !(r->aux >= b->aux_min && r->aux <= b->aux_max)) {
    r->failed |= HARD_CHECK_AUX;
  }
}


//---------------------------------- Report --------------------------------------------------------

// Write the names of the failed checks of r, comma-separated, into buf ("" if none).
static void hard_failedNames(const hardRun* r, char* buf, int sz) {
  buf[0] = 0;
  for (int k = 0; k < HARD_NCHECK; k++) {
    if (r->failed & (1 << k)) {
      size_t len = strlen(buf);
      snprintf(buf + len, sz - len, "%s%s", len ? "," : "", kHardCheckNames[k]);
    }
  }
}


// Format x with %.3g into buf; "-" if not finite.
static const char* hard_num(double x, char* buf, int sz) {
  if (isfinite(x)) {
    snprintf(buf, sz, "%.3g", x);
  } else {
    snprintf(buf, sz, "-");
  }
  return buf;
}


// Print a case's header in the table: scene, metric names, Ostrich's bounds.
static void hard_printCaseHeader(FILE* f, const hardCase* c) {
  const hardBounds* b = &c->expect;
  fprintf(f, "\n%s: %s\n  Ostrich expected", c->name, c->summary);
  if (isfinite(b->h_max)) {
    fprintf(f, " for h <= %g", b->h_max);
  }
  fprintf(f, ": finished");
  if (isfinite(b->penetration)) {
    fprintf(f, ", penetration <= %g m", b->penetration);
  }
  if (!c->actuated) {
    fprintf(f, ", energy gain <= %g J", b->energy_gain);
  }
  if (isfinite(b->metric)) {
    fprintf(f, ", %s <= %g", c->metric_name, b->metric);
  }
  if (c->aux_name && isfinite(b->aux_min) && isfinite(b->aux_max)) {
    fprintf(f, ", %s in [%g, %g]", c->aux_name, b->aux_min, b->aux_max);
  } else if (c->aux_name && isfinite(b->aux_min)) {
    fprintf(f, ", %s >= %g", c->aux_name, b->aux_min);
  } else if (c->aux_name && isfinite(b->aux_max)) {
    fprintf(f, ", %s <= %g", c->aux_name, b->aux_max);
  }
  fprintf(f, "\n  (%s)\n", c->why);
  fprintf(f, "  %-8s %-7s %-8s %6s %8s %9s %9s %-14s %-14s %6s  %s\n", "h", "engine", "status",
          "steps", "wall_s", "pen_m", "E_gain_J", c->metric_name, c->aux_name ? c->aux_name : "",
          "unconv", "verdict");
}


// Print the table of all runs on stderr.
static void hard_printTable(const hardRun* runs, int nrun) {
  FILE* f = stderr;
  fprintf(f, "\nostrich: compare hard: results (verdict: Ostrich rows checked against the case's "
             "bounds, FAIL sets exit 1;\nMuJoCo rows, in parentheses, against the same bounds "
             "for comparison only)\n");
  for (int i = 0; i < nrun; i++) {
    const hardRun* r = runs + i;
    const hardCase* c = kHardCases + r->icase;
    if (i == 0 || runs[i - 1].icase != r->icase) {
      hard_printCaseHeader(f, c);
    }
    char pen[32], gain[32], metric[32], aux[32], unconv[32], failed[128], verdict[160];
    hard_failedNames(r, failed, sizeof(failed));
    if (r->expected) {
      snprintf(verdict, sizeof(verdict), "%s%s", r->failed ? "FAIL: " : "ok", failed);
    } else {
      snprintf(verdict, sizeof(verdict), "(%s%s)", r->failed ? "fail: " : "ok", failed);
    }
    snprintf(unconv, sizeof(unconv), "%d", r->unconverged);
    fprintf(f, "  %-8g %-7s %-8s %6ld %8.3f %9s %9s %-14s %-14s %6s  %s\n", r->h,
            r->ostrich ? "ostrich" : "mujoco", kHardStatusNames[r->status], r->steps, r->wall,
            hard_num(r->max_penetration, pen, sizeof(pen)),
            hard_num(r->energy_gain, gain, sizeof(gain)),
            hard_num(r->metric, metric, sizeof(metric)),
            c->aux_name ? hard_num(r->aux, aux, sizeof(aux)) : "",
            r->ostrich ? unconv : "-", verdict);
  }
}


// Print a CSV number (%.10g; empty if not finite).
static void hard_csvNumber(FILE* f, double x) {
  if (isfinite(x)) {
    fprintf(f, "%.10g", x);
  }
}


// Write the CSV file; return 0, else print why.
static int hard_writeCsv(const char* path, const hardRun* runs, int nrun) {
  char tmp[CLI_PATH_SZ];
  FILE* f = cli_openOutput(path, tmp, sizeof(tmp));
  if (!f) {
    return 1;
  }
  fprintf(f, "case,engine,h,status,steps,wall_s,max_penetration,energy_gain,metric_name,metric,"
             "aux_name,aux,unconverged,expected,within_bounds,failed_checks\n");
  for (int i = 0; i < nrun; i++) {
    const hardRun* r = runs + i;
    const hardCase* c = kHardCases + r->icase;
    char failed[128];
    hard_failedNames(r, failed, sizeof(failed));
    fprintf(f, "%s,%s,%.10g,%s,%ld,%.6f,", c->name, r->ostrich ? "ostrich" : "mujoco", r->h,
            kHardStatusNames[r->status], r->steps, r->wall);
    hard_csvNumber(f, r->max_penetration);
    fputc(',', f);
    hard_csvNumber(f, r->energy_gain);
    fprintf(f, ",%s,", c->metric_name);
    hard_csvNumber(f, r->metric);
    fprintf(f, ",%s,", c->aux_name ? c->aux_name : "");
    hard_csvNumber(f, r->aux);
    fputc(',', f);
    hard_csvNumber(f, r->ostrich ? r->unconverged : NAN);
    fprintf(f, ",%d,%d,\"%s\"\n", r->expected, !r->failed, failed);
  }
  return cli_commitOutput(f, tmp, path);
}


// Print the one-line JSON summary on stdout.
static void hard_printJson(const hardPlan* plan, const hardRun* runs, int nrun, double wall) {
  int nexpected = 0, nfailed = 0;
  for (int i = 0; i < nrun; i++) {
    nexpected += runs[i].expected;
    nfailed += runs[i].expected && runs[i].failed;
  }
  printf("{\"command\":\"compare hard\",\"h_grid\":[");
  for (int i = 0; i < plan->nh; i++) {
    printf(i ? "," : "");
    cli_jsonNumber(stdout, plan->h[i]);
  }
  printf("],\"runs\":%d,\"ostrich_expected\":%d,\"ostrich_failed\":%d,\"ok\":%s,\"wall_s\":",
         nrun, nexpected, nfailed, nfailed ? "false" : "true");
  cli_jsonNumber(stdout, wall);
  printf(",\"failed\":[");
  for (int i = 0, first = 1; i < nrun; i++) {
    if (runs[i].expected && runs[i].failed) {
      printf("%s\"%s@%g\"", first ? "" : ",", kHardCases[runs[i].icase].name, runs[i].h);
      first = 0;
    }
  }
  printf("],\"results\":[");
  for (int i = 0; i < nrun; i++) {
    const hardRun* r = runs + i;
    const hardCase* c = kHardCases + r->icase;
    printf("%s{\"case\":", i ? "," : "");
    cli_jsonString(stdout, c->name);
    printf(",\"engine\":\"%s\",\"h\":", r->ostrich ? "ostrich" : "mujoco");
    cli_jsonNumber(stdout, r->h);
    printf(",\"status\":\"%s\",\"steps\":%ld,\"wall_s\":", kHardStatusNames[r->status], r->steps);
    cli_jsonNumber(stdout, r->wall);
    printf(",\"max_penetration\":");
    cli_jsonNumber(stdout, r->max_penetration);
    printf(",\"energy_gain\":");
    cli_jsonNumber(stdout, r->energy_gain);
    printf(",\"metric_name\":\"%s\",\"metric\":", c->metric_name);
    cli_jsonNumber(stdout, r->metric);
    printf(",\"aux_name\":");
    if (c->aux_name) {
      cli_jsonString(stdout, c->aux_name);
    } else {
      printf("null");
    }
    printf(",\"aux\":");
    cli_jsonNumber(stdout, r->aux);
    printf(",\"unconverged\":");
    cli_jsonNumber(stdout, r->ostrich ? r->unconverged : NAN);
    printf(",\"expected\":%s,\"within_bounds\":%s}", r->expected ? "true" : "false",
           r->failed ? "false" : "true");
  }
  printf("]}\n");
  fflush(stdout);
}


//---------------------------------- compare hard --------------------------------------------------

// Load the model of case c and check that Ostrich accepts it; return 0, else print why.
static int hard_loadCase(const hardCase* c, const hardArgs* a, mjModel** m) {
  char path[4096];
  mjData* d = NULL;
  char err[CLI_MSG_SZ] = "";
  if (c->model) {
    snprintf(path, sizeof(path), "%s/%s", a->models, c->model);
  } else {
    snprintf(path, sizeof(path), "%s", a->humanoid);
  }
  int failed = cli_loadModel(path, m, &d);
  if (d) {
    mj_deleteData(d);
  }
  ostOptions opt;
  if (!failed && cli_ostrichOptions(*m, 0, -1, -1, NULL, &opt, err, sizeof(err))) {
    cli_error("%s: %s", path, err);  // the acceptance test and message of `ostrich sim`
    failed = 1;
  }
  return failed;
}


// `ostrich compare hard [options]`
int compare_hard_main(int argc, char** argv) {
  hardArgs a = {.h_grid = "0.001,0.01,0.05,0.1", .engine = "ostrich,mujoco",
                .duration_scale = 1, .models = "mjcf_models", .humanoid = HARD_DEFAULT_HUMANOID};
  hardPlan plan;
  if (cli_parseArgs("compare hard", argc, argv, kHardOptions, kHardNumOptions, &a, NULL,
                    &a.help)) {
    return CLI_USAGE;
  }
  if (a.help) {
    hard_usage(stdout);
    return CLI_OK;
  }
  if (hard_parseGrid(a.h_grid, &plan) || hard_parseCases(a.cases, &plan) ||
      hard_parseEngines(a.engine, &plan) || (a.csv && cli_checkOutput("--csv", a.csv))) {
    return CLI_USAGE;
  }

  // load every model first, so that a missing one is a usage error before any run
  mjModel* models[HARD_MAX_CASES] = {NULL};
  int status = CLI_OK;
  for (int i = 0; i < plan.ncase && status == CLI_OK; i++) {
    if (hard_loadCase(kHardCases + plan.cases[i], &a, models + i)) {
      status = CLI_USAGE;
    }
  }
  int nrun = plan.ncase * plan.nh * plan.nengine;
  hardRun* runs = status == CLI_OK ? (hardRun*)calloc(nrun, sizeof(hardRun)) : NULL;
  if (status == CLI_OK && !runs) {
    cli_error("compare hard: out of memory");
    status = CLI_FAIL;
  }

  // run: case, then h, then engine
  double start = cli_now();
  for (int k = 0; status == CLI_OK && k < nrun; k++) {
    int ic = k / (plan.nh * plan.nengine), ih = (k / plan.nengine) % plan.nh;
    hardRun* r = runs + k;
    const hardCase* c = kHardCases + plan.cases[ic];
    *r = (hardRun){.icase = plan.cases[ic], .ostrich = plan.ostrich[k % plan.nengine],
                   .h = plan.h[ih]};
    hard_run(c, models[ic], c->duration * a.duration_scale, r);
    hard_check(c, r);
    if (cli_progress()) {
      fprintf(stderr, "ostrich: [%d/%d] %s h=%g %s: %s, %ld/%ld steps, %.2f s%s\n", k + 1, nrun,
              c->name, r->h, r->ostrich ? "ostrich" : "mujoco", kHardStatusNames[r->status],
              r->steps, r->nstep, r->wall, r->expected && r->failed ? " (FAIL)" : "");
    }
  }

  // report
  if (status == CLI_OK) {
    double wall = cli_now() - start;
    hard_printTable(runs, nrun);
    fprintf(stderr, "\nostrich: compare hard: %d runs in %.1f s\n", nrun, wall);
    hard_printJson(&plan, runs, nrun, wall);
    for (int k = 0; k < nrun; k++) {
      if (runs[k].expected && runs[k].failed) {
        status = CLI_FAIL;
      }
    }
    if (a.csv && hard_writeCsv(a.csv, runs, nrun)) {
      status = CLI_FAIL;
    }
  }
  for (int i = 0; i < plan.ncase; i++) {
    if (models[i]) {
      mj_deleteModel(models[i]);
    }
  }
  free(runs);
  return status;
}
