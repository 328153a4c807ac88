// compare_models.c: `ostrich compare models FILE.xml... | DIR`, the check a MuJoCo user runs to
// judge Ostrich on their own models. Each model is loaded, checked (ost_checkModel: a refusal is
// a result with its reason), then stepped by stock MuJoCo and by Ostrich from its initial state
// with zero and with seeded random controls, at its own timestep and at multiples of it; every
// run's error is taken against stock MuJoCo at a quarter of the model's timestep on the same
// controls, with the sweep's metric (compare_run.c: base pose for a free-floating model, joint
// RMS otherwise). Output (compare_models_out.c): a table, a CSV, a plot and a summary.
//
// Invariant: the same controls reach every engine and the reference: random blocks switch half a
// reference step before a multiple of every step size run, so no engine sees a switch a step
// earlier or later than another through round-off in its clock.
#define _POSIX_C_SOURCE 200809L

#include <dirent.h>
#include <errno.h>
#include <math.h>
#include <stddef.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

#include "compare.h"
#include "compare_models.h"
#include "ostrich.h"

#define MODELS_BLOCK 0.1          // random controls hold for about this long (s)


//---------------------------------- Arguments -----------------------------------------------------

typedef struct modelsArgs_ {      // arguments of `ostrich compare models`
  const char* engines;            // comma list of engines
  const char* scales;             // comma list of h-scales
  const char* ctrl;               // comma list of control modes
  double      duration;           // simulated seconds
  double      max_wall;           // wall seconds per run
  long        seed;               // random controls' seed
  long        key;                // keyframe; -1: qpos0
  const char* csv;                // CSV path
  const char* plot;               // PNG path
  int         mujoco3;            // run compare/mujoco3_models.py too
  int         recursive;          // look for models in subdirectories too
  int         help;               // --help was given
} modelsArgs;

static const cliOption kModelsOptions[] = {
  {"--engine", CLI_ARG_STRING, offsetof(modelsArgs, engines), "ostrich,mujoco",
   "engines to run (default both)"},
  {"--h-scale", CLI_ARG_STRING, offsetof(modelsArgs, scales), "1,2,5,10",
   "step sizes as multiples of the model's opt.timestep (default 1,2,5,10)"},
  {"--duration", CLI_ARG_POSITIVE, offsetof(modelsArgs, duration), "SEC",
   "simulated time per run (default 1)"},
  {"--max-wall", CLI_ARG_POSITIVE, offsetof(modelsArgs, max_wall), "SEC",
   "stop a run after SEC seconds in the step calls: status timeout, its\n"
   "error over the time reached (default 60)"},
  {"--seed", CLI_ARG_COUNT, offsetof(modelsArgs, seed), "S", "random controls' seed (default 1)"},
  {"--key", CLI_ARG_COUNT, offsetof(modelsArgs, key), "K",
   "start from keyframe K (a model without it starts from qpos0, noted)"},
  {"--ctrl", CLI_ARG_STRING, offsetof(modelsArgs, ctrl), "zero,random",
   "controls: all zero, and/or uniform in ctrlrange (else [-1, 1]) held\n"
   "for 0.1 s blocks, the same sequence for every engine (default both)"},
  {"--csv", CLI_ARG_STRING, offsetof(modelsArgs, csv), "FILE.csv",
   "write the rows as CSV (a temporary file renamed over FILE at the end)"},
  {"--plot", CLI_ARG_STRING, offsetof(modelsArgs, plot), "FILE.png",
   "plot wall time per simulated second against error, one panel per\n"
   "model (gnuplot; skipped with a note without it)"},
  {"--mujoco3", CLI_ARG_FLAG, offsetof(modelsArgs, mujoco3), "",
   "also run the same models with MuJoCo 3 (python3 and the PyPI mujoco\n"
   "package; compare/mujoco3_models.py), integrator implicitfast and,\n"
   "where it exists, discrete; skipped with a note if not installed"},
  {"--recursive", CLI_ARG_FLAG, offsetof(modelsArgs, recursive), "",
   "a DIR argument includes the *.xml of its subdirectories"},
};

static const int kModelsNumOptions = (int)(sizeof(kModelsOptions) / sizeof(kModelsOptions[0]));


// Print the usage of `ostrich compare models`.
static void models_usage(FILE* f) {
  fprintf(f,
    "usage: ostrich compare models FILE.xml... | DIR... [options]\n"
    "\n"
    "Judge Ostrich on your models. For each model (the files given, and every *.xml of each\n"
    "DIR, sorted): load it in MuJoCo 2.2.2 (a failure is reported), check it with Ostrich (a\n"
    "refusal is reported with its reason), then run each engine from the initial state\n"
    "(qpos0, or --key) with each kind of controls at h = scale x opt.timestep for --duration.\n"
    "The reference is stock MuJoCo at opt.timestep / 4 on the same controls; the error is the\n"
    "RMS over samples every 10 ms of the base position (plus 0.5 m x the yaw error) for a\n"
    "model whose first joint is free, else of |qpos - qpos_ref|. A run diverged if its state\n"
    "became non-finite or |qvel| > 1e6; Ostrich steps that returned OST_OK are converged,\n"
    "warnings (OST_WARN_NOT_CONVERGED) are taken but not converged, an error is a failed step\n"
    "and ends the run. MuJoCo has no convergence status (converged_pct empty). A run slower\n"
    "than --max-wall stops (status timeout; the reference gets 4x as long).\n"
    "\n"
    "Prints one line per run (a table), then a summary: the converged-step share per model\n"
    "and over all, and the refusal reasons ranked by how many models they block. Progress on\n"
    "stderr (OSTRICH_QUIET=1 silences it).\n"
    "\n"
    "options:\n");
  cli_printOptions(f, kModelsOptions, kModelsNumOptions);
  cli_printHelpOption(f);
  fprintf(f,
    "\n"
    "CSV columns: " MODELS_CSV_HEADER "\n"
    "(status: ok, diverged, failed, timeout, refused, load_failed, setup_failed; empty = not\n"
    "measured)\n"
    "\n"
    "Example: ostrich compare models /usr/share/mujoco/model --recursive --csv models.csv\n"
    "Exit status: 0 every Ostrich run on an accepted model completed; 1 one diverged or had a\n"
    "failed step (MuJoCo's divergences and timeouts are results, not failures), or an output\n"
    "could not be written; 2 bad usage (output paths are checked before any run).\n");
}


// Collect the positional arguments (models and directories) and parse the options; return 0 on
// success. positional gets at most argc entries.
static int models_parse(int argc, char** argv, modelsArgs* a, const char** positional,
                        int* npos) {
  *a = (modelsArgs){.engines = "ostrich,mujoco", .scales = "1,2,5,10", .ctrl = "zero,random",
                    .duration = 1.0, .max_wall = 60, .seed = 1, .key = -1};
  return cli_parseArgsList("compare models", argc, argv, kModelsOptions, kModelsNumOptions, a,
                           positional, argc, npos, &a->help);
}


// Check the arguments into s; return 0 on success.
static int models_setup(const modelsArgs* a, int npos, modelsState* s) {
  if (!npos) {
    cli_error("compare models: missing FILE.xml or DIR (see ostrich compare models --help)");
    return 1;
  }
  s->nscale = cmp_parsePositiveList("--h-scale", a->scales, s->scale, MODELS_MAX_SCALE, 1);
  if (s->nscale < 0 || cmp_parseEngines(a->engines, s->use)) {
    return 1;
  }
  char buf[64];
  const char* item[4];
  int n = cmp_splitList("--ctrl", a->ctrl, buf, sizeof(buf), item, 4);
  for (int i = 0; i < n; i++) {
    if (!strcmp(item[i], "zero") || !strcmp(item[i], "random")) {
      *(item[i][0] == 'z' ? &s->ctrl_zero : &s->ctrl_random) = 1;
    } else {
      cli_error("--ctrl: '%s' is not zero or random", item[i]);
      return 1;
    }
  }
  if (n < 0 || (a->csv && cli_checkOutput("--csv", a->csv)) ||
      (a->plot && cli_checkOutput("--plot", a->plot))) {
    return 1;
  }
  s->duration = a->duration;
  s->max_wall = a->max_wall;
  s->seed = a->seed;
  s->key = a->key + 1;
  s->csv = a->csv;
  s->plot = a->plot;
  s->mujoco3 = a->mujoco3;
  return 0;
}


//---------------------------------- Model files ---------------------------------------------------

// Append a copy of path to s->path; return 0 on success.
static int models_addPath(modelsState* s, const char* path, int* cap) {
  if (s->nmodel == *cap) {
    *cap = *cap ? 2 * *cap : 64;
    char** grown = realloc(s->path, sizeof(char*) * (size_t)*cap);
    if (!grown) {
      return 1;
    }
    s->path = grown;
  }
  s->path[s->nmodel] = strdup(path);
  return !s->path[s->nmodel++];
}


static int models_comparePaths(const void* a, const void* b) {
  return strcmp(*(char* const*)a, *(char* const*)b);
}


// Add the *.xml files of directory dir (and of its subdirectories if recursive), sorted by path;
// return 0 on success.
static int models_scanDir(modelsState* s, const char* dir, int recursive, int* cap) {
  DIR* d = opendir(dir);
  if (!d) {
    cli_error("cannot read directory '%s': %s", dir, strerror(errno));
    return 1;
  }
  int first = s->nmodel, status = 0;
  for (struct dirent* e; !status && (e = readdir(d));) {
    char path[MODELS_PATH_SZ];
    size_t len = strlen(e->d_name);
    struct stat st;
    if (e->d_name[0] == '.' ||
        snprintf(path, sizeof(path), "%s/%s", dir, e->d_name) >= (int)sizeof(path) ||
        stat(path, &st)) {
      continue;
    }
    if (S_ISDIR(st.st_mode) && recursive) {
      status = models_scanDir(s, path, recursive, cap);
    } else if (S_ISREG(st.st_mode) && len > 4 && !strcmp(e->d_name + len - 4, ".xml")) {
      status = models_addPath(s, path, cap);
    }
  }
  closedir(d);
  qsort(s->path + first, (size_t)(s->nmodel - first), sizeof(char*), models_comparePaths);
  return status;
}


// The model files of the positional arguments, in order; return 0 on success.
static int models_list(modelsState* s, const char** positional, int npos, int recursive) {
  int cap = 0;
  for (int i = 0; i < npos; i++) {
    struct stat st;
    int dir = !stat(positional[i], &st) && S_ISDIR(st.st_mode);
    if (dir ? models_scanDir(s, positional[i], recursive, &cap) :
              models_addPath(s, positional[i], &cap)) {
      return 1;
    }
  }
  if (!s->nmodel) {
    cli_error("compare models: no *.xml file in the directories given");
    return 1;
  }
  return 0;
}


//---------------------------------- Runs ----------------------------------------------------------

// Controls of one mode: zero (one row of zeros, so a keyframe's ctrl does not persist) or random
// blocks; return 0 on success.
static int models_controls(const modelsState* s, const mjModel* m, int random, cmpCommands* c) {
  double hmax = m->opt.timestep * s->scale[s->nscale - 1];
  double block = ceil(MODELS_BLOCK / hmax - 1e-9) * hmax;
  int nrow = random ? (int)ceil(s->duration / block) + 1 : 1;
  if (cmp_allocCommands(c, nrow, m->nu)) {
    return 1;
  }
  cliRng rng;
  cli_rngSeed(&rng, (unsigned long long)s->seed);
  for (int i = 0; i < nrow; i++) {
    // switch half a reference step early (see the invariant at the top)
    c->time[i] = i ? i * block - m->opt.timestep / 8 : 0;
    for (int j = 0; j < m->nu && random; j++) {
      int limited = m->actuator_ctrllimited[j];
      double lo = limited ? m->actuator_ctrlrange[2 * j] : -1;
      double hi = limited ? m->actuator_ctrlrange[2 * j + 1] : 1;
      c->ctrl[(size_t)i * (size_t)m->nu + j] = cli_uniform(&rng, lo, hi);
    }
  }
  return 0;
}


// Fill a row from a run's result.
static void models_fillRow(modelsRow* r, int engine, const cmpRunResult* res, double error) {
  snprintf(r->engine, sizeof(r->engine), "%s", kCmpEngineNames[engine]);
  static const char* kStatus[] = {"ok", "diverged", "failed", "setup_failed", "timeout"};
  snprintf(r->status, sizeof(r->status), "%s", kStatus[res->outcome]);
  r->steps = res->steps;
  r->simulated = res->simulated;
  r->failed = res->failed;
  r->max_penetration = res->max_penetration;
  r->wall_per_sim = res->simulated > 0 ? res->wall / res->simulated : NAN;
  r->error = error;
  models_setText(r->reason, sizeof(r->reason), res->why);
  if (engine == CMP_OSTRICH && res->outcome != CMP_SETUP_FAILED) {
    long attempted = res->steps + (res->outcome == CMP_NAN || res->outcome == CMP_STEP_FAILED);
    r->unconverged = res->unconverged;
    r->converged_pct = attempted ? 100.0 * (double)(attempted - res->unconverged - res->failed) /
                                   (double)attempted : NAN;
  }
}


// Write the mujoco3 job of one model and control mode: its reference and controls; return 0 on
// success (a failure only drops the job, with a note).
static void models_addJob(modelsState* s, int i, const char* name, const char* ctrl,
                          const mjModel* m, const cmpTrajectory* ref, const cmpCommands* c) {
  char refp[MODELS_PATH_SZ + 64], ctrlp[MODELS_PATH_SZ + 64];
  snprintf(refp, sizeof(refp), "%s/ref_%d_%s.csv", s->jobs_dir, i, ctrl);
  snprintf(ctrlp, sizeof(ctrlp), "%s/ctrl_%d_%s.csv", s->jobs_dir, i, ctrl);
  if (strchr(s->path[i], ',') || cmp_writeTrajectory(refp, ref)) {
    cli_error("mujoco3: %s skipped (a comma in its path, or its reference not written)", name);
    return;
  }
  char** names = calloc((size_t)(m->nu + 1), sizeof(char*));
  char(*buf)[16] = calloc((size_t)(m->nu + 1), sizeof(*buf));
  for (int j = 0; names && buf && j < m->nu; j++) {
    snprintf(buf[j], sizeof(buf[j]), "u%d", j);
    names[j] = buf[j];
  }
  if (names && buf && !cmp_writeCommands(ctrlp, c, (const char* const*)names)) {
    fprintf(s->jobs, "%s,%s,%ld,%s,%.17g,%.17g,", name, s->path[i], s->key - 1, ctrl,
            m->opt.timestep, s->duration);
    for (int k = 0; k < s->nscale; k++) {
      fprintf(s->jobs, "%s%.17g", k ? " " : "", s->scale[k]);
    }
    fprintf(s->jobs, ",%s,%s\n", refp, ctrlp);
  }
  free(names);
  free(buf);
}


// Run every engine and h-scale of one model and control mode; return 0 unless out of memory.
static int models_runMode(modelsState* s, int i, const char* name, mjModel* m, int random) {
  cmpCommands c = {0};
  cmpTrajectory ref = {0};
  cmpRunResult res;
  const char* ctrl = random ? "random" : "zero";
  double h0 = m->opt.timestep;
  int key = s->key <= m->nkey ? (int)s->key : 0;
  if (models_controls(s, m, random, &c)) {
    return 1;
  }

  // the reference: stock MuJoCo at h0 / 4
  cmpRunSpec spec = {.engine = CMP_MUJOCO, .h = h0 / 4, .duration = s->duration,
                     .commands = &c, .key = key, .max_qvel = MODELS_MAX_QVEL,
                     .max_wall = 4 * s->max_wall};
  int oom = cmp_run(m, &spec, &ref, &res);
  int ref_ok = !oom && res.outcome == CMP_COMPLETED;
  if (!oom && !ref_ok) {
    cli_error("%s (%s controls): the reference (mujoco, h = %g) failed: %s; errors are over "
              "its %g s", name, ctrl, h0 / 4, res.why, res.simulated);
  }
  if (!oom && s->jobs) {
    models_addJob(s, i, name, ctrl, m, &ref, &c);
  }

  // every engine (ostrich first) at every h-scale
  for (int e = CMP_NENGINE - 1; e >= 0 && !oom; e--) {
    for (int k = 0; k < s->nscale && s->use[e] && !oom; k++) {
      cmpTrajectory tr;
      spec.engine = e;
      spec.h = h0 * s->scale[k];
      spec.max_wall = s->max_wall;
      oom = cmp_run(m, &spec, &tr, &res);
      double error = oom ? NAN : cmp_trajectoryError(&tr, &ref, CMP_SAMPLE_DT);
      cmp_freeTrajectory(&tr);
      modelsRow* r = oom ? NULL : models_addRow(s);
      if (!r) {
        oom = 1;
        break;
      }
      snprintf(r->model, sizeof(r->model), "%s", name);
      snprintf(r->ctrl, sizeof(r->ctrl), "%s", ctrl);
      r->h_scale = s->scale[k];
      r->h = spec.h;
      models_fillRow(r, e, &res, error);
      s->nbad += e == CMP_OSTRICH && res.outcome != CMP_COMPLETED && res.outcome != CMP_TIMEOUT;
      s->ntimeout += res.outcome == CMP_TIMEOUT;
      if (cli_progress() && res.wall > 1.0) {
        fprintf(stderr, "ostrich: models: %s %s %s h x%g: %.1f s wall, %s\n", name,
                kCmpEngineNames[e], ctrl, s->scale[k], res.wall, r->status);
      }
    }
  }
  cmp_freeTrajectory(&ref);
  cmp_freeCommands(&c);
  return oom;
}


// Load, check and run model i; return 0 unless out of memory.
static int models_runModel(modelsState* s, int i) {
  // the name: the file name without .xml
  const char* base = strrchr(s->path[i], '/') ? strrchr(s->path[i], '/') + 1 : s->path[i];
  char name[128], err[CLI_MSG_SZ] = "";
  snprintf(name, sizeof(name), "%.*s", (int)(strlen(base) > 4 && !strcmp(base + strlen(base) - 4,
           ".xml") ? strlen(base) - 4 : strlen(base)), base);
  if (cli_progress()) {
    fprintf(stderr, "ostrich: models: %d/%d %s\n", i + 1, s->nmodel, s->path[i]);
  }

  // load; a failure or a refusal is one row
  mjModel* m = mj_loadXML(s->path[i], NULL, err, sizeof(err));
  int refused = m && ost_checkModel(m, err, sizeof(err)) != OST_OK;
  if (!m || refused) {
    modelsRow* r = models_addRow(s);
    if (!r) {
      mj_deleteModel(m);
      return 1;
    }
    snprintf(r->model, sizeof(r->model), "%s", name);
    snprintf(r->engine, sizeof(r->engine), "%s", m ? "ostrich" : "mujoco");
    snprintf(r->status, sizeof(r->status), "%s", m ? "refused" : "load_failed");
    cli_oneLine(err);
    models_setText(r->reason, sizeof(r->reason), err[0] ? err : "unknown error");
    s->nrefused += refused;
    s->nload_failed += !m;
    mj_deleteModel(m);
    return 0;
  }
  if (s->key > m->nkey) {
    cli_error("%s has no keyframe %ld: it starts from qpos0", name, s->key - 1);
  }
  int oom = (s->ctrl_zero && models_runMode(s, i, name, m, 0)) ||
            (s->ctrl_random && models_runMode(s, i, name, m, 1));
  mj_deleteModel(m);
  return oom;
}


//---------------------------------- models --------------------------------------------------------

// Open the mujoco3 jobs directory and file; without them the run goes on without mujoco3.
static void models_openJobs(modelsState* s) {
  const char* tmp = getenv("TMPDIR");
  snprintf(s->jobs_dir, sizeof(s->jobs_dir), "%s/ostrich-models-XXXXXX", tmp ? tmp : "/tmp");
  char path[MODELS_PATH_SZ + 16];
  if (!mkdtemp(s->jobs_dir)) {
    cli_error("mujoco3 skipped: cannot make a temporary directory: %s", strerror(errno));
    s->jobs_dir[0] = 0;
    return;
  }
  snprintf(path, sizeof(path), "%s/jobs.csv", s->jobs_dir);
  if ((s->jobs = fopen(path, "w"))) {
    fprintf(s->jobs, "model,path,key,ctrl,h0,duration,h_scales,ref,ctrl_file\n");
  }
}


// Remove the mujoco3 jobs directory and its files.
static void models_removeJobs(modelsState* s) {
  if (!s->jobs_dir[0]) {
    return;
  }
  DIR* d = opendir(s->jobs_dir);
  for (struct dirent* e; d && (e = readdir(d));) {
    char path[MODELS_PATH_SZ + 256];
    if (e->d_name[0] != '.') {
      snprintf(path, sizeof(path), "%s/%s", s->jobs_dir, e->d_name);
      remove(path);
    }
  }
  if (d) {
    closedir(d);
  }
  rmdir(s->jobs_dir);
}


// `ostrich compare models FILE.xml... | DIR... [options]`
int compare_models_main(int argc, char** argv) {
  modelsArgs a;
  modelsState s = {0};
  const char** positional = malloc(sizeof(char*) * (size_t)(argc + 1));
  int npos = 0;
  int status = !positional || models_parse(argc, argv, &a, positional, &npos) ? CLI_USAGE : CLI_OK;
  if (status == CLI_OK && a.help) {
    models_usage(stdout);
    free(positional);
    return CLI_OK;
  }
  if (status == CLI_OK && (models_setup(&a, npos, &s) ||
                           models_list(&s, positional, npos, a.recursive))) {
    status = CLI_USAGE;
  }
  free(positional);

  // every model, then mujoco3's rows, then the outputs
  if (status == CLI_OK && s.mujoco3) {
    models_openJobs(&s);
  }
  for (int i = 0; i < s.nmodel && status == CLI_OK; i++) {
    if (models_runModel(&s, i)) {
      cli_error("out of memory");
      status = CLI_FAIL;
    }
  }
  if (s.jobs) {
    fclose(s.jobs);
    s.jobs = NULL;
    if (status == CLI_OK) {
      models_runMujoco3(&s);
    }
  }
  models_removeJobs(&s);
  if (status == CLI_OK) {
    models_printTable(&s);
    models_printSummary(&s);
    status = s.nbad ? CLI_FAIL : CLI_OK;
    if (s.csv && models_writeCsv(&s)) {
      status = CLI_FAIL;
    }
    if (s.plot && models_writePlot(&s)) {
      status = CLI_FAIL;
    }
  }
  for (int i = 0; i < s.nmodel; i++) {
    free(s.path[i]);
  }
  free(s.path);
  free(s.row);
  return status;
}
