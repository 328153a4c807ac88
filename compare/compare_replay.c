// compare_replay.c: the sim-to-real half of the A/B harness: `ostrich compare replay`
// replays a logged run of the robot open-loop with each engine, `identify` fits each engine's
// dominant parameters on training logs and scores held-out logs, and `gen-logs` writes the
// synthetic pallet-traversal logs (a fine-step stock MuJoCo reference with "true" parameters
// plus measurement noise). Engine runs and the error metric come from compare_run.c.
//
// Log format (CSV, 100 Hz; '#' lines are comments):
//   time,cmd_left,cmd_right,cmd_rear,x,y,z,yaw
// time in s; one wheel-velocity command (rad/s) per actuator of the model, in actuator order;
// then the measured base pose: position (m) and yaw (rad). The replay starts from the log's
// first pose and holds each row's commands until the next row.
//
// Invariant: a replay never reads the log's poses after the start; parameters are set on a copy
// of the loaded model, so every grid point starts from the model as written.
#define _POSIX_C_SOURCE 200809L

#include <errno.h>
#include <math.h>
#include <stddef.h>
#include <stdlib.h>
#include <string.h>

#include "compare.h"
#include "compare_run.h"

#define REPLAY_MAX_LOGS  64       // logs per --train or --test list
#define REPLAY_MAX_GRID  16       // values per parameter grid
#define REPLAY_REST      0.5      // s: the start pose averages the leading rest rows up to this


//---------------------------------- Parameters ----------------------------------------------------

typedef enum replayParam_ {       // the parameters identify may set
  PARAM_KV = 0,                   // gain kv of every velocity servo (gainprm[0], -biasprm[2])
  PARAM_FRICTION,                 // sliding friction of every geom (MuJoCo takes a pair's max)
  PARAM_SOLREF,                   // solref time constant of every geom (MuJoCo only)
  NPARAM
} replayParam;

static const char* const kParamNames[NPARAM] = {"kv", "friction", "solref"};


// Copy base into m and set the parameters p (NPARAM values; NaN keeps the model's).
static void replay_applyParams(mjModel* m, const mjModel* base, const double* p) {
  mj_copyModel(m, base);
  for (int i = 0; i < m->nu && !isnan(p[PARAM_KV]); i++) {
    // a velocity servo: fixed gain kv, affine bias -kv * velocity
    mjtNum* gain = m->actuator_gainprm + mjNGAIN * i;
    mjtNum* bias = m->actuator_biasprm + mjNBIAS * i;
    if (m->actuator_gaintype[i] == mjGAIN_FIXED && m->actuator_biastype[i] == mjBIAS_AFFINE &&
        bias[1] == 0 && bias[2] == -gain[0]) {
      gain[0] = p[PARAM_KV];
      bias[2] = -p[PARAM_KV];
    }
  }
  for (int g = 0; g < m->ngeom; g++) {
    if (!isnan(p[PARAM_FRICTION])) {
      m->geom_friction[3 * g] = p[PARAM_FRICTION];
    }
    if (!isnan(p[PARAM_SOLREF])) {
      m->geom_solref[mjNREF * g] = p[PARAM_SOLREF];
    }
  }
}


// Print the parameters that are set, "name=value ...", into buf.
static void replay_formatParams(char* buf, int buf_sz, const double* p) {
  buf[0] = 0;
  for (int k = 0; k < NPARAM; k++) {
    if (!isnan(p[k])) {
      size_t len = strlen(buf);
      snprintf(buf + len, (size_t)buf_sz - len, "%s%s=%g", len ? " " : "", kParamNames[k], p[k]);
    }
  }
  if (!buf[0]) {
    snprintf(buf, (size_t)buf_sz, "model defaults");
  }
}


//---------------------------------- Logs ----------------------------------------------------------

typedef struct replayLog_ {       // one log, read for one model
  const char*   path;             // file
  cmpCommands   commands;         // wheel commands, time from 0
  cmpTrajectory measured;         // measured pose, time from 0
  double        duration;         // last time (s)
  mjtNum*       qpos0;            // start configuration                            (nq)
} replayLog;


// Start configuration: the model's qpos0 with the base at the mean pose of the leading rest
// rows (all commands 0, t <= REPLAY_REST; at least the first row). z stays the model's, so the
// robot starts resting on the floor whatever the noise on the measured z.
static void replay_startPose(const mjModel* m, replayLog* log) {
  const cmpTrajectory* tr = &log->measured;
  double x = 0, y = 0, c = 0, s = 0;
  int n = 0;
  for (int i = 0; i < tr->n && (i == 0 || tr->time[i] <= REPLAY_REST); i++) {
    const double* u = log->commands.ctrl + (size_t)i * (size_t)log->commands.nu;
    int rest = 1;
    for (int j = 0; j < log->commands.nu; j++) {
      rest = rest && u[j] == 0;
    }
    if (i > 0 && !rest) {
      break;
    }
    const double* pose = tr->coord + 4 * i;
    x += pose[0];
    y += pose[1];
    c += cos(pose[3]);
    s += sin(pose[3]);
    n++;
  }

  // circular mean of the yaw; quaternion of a rotation about z
  double yaw = atan2(s, c);
  mju_copy(log->qpos0, m->qpos0, m->nq);
  log->qpos0[0] = x / n;
  log->qpos0[1] = y / n;
  log->qpos0[3] = cos(0.5 * yaw);
  log->qpos0[4] = 0;
  log->qpos0[5] = 0;
  log->qpos0[6] = sin(0.5 * yaw);
}


// Free a log.
static void replay_freeLog(replayLog* log) {
  cmp_freeCommands(&log->commands);
  cmp_freeTrajectory(&log->measured);
  free(log->qpos0);
  *log = (replayLog){0};
}


// Read a log for model m; return 0 on success, else print why.
static int replay_readLog(const char* path, const mjModel* m, replayLog* log) {
  *log = (replayLog){.path = path};
  if (cmp_modelKind(m) != CMP_POSE) {
    cli_error("replay: the model has no free joint at qpos 0 (the logs give a base pose)");
    return 1;
  }
  cmpTable t;
  if (cmp_readTable(path, &t)) {
    return 1;
  }

  // time, nu commands, x, y, z, yaw
  int nu = m->nu, status = 1;
  int pose_cols = t.ncol == 1 + nu + 4 && cmp_tableColumn(&t, "x") == 1 + nu &&
                  cmp_tableColumn(&t, "y") == 2 + nu && cmp_tableColumn(&t, "z") == 3 + nu &&
                  cmp_tableColumn(&t, "yaw") == 4 + nu;
  if (!pose_cols) {
    cli_error("%s: expected the columns time, %d commands (nu of the model), x, y, z, yaw; got "
              "%d columns", path, nu, t.ncol);
  } else if (!cmp_commandsFromTable(&t, 1, nu, &log->commands) &&
             !cmp_tableTrajectory(path, &t, CMP_POSE, m->nq, t.data[0], &log->measured) &&
             (log->qpos0 = malloc(sizeof(mjtNum) * (size_t)m->nq))) {
    status = 0;
  }

  // times from 0
  if (!status) {
    for (int i = 0; i < log->commands.nrow; i++) {
      log->commands.time[i] -= t.data[0];
    }
    log->duration = log->commands.time[log->commands.nrow - 1];
    replay_startPose(m, log);
  }
  cmp_freeTable(&t);
  if (status) {
    replay_freeLog(log);
  }
  return status;
}


// Read a comma list of logs; return the count, or -1 after printing why.
static int replay_readLogs(const char* option, const char* list, const mjModel* m,
                           replayLog* logs, char* buf, int buf_sz) {
  const char* paths[REPLAY_MAX_LOGS];
  int n = cmp_splitList(option, list, buf, buf_sz, paths, REPLAY_MAX_LOGS);
  for (int i = 0; i < n; i++) {
    if (replay_readLog(paths[i], m, logs + i)) {
      return -1;
    }
  }
  return n;
}


// Replay one log with engine e at step h on m; return its error against the measured pose (NaN
// if the run failed: res says why). Out of memory also gives NaN. If traj_path is not NULL, the
// replayed trajectory is written there.
static double replay_runLog(mjModel* m, const replayLog* log, int engine, double h,
                            cmpRunResult* res, const char* traj_path) {
  cmpRunSpec spec = {.engine = engine, .h = h, .duration = log->duration,
                     .commands = &log->commands, .qpos0 = log->qpos0};
  cmpTrajectory tr;
  double error = NAN;
  if (!cmp_run(m, &spec, &tr, res) && res->outcome == CMP_COMPLETED) {
    error = cmp_trajectoryError(&tr, &log->measured, CMP_SAMPLE_DT);
  }
  if (traj_path && cmp_writeTrajectory(traj_path, &tr)) {
    error = NAN;
  }
  cmp_freeTrajectory(&tr);
  return error;
}


//---------------------------------- Arguments -----------------------------------------------------

typedef struct replayArgs_ {      // arguments of replay, identify and gen-logs
  const char* log;                // replay: LOG.csv
  const char* model;              // MJCF path
  const char* engine;             // comma list of engines
  double      h[CMP_NENGINE];     // step per engine (s)
  double      param[NPARAM];      // replay: parameters (0: the model's)
  const char* train;              // identify: training logs
  const char* test;               // identify: held-out logs
  const char* grid[NPARAM];       // identify: grid per parameter
  const char* out;                // replay, gen-logs: output directory
  const char* csv;                // identify: CSV of every error
  long        seed;               // gen-logs: noise seed
  long        nlog;               // gen-logs: logs to write (the first N)
  int         help;               // --help was given
} replayArgs;

#define REPLAY_ENGINE_OPTIONS \
  {"--engine", CLI_ARG_STRING, offsetof(replayArgs, engine), "ostrich,mujoco", \
   "engines (default both)"}, \
  {"--h-ostrich", CLI_ARG_POSITIVE, offsetof(replayArgs, h) + sizeof(double) * CMP_OSTRICH, \
   "SEC", "Ostrich's step (default 0.05)"}, \
  {"--h-mujoco", CLI_ARG_POSITIVE, offsetof(replayArgs, h) + sizeof(double) * CMP_MUJOCO, \
   "SEC", "stock MuJoCo's step (default 0.002)"}

static const cliOption kReplayOptions[] = {
  REPLAY_ENGINE_OPTIONS,
  {"--kv", CLI_ARG_POSITIVE, offsetof(replayArgs, param) + sizeof(double) * PARAM_KV, "KV",
   "gain of every velocity servo (default: the model's)"},
  {"--friction", CLI_ARG_POSITIVE, offsetof(replayArgs, param) + sizeof(double) * PARAM_FRICTION,
   "MU", "sliding friction of every geom (default: the model's)"},
  {"--solref", CLI_ARG_POSITIVE, offsetof(replayArgs, param) + sizeof(double) * PARAM_SOLREF,
   "SEC", "solref time constant of every geom (default: the model's)"},
  {"--out", CLI_ARG_STRING, offsetof(replayArgs, out), "DIR",
   "write each replayed trajectory to DIR/replay_<engine>.csv\n"
   "(time,x,y,z,yaw); DIR is created if missing"},
};

static const cliOption kIdentifyOptions[] = {
  {"--train", CLI_ARG_STRING, offsetof(replayArgs, train), "LOG1,LOG2,...",
   "training logs (required)"},
  {"--test", CLI_ARG_STRING, offsetof(replayArgs, test), "LOG1,LOG2,...",
   "held-out logs (required)"},
  REPLAY_ENGINE_OPTIONS,
  {"--kv-grid", CLI_ARG_STRING, offsetof(replayArgs, grid) + sizeof(char*) * PARAM_KV,
   "K1,K2,...", "Ostrich's servo gains (default 210,240,270,300,330)"},
  {"--friction-grid", CLI_ARG_STRING, offsetof(replayArgs, grid) + sizeof(char*) * PARAM_FRICTION,
   "M1,M2,...", "friction, both engines (default 0.7,0.8,0.9,1.0)"},
  {"--solref-grid", CLI_ARG_STRING, offsetof(replayArgs, grid) + sizeof(char*) * PARAM_SOLREF,
   "T1,T2,...", "MuJoCo's solref time constants (default 0.005,0.01,0.02,0.04)"},
  {"--csv", CLI_ARG_STRING, offsetof(replayArgs, csv), "FILE.csv",
   "every error, one row per engine, grid point and log (default\n"
   "identify.csv; checked before the runs, written at the end)"},
};

static const cliOption kGenlogsOptions[] = {
  {"--out", CLI_ARG_STRING, offsetof(replayArgs, out), "DIR",
   "output directory, created if missing (required)"},
  {"--seed", CLI_ARG_COUNT, offsetof(replayArgs, seed), "S", "noise seed (default 1)"},
  {"--logs", CLI_ARG_COUNT, offsetof(replayArgs, nlog), "N",
   "write only the first N of the 14 logs (default 14)"},
};

#define REPLAY_NUM(options) ((int)(sizeof(options) / sizeof(options[0])))


// Defaults shared by the three subcommands.
static replayArgs replay_defaultArgs(void) {
  replayArgs a = {.engine = "ostrich,mujoco", .out = NULL, .seed = 1, .nlog = 14};
  a.h[CMP_OSTRICH] = 0.05;
  a.h[CMP_MUJOCO] = 0.002;
  return a;
}


// Print the usage of `ostrich compare replay`.
static void replay_usage(FILE* f) {
  fprintf(f,
    "usage: ostrich compare replay LOG.csv MODEL.xml [options]\n"
    "\n"
    "Replay a logged run open-loop with each engine: start from the log's first pose (the mean\n"
    "of the leading rows at rest, up to 0.5 s; z from the model), hold each row's commands\n"
    "until the next row, and print one JSON line with each engine's error against the logged\n"
    "pose: sqrt(<|dp|^2> + (0.5 m * RMS(dyaw))^2) over samples every 10 ms.\n"
    "\n"
    "Log format (CSV, 100 Hz, '#' lines are comments): the header\n"
    "  time,cmd_left,cmd_right,cmd_rear,x,y,z,yaw\n"
    "then one row per sample: time (s), one wheel-velocity command (rad/s) per actuator of the\n"
    "model in actuator order, the measured base position (m) and yaw (rad).\n"
    "\n"
    "options:\n");
  cli_printOptions(f, kReplayOptions, REPLAY_NUM(kReplayOptions));
  cli_printHelpOption(f);
  fprintf(f, "\nExit status: 0 success; 1 an engine's run failed; 2 bad usage or input.\n");
}


//---------------------------------- replay --------------------------------------------------------

// Print one engine's replay result as a JSON member.
static void replay_reportEngine(int e, double h, double error, const cmpRunResult* res) {
  printf(",\"%s\":{\"h\":", kCmpEngineNames[e]);
  cli_jsonNumber(stdout, h);
  printf(",\"error\":");
  cli_jsonNumber(stdout, error);
  printf(",\"outcome\":\"%s\",\"steps\":%ld,\"wall_s\":%.6f}", kCmpOutcomeNames[res->outcome],
         res->steps, res->wall);
}


// `ostrich compare replay LOG.csv MODEL.xml [options]`
int compare_replay_main(int argc, char** argv) {
  replayArgs a = replay_defaultArgs();
  const char* positional[2] = {NULL, NULL};
  int use[CMP_NENGINE];
  if (cmp_parseArgs("compare replay", argc, argv, kReplayOptions, REPLAY_NUM(kReplayOptions),
                    &a, positional, 2, &a.help)) {
    return CLI_USAGE;
  }
  if (a.help) {
    replay_usage(stdout);
    return CLI_OK;
  }
  a.log = positional[0];
  a.model = positional[1];
  if (!a.log || !a.model) {
    cli_error("compare replay: expected LOG.csv MODEL.xml (see ostrich compare replay --help)");
    return CLI_USAGE;
  }
  if (cmp_parseEngines(a.engine, use) || (a.out && cli_checkOutputDir("--out", a.out))) {
    return CLI_USAGE;
  }

  // model with the requested parameters, then the log
  mjModel *base = NULL, *m = NULL;
  mjData* d = NULL;
  replayLog log = {0};
  int status = CLI_USAGE;
  if (!cli_loadModel(a.model, &base, &d) && (m = mj_copyModel(NULL, base)) &&
      !replay_readLog(a.log, base, &log)) {
    double p[NPARAM];
    for (int k = 0; k < NPARAM; k++) {
      p[k] = a.param[k] > 0 ? a.param[k] : NAN;
    }
    replay_applyParams(m, base, p);

    // one run per engine; a failed run is reported and makes the exit status 1
    status = CLI_OK;
    printf("{\"log\":");
    cli_jsonString(stdout, a.log);
    printf(",\"model\":");
    cli_jsonString(stdout, a.model);
    printf(",\"duration\":");
    cli_jsonNumber(stdout, log.duration);
    for (int e = CMP_NENGINE - 1; e >= 0; e--) {
      if (!use[e]) {
        continue;
      }
      cmpRunResult res;
      char traj[4096];
      snprintf(traj, sizeof(traj), "%s/replay_%s.csv", a.out ? a.out : "", kCmpEngineNames[e]);
      double error = replay_runLog(m, &log, e, a.h[e], &res, a.out ? traj : NULL);
      if (res.outcome != CMP_COMPLETED || isnan(error)) {
        cli_error("replay: %s: %s", kCmpEngineNames[e], res.why[0] ? res.why : "out of memory");
        status = CLI_FAIL;
      } else if (cli_progress()) {
        fprintf(stderr, "ostrich: replay %s h=%g: error %.4g (%ld steps, %.3f s)\n",
                kCmpEngineNames[e], a.h[e], error, res.steps, res.wall);
      }
      replay_reportEngine(e, a.h[e], error, &res);
    }
    printf("}\n");
    fflush(stdout);
  }
  replay_freeLog(&log);
  if (d) {
    mj_deleteData(d);
  }
  if (m) {
    mj_deleteModel(m);
  }
  if (base) {
    mj_deleteModel(base);
  }
  return status;
}


//---------------------------------- identify ------------------------------------------------------

typedef struct identifyScore_ {   // the errors of one parameter set over a list of logs
  double mean;                    // mean error over the runs that completed (NaN if none)
  int    failed;                  // runs that failed (diverged or a failed step)
} identifyScore;

typedef struct identifyFit_ {     // one engine's identification
  int           engine;           // cmpEngine
  int           axis[2];          // the two parameters swept (replayParam)
  double        best[NPARAM];     // identified parameters (NaN: the model's)
  identifyScore train;            // training logs at best
  identifyScore test;             // held-out logs at best
  identifyScore test_default;     // held-out logs at the model's own parameters
  double*       test_errors;      // held-out error per log at best, NaN if failed    (ntest)
} identifyFit;

typedef struct identifyState_ {   // the whole identification
  mjModel*   base;                // the model as loaded
  mjModel*   m;                   // working copy with parameters set
  replayLog  train[REPLAY_MAX_LOGS];
  replayLog  test[REPLAY_MAX_LOGS];
  int        ntrain, ntest;       // logs
  double     grid[NPARAM][REPLAY_MAX_GRID];  // values per parameter
  int        ngrid[NPARAM];       // sizes
  FILE*      csv;                 // every error (its temporary file until committed)
  char       csv_tmp[CLI_PATH_SZ];  // name of that temporary file
} identifyState;


// Print the usage of `ostrich compare identify`.
static void identify_usage(FILE* f) {
  fprintf(f,
    "usage: ostrich compare identify --train LOG,... --test LOG,... MODEL.xml [options]\n"
    "\n"
    "For each engine, replay every training log (see ostrich compare replay --help) at each\n"
    "point of a grid over the engine's two dominant parameters and pick the point with the\n"
    "fewest failed runs, then the smallest mean training error over the runs that completed.\n"
    "Replay the held-out logs there, and at the model's own parameters for comparison.\n"
    "Ostrich's parameters: the servo gain kv of every velocity actuator and the friction;\n"
    "stock MuJoCo's: the friction and the solref time constant. Friction and solref are set\n"
    "on every geom (MuJoCo takes a pair's maximum friction).\n"
    "\n"
    "Prints one JSON line: per engine the identified parameters and the mean training and\n"
    "held-out errors over completed runs with the count of failed runs, and both engines'\n"
    "mean held-out error over the logs where both completed, with their ratio. Writes every\n"
    "error to a CSV (an empty parameter field means the model's value).\n"
    "\n"
    "options:\n");
  cli_printOptions(f, kIdentifyOptions, REPLAY_NUM(kIdentifyOptions));
  cli_printHelpOption(f);
  fprintf(f, "\nExit status: 0 success (failed runs are results, counted in the JSON); 1 the\n"
          "CSV could not be written; 2 bad usage or input.\n");
}


// Write the CSV fields of the parameters p (empty: the model's).
static void identify_csvParams(FILE* f, const double* p) {
  for (int k = 0; k < NPARAM; k++) {
    if (!isnan(p[k])) {
      fprintf(f, "%g", p[k]);
    }
    fputc(',', f);
  }
}


// Replay logs with fit->engine at parameters p; store each error in errors (if not NULL, NaN
// for a failed run), write CSV rows labelled split, and return the score.
static identifyScore identify_score(identifyState* s, const identifyFit* fit, double h,
                                    const double* p, const replayLog* logs, int n,
                                    const char* split, double* errors) {
  identifyScore score = {0, 0};
  replay_applyParams(s->m, s->base, p);
  for (int i = 0; i < n; i++) {
    cmpRunResult res;
    double error = replay_runLog(s->m, logs + i, fit->engine, h, &res, NULL);
    if (isnan(error)) {
      score.failed++;
    } else {
      score.mean += error;
    }
    if (errors) {
      errors[i] = error;
    }
    fprintf(s->csv, "%s,%g,", kCmpEngineNames[fit->engine], h);
    identify_csvParams(s->csv, p);
    fprintf(s->csv, "%s,%s,%.6g,%s\n", split, logs[i].path, error,
            kCmpOutcomeNames[res.outcome]);
  }
  score.mean = score.failed < n ? score.mean / (n - score.failed) : NAN;
  return score;
}


// 1 if score a is better than b: fewer failed runs, then a smaller mean.
static int identify_better(identifyScore a, identifyScore b) {
  if (a.failed != b.failed) {
    return a.failed < b.failed;
  }
  return a.mean < b.mean || (isnan(b.mean) && !isnan(a.mean));
}


// Identify one engine: grid search on the training logs, then the held-out logs.
static void identify_fit(identifyState* s, identifyFit* fit, double h) {
  int a0 = fit->axis[0], a1 = fit->axis[1];
  fit->train = (identifyScore){NAN, s->ntrain + 1};  // worse than any grid point
  for (int i = 0; i < s->ngrid[a0]; i++) {
    for (int j = 0; j < s->ngrid[a1]; j++) {
      double p[NPARAM] = {NAN, NAN, NAN};
      p[a0] = s->grid[a0][i];
      p[a1] = s->grid[a1][j];
      identifyScore score = identify_score(s, fit, h, p, s->train, s->ntrain, "train", NULL);
      if (cli_progress()) {
        char text[128];
        replay_formatParams(text, sizeof(text), p);
        fprintf(stderr, "ostrich: identify %s %s: mean training error %.4g, %d failed\n",
                kCmpEngineNames[fit->engine], text, score.mean, score.failed);
      }
      if (identify_better(score, fit->train)) {
        fit->train = score;
        memcpy(fit->best, p, sizeof(p));
      }
    }
  }

  // held out: at the identified parameters, and at the model's own for comparison
  double defaults[NPARAM] = {NAN, NAN, NAN};
  fit->test = identify_score(s, fit, h, fit->best, s->test, s->ntest, "test", fit->test_errors);
  fit->test_default = identify_score(s, fit, h, defaults, s->test, s->ntest, "test_default",
                                     NULL);
  if (cli_progress()) {
    fprintf(stderr, "ostrich: identify %s: held-out error %.4g, %d failed (model defaults: "
            "%.4g, %d failed)\n", kCmpEngineNames[fit->engine], fit->test.mean,
            fit->test.failed, fit->test_default.mean, fit->test_default.failed);
  }
}


// Print a score as JSON members "<name>_error" and "<name>_failed".
static void identify_reportScore(const char* name, identifyScore score) {
  printf(",\"%s_error\":", name);
  cli_jsonNumber(stdout, score.mean);
  printf(",\"%s_failed\":%d", name, score.failed);
}


// Print one engine's fit as a JSON member.
static void identify_reportFit(const identifyState* s, const identifyFit* fit, double h) {
  printf(",\"%s\":{\"h\":", kCmpEngineNames[fit->engine]);
  cli_jsonNumber(stdout, h);
  for (int k = 0; k < 2; k++) {
    printf(",\"%s\":", kParamNames[fit->axis[k]]);
    cli_jsonNumber(stdout, fit->best[fit->axis[k]]);
  }
  identify_reportScore("train", fit->train);
  identify_reportScore("test", fit->test);
  identify_reportScore("test_model_defaults", fit->test_default);
  printf(",\"test_errors\":");
  cmp_jsonArray(stdout, fit->test_errors, s->ntest);
  printf("}");
}


// Print the comparison on the held-out logs where both engines completed.
static void identify_reportCommon(const identifyState* s, const identifyFit* fits) {
  double sum[CMP_NENGINE] = {0, 0};
  int n = 0;
  for (int i = 0; i < s->ntest; i++) {
    if (!isnan(fits[CMP_MUJOCO].test_errors[i]) && !isnan(fits[CMP_OSTRICH].test_errors[i])) {
      sum[CMP_MUJOCO] += fits[CMP_MUJOCO].test_errors[i];
      sum[CMP_OSTRICH] += fits[CMP_OSTRICH].test_errors[i];
      n++;
    }
  }
  printf(",\"common_test_logs\":%d,\"common_test_error\":{\"ostrich\":", n);
  cli_jsonNumber(stdout, n ? sum[CMP_OSTRICH] / n : NAN);
  printf(",\"mujoco\":");
  cli_jsonNumber(stdout, n ? sum[CMP_MUJOCO] / n : NAN);
  printf("},\"common_test_error_ratio_mujoco_over_ostrich\":");
  cli_jsonNumber(stdout, n ? sum[CMP_MUJOCO] / sum[CMP_OSTRICH] : NAN);
}


// Read the model, the logs and the grids into s; return 0 on success.
static int identify_setup(const replayArgs* a, identifyState* s, char* buf, int buf_sz) {
  static const char* defaults[NPARAM] = {"210,240,270,300,330", "0.7,0.8,0.9,1.0",
                                         "0.005,0.01,0.02,0.04"};
  static const char* options[NPARAM] = {"--kv-grid", "--friction-grid", "--solref-grid"};
  for (int k = 0; k < NPARAM; k++) {
    s->ngrid[k] = cmp_parsePositiveList(options[k], a->grid[k] ? a->grid[k] : defaults[k],
                                        s->grid[k], REPLAY_MAX_GRID, 1);
    if (s->ngrid[k] < 0) {
      return 1;
    }
  }
  mjData* d = NULL;
  int status = cli_loadModel(a->model, &s->base, &d);
  if (d) {
    mj_deleteData(d);
  }
  if (status || !(s->m = mj_copyModel(NULL, s->base))) {
    return 1;
  }
  s->ntrain = replay_readLogs("--train", a->train, s->base, s->train, buf, buf_sz / 2);
  s->ntest = s->ntrain < 0 ? -1 : replay_readLogs("--test", a->test, s->base, s->test,
                                                  buf + buf_sz / 2, buf_sz / 2);
  if (s->ntest < 0) {
    return 1;
  }
  if (!(s->csv = cli_openOutput(a->csv, s->csv_tmp, sizeof(s->csv_tmp)))) {
    return 1;
  }
  fprintf(s->csv, "engine,h,kv,friction,solref,split,log,error,outcome\n");
  return 0;
}


// Free what the identification holds.
static void identify_free(identifyState* s) {
  for (int i = 0; i < REPLAY_MAX_LOGS; i++) {
    replay_freeLog(s->train + i);
    replay_freeLog(s->test + i);
  }
  if (s->m) {
    mj_deleteModel(s->m);
  }
  if (s->base) {
    mj_deleteModel(s->base);
  }
}


// `ostrich compare identify --train LOG,... --test LOG,... MODEL.xml [options]`
int compare_identify_main(int argc, char** argv) {
  replayArgs a = replay_defaultArgs();
  a.csv = "identify.csv";
  int use[CMP_NENGINE];
  if (cli_parseArgs("compare identify", argc, argv, kIdentifyOptions,
                    REPLAY_NUM(kIdentifyOptions), &a, &a.model, &a.help)) {
    return CLI_USAGE;
  }
  if (a.help) {
    identify_usage(stdout);
    return CLI_OK;
  }
  if (!a.model || !a.train || !a.test) {
    cli_error("compare identify: expected --train, --test and MODEL.xml (see --help)");
    return CLI_USAGE;
  }
  if (cmp_parseEngines(a.engine, use) || cli_checkOutput("--csv", a.csv)) {
    return CLI_USAGE;
  }

  // the logs' paths live in buf while the logs do; both are large, hence static
  static char buf[2 * 16384];
  static identifyState s;
  static double test_errors[CMP_NENGINE][REPLAY_MAX_LOGS];
  double start = cli_now();
  int status = CLI_USAGE;
  identifyFit fits[CMP_NENGINE] = {
    [CMP_MUJOCO] = {.engine = CMP_MUJOCO, .axis = {PARAM_FRICTION, PARAM_SOLREF}},
    [CMP_OSTRICH] = {.engine = CMP_OSTRICH, .axis = {PARAM_KV, PARAM_FRICTION}},
  };
  if (!identify_setup(&a, &s, buf, sizeof(buf))) {
    status = CLI_OK;
    for (int e = CMP_NENGINE - 1; e >= 0; e--) {
      fits[e].test_errors = test_errors[e];
      for (int i = 0; i < REPLAY_MAX_LOGS; i++) {
        test_errors[e][i] = NAN;
      }
      if (use[e]) {
        identify_fit(&s, fits + e, a.h[e]);
      }
    }

    // one JSON line: each engine's fit, then the comparison on the common held-out logs
    printf("{\"model\":");
    cli_jsonString(stdout, a.model);
    printf(",\"train_logs\":%d,\"test_logs\":%d", s.ntrain, s.ntest);
    for (int e = CMP_NENGINE - 1; e >= 0; e--) {
      if (use[e]) {
        identify_reportFit(&s, fits + e, a.h[e]);
      }
    }
    identify_reportCommon(&s, fits);
    printf(",\"csv\":");
    cli_jsonString(stdout, a.csv);
    printf(",\"wall_s\":%.3f}\n", cli_now() - start);
    fflush(stdout);
  }
  if (s.csv && status == CLI_OK) {
    status = cli_commitOutput(s.csv, s.csv_tmp, a.csv) ? CLI_FAIL : CLI_OK;
  } else if (s.csv) {
    cli_discardOutput(s.csv, s.csv_tmp);
  }
  identify_free(&s);
  return status;
}


//---------------------------------- gen-logs ------------------------------------------------------

// The synthetic logs: traversals of the pallet at 14 speeds (0.12 to 2.05 m/s) with heading
// changes up to 130 deg, 4 for training and 10 held out (as the paper's split).
typedef struct genlogCase_ {
  double speed;                   // m/s
  double turn_deg;                // heading change, + = left
  int    train;                   // 1: training log, 0: held out
} genlogCase;

static const genlogCase kGenlogCases[] = {
  {0.12, 30, 0},   {0.27, -60, 0},  {0.42, 90, 1},   {0.57, -130, 0}, {0.72, 0, 0},
  {0.87, 45, 0},   {1.02, -90, 1},  {1.17, 130, 0},  {1.31, -20, 0},  {1.46, 75, 1},
  {1.61, -110, 0}, {1.76, 60, 0},   {1.90, -45, 1},  {2.05, 110, 0},
};

#define GENLOG_NUM     ((int)(sizeof(kGenlogCases) / sizeof(kGenlogCases[0])))
#define GENLOG_H       0.0005     // step of the stock MuJoCo reference (s)
#define GENLOG_KV      270.0      // "true" servo gain (the model: 300)
#define GENLOG_MU      0.85       // "true" friction (the model: 1.0)
#define GENLOG_SIGMA_P 0.01       // measurement noise on x, y, z (m)
#define GENLOG_SIGMA_Y 0.01       // measurement noise on yaw (rad)
#define GENLOG_CROSSED 2.6        // base x (m) past which the rear wheel has left the pallet


// Standard normal draw (Box-Muller).
static double genlog_gauss(cliRng* rng) {
  double u = cli_uniform(rng, 0, 1), v = cli_uniform(rng, 0, 1);
  return sqrt(-2 * log(1 - u)) * cos(2 * 3.14159265358979323846 * v);
}


// Write one log: the commands, and the reference's pose at their times plus noise.
static int genlog_write(const char* path, const char* label, const cmpCommands* c,
                        const cmpTrajectory* tr, long seed, cliRng* rng) {
  char tmp[CLI_PATH_SZ];
  FILE* f = cli_openOutput(path, tmp, sizeof(tmp));
  if (!f) {
    return 1;
  }
  fprintf(f,
    "# SYNTHETIC LOG, NOT A MEASUREMENT. Written by `ostrich compare gen-logs --seed %ld`.\n"
    "# Reference: stock MuJoCo %s at h = %g s on robot_pallet.xml with \"true\" parameters\n"
    "#   kv = %g (model 300) on every velocity servo, friction = %g (model 1.0) on every geom,\n"
    "#   solref as the model; then Gaussian noise on the pose: sigma %g m on x, y, z and\n"
    "#   %g rad on yaw.\n"
    "# Label: %s\n"
    "# Columns: time (s); wheel-velocity commands (rad/s) of v_left, v_right, v_rear;\n"
    "#   measured base position x, y, z (m) and yaw (rad, in (-pi, pi]). 100 Hz.\n",
    seed, mj_versionString(), GENLOG_H, GENLOG_KV, GENLOG_MU, GENLOG_SIGMA_P, GENLOG_SIGMA_Y,
    label);
  fprintf(f, "time,%s,%s,%s,x,y,z,yaw\n", kCmpRobotColumns[0], kCmpRobotColumns[1],
          kCmpRobotColumns[2]);
  for (int i = 0; i < c->nrow; i++) {
    double pose[4];
    cmp_sampleAt(tr, c->time[i], pose);
    for (int j = 0; j < 3; j++) {
      pose[j] += GENLOG_SIGMA_P * genlog_gauss(rng);
    }
    pose[3] = cmp_wrapAngle(pose[3] + GENLOG_SIGMA_Y * genlog_gauss(rng));
    const double* u = c->ctrl + 3 * i;
    fprintf(f, "%.2f,%.6g,%.6g,%.6g,%.4f,%.4f,%.4f,%.4f\n", c->time[i], u[0], u[1], u[2],
            pose[0], pose[1], pose[2], pose[3]);
  }
  return cli_commitOutput(f, tmp, path);
}


// 1 if the reference's base got past x = GENLOG_CROSSED (the rear wheel off the pallet).
static int genlog_crossed(const cmpTrajectory* tr) {
  for (int i = 0; i < tr->n; i++) {
    if (tr->coord[4 * i] > GENLOG_CROSSED) {
      return 1;
    }
  }
  return 0;
}


// Generate log k into dir (name from its split) and add its line to the index; return CLI_*.
static int genlog_one(mjModel* m, int k, const char* dir, FILE* index, long seed, cliRng* rng,
                      int* ntrain, int* ntest) {
  const genlogCase* g = kGenlogCases + k;
  cmpTraversal p = {g->speed, g->turn_deg * 3.14159265358979323846 / 180};
  cmpCommands c;
  if (cmp_traversalCommands(&p, 100, &c)) {
    return CLI_FAIL;
  }

  // the reference from the model's initial pose (origin, heading +x)
  cmpRunSpec spec = {.engine = CMP_MUJOCO, .h = GENLOG_H, .duration = c.time[c.nrow - 1],
                     .commands = &c};
  cmpTrajectory tr;
  cmpRunResult res;
  int status = CLI_OK;
  if (cmp_run(m, &spec, &tr, &res) || res.outcome != CMP_COMPLETED) {
    cli_error("gen-logs: the reference run of log %d failed: %s", k + 1, res.why);
    status = CLI_FAIL;
  }
  if (status == CLI_OK) {
    char name[64], path[4096], label[256];
    snprintf(name, sizeof(name), g->train ? "train_%02d.csv" : "test_%02d.csv",
             g->train ? ++*ntrain : ++*ntest);
    snprintf(path, sizeof(path), "%s/%s", dir, name);
    snprintf(label, sizeof(label), "split=%s speed=%.2f m/s turn=%+.0f deg duration=%.2f s "
             "crossed_pallet=%s", g->train ? "train" : "test", g->speed, g->turn_deg,
             spec.duration, genlog_crossed(&tr) ? "yes" : "no (stalls at its edge)");
    status = genlog_write(path, label, &c, &tr, seed, rng) ? CLI_FAIL : CLI_OK;
    fprintf(index, "%s,%s,%.2f,%.0f,%.2f,%d\n", name, g->train ? "train" : "test", g->speed,
            g->turn_deg, spec.duration, genlog_crossed(&tr));
    if (cli_progress()) {
      fprintf(stderr, "ostrich: gen-logs %d/%d: %s (%s)\n", k + 1, GENLOG_NUM, path, label);
    }
  }
  cmp_freeTrajectory(&tr);
  cmp_freeCommands(&c);
  return status;
}


// Print the usage of `ostrich compare gen-logs`.
static void genlogs_usage(FILE* f) {
  fprintf(f,
    "usage: ostrich compare gen-logs --out DIR [MODEL.xml] [options]\n"
    "\n"
    "Write 14 SYNTHETIC logs of the robot traversing the pallet (speeds 0.12 to 2.05 m/s,\n"
    "heading changes up to 130 deg after the pallet), in the log format of `ostrich compare\n"
    "replay`: DIR/train_01..04.csv and DIR/test_01..10.csv. The pose is that of stock MuJoCo\n"
    "at h = 0.5 ms with \"true\" parameters (kv 270, friction 0.85 on every geom) plus\n"
    "Gaussian noise (0.01 m, 0.01 rad). Also writes DIR/index.csv (file, split, speed, turn)\n"
    "and DIR/pallet_commands.csv (the default traversal, as compare/pallet_commands.csv).\n"
    "MODEL.xml is the robot scene (default mjcf_models/robot_pallet.xml). DIR is checked\n"
    "before the reference runs; each file is written to a temporary name, then renamed.\n"
    "\n"
    "options:\n");
  cli_printOptions(f, kGenlogsOptions, REPLAY_NUM(kGenlogsOptions));
  cli_printHelpOption(f);
}


// `ostrich compare gen-logs --out DIR [MODEL.xml] [--seed S] [--logs N]`
int compare_genlogs_main(int argc, char** argv) {
  replayArgs a = replay_defaultArgs();
  const char* model = NULL;
  if (cli_parseArgs("compare gen-logs", argc, argv, kGenlogsOptions,
                    REPLAY_NUM(kGenlogsOptions), &a, &model, &a.help)) {
    return CLI_USAGE;
  }
  if (a.help) {
    genlogs_usage(stdout);
    return CLI_OK;
  }
  if (!a.out) {
    cli_error("compare gen-logs: missing --out DIR (see ostrich compare gen-logs --help)");
    return CLI_USAGE;
  }
  a.model = model ? model : "mjcf_models/robot_pallet.xml";
  if (cli_checkOutputDir("--out", a.out)) {
    return CLI_USAGE;
  }

  // the robot model with the "true" parameters; the output directory
  mjModel *base = NULL, *m = NULL;
  mjData* d = NULL;
  int status = CLI_USAGE;
  if (!cli_loadModel(a.model, &base, &d) && (m = mj_copyModel(NULL, base))) {
    status = CLI_OK;
    if (!cmp_isRobot(m) || cmp_modelKind(m) != CMP_POSE) {
      cli_error("gen-logs: '%s' is not the robot (free base, actuators v_left, v_right, "
                "v_rear)", a.model);
      status = CLI_USAGE;
    }
  }
  char path[4096], index_path[4096], index_tmp[CLI_PATH_SZ];
  FILE* index = NULL;
  if (status == CLI_OK) {
    double p[NPARAM] = {GENLOG_KV, GENLOG_MU, NAN};
    replay_applyParams(m, base, p);
    snprintf(index_path, sizeof(index_path), "%s/index.csv", a.out);
    if (!(index = cli_openOutput(index_path, index_tmp, sizeof(index_tmp)))) {
      status = CLI_USAGE;
    }
  }

  // the default commands, then the logs; the noise stream runs through all logs in order
  int nlog = a.nlog < GENLOG_NUM ? (int)a.nlog : GENLOG_NUM, ntrain = 0, ntest = 0;
  double start = cli_now();
  if (status == CLI_OK) {
    cmpCommands c;
    const char* names[3] = {"v_left", "v_right", "v_rear"};
    snprintf(path, sizeof(path), "%s/pallet_commands.csv", a.out);
    status = cmp_traversalCommands(&kCmpDefaultTraversal, 100, &c) ||
             cmp_writeCommands(path, &c, names) ? CLI_FAIL : CLI_OK;
    cmp_freeCommands(&c);
    fprintf(index, "# SYNTHETIC logs of `ostrich compare gen-logs --seed %ld`\n"
            "file,split,speed,turn_deg,duration,crossed_pallet\n", a.seed);
  }
  cliRng rng;
  cli_rngSeed(&rng, (unsigned long long)a.seed);
  for (int k = 0; k < nlog && status == CLI_OK; k++) {
    status = genlog_one(m, k, a.out, index, a.seed, &rng, &ntrain, &ntest);
  }
  if (index && status == CLI_OK) {
    status = cli_commitOutput(index, index_tmp, index_path) ? CLI_FAIL : CLI_OK;
  } else if (index) {
    cli_discardOutput(index, index_tmp);
  }
  if (status == CLI_OK) {
    printf("{\"out\":");
    cli_jsonString(stdout, a.out);
    printf(",\"logs\":%d,\"train\":%d,\"test\":%d,\"seed\":%ld,\"synthetic\":true,"
           "\"reference\":{\"engine\":\"mujoco\",\"h\":%g,\"kv\":%g,\"friction\":%g},"
           "\"wall_s\":%.3f}\n", nlog, ntrain, ntest, a.seed, GENLOG_H,
           GENLOG_KV, GENLOG_MU, cli_now() - start);
  }
  if (d) {
    mj_deleteData(d);
  }
  if (m) {
    mj_deleteModel(m);
  }
  if (base) {
    mj_deleteModel(base);
  }
  return status;
}
