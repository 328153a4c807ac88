// ost_cli_bench_models.c: `ostrich bench models`, Ostrich's ost_step against stock MuJoCo's
// mj_step on one core (both single-threaded). For each MJCF model on the command line, from the
// start state (qpos0, or --key K) over the same simulated duration: mj_step at h = opt.timestep,
// then ost_step at h and at each --h-scale multiple of h (ost_setOptions' timestep). Each run
// takes one untimed step and resets first, so allocation and model packing are not timed. With
// --scaling, models of N copies of MuJoCo's humanoid are generated on a grid into a temporary
// directory (mkdtemp, removed before returning), stepped by both engines at the same h, and
// log(time per step) is fitted against log(nv) by least squares for each engine. The timing
// loop mirrors MuJoCo's sample/testspeed.cc. This file holds the options, the timed runs and
// the driver; the humanoid copies are made by ost_cli_bench_humanoids.c and the table, fit, CSV
// and plot are written by ost_cli_bench_report.c (ost_cli_bench_models.h joins them).
// Invariant: every figure printed was measured in this run; a refused model, a failed step and
// a run stopped by --max-wall are reported as such, never dropped.
#define _POSIX_C_SOURCE 200809L

#include <math.h>
#include <stddef.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include <mujoco/mujoco.h>

#include "ost_cli_bench_models.h"
#include "ost_cli_util.h"
#include "ostrich.h"

#define MODELS_MAX_SCALES  16     // --h-scale entries
#define MODELS_MAX_COPIES  32     // --scaling entries
#define MODELS_PROGRESS_S  2.0    // seconds between progress lines of one run
#define MODELS_MAX_REPEAT  101    // --repeat at most

typedef struct modelsArgs_ {      // arguments of `ostrich bench models`
  const char* h_scale;            // comma list of step-size factors for Ostrich
  const char* scaling;            // comma list of humanoid copy counts, NULL: none
  const char* humanoid;           // MJCF file copied by --scaling
  const char* csv;                // CSV path or NULL
  const char* plot;               // PNG path or NULL
  double      duration;           // simulated seconds per run
  double      settle;             // untimed simulated seconds before the scaling steps
  double      max_wall;           // wall seconds after which a run stops
  long        scaling_steps;      // timed steps per engine and copy count
  long        repeat;             // timed runs per model, engine and h (the median is kept)
  long        key;                // start keyframe, CLI_KEY_NONE: qpos0
  int         help;
} modelsArgs;

static const cliOption kModelsOptions[] = {
  {"--duration", CLI_ARG_POSITIVE, offsetof(modelsArgs, duration), "SEC",
   "simulated seconds per run, the same for every engine and h (default 1)"},
  {"--h-scale", CLI_ARG_STRING, offsetof(modelsArgs, h_scale), "S1,S2,...",
   "Ostrich also runs at h = S x opt.timestep for each S (default 5,10)"},
  CLI_KEY_OPTION(modelsArgs),
  {"--max-wall", CLI_ARG_POSITIVE, offsetof(modelsArgs, max_wall), "SEC",
   "stop a run after SEC wall seconds, reported as stopped (default 20)"},
  {"--repeat", CLI_ARG_COUNT, offsetof(modelsArgs, repeat), "R",
   "time each model's runs R times from the same start and keep the median\n"
   "wall time (default 1; a stopped run is not repeated; --scaling runs once)"},
  {"--scaling", CLI_ARG_STRING, offsetof(modelsArgs, scaling), "N1,N2,...",
   "also time models of N copies of the humanoid (e.g. 1,2,5,10,22,100)\n"
   "and fit log(us per step) against log(nv) for each engine"},
  {"--scaling-steps", CLI_ARG_COUNT, offsetof(modelsArgs, scaling_steps), "T",
   "timed steps per engine and copy count, at the humanoid's h (default 50)"},
  {"--scaling-settle", CLI_ARG_POSITIVE, offsetof(modelsArgs, settle), "SEC",
   "step the copies SEC simulated seconds untimed first, each engine\n"
   "its own trajectory, so that the timed steps have contacts (default 0:\n"
   "timed from the start, falling; the humanoid lands after about 0.2 s)"},
  {"--humanoid", CLI_ARG_STRING, offsetof(modelsArgs, humanoid), "FILE.xml",
   "model copied by --scaling\n(default /usr/share/mujoco/model/humanoid/humanoid.xml)"},
  {"--csv", CLI_ARG_STRING, offsetof(modelsArgs, csv), "FILE.csv",
   "write every row as CSV (FILE.tmp, then renamed)"},
  {"--plot", CLI_ARG_STRING, offsetof(modelsArgs, plot), "FILE.png",
   "gnuplot: us per step against nv (log-log, --scaling) and each\n"
   "model's us per simulated second, one panel each"},
};

static const int kModelsNumOptions = (int)(sizeof(kModelsOptions) / sizeof(kModelsOptions[0]));


//---------------------------------- Timing --------------------------------------------------------

// a step's status is an error (not OK and not a warning)
static int stepFailed(int status) {
  return status != OST_OK && !OST_IS_WARNING(status);
}


// Run r's engine on (m, d) from the start state for nstep timed steps (or until --max-wall):
// one untimed step and a reset (nsettle = 0), or nsettle untimed steps, then the timed steps.
// Fills steps, wall_s, converged, status and msg.
static void modelsMeasure(mjModel* m, mjData* d, long key, long nsettle, long nstep,
                          const modelsArgs* a, modelsRow* r) {
  double timestep = m->opt.timestep;
  int status = OST_OK;
  const char* mj_error = cli_mujocoError();
  r->steps = 0;
  r->wall_s = 0;
  r->converged = 0;
  r->status = RUN_OK;
  r->msg[0] = 0;
  if (r->ostrich) {
    ostOptions opt;
    ost_defaultOptions(&opt);
    if (ost_readOptions(m, &opt, r->msg, sizeof(r->msg)) != OST_OK) {
      r->status = RUN_REFUSED;
      return;
    }
    opt.timestep = r->h;
    if ((status = ost_setOptions(m, d, &opt)) != OST_OK) {
      snprintf(r->msg, sizeof(r->msg), "options refused (status %d): %s", status,
               ost_lastError(d));
      r->status = RUN_FAILED;
      ost_detach(d);
      return;
    }
  }

  // keep the model consistent with the step size, as `ostrich sim` does (stock stages read
  // opt.timestep); restored below
  m->opt.timestep = r->h;
  cli_resetStart(m, d, key);
  for (long i = 0; r->status == RUN_OK && i < (nsettle > 0 ? nsettle : 1); i++) {
    status = r->ostrich ? ost_step(m, d) : (mj_step(m, d), OST_OK);
    if (status == OST_ERR_MODEL) {
      snprintf(r->msg, sizeof(r->msg), "%s", ost_lastError(d));
      r->status = RUN_REFUSED;
    } else if (stepFailed(status)) {
      snprintf(r->msg, sizeof(r->msg), "untimed step %ld: status %d: %s", i + 1, status,
               ost_lastError(d));
      r->status = RUN_FAILED;
    }
  }

  // timed steps (mj_resetData clears MuJoCo's warning counts), --repeat times from the same
  // start when the runs start from the reset state (each a cold start, so the same work), the
  // median wall time kept; a stopped or failed run ends the repeats
  int nrep = nsettle > 0 ? 1 : (int)a->repeat, done = 0;
  double wall[MODELS_MAX_REPEAT];
  while (done < nrep && r->status == RUN_OK) {
    if (nsettle <= 0) {
      cli_resetStart(m, d, key);
    }
    long steps = 0, converged = 0;
    double t0 = cli_now(), shown = t0, now = t0;
    while (r->status == RUN_OK && steps < nstep) {
      status = r->ostrich ? ost_step(m, d) : (mj_step(m, d), OST_OK);
      if (stepFailed(status)) {
        snprintf(r->msg, sizeof(r->msg), "step %ld (t = %.6g s): status %d: %s", steps + 1,
                 d->time, status, ost_lastError(d));
        r->status = RUN_FAILED;
        break;
      }
      now = cli_now();
      steps++;
      converged += (status == OST_OK);
      if (now - t0 > a->max_wall && steps < nstep) {
        snprintf(r->msg, sizeof(r->msg), "stopped by --max-wall %g s after %ld of %ld steps",
                 a->max_wall, steps, nstep);
        r->status = RUN_STOPPED;
      }
      if (cli_progress() && now - shown > MODELS_PROGRESS_S) {
        fprintf(stderr, "ostrich: bench models: %s, %s h = %g s: %ld of %ld steps, %.0f s\n",
                r->label, r->ostrich ? "ostrich" : "mujoco", r->h, steps, nstep, now - t0);
        shown = now;
      }
    }
    wall[done++] = now - t0;
    r->steps = steps;  // the same every repeat (deterministic) unless one stopped or failed
    r->converged = converged;
  }
  // the median of complete runs, or the run that stopped or failed (none: the untimed step
  // was refused or failed)
  r->wall_s = !done ? 0 : r->status == RUN_OK ? cli_median(wall, done) : wall[done - 1];

  // what MuJoCo reported on the way (a failed mj_step is never silent)
  if (cli_mujocoError() != mj_error && r->status != RUN_FAILED) {
    snprintf(r->msg, sizeof(r->msg), "MuJoCo error: %s", cli_mujocoError());
    r->status = RUN_FAILED;
  }
  int nwarn = d->warning[mjWARN_CONTACTFULL].number + d->warning[mjWARN_CNSTRFULL].number
              + d->warning[mjWARN_BADQPOS].number + d->warning[mjWARN_BADQVEL].number
              + d->warning[mjWARN_BADQACC].number;
  if (nwarn && !r->msg[0]) {
    snprintf(r->msg, sizeof(r->msg), "MuJoCo warnings: %d contact full, %d constraint full, "
             "%d bad qpos/qvel/qacc (state reset)", d->warning[mjWARN_CONTACTFULL].number,
             d->warning[mjWARN_CNSTRFULL].number, d->warning[mjWARN_BADQPOS].number
             + d->warning[mjWARN_BADQVEL].number + d->warning[mjWARN_BADQACC].number);
  }
  m->opt.timestep = timestep;
  ost_detach(d);  // the next run starts without this one's warm start
}


//---------------------------------- Driver --------------------------------------------------------

// the last two parts of a path ("humanoid/humanoid.xml")
static void modelLabel(char* out, int out_sz, const char* path) {
  const char* last = strrchr(path, '/');
  const char* start = path;
  for (const char* c = path; last && c < last; c++) {
    start = *c == '/' ? c + 1 : start;
  }
  snprintf(out, out_sz, "%s", start);
}


// parse a comma list of positive numbers (whole numbers if counts) into v; the count, -1 if bad
static int parseList(const char* s, double* v, int nmax, int counts) {
  int n = 0;
  for (const char* p = s; *p; n++) {
    char item[64], *end;
    int len = (int)strcspn(p, ",");
    snprintf(item, sizeof(item), "%.*s", len, p);
    double x = strtod(item, &end);
    if (n >= nmax || len == 0 || len >= (int)sizeof(item) || *end || !(x > 0) || !isfinite(x)
        || (counts && (x != floor(x) || x > 10000)) || (p[len] == ',' && !p[len + 1])) {
      return -1;
    }
    v[n] = x;
    p += len + (p[len] == ',');
  }
  return n;
}



// steps that cover duration at step size h (at least one)
static long stepsFor(double duration, double h) {
  long n = (long)ceil(duration / h - 1e-9);
  return n > 0 ? n : 1;
}


// start a row of one run
static modelsRow* newRow(modelsRow* r, const char* kind, const char* label, const char* path,
                         int copies, const mjModel* m, int ostrich, double scale) {
  memset(r, 0, sizeof(*r));
  r->kind = kind;
  snprintf(r->label, sizeof(r->label), "%s", label);
  r->path = path;
  r->copies = copies;
  r->nv = m->nv;
  r->ostrich = ostrich;
  r->scale = scale;
  r->h = scale * m->opt.timestep;
  r->ratio_step = r->ratio_sim = NAN;
  return r;
}


// time the N-copy humanoids; rows appended at rows + *nrow; 0 on success
static int runScaling(const modelsArgs* a, const char* src, int nv1, const double* copies,
                      int ncopy, const char* dir, modelsRow* rows, int* nrow) {
  int bad = 0;
  for (int i = 0; i < ncopy; i++) {
    int n = (int)copies[i], njmax;
    char path[4096], label[64];
    mjModel* m;
    mjData* d;
    if (bench_models_makeHumanoids(src, a->humanoid, n, nv1, dir, path, sizeof(path), &m, &d,
                                   &njmax)) {
      bad = 1;
      continue;
    }
    snprintf(label, sizeof(label), "humanoids_%d", n);
    int first = *nrow;
    for (int e = 0; e < 2; e++) {
      modelsRow* r = newRow(rows + (*nrow)++, "scaling", label, "", n, m, e, 1);
      modelsMeasure(m, d, CLI_KEY_NONE, a->settle > 0 ? stepsFor(a->settle, r->h) : 0,
                    a->scaling_steps, a, r);
      bad = bad || r->status == RUN_FAILED;
    }
    bench_models_setRatios(rows, first, *nrow);
    if (njmax < MODELS_NJMAX_COPY * n && !rows[first].msg[0]) {
      snprintf(rows[first].msg, sizeof(rows[first].msg), "njmax %d (< 160 N: MuJoCo's buffer)",
               njmax);
    }
    for (int r = first; r < *nrow; r++) {
      bench_models_printRow(rows + r, r == first);
    }
    fflush(stdout);
    ost_deleteData(d);
    mj_deleteModel(m);
    remove(path);
  }
  return bad;
}


// remove dir and the plot's files (each humanoid file is removed once timed, or once refused)
static void removeDir(const char* dir) {
  char path[4096];
  for (int i = 0; i < MODELS_NSCRATCH; i++) {
    snprintf(path, sizeof(path), "%s/%s", dir, kBenchModelsScratch[i]);
    remove(path);
  }
  rmdir(dir);
}


static void modelsHelp(void) {
  printf("usage: ostrich bench models MODEL.xml ... [options]\n\n"
         "Time Ostrich's ost_step against stock MuJoCo's mj_step on one core (both run\n"
         "single-threaded). Each model is stepped from its start state over the same simulated\n"
         "duration by mj_step at h = opt.timestep and by ost_step at h and at each --h-scale\n"
         "multiple of h (ost_setOptions' timestep; opt.timestep is set to match, as in `sim`).\n"
         "Every run takes one untimed step and resets first, so that allocation and model\n"
         "packing are not timed; controls stay at zero (or the keyframe's).\n\n"
         "Columns: us/step and us/sim_s, wall microseconds per step and per simulated second;\n"
         "ratio/step and ratio/sim_s, Ostrich / MuJoCo at opt.timestep (below 1: faster);\n"
         "converged, the Ostrich steps that returned OST_OK (OST_WARN_NOT_CONVERGED does not\n"
         "count); status: ok, stopped (by --max-wall; the steps taken are timed), refused\n"
         "(Ostrich refuses the model; ost_lastError's message is printed) or failed (a step\n"
         "returned an error; the run stops there and the message is printed).\n\n"
         "--scaling N1,N2,... writes models of N copies of the --humanoid file into a temporary\n"
         "directory (names prefixed hK_, copies on a %g m grid, nconmax 40 N, njmax 160 N or\n"
         "less where MuJoCo's buffer would not fit, keyframes dropped), times --scaling-steps\n"
         "steps of both engines at the model's h and fits the slope of log(us per step)\n"
         "against log(nv) for each engine: a slope difference d means that the ratio\n"
         "ostrich/mujoco grows as nv^d.\n\n"
         "Exit status: 0 on success (refused models and stopped runs included), 2 on bad usage\n"
         "(a model that does not load, an unwritable output directory), 1 if a run failed or\n"
         "an output could not be written. OSTRICH_QUIET=1 silences the progress lines.\n\n"
         "options:\n", MODELS_SPACING);
  cli_printOptions(stdout, kModelsOptions, kModelsNumOptions);
  cli_printHelpOption(stdout);
  printf("\nexample:\n  ostrich bench models /usr/share/mujoco/model/humanoid/humanoid.xml \\\n"
         "    --scaling 1,2,5,10,22,100 --csv models.csv --plot models.png\n");
}


int bench_models_main(int argc, char** argv) {
  modelsArgs a = {"5,10", NULL, "/usr/share/mujoco/model/humanoid/humanoid.xml", NULL, NULL, 1,
                  0, 20, 50, 1, CLI_KEY_NONE, 0};
  const char** path = (const char**)calloc(argc + 1, sizeof(char*));
  int npath = 0;

  // options and model paths, in any order
  if (!path || cli_parseArgsList("bench models", argc, argv, kModelsOptions, kModelsNumOptions,
                                 &a, path, argc, &npath, &a.help)) {
    free(path);
    return CLI_USAGE;
  }
  if (a.help) {
    modelsHelp();
    free(path);
    return CLI_OK;
  }

  // everything that can be checked before measuring
  double scale[MODELS_MAX_SCALES], copies[MODELS_MAX_COPIES];
  int nscale = parseList(a.h_scale, scale, MODELS_MAX_SCALES, 0);
  int ncopy = a.scaling ? parseList(a.scaling, copies, MODELS_MAX_COPIES, 1) : 0;
  int ok = path != NULL;
  if (ok && (nscale < 0 || ncopy < 0 || a.scaling_steps < 1 || a.repeat < 1
             || a.repeat > MODELS_MAX_REPEAT)) {
    cli_error("bench models: %s", nscale < 0 ? "--h-scale must be a list of positive numbers"
              : ncopy < 0 ? "--scaling must be a list of copy counts from 1 to 10000"
              : a.scaling_steps < 1 ? "--scaling-steps must be >= 1"
              : "--repeat must be in [1, 101]");
    ok = 0;
  }
  if (ok && npath == 0 && ncopy == 0) {
    cli_error("bench models: no model and no --scaling (see ostrich bench models --help)");
    ok = 0;
  }
  if (ok && a.plot && (strchr(a.plot, '\'') || system("command -v gnuplot >/dev/null 2>&1"))) {
    cli_error("bench models: --plot needs gnuplot on PATH and a file name without quotes");
    ok = 0;
  }
  ok = ok && (!a.csv || !cli_checkOutput("--csv", a.csv))
       && (!a.plot || !cli_checkOutput("--plot", a.plot));
  char* src = ok && ncopy ? bench_models_readSource(a.humanoid) : NULL;
  mjModel* m1 = NULL;
  mjData* d1 = NULL;
  if (ok && ncopy) {
    ok = !cli_loadModel(a.humanoid, &m1, &d1) && src;
  }
  mjModel** m = (mjModel**)calloc(npath + 1, sizeof(mjModel*));
  mjData** d = (mjData**)calloc(npath + 1, sizeof(mjData*));
  ok = ok && m && d;
  for (int i = 0; ok && i < npath; i++) {
    ok = !cli_loadModel(path[i], m + i, d + i) && !cli_checkKey(m[i], a.key);
  }
  char dir[] = "/tmp/ostrich_bench_models_XXXXXX";
  int have_dir = ok && (ncopy || a.plot) && mkdtemp(dir);
  if (ok && (ncopy || a.plot) && !have_dir) {
    cli_error("bench models: cannot make a temporary directory");
    ok = 0;
  }
  int nrow_max = npath * (2 + nscale) + 2 * ncopy;
  modelsRow* rows = ok ? (modelsRow*)calloc(nrow_max + 1, sizeof(modelsRow)) : NULL;
  int status = ok && rows ? CLI_OK : ok ? CLI_FAIL : CLI_USAGE, nrow = 0;

  // the machine's load at the start (the runs share it)
  char load[64] = "?";
  FILE* f = status == CLI_OK ? fopen("/proc/loadavg", "r") : NULL;
  if (f && fscanf(f, "%63s", load) != 1) {
    snprintf(load, sizeof(load), "?");
  }
  if (f) {
    fclose(f);
  }
  if (status == CLI_OK) {
    printf("ostrich bench models: one thread; %ld CPUs online, load average %s at the start\n\n",
           sysconf(_SC_NPROCESSORS_ONLN), load);
  }

  // the models: MuJoCo at opt.timestep, Ostrich at h and each multiple
  if (status == CLI_OK && npath) {
    bench_models_printHeader("models: the same simulated duration per run");
  }
  for (int i = 0; status != CLI_USAGE && rows && i < npath; i++) {
    char label[128];
    modelLabel(label, sizeof(label), path[i]);
    int first = nrow;
    for (int s = -1; s <= nscale; s++) {
      modelsRow* r = newRow(rows + nrow++, "model", label, path[i], 0, m[i], s >= 0,
                            s > 0 ? scale[s - 1] : 1);
      modelsMeasure(m[i], d[i], a.key, 0, stepsFor(a.duration, r->h), &a, r);
      status = r->status == RUN_FAILED ? CLI_FAIL : status;
      if (r->status == RUN_REFUSED) {
        break;  // the other step sizes are refused alike
      }
    }
    bench_models_setRatios(rows, first, nrow);
    for (int r = first; r < nrow; r++) {
      bench_models_printRow(rows + r, r == first);
    }
    fflush(stdout);
  }
  if (npath && rows) {
    bench_models_printNotes(rows, nrow);
  }

  // the humanoid copies, and the fit of each engine
  int nmodelrow = nrow, npoint[2] = {0, 0};
  double slope[2] = {NAN, NAN};
  if (status != CLI_USAGE && rows && ncopy) {
    bench_models_printHeader("\nscaling: copies of the humanoid, both engines at the same h");
    if (runScaling(&a, src, m1->nv, copies, ncopy, dir, rows, &nrow)) {
      status = CLI_FAIL;
    }
    bench_models_printNotes(rows + nmodelrow, nrow - nmodelrow);
    bench_models_printFit(rows, nrow, slope, npoint);
  }

  // outputs
  if (status != CLI_USAGE && rows && a.csv
      && bench_models_writeCsv(a.csv, rows, nrow, slope, npoint, ncopy)) {
    cli_error("bench models: cannot write %s", a.csv);
    status = CLI_FAIL;
  }
  if (status != CLI_USAGE && rows && a.plot
      && bench_models_writePlot(a.plot, dir, rows, nrow, scale, nscale)) {
    cli_error("bench models: gnuplot could not draw %s", a.plot);
    status = CLI_FAIL;
  }
  if (have_dir) {
    removeDir(dir);
  }
  for (int i = 0; m && d && i < npath; i++) {
    ost_deleteData(d[i]);
    mj_deleteModel(m[i]);
  }
  mj_deleteData(d1);
  mj_deleteModel(m1);
  free(rows);
  free(m);
  free(d);
  free(src);
  free(path);
  return status;
}
