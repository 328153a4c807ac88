// ost_cli_bench.c: `ostrich bench scale`, the world-scaling benchmark of the batched API
// on the box-traversal scene of `ostrich synth` (robot_box.xml, h = 0.1 s, 60 steps
// over the 6 s horizon). For each world count and device: every world starts from its own
// random start (synth's distribution) and follows synth's initial wheel command (1.5 rad/s,
// ramping to 0 over the last second); one untimed rollout warms up, then --repeat timed
// rollouts of the whole horizon, and --repeat timed optimization iterations (the rollout and
// its backward pass, ost_batchBackward with segment checkpoints every --checkpoint steps, kept
// by the rollout unless --replay-checkpoints, for a loss of every world's final position). Reports the median rollout time, world-rollouts and
// world-steps per second, the median iteration time and world-iterations per second, the
// device's memory in use after the backward pass, and each device's ratios to the CPU batch
// with all cores in the same run.
// Invariant: every figure printed was measured in this run.
#define _POSIX_C_SOURCE 200809L

#include <math.h>
#include <stddef.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <mujoco/mujoco.h>

#include "ost_cli_util.h"
#include "ostrich.h"

#define BENCH_MAX_COUNTS 32

// the default --device: the CPU batch alone unless this build has the CUDA backend
#ifdef OSTRICH_HAVE_CUDA
#define BENCH_DEFAULT_DEVICE "both"
#else
#define BENCH_DEFAULT_DEVICE "cpu"
#endif

typedef struct benchArgs_ {       // arguments of `ostrich bench scale`
  const char* device;             // cuda | cpu | both
  const char* worlds;             // comma-separated world counts
  const char* model;              // MJCF path (the positional argument)
  const char* csv;                // CSV path or NULL
  const char* plot;               // PNG path or NULL
  long        repeat;             // timed rollouts per point
  long        steps;              // steps per rollout
  long        cpu_max;            // largest world count run on the CPU
  long        checkpoint;         // backward segment length (steps)
  int         replay;             // 1: the backward pass replays to make its checkpoints
  int         help;
} benchArgs;

static const cliOption kBenchOptions[] = {
  {"--device", CLI_ARG_STRING, offsetof(benchArgs, device), "cuda|cpu|both",
   "batch device; both runs cuda and the CPU (all cores) (default: both\n"
   "in a build with CUDA, else cpu; this build: " BENCH_DEFAULT_DEVICE ")"},
  {"--worlds", CLI_ARG_STRING, offsetof(benchArgs, worlds), "N1,N2,...",
   "world counts (default 1,8,64,512,4096,8192,32768)"},
  {"--steps", CLI_ARG_COUNT, offsetof(benchArgs, steps), "T",
   "steps per rollout (default 60: synth's 6 s at h = 0.1 s)"},
  {"--repeat", CLI_ARG_COUNT, offsetof(benchArgs, repeat), "R",
   "timed rollouts per point, median reported (default 3)"},
  {"--cpu-max", CLI_ARG_COUNT, offsetof(benchArgs, cpu_max), "N",
   "largest world count run on the CPU (default 8192)"},
  {"--checkpoint", CLI_ARG_COUNT, offsetof(benchArgs, checkpoint), "S",
   "backward pass: checkpoint every S steps (default 10)"},
  {"--replay-checkpoints", CLI_ARG_FLAG, offsetof(benchArgs, replay), "",
   "the backward pass replays the rollout to make its checkpoints\n"
   "(default: the rollout keeps them, T/S world copies more memory)"},
  {"--csv", CLI_ARG_STRING, offsetof(benchArgs, csv), "FILE.csv",
   "write the table as CSV (checked first, written at the end)"},
  {"--plot", CLI_ARG_STRING, offsetof(benchArgs, plot), "FILE.png",
   "plot world-steps/s against worlds (gnuplot; needs --csv)"},
};

static const int kBenchNumOptions = (int)(sizeof(kBenchOptions) / sizeof(kBenchOptions[0]));

typedef struct benchRow_ {        // one measured point
  const char* device;
  int    worlds;
  double rollout_s;               // median rollout time
  double world_rollouts_per_s;
  double world_steps_per_s;
  double iter_s;                  // median optimization iteration: rollout + backward
  double mem_gb;                  // device memory in use (cuda) or batch bytes (cpu), GB
  int    failed;                  // worlds with a failure bit at the end
} benchRow;


// synth's start distribution and initial command for nworld worlds (seeded)
static void benchInputs(const mjModel* m, int nworld, int T, double h, mjtNum* q0,
                        mjtNum* ctrl) {
  cliRng rng;
  cli_rngSeed(&rng, 1);
  for (int w = 0; w < nworld; w++) {
    mjtNum* q = q0 + (size_t)w * m->nq;
    memcpy(q, m->qpos0, m->nq * sizeof(mjtNum));
    q[0] += cli_uniform(&rng, -0.2, 0.2);
    q[1] += cli_uniform(&rng, -0.2, 0.2);
    mjtNum yaw = cli_uniform(&rng, -0.2, 0.2);
    q[3] = cos(yaw / 2);
    q[6] = sin(yaw / 2);
  }
  for (int t = 0; t < T; t++) {
    double time = (t + 0.5) * h, horizon = T * h, ramp = horizon - 1;
    double u = time < ramp ? 1.5 : 1.5 * (horizon - time);
    for (size_t i = 0; i < (size_t)nworld * m->nu; i++) {
      ctrl[(size_t)t * nworld * m->nu + i] = u;
    }
  }
}


// measure one point; returns 0 or 1 (message printed)
static int benchPoint(const mjModel* m, const char* device, int nworld, const benchArgs* a,
                      benchRow* row) {
  char err[1000];
  int T = (int)a->steps;
  double h = 0.1;
  ostOptions o;
  if (!ost_readOptions(m, &o, NULL, 0) && o.timestep > 0) {
    h = o.timestep;
  }
  mjtNum* q0 = (mjtNum*)malloc(sizeof(mjtNum) * nworld * m->nq);
  mjtNum* ctrl = (mjtNum*)malloc(sizeof(mjtNum) * (size_t)T * nworld * m->nu);
  int* status = (int*)malloc(sizeof(int) * nworld);
  double* times = (double*)malloc(sizeof(double) * (a->repeat + 1));
  ostBatch* b = (q0 && ctrl && status && times) ? ost_batchCreate(m, nworld, device, err,
                                                                  sizeof(err)) : NULL;
  int bad = !b;
  if (bad) {
    cli_error("bench scale: %s, %d worlds: %s", device, nworld,
              q0 && ctrl && status && times ? err : "out of memory");
  }
  if (!bad) {
    benchInputs(m, nworld, T, h, q0, ctrl);
    for (int r = 0; r <= a->repeat && !bad; r++) {
      double t0 = cli_now();
      bad = ost_batchSetState(b, q0, NULL) || ost_batchRollout(b, T, ctrl, NULL, NULL);
      times[r] = cli_now() - t0;  // r = 0 warms up
    }
    if (bad) {
      cli_error("bench scale: %s, %d worlds: %s", device, nworld, ost_batchError(b));
    }
  }

  // optimization iterations: the rollout and its backward pass for a loss of the final state
  // (cotangent 1 on each world's final x)
  row->iter_s = NAN;
  size_t n = ((size_t)T + 1) * nworld * m->nv;
  mjtNum* gq = bad ? NULL : (mjtNum*)calloc(n, sizeof(mjtNum));
  mjtNum* gctrl = bad ? NULL : (mjtNum*)malloc(sizeof(mjtNum) * (size_t)T * nworld * m->nu);
  if (!bad && (!gq || !gctrl)) {
    cli_error("bench scale: %s, %d worlds: out of memory", device, nworld);
    bad = 1;
  }
  for (int w = 0; !bad && w < nworld; w++) {
    gq[((size_t)T * nworld + w) * m->nv] = 1;
  }
  double* iters = (double*)malloc(sizeof(double) * a->repeat);
  bad = bad || ost_batchKeepCheckpoints(b, a->replay ? 0 : (int)a->checkpoint);
  for (int r = 0; r < a->repeat && !bad; r++) {
    double t0 = cli_now();
    bad = ost_batchSetState(b, q0, NULL) || ost_batchRollout(b, T, ctrl, NULL, NULL)
          || ost_batchBackward(b, NULL, (int)a->checkpoint, gq, NULL, gctrl, NULL, NULL);
    iters[r] = cli_now() - t0;
    if (bad) {
      cli_error("bench scale: %s, %d worlds, backward: %s", device, nworld, ost_batchError(b));
    }
  }
  if (!bad) {
    row->iter_s = cli_median(iters, (int)a->repeat);
  }
  free(iters);
  free(gq);
  free(gctrl);
  if (!bad) {
    size_t used = 0, total = 0;
    ost_batchMemory(b, &used, &total);
    ost_batchStatus(b, status);
    double med = cli_median(times + 1, (int)a->repeat);
    row->device = device;
    row->worlds = nworld;
    row->rollout_s = med;
    row->world_rollouts_per_s = nworld / med;
    row->world_steps_per_s = nworld * (double)T / med;
    row->mem_gb = used / 1e9;
    row->failed = 0;
    for (int w = 0; w < nworld; w++) {
      row->failed += (status[w] & (OST_OVERFLOW | OST_NAN | OST_CHOL_FAIL)) != 0;
    }
  }
  ost_batchDelete(b);
  free(q0);
  free(ctrl);
  free(status);
  free(times);
  return bad;
}


// plot world-steps/s against worlds, one line per device (into png's temporary name, renamed)
static int benchPlot(const char* png, const char* csv) {
  char cmd[4 * CLI_PATH_SZ], tmp[CLI_PATH_SZ];
  if (cli_outputTemp(png, tmp, sizeof(tmp))) {
    return 1;
  }
  snprintf(cmd, sizeof(cmd),
           "gnuplot -e \"set terminal png size 900,600; set output '%s'; set logscale xy; "
           "set datafile separator ','; set key top left; set xlabel 'worlds'; "
           "set ylabel 'per second'; set title 'ostrich bench scale'; "
           "plot '< grep ^cuda, %s' using 2:5 with linespoints title 'cuda world-steps (forward)', "
           "'< grep ^cpu, %s' using 2:5 with linespoints title 'cpu world-steps (forward, all cores)', "
           "'< grep ^cuda, %s' using 2:7 with linespoints title 'cuda world-iterations (fwd+bwd)', "
           "'< grep ^cpu, %s' using 2:7 with linespoints title 'cpu world-iterations (fwd+bwd)'\" 1>&2",
           tmp, csv, csv, csv, csv);
  if (system(cmd) != 0) {
    cli_discardOutput(NULL, tmp);
    return 1;
  }
  return cli_commitOutput(NULL, tmp, png);
}


static int benchScale(int argc, char** argv) {
  benchArgs a = {BENCH_DEFAULT_DEVICE, "1,8,64,512,4096,8192,32768", NULL, NULL, NULL,
                 3, 60, 8192, 10, 0, 0};
  if (cli_parseArgs("bench scale", argc, argv, kBenchOptions, kBenchNumOptions, &a, &a.model,
                    &a.help)) {
    return CLI_USAGE;
  }
  if (a.help) {
    printf("usage: ostrich bench scale [MODEL.xml] [options]\n\n"
           "World scaling of the batched API on the box-traversal scene (forward rollouts and\n"
           "optimization iterations: rollout + backward pass). MODEL.xml: the scene (default\n"
           "mjcf_models/robot_box.xml). One progress line per point goes to stderr, unless\n"
           "OSTRICH_QUIET=1.\n\n"
           "options:\n");
    cli_printOptions(stdout, kBenchOptions, kBenchNumOptions);
    cli_printHelpOption(stdout);
    return CLI_OK;
  }
  int cuda = strcmp(a.device, "cpu") != 0, cpu = strcmp(a.device, "cuda") != 0;
  if (strcmp(a.device, "cuda") && strcmp(a.device, "cpu") && strcmp(a.device, "both")) {
    cli_error("bench scale: --device must be cuda, cpu or both");
    return CLI_USAGE;
  }
  if (a.repeat < 1 || a.steps < 1 || a.checkpoint < 1) {
    cli_error("bench scale: --repeat, --steps and --checkpoint must be >= 1");
    return CLI_USAGE;
  }
  if (a.plot && !a.csv) {
    cli_error("bench scale: --plot needs --csv");
    return CLI_USAGE;
  }
  if ((a.csv && cli_checkOutput("--csv", a.csv)) ||
      (a.plot && cli_checkOutput("--plot", a.plot))) {
    return CLI_USAGE;
  }
  if (!a.model) {
    a.model = "mjcf_models/robot_box.xml";
  }
  long counts[BENCH_MAX_COUNTS];
  int ncount = 0;
  for (const char* p = a.worlds; *p && ncount < BENCH_MAX_COUNTS;) {
    char* end;
    counts[ncount] = strtol(p, &end, 10);
    if (end == p || counts[ncount] < 1 || counts[ncount] > 100000000 || (*end && *end != ',')) {
      cli_error("bench scale: --worlds must be a list of counts >= 1, e.g. 1,8,64");
      return CLI_USAGE;
    }
    ncount++;
    p = *end ? end + 1 : end;
  }
  mjModel* m;
  mjData* d;
  if (cli_loadModel(a.model, &m, &d)) {
    return CLI_USAGE;
  }
  mj_deleteData(d);
  benchRow rows[2 * BENCH_MAX_COUNTS];
  int nrow = 0, status = CLI_OK;
  for (int i = 0; i < ncount; i++) {
    int n = (int)counts[i];
    for (int dev = 0; dev < 2; dev++) {
      const char* name = dev == 0 ? "cuda" : "cpu";
      if ((dev == 0 && !cuda) || (dev == 1 && (!cpu || n > a.cpu_max))) {
        continue;
      }
      if (cli_progress()) {
        fprintf(stderr, "ostrich: bench scale: %s, %d worlds ...\n", name, n);
      }
      if (benchPoint(m, name, n, &a, rows + nrow)) {
        status = CLI_FAIL;
        continue;
      }
      nrow++;
    }
  }

  // the table, with the ratio to the CPU at the same world count
  printf("%-6s %8s %12s %16s %14s %12s %14s %9s %7s %10s %10s\n", "device", "worlds",
         "rollout_s", "world_rollouts/s", "world_steps/s", "iter_s", "world_iters/s", "mem_GB",
         "failed", "fwd_vs_cpu", "iter_vs_cpu");
  char tmp[CLI_PATH_SZ];
  FILE* f = a.csv ? cli_openOutput(a.csv, tmp, sizeof(tmp)) : NULL;
  if (a.csv && !f) {
    status = CLI_FAIL;
  }
  if (f) {
    fprintf(f, "device,worlds,rollout_s,world_rollouts_per_s,world_steps_per_s,iter_s,"
            "world_iters_per_s,mem_gb,failed,fwd_ratio_vs_cpu,iter_ratio_vs_cpu\n");
  }
  for (int r = 0; r < nrow; r++) {
    double ratio = NAN, iratio = NAN;
    for (int c = 0; c < nrow; c++) {
      if (!strcmp(rows[c].device, "cpu") && rows[c].worlds == rows[r].worlds) {
        ratio = rows[r].world_steps_per_s / rows[c].world_steps_per_s;
        iratio = rows[c].iter_s / rows[r].iter_s;
      }
    }
    double wips = rows[r].worlds / rows[r].iter_s;
    printf("%-6s %8d %12.4f %16.1f %14.1f %12.4f %14.1f %9.3f %7d %10.3f %10.3f\n",
           rows[r].device, rows[r].worlds, rows[r].rollout_s, rows[r].world_rollouts_per_s,
           rows[r].world_steps_per_s, rows[r].iter_s, wips, rows[r].mem_gb, rows[r].failed, ratio,
           iratio);
    if (f) {
      fprintf(f, "%s,%d,%.6g,%.6g,%.6g,%.6g,%.6g,%.6g,%d,%.6g,%.6g\n", rows[r].device,
              rows[r].worlds, rows[r].rollout_s, rows[r].world_rollouts_per_s,
              rows[r].world_steps_per_s, rows[r].iter_s, wips, rows[r].mem_gb, rows[r].failed,
              ratio, iratio);
    }
  }
  if (f && cli_commitOutput(f, tmp, a.csv)) {
    status = CLI_FAIL;
  } else if (f && a.plot && benchPlot(a.plot, a.csv)) {
    cli_error("bench scale: gnuplot could not draw %s", a.plot);
    status = CLI_FAIL;
  }
  mj_deleteModel(m);
  return status;
}


int bench_main(int argc, char** argv) {
  if (argc < 1 || !strcmp(argv[0], "--help") || !strcmp(argv[0], "-h")) {
    printf("usage: ostrich bench scale [MODEL.xml] [options]  (see ostrich bench scale --help)\n"
           "       ostrich bench models MODEL.xml ... [options]  (ostrich bench models --help)\n"
           "       ostrich bench adjoint MODEL.xml ... [options]  (ostrich bench adjoint --help)\n");
    return argc < 1 ? CLI_USAGE : CLI_OK;
  }
  if (!strcmp(argv[0], "scale")) {
    return benchScale(argc - 1, argv + 1);
  }
  if (!strcmp(argv[0], "models")) {
    return bench_models_main(argc - 1, argv + 1);
  }
  if (!strcmp(argv[0], "adjoint")) {
    return bench_adjoint_main(argc - 1, argv + 1);
  }
  cli_error("bench: unknown benchmark '%s' (scale, models, adjoint)", argv[0]);
  return CLI_USAGE;
}
