// compare_sweep.c: `ostrich compare sweep`, the timestep sweep of the A/B harness.
// Every engine runs at every step size of a grid on the same commands; each run's error against
// one reference trajectory (compare_run.c's metric), its wall time per simulated second and its
// divergence are written to DIR/sweep.csv, plotted with gnuplot (error against h, error against
// wall time), and summarised per engine by its usable plateau. Mirrors a MAGMA tester's sweep:
// one row per (engine, h), a summary line at the end.
//
// Invariant: every run starts from the model's qpos0 with a fresh mjData; within a repeat every
// run sees the same commands, and the repeat's reference is fixed before its first run.
#define _POSIX_C_SOURCE 200809L

#include <errno.h>
#include <math.h>
#include <stddef.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

#include "compare.h"
#include "compare_run.h"

#define SWEEP_MAX_H   32          // step sizes in a grid
#define SWEEP_PATH_SZ 4096        // size of an output path


//---------------------------------- Arguments -----------------------------------------------------

typedef struct sweepArgs_ {       // arguments of `ostrich compare sweep`
  const char* model;              // MJCF path (positional)
  const char* ctrl_file;          // command CSV; NULL: built-in traversal (robot) or zeros
  const char* h_grid;             // comma list of step sizes (s)
  const char* engine;             // comma list of engines
  const char* reference;          // trajectory CSV; NULL: stock MuJoCo at h_ref
  double      h_ref;              // step of the reference run; 0: the grid's smallest h / 2
  double      duration;           // simulated seconds; 0: from the commands or reference
  double      ceiling;            // error (m or rad) above which a run counts as diverged
  long        repeat;             // runs per engine and h, the commands perturbed by 1e-9
  const char* out;                // output directory
  long        key;                // start from this keyframe; -1: qpos0 at rest
  int         help;               // --help was given
} sweepArgs;

static const cliOption kSweepOptions[] = {
  {"--key", CLI_ARG_COUNT, offsetof(sweepArgs, key), "K",
   "start every run and the reference from keyframe K (mj_resetDataKeyframe:\n"
   "time, qpos, qvel, act, ctrl, mocap); default: qpos0 at rest"},
  {"--ctrl-file", CLI_ARG_STRING, offsetof(sweepArgs, ctrl_file), "CMD.csv",
   "commands: header time,<one column per actuator>; zero-order hold.\n"
   "Default: the robot (actuators v_left,v_right,v_rear) gets the built-in\n"
   "traversal of compare/pallet_commands.csv, other models all zeros"},
  {"--h-grid", CLI_ARG_STRING, offsetof(sweepArgs, h_grid), "H1,H2,...",
   "step sizes (s) (default 0.0005,0.001,0.002,0.005,0.01,0.02,0.05,0.1,0.2)"},
  {"--engine", CLI_ARG_STRING, offsetof(sweepArgs, engine), "ostrich,mujoco",
   "engines to sweep (default both)"},
  {"--reference", CLI_ARG_STRING, offsetof(sweepArgs, reference), "FILE.csv",
   "reference trajectory: a log (time,...,x,y,z,yaw) or `ostrich sim --csv`\n"
   "CSV. Default: stock MuJoCo at --h-ref on the same commands"},
  {"--h-ref", CLI_ARG_POSITIVE, offsetof(sweepArgs, h_ref), "SEC",
   "step of the reference MuJoCo run (default: the grid's smallest h / 2)"},
  {"--duration", CLI_ARG_POSITIVE, offsetof(sweepArgs, duration), "SEC",
   "simulated time (default: the last command time, else the reference\n"
   "file's last time, else 5 s)"},
  {"--ceiling", CLI_ARG_POSITIVE, offsetof(sweepArgs, ceiling), "ERR",
   "error above which a run counts as diverged (default 0.5)"},
  {"--repeat", CLI_ARG_COUNT, offsetof(sweepArgs, repeat), "N",
   "repeat the sweep N times (default 5); repeat r > 0 multiplies every\n"
   "command by 1 + 1e-9 u, u uniform in [-1, 1] (and, without --reference,\n"
   "runs its own reference); errors are averaged (contact at the pallet's\n"
   "edge is chaotic)"},
  {"--out", CLI_ARG_STRING, offsetof(sweepArgs, out), "DIR",
   "output directory, created if missing (default ./sweep); checked\n"
   "before the runs; each file written to a temporary name, then renamed"},
};

static const int kSweepNumOptions = (int)(sizeof(kSweepOptions) / sizeof(kSweepOptions[0]));


// Print the usage of `ostrich compare sweep`.
static void sweep_usage(FILE* f) {
  fprintf(f,
    "usage: ostrich compare sweep MODEL.xml [options]\n"
    "\n"
    "Run each engine at each step size h of a grid on the same commands, from the model's\n"
    "initial state. Each run's error against the reference: for a free-floating base\n"
    "sqrt(<|dp|^2> + (0.5 m * RMS(dyaw))^2) over samples every 10 ms (p the base position,\n"
    "yaw wrapped to (-pi, pi]); otherwise the RMS of |dqpos|. A run diverged if its state\n"
    "became non-finite, a step failed, or its error is above --ceiling. With --repeat N,\n"
    "each (engine, h) runs N times on perturbed commands, the error is the mean over the\n"
    "repeats and the run diverged if any repeat did.\n"
    "An engine's plateau is the longest run of consecutive grid steps that holds the step of\n"
    "its smallest error (the reference run itself excluded) in which no run diverged and\n"
    "every error is at most twice that smallest error; its largest h is the plateau edge.\n"
    "The strict edge is the edge if no smaller h of the grid diverged, else null.\n"
    "\n"
    "Writes DIR/sweep.csv (one row per engine and h), DIR/error_vs_h.png and\n"
    "DIR/error_vs_walltime.png (gnuplot, pngcairo; skipped with a warning without gnuplot),\n"
    "and prints one JSON line: per engine the smallest error and the plateau edges, and the\n"
    "ratio of the engines' edges. Progress on stderr, one line per run.\n"
    "\n"
    "options:\n");
  cli_printOptions(f, kSweepOptions, kSweepNumOptions);
  cli_printHelpOption(f);
  fprintf(f,
    "\n"
    "Full run on the pallet (about 15 s on one core):\n"
    "  ostrich compare sweep mjcf_models/robot_pallet.xml \\\n"
    "      --ctrl-file compare/pallet_commands.csv --out /tmp/sweep\n"
    "Exit status: 0 success (diverged runs are results, not failures); 1 the reference run\n"
    "failed or an output could not be written; 2 bad usage or input.\n");
}


//---------------------------------- Runs ----------------------------------------------------------

typedef struct sweepRow_ {        // one engine at one h, accumulated over the repeats
  int    engine;                  // cmpEngine
  double h;                       // step size (s)
  int    is_reference;            // this run is the reference itself
  int    nrepeat;                 // repeats run
  int    ndiverged;               // repeats that diverged (outcome or error above the ceiling)
  int    failure;                 // first failed cmpOutcome over the repeats, else completed
  long   steps;                   // steps of the last repeat
  double simulated;               // simulated time, summed over repeats (s)
  double wall;                    // wall time in the step calls, summed over repeats (s)
  double iter;                    // mean solver iterations, summed over repeats
  double max_penetration;         // deepest contact over all repeats (m)
  double error_sum;               // error against the reference, summed over repeats
  double error_min, error_max;    // its range over the repeats
  double error;                   // mean error over the repeats (after sweep_finish)
  int    diverged;                // any repeat diverged
  int    in_plateau;              // the row belongs to its engine's plateau
} sweepRow;

typedef struct sweepPlateau_ {    // an engine's summary
  int    nrun;                    // runs of this engine
  int    ndiverged;               // of which diverged
  int    ndiverged_below;         // of which below the plateau
  double min_error;               // smallest error, reference run excluded (NaN: none)
  double lo;                      // smallest h of the plateau (s), NaN if none
  double edge;                    // largest h of the plateau, the plateau edge (s), NaN if none
  double strict_edge;             // edge if no smaller h diverged, else NaN
} sweepPlateau;

typedef struct sweepState_ {      // the whole sweep
  mjModel*      m;                // model
  cmpCommands   commands;         // controls as given (nrow 0: zeros)
  cmpCommands   perturbed;        // the controls of the current repeat
  const char*   commands_source;  // "file", "builtin" or "zero"
  double        duration;         // simulated time (s)
  double        h[SWEEP_MAX_H];   // grid, ascending
  int           nh;               // grid size
  int           use[CMP_NENGINE]; // engines swept
  cmpTrajectory reference;        // the reference trajectory
  double        h_ref;            // reference step (s), 0 if from a file
  sweepRow*     rows;             // runs, engine-major, h ascending                 (nrow)
  int           nrow;             // runs
  sweepPlateau  plateau[CMP_NENGINE];  // per engine
  char          csv_path[SWEEP_PATH_SZ];
  int           plots;            // 1 if the two PNGs were written
  int           key;              // runs start from keyframe key - 1; 0: qpos0 at rest
} sweepState;


// Resolve the commands and the duration; return 0 on success.
static int sweep_commands(const sweepArgs* a, sweepState* s) {
  if (a->ctrl_file) {
    s->commands_source = "file";
    if (cmp_readCommands(a->ctrl_file, s->m->nu, &s->commands)) {
      return 1;
    }
  } else if (cmp_isRobot(s->m)) {
    s->commands_source = "builtin";
    if (cmp_traversalCommands(&kCmpDefaultTraversal, 100, &s->commands)) {
      return 1;
    }
  } else {
    s->commands_source = "zero";
  }
  double last = s->commands.nrow ? s->commands.time[s->commands.nrow - 1] : 0;
  s->duration = a->duration > 0 ? a->duration : (last > 0 ? last : 5.0);
  return 0;
}


// The commands of repeat r into s->perturbed: as given for r = 0, else each control times
// 1 + 1e-9 u (u uniform in [-1, 1], seeded by r), a perturbation at the level of round-off.
static int sweep_perturb(sweepState* s, int r) {
  cmp_freeCommands(&s->perturbed);
  if (!s->commands.nrow) {
    return 0;
  }
  if (cmp_allocCommands(&s->perturbed, s->commands.nrow, s->commands.nu)) {
    return 1;
  }
  cliRng rng;
  cli_rngSeed(&rng, (unsigned long long)r);
  size_t n = (size_t)s->commands.nrow * (size_t)s->commands.nu;
  memcpy(s->perturbed.time, s->commands.time, sizeof(double) * (size_t)s->commands.nrow);
  for (size_t i = 0; i < n; i++) {
    s->perturbed.ctrl[i] = s->commands.ctrl[i] * (r ? 1 + 1e-9 * cli_uniform(&rng, -1, 1) : 1);
  }
  return 0;
}


// Fix the reference of repeat r: read the file (once), or run stock MuJoCo at h_ref on this
// repeat's commands; return CLI_OK, CLI_FAIL (the reference run failed) or CLI_USAGE (file).
static int sweep_reference(const sweepArgs* a, sweepState* s, int r) {
  if (a->reference) {
    if (r > 0) {
      return CLI_OK;
    }
    cmpTable t;
    int kind = cmp_modelKind(s->m);
    if (cmp_readTable(a->reference, &t)) {
      return CLI_USAGE;
    }
    int status = cmp_tableTrajectory(a->reference, &t, kind, s->m->nq, 0, &s->reference);
    cmp_freeTable(&t);

    // without commands or --duration, run as long as the reference
    if (!status && !(a->duration > 0) && !s->commands.nrow) {
      s->duration = s->reference.time[s->reference.n - 1];
    }
    return status ? CLI_USAGE : CLI_OK;
  }
  cmpRunResult res;
  cmpRunSpec spec = {.engine = CMP_MUJOCO, .h = s->h_ref, .duration = s->duration,
                     .commands = s->perturbed.nrow ? &s->perturbed : NULL, .key = s->key};
  cmp_freeTrajectory(&s->reference);
  if (cmp_run(s->m, &spec, &s->reference, &res) || res.outcome != CMP_COMPLETED) {
    cli_error("the reference run (mujoco, h = %g) failed: %s", s->h_ref, res.why);
    return CLI_FAIL;
  }
  if (cli_progress()) {
    fprintf(stderr, "ostrich: sweep: repeat %d: reference mujoco h=%g: %ld steps, %.3f s wall\n",
            r + 1, s->h_ref, res.steps, res.wall);
  }
  return CLI_OK;
}


// Allocate one row per engine and h: engine-major (ostrich first), h ascending.
static int sweep_allocRows(sweepState* s) {
  int nengine = 0;
  for (int e = 0; e < CMP_NENGINE; e++) {
    nengine += s->use[e];
  }
  s->rows = calloc((size_t)(nengine * s->nh), sizeof(sweepRow));
  if (!s->rows) {
    cli_error("out of memory");
    return 1;
  }
  for (int e = CMP_NENGINE - 1; e >= 0; e--) {
    for (int k = 0; k < s->nh && s->use[e]; k++) {
      s->rows[s->nrow++] = (sweepRow){.engine = e, .h = s->h[k], .error_min = INFINITY,
                                      .error_max = -INFINITY, .is_reference = s->h_ref > 0 &&
                                      e == CMP_MUJOCO && s->h[k] == s->h_ref};
    }
  }
  return 0;
}


// Run one row once (one repeat), measure its error and add the results; return 0 unless out
// of memory. The error of a repeat that diverged is still summed (it is shown, not used).
static int sweep_runOne(sweepState* s, sweepRow* row, double ceiling, double* error,
                        cmpRunResult* res) {
  cmpTrajectory tr;
  cmpRunSpec spec = {.engine = row->engine, .h = row->h, .duration = s->duration,
                     .commands = s->perturbed.nrow ? &s->perturbed : NULL, .key = s->key};
  int oom = cmp_run(s->m, &spec, &tr, res);
  *error = oom ? NAN : cmp_trajectoryError(&tr, &s->reference, CMP_SAMPLE_DT);
  cmp_freeTrajectory(&tr);
  if (oom) {
    cli_error("out of memory in the run");
    return 1;
  }
  int diverged = res->outcome != CMP_COMPLETED || !(*error <= ceiling);
  row->nrepeat++;
  row->ndiverged += diverged;
  row->failure = row->failure ? row->failure : res->outcome;
  row->steps = res->steps;
  row->simulated += res->simulated;
  row->wall += res->wall;
  row->iter += res->mean_iter;
  row->max_penetration = fmax(row->max_penetration, res->max_penetration);
  row->error_sum += *error;
  row->error_min = fmin(row->error_min, *error);
  row->error_max = fmax(row->error_max, *error);
  return 0;
}


// Run every row once for repeat r, printing one progress line per run; return 0 on success.
static int sweep_runAll(sweepState* s, double ceiling, int r, int repeats) {
  for (int i = 0; i < s->nrow; i++) {
    sweepRow* row = s->rows + i;
    double error;
    cmpRunResult res;
    if (sweep_runOne(s, row, ceiling, &error, &res)) {
      return 1;
    }
    if (cli_progress()) {
      int diverged = res.outcome != CMP_COMPLETED || !(error <= ceiling);
      fprintf(stderr, "ostrich: sweep %d/%d (repeat %d/%d): %s h=%g: error %.4g, %.4g s wall "
              "per simulated s, %s%s%s%s\n", i + 1, s->nrow, r + 1, repeats,
              kCmpEngineNames[row->engine], row->h, error,
              res.wall / fmax(res.simulated, 1e-300), diverged ? "DIVERGED, " : "",
              kCmpOutcomeNames[res.outcome], res.why[0] ? ": " : "", res.why);
    }
  }
  return 0;
}


// Turn the sums of the rows into means.
static void sweep_finish(sweepState* s) {
  for (int i = 0; i < s->nrow; i++) {
    sweepRow* row = s->rows + i;
    double n = row->nrepeat > 0 ? row->nrepeat : 1;
    row->error = row->error_sum / n;
    row->iter /= n;
    row->diverged = row->ndiverged > 0;
  }
}


//---------------------------------- Plateaus ------------------------------------------------------

// 1 if run r is usable for the plateau of min_error: not diverged, error within 2x.
static int sweep_within(const sweepRow* r, double min_error) {
  return !r->diverged && (r->is_reference || r->error <= 2 * min_error);
}


// Summarise engine e: smallest error and plateau (see sweep_usage for the definition).
static void sweep_plateau(sweepState* s, int e, sweepPlateau* p) {
  *p = (sweepPlateau){.min_error = NAN, .lo = NAN, .edge = NAN, .strict_edge = NAN};

  // the engine's runs are consecutive in s->rows, in ascending h; find its smallest error
  int first = -1, best = -1;
  for (int i = 0; i < s->nrow; i++) {
    const sweepRow* r = s->rows + i;
    if (r->engine != e) {
      continue;
    }
    first = first < 0 ? i : first;
    p->nrun++;
    p->ndiverged += r->diverged;
    if (!r->diverged && !r->is_reference && !(r->error >= p->min_error)) {
      p->min_error = r->error;
      best = i;
    }
  }
  // only the reference run itself did not diverge: the plateau is that run alone
  for (int i = first; best < 0 && i >= 0 && i < first + p->nrun; i++) {
    if (s->rows[i].is_reference && !s->rows[i].diverged) {
      best = i;
      p->min_error = 0;
    }
  }
  if (best < 0) {
    return;
  }

  // grow the plateau from the best run in both directions while runs stay within 2x
  int lo = best, hi = best;
  while (lo > first && sweep_within(s->rows + lo - 1, p->min_error)) {
    lo--;
  }
  while (hi + 1 < first + p->nrun && sweep_within(s->rows + hi + 1, p->min_error)) {
    hi++;
  }
  p->lo = s->rows[lo].h;
  p->edge = s->rows[hi].h;
  for (int i = first; i < lo; i++) {
    p->ndiverged_below += s->rows[i].diverged;
  }
  p->strict_edge = p->ndiverged_below ? NAN : p->edge;
  for (int i = lo; i <= hi; i++) {
    s->rows[i].in_plateau = 1;
  }
}


//---------------------------------- Output --------------------------------------------------------

// Write DIR/sweep.csv; return 0 on success.
static int sweep_writeCsv(sweepState* s, const char* dir) {
  snprintf(s->csv_path, sizeof(s->csv_path), "%s/sweep.csv", dir);
  char tmp[SWEEP_PATH_SZ + 32];
  FILE* f = cli_openOutput(s->csv_path, tmp, sizeof(tmp));
  if (!f) {
    return 1;
  }
  fprintf(f, "engine,h,steps,simulated_s,wall_s,wall_per_sim_s,error,diverged,outcome,"
          "mean_iter,max_penetration,within_2x_min,in_plateau,repeats,diverged_repeats,"
          "error_min,error_max\n");
  for (int i = 0; i < s->nrow; i++) {
    const sweepRow* r = s->rows + i;
    const sweepPlateau* p = s->plateau + r->engine;
    const char* outcome = r->failure ? kCmpOutcomeNames[r->failure] :
                          (r->diverged ? "error_ceiling" : "completed");
    fprintf(f, "%s,%.10g,%ld,%.10g,%.6g,%.6g,%.6g,%d,%s,%.4g,%.4g,%d,%d,%d,%d,%.6g,%.6g\n",
            kCmpEngineNames[r->engine], r->h, r->steps, r->simulated / r->nrepeat,
            r->wall / r->nrepeat, r->wall / fmax(r->simulated, 1e-300), r->error, r->diverged,
            outcome, r->iter, r->max_penetration, sweep_within(r, p->min_error), r->in_plateau,
            r->nrepeat, r->ndiverged, r->error_min, r->error_max);
  }
  return cli_commitOutput(f, tmp, s->csv_path);
}


// Write the gnuplot script of one plot into f, drawn into the file named by gnuplot variable
// var (default png); x is the CSV column of the abscissa.
static void sweep_writePlot(FILE* f, const sweepState* s, const char* var, const char* png,
                            const char* xlabel, int x, double ceiling) {
  static const char* color[CMP_NENGINE] = {"#e07b00", "#1f5fbf"};  // mujoco, ostrich
  fprintf(f, "if (!exists('%s')) %s = '%s'\nset output %s\nset xlabel '%s'\n", var, var, png,
          var, xlabel);
  // the ceiling is drawn through the data's abscissae, so the axes always get a valid range
  fprintf(f, "plot '%s' using ($%d > 0 ? $%d : 1/0):(%g) smooth unique with lines dt 2 "
          "lc rgb 'gray40' title 'divergence ceiling'", s->csv_path, x, x, ceiling);
  for (int e = CMP_NENGINE - 1; e >= 0; e--) {
    if (!s->use[e]) {
      continue;
    }
    // columns: 1 engine, 2 h, 6 wall per simulated s, 7 error, 8 diverged; a diverged run is
    // drawn at min(error, ceiling), at the ceiling if it has no error
    const char* name = kCmpEngineNames[e];
    fprintf(f, ", \\\n  '%s' using (strcol(1) eq '%s' && $8 == 0 && $7 > 0 ? $%d : 1/0):7 "
            "with linespoints lw 2 pt 7 lc rgb '%s' title '%s'", s->csv_path, name, x, color[e],
            name);
    fprintf(f, ", \\\n  '' using (strcol(1) eq '%s' && $8 != 0 ? $%d : 1/0):"
            "($7 == $7 && $7 > 0 && $7 < %g ? $7 : %g) with points pt 2 ps 2 lw 2 lc rgb '%s' "
            "title '%s diverged'", name, x, ceiling, ceiling, color[e], name);
    fprintf(f, ", \\\n  '' using (strcol(1) eq '%s' && ($7 > 0 || $8 != 0) ? $%d : 1/0):"
            "($7 == $7 && $7 > 0 && $7 < %g ? $7 : %g):(sprintf('%%g', $2)) with labels "
            "offset 0.5,0.7 font ',8' tc rgb '%s' notitle", name, x, ceiling, ceiling, color[e]);
  }
  fprintf(f, "\n");
}


// Write DIR/sweep.gp and run gnuplot on it; set s->plots. Missing gnuplot is only a warning.
// gnuplot draws each PNG into its temporary name; both are renamed once it succeeds.
static void sweep_plots(sweepState* s, const char* dir, const char* model, double ceiling,
                        int repeats) {
  static const char* kPng[2] = {"error_vs_h.png", "error_vs_walltime.png"};
  char gp[SWEEP_PATH_SZ], gp_tmp[SWEEP_PATH_SZ + 32], log[SWEEP_PATH_SZ];
  char png[2][SWEEP_PATH_SZ], png_tmp[2][SWEEP_PATH_SZ + 32];
  snprintf(gp, sizeof(gp), "%s/sweep.gp", dir);
  snprintf(log, sizeof(log), "%s/gnuplot.log", dir);
  for (int i = 0; i < 2; i++) {
    snprintf(png[i], sizeof(png[i]), "%s/%s", dir, kPng[i]);
    cli_outputTemp(png[i], png_tmp[i], sizeof(png_tmp[i]));
  }
  if (strchr(dir, '\'')) {
    cli_error("plots skipped: the output directory's name contains a quote");
    return;
  }
  FILE* f = cli_openOutput(gp, gp_tmp, sizeof(gp_tmp));
  if (!f) {
    cli_error("plots skipped");
    return;
  }
  fprintf(f, "# written by `ostrich compare sweep`; rerun with: gnuplot %s\n"
          "set datafile separator ','\nset terminal pngcairo size 1000,650 font 'Sans,11'\n"
          "set logscale xy\nset grid\nset key outside right top\nset format x '%%g'\n"
          "set ylabel 'error against the reference (m)'\n", gp);
  const char* base = strrchr(model, '/') ? strrchr(model, '/') + 1 : model;
  fprintf(f, "set title '%s: error against %s, mean of %d repeats (labels: h in s)' "
          "noenhanced\n", base,
          s->h_ref > 0 ? "stock MuJoCo at the reference step" : "the reference file", repeats);
  sweep_writePlot(f, s, "out_h", png[0], "step size h (s)", 2, ceiling);
  sweep_writePlot(f, s, "out_wall", png[1], "wall time per simulated second (s)", 6, ceiling);
  if (cli_commitOutput(f, gp_tmp, gp)) {
    cli_error("plots skipped");
    return;
  }
  // this run draws into the temporary names (the script alone draws into the final ones)
  char vars[3 * SWEEP_PATH_SZ];
  snprintf(vars, sizeof(vars), "out_h = '%s'; out_wall = '%s'", png_tmp[0], png_tmp[1]);
  char* argv[] = {"gnuplot", "-e", vars, gp, NULL};
  int status = cmp_spawn(argv, log, log);
  if (status == 127) {
    cli_error("plots skipped: gnuplot not found (install gnuplot-nox); script in %s", gp);
  } else if (status) {
    cli_error("plots failed: gnuplot exit %d, see %s", status, log);
  }
  s->plots = !status;
  for (int i = 0; i < 2; i++) {
    if (status) {
      cli_discardOutput(NULL, png_tmp[i]);
    } else if (cli_commitOutput(NULL, png_tmp[i], png[i])) {
      s->plots = 0;
    }
  }
}


// Print the one-line JSON summary.
static void sweep_report(const sweepArgs* a, const sweepState* s, const char* dir, double wall) {
  printf("{\"model\":");
  cli_jsonString(stdout, a->model);
  if (s->key > 0) {
    printf(",\"key\":%d", s->key - 1);
  } else {
    printf(",\"key\":null");
  }
  printf(",\"commands\":");
  cli_jsonString(stdout, a->ctrl_file ? a->ctrl_file : s->commands_source);
  printf(",\"duration\":");
  cli_jsonNumber(stdout, s->duration);
  printf(",\"reference\":");
  if (s->h_ref > 0) {
    printf("{\"engine\":\"mujoco\",\"h\":");
    cli_jsonNumber(stdout, s->h_ref);
    printf("}");
  } else {
    cli_jsonString(stdout, a->reference);
  }
  printf(",\"h_grid\":");
  cmp_jsonArray(stdout, s->h, s->nh);
  printf(",\"runs\":%d,\"repeats\":%ld", s->nrow, a->repeat);
  for (int e = CMP_NENGINE - 1; e >= 0; e--) {
    const sweepPlateau* p = s->plateau + e;
    if (!s->use[e]) {
      continue;
    }
    printf(",\"%s\":{\"min_error\":", kCmpEngineNames[e]);
    cli_jsonNumber(stdout, p->min_error);
    printf(",\"plateau_lo\":");
    cli_jsonNumber(stdout, p->lo);
    printf(",\"plateau_h\":");
    cli_jsonNumber(stdout, p->edge);
    printf(",\"strict_plateau_h\":");
    cli_jsonNumber(stdout, p->strict_edge);
    printf(",\"diverged\":%d,\"diverged_below_plateau\":%d}", p->ndiverged,
           p->ndiverged_below);
  }
  printf(",\"plateau_ratio\":");
  cli_jsonNumber(stdout, s->plateau[CMP_OSTRICH].edge / s->plateau[CMP_MUJOCO].edge);
  printf(",\"csv\":");
  cli_jsonString(stdout, s->csv_path);
  printf(",\"plots\":%s,\"wall_s\":%.3f}\n", s->plots ? "true" : "false", wall);
  fflush(stdout);
}


//---------------------------------- sweep ---------------------------------------------------------

// Parse and check the arguments into a and s; return 0 on success.
static int sweep_parse(int argc, char** argv, sweepArgs* a, sweepState* s) {
  *a = (sweepArgs){.h_grid = "0.0005,0.001,0.002,0.005,0.01,0.02,0.05,0.1,0.2",
                   .engine = "ostrich,mujoco", .ceiling = 0.5, .repeat = 5,
                   .out = "sweep", .key = -1};
  if (cli_parseArgs("compare sweep", argc, argv, kSweepOptions, kSweepNumOptions, a, &a->model,
                    &a->help)) {
    return 1;
  }
  if (a->help) {
    return 0;
  }
  if (!a->model) {
    cli_error("compare sweep: missing MODEL.xml (see ostrich compare sweep --help)");
    return 1;
  }
  if (a->repeat < 1) {
    cli_error("--repeat: must be at least 1");
    return 1;
  }
  s->nh = cmp_parsePositiveList("--h-grid", a->h_grid, s->h, SWEEP_MAX_H, 1);
  return s->nh < 0 || cmp_parseEngines(a->engine, s->use) || cli_checkOutputDir("--out", a->out);
}


// Free what the sweep holds.
static void sweep_free(sweepState* s) {
  cmp_freeCommands(&s->commands);
  cmp_freeCommands(&s->perturbed);
  cmp_freeTrajectory(&s->reference);
  free(s->rows);
  if (s->m) {
    mj_deleteModel(s->m);
  }
}


// `ostrich compare sweep MODEL.xml [options]`
int compare_sweep_main(int argc, char** argv) {
  sweepArgs a;
  sweepState s = {0};
  if (sweep_parse(argc, argv, &a, &s)) {
    return CLI_USAGE;
  }
  if (a.help) {
    sweep_usage(stdout);
    return CLI_OK;
  }

  // inputs: model (its mjData is not needed: every run makes its own), commands, output dir
  double start = cli_now();
  mjData* d = NULL;
  int status = cli_loadModel(a.model, &s.m, &d) || sweep_commands(&a, &s) ? CLI_USAGE : CLI_OK;
  if (d) {
    mj_deleteData(d);
  }
  if (status == CLI_OK && a.key >= s.m->nkey) {
    cli_error("--key %ld: %s has %d keyframes", a.key, a.model, s.m->nkey);
    status = CLI_USAGE;
  }
  s.key = (int)a.key + 1;

  // the rows, then per repeat: commands, reference, every run; then plateaus and outputs
  if (status == CLI_OK) {
    s.h_ref = a.reference ? 0 : (a.h_ref > 0 ? a.h_ref : 0.5 * s.h[0]);
    status = sweep_allocRows(&s) ? CLI_FAIL : CLI_OK;
  }
  for (int r = 0; r < a.repeat && status == CLI_OK; r++) {
    status = sweep_perturb(&s, r) ? CLI_FAIL : sweep_reference(&a, &s, r);
    if (status == CLI_OK) {
      status = sweep_runAll(&s, a.ceiling, r, (int)a.repeat) ? CLI_FAIL : CLI_OK;
    }
  }
  if (status == CLI_OK) {
    sweep_finish(&s);
  }
  if (status == CLI_OK) {
    for (int e = 0; e < CMP_NENGINE; e++) {
      sweep_plateau(&s, e, s.plateau + e);
    }
    status = sweep_writeCsv(&s, a.out) ? CLI_FAIL : CLI_OK;
  }
  if (status == CLI_OK) {
    sweep_plots(&s, a.out, a.model, a.ceiling, (int)a.repeat);
    sweep_report(&a, &s, a.out, cli_now() - start);
  }
  sweep_free(&s);
  return status;
}
