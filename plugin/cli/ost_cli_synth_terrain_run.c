// ost_cli_synth_terrain_run.c: the driver of `ostrich synth --scene terrain`: per instance, the
// terrain and the target path on each engine's scene, Adam from the guess, then the summary (one
// JSON line), the CSV files and the PNG. The task and the loss: ost_cli_synth_terrain.c.
//
// Invariant: an iterate whose rollout or gradient failed is recorded with a NaN loss and RMSE and
// never enters a best RMSE, a median or a plotted path; its time still counts.
#define _POSIX_C_SOURCE 200809L

#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/wait.h>

#include <mujoco/mujoco.h>

#include "ost_cli_synth.h"
#include "ost_cli_synth_terrain.h"
#include "ost_cli_util.h"
#include "ostrich.h"


//---------------------------------- Results -------------------------------------------------------

typedef struct terResult_ {       // one engine's results over all trials
  int      trials, iters;         // sizes
  int      nsample;               // loss samples per rollout (S)
  terEval* ev;                    // iterates' outcomes                      (trials x iters)
  double*  ms;                    // iterations' wall time (ms)              (trials x iters)
  float*   path;                  // chassis xy per sample, slot 0 the target path
                                  //                       (trials x (iters + 1) x (S + 1) x 2)
  int*     done;                  // iterations run per trial, failed ones included (trials)
  int*     failed;                // the trial ended early                          (trials)
  int      bad_rollouts;          // iterations whose rollout or gradient failed
  double   total_s;               // wall time of all trials (s)
  long     fd_fallback;           // finite differences taken one-sided after a failure
} terResult;

typedef struct terSummary_ {      // one engine's summary over the trials
  int    successes;               // best RMSE below TER_RMSE_OK
  int    good;                    // best RMSE below TER_RMSE_GOOD
  int    failed;                  // trials that ended early
  double median_best;             // median of the per-trial best RMSE (m; +inf if none)
  double mean_best, std_best;     // mean and standard deviation of the finite best RMSEs (m)
  double median_initial;          // median RMSE of the guesses (m)
  double median_last;             // median RMSE of the last good iterates (m)
  double median_warm_ms;          // median iteration time, each trial's first excluded (ms)
} terSummary;


// Path slot of trial t, iteration i (0: the target, i >= 1: iterate i).
static float* ter_path(const terResult* r, int t, int i) {
  return r->path + ((size_t)t * (size_t)(r->iters + 1) + (size_t)i) * (size_t)(r->nsample + 1) * 2;
}


// Allocate a result; return 0, else print why.
static int ter_resultAlloc(terResult* r, int trials, int iters, int nsample) {
  int bad = 0;
  size_t n = (size_t)trials * (size_t)iters;
  memset(r, 0, sizeof(*r));
  r->trials = trials;
  r->iters = iters;
  r->nsample = nsample;
  r->ev = (terEval*)synth_alloc(n, sizeof(terEval), &bad);
  r->ms = (double*)synth_alloc(n, sizeof(double), &bad);
  r->path = (float*)synth_alloc((size_t)trials * (size_t)(iters + 1) * (size_t)(nsample + 1) * 2,
                                sizeof(float), &bad);
  r->done = (int*)synth_alloc((size_t)trials, sizeof(int), &bad);
  r->failed = (int*)synth_alloc((size_t)trials, sizeof(int), &bad);
  if (bad) {
    cli_error("synth: out of memory");
  }
  return bad;
}


// Free a result.
static void ter_resultFree(terResult* r) {
  free(r->ev);
  free(r->ms);
  free(r->path);
  free(r->done);
  free(r->failed);
}


// Copy the xy of the sample states into a path slot.
static void ter_keepPath(const terEngine* e, const mjtNum* qs, float* path) {
  for (int s = 0; s <= e->nsample; s++) {
    path[2 * s] = (float)qs[s * e->m->nq];
    path[2 * s + 1] = (float)qs[s * e->m->nq + 1];
  }
}


//---------------------------------- Optimization --------------------------------------------------

// Optimize trial t from task->guess (the engine's terrain and target already set): iters
// rollouts with gradients and Adam steps (step lr decaying by synth_decay), projected onto the
// control range. A failed iterate (TER_BAD) is recorded with NaN and replaced by the last good
// iterate's step at half the step size (kept for the rest of the trial); the trial ends at a
// failure of its first iterate, after TER_MAX_BAD in a row, or at TER_FAILED. Return 0, or 1 if
// the trial ended early.
static int ter_trial(terEngine* e, const synthArgs* a, const terTask* task, int t,
                     terResult* r) {
  double knots[TER_NVAR], prev[TER_NVAR], grad[TER_NVAR], dir[TER_NVAR];
  double mom[TER_NVAR] = {0}, var2[TER_NVAR] = {0};
  int status = TER_OK, ngood = 0, nbad = 0;
  double lr = a->lr;
  memcpy(knots, task->guess, sizeof(knots));
  for (int i = 0; i < r->iters && status != TER_FAILED; i++) {
    terEval* ev = r->ev + t * r->iters + i;
    double start = cli_now();
    status = e->ostrich ? ter_gradAdjoint(e, knots, ev, grad) : ter_gradFD(e, knots, ev, grad);
    if (status == TER_OK) {
      synth_adam(TER_NVAR, ++ngood, grad, mom, var2, dir);
      memcpy(prev, knots, sizeof(prev));
      nbad = 0;
    } else if (status == TER_BAD && ngood > 0) {
      lr *= 0.5;
      nbad++;
    }
    if (ngood > 0) {
      double step = lr * synth_decay(i, r->iters);
      for (int c = 0; c < TER_NVAR; c++) {
        double k = prev[c] - step * dir[c];
        knots[c] = k < e->lo ? e->lo : (k > e->hi ? e->hi : k);
      }
    }
    r->ms[t * r->iters + i] = 1e3 * (cli_now() - start);
    r->done[t] = i + 1;

    // record and report
    if (status != TER_OK) {
      *ev = (terEval){NAN, NAN};
      r->bad_rollouts += (status == TER_BAD);
      int end = (status == TER_FAILED || ngood == 0 || nbad >= TER_MAX_BAD);
      if (status == TER_BAD) {
        cli_error("synth: %s trial %d iteration %d: %s; %s", e->name, t + 1, i + 1, e->why,
                  end ? "trial ended" : "retrying the last step at half the step size");
      }
      status = end ? TER_FAILED : status;
      continue;
    }
    ter_keepPath(e, e->qs, ter_path(r, t, i + 1));
    if (cli_progress()) {
      fprintf(stderr, "ostrich: synth terrain %s trial %d/%d iter %d/%d loss %.5g rmse %.4f m "
              "%.1f ms\n", e->name, t + 1, r->trials, i + 1, r->iters, ev->loss, ev->rmse,
              r->ms[t * r->iters + i]);
    }
  }
  r->failed[t] = (status == TER_FAILED);
  return r->failed[t];
}


// Run every instance on one engine: its terrain, its target path, then the trial. Return the
// number of trials that ended early (a target rollout that fails ends its trial).
static int ter_run(terEngine* e, const synthArgs* a, const terTask* tasks, terResult* r) {
  int nfailed = 0;
  float* data = (float*)malloc(sizeof(float) * TER_NGRID * TER_NGRID);
  double start = cli_now();
  if (!data) {
    cli_error("synth: out of memory");
    return r->trials;
  }
  for (int t = 0; t < r->trials; t++) {
    ter_heights(tasks + t, data);
    ter_setTerrain(e, data);
    int status = ter_setTarget(e, tasks[t].target);
    if (status != TER_OK) {
      if (status == TER_BAD) {
        cli_error("synth: %s trial %d (seed %ld): the target rollout failed: %s; trial ended",
                  e->name, t + 1, a->seed + t, e->why);
      }
      r->failed[t] = 1;
      nfailed++;
      continue;
    }
    ter_keepPath(e, e->qs, ter_path(r, t, 0));
    if (cli_progress()) {
      const double* ref = e->ref + 3 * e->nsample;
      fprintf(stderr, "ostrich: synth terrain %s trial %d/%d (seed %ld): target path ends at "
              "(%.3f, %.3f) m heading %.3f rad\n", e->name, t + 1, r->trials, a->seed + t,
              ref[0], ref[1], ref[2]);
    }
    nfailed += ter_trial(e, a, tasks + t, t, r);
  }
  free(data);
  r->total_s = cli_now() - start;
  r->fd_fallback = e->fd_fallback;
  return nfailed;
}


//---------------------------------- Summary -------------------------------------------------------

// Best RMSE of trial t over its good iterates; +inf if it has none.
static double ter_bestRmse(const terResult* r, int t) {
  double best = INFINITY;
  for (int i = 0; i < r->done[t]; i++) {
    double x = r->ev[t * r->iters + i].rmse;
    best = isfinite(x) && x < best ? x : best;
  }
  return best;
}


// Index of trial t's best-RMSE iterate, -1 if none.
static int ter_bestIter(const terResult* r, int t) {
  int best = -1;
  for (int i = 0; i < r->done[t]; i++) {
    double x = r->ev[t * r->iters + i].rmse;
    if (isfinite(x) && (best < 0 || x < r->ev[t * r->iters + best].rmse)) {
      best = i;
    }
  }
  return best;
}


// Summarize one engine's result; return 0, else print why (out of memory).
static int ter_summarize(const terResult* r, terSummary* s) {
  int bad = 0, nfin = 0, ninit = 0, nlast = 0, nwarm = 0;
  double* best = (double*)synth_alloc((size_t)r->trials, sizeof(double), &bad);
  double* init = (double*)synth_alloc((size_t)r->trials, sizeof(double), &bad);
  double* last = (double*)synth_alloc((size_t)r->trials, sizeof(double), &bad);
  double* warm = (double*)synth_alloc((size_t)r->trials * (size_t)r->iters, sizeof(double), &bad);
  double sum = 0, sum2 = 0;
  memset(s, 0, sizeof(*s));
  for (int t = 0; t < r->trials && !bad; t++) {
    s->failed += r->failed[t];
    best[t] = ter_bestRmse(r, t);
    s->successes += best[t] < TER_RMSE_OK;
    s->good += best[t] < TER_RMSE_GOOD;
    if (isfinite(best[t])) {
      nfin++;
      sum += best[t];
      sum2 += best[t] * best[t];
    }
    if (r->done[t] > 0 && isfinite(r->ev[t * r->iters].rmse)) {
      init[ninit++] = r->ev[t * r->iters].rmse;
    }
    for (int i = r->done[t] - 1; i >= 0; i--) {
      if (isfinite(r->ev[t * r->iters + i].rmse)) {
        last[nlast++] = r->ev[t * r->iters + i].rmse;
        break;
      }
    }
    for (int i = 1; i < r->done[t]; i++) {
      warm[nwarm++] = r->ms[t * r->iters + i];
    }
  }
  if (!bad) {
    s->median_best = synth_median(best, r->trials);
    s->mean_best = nfin ? sum / nfin : NAN;
    s->std_best = nfin > 1 ? sqrt(fmax(0, (sum2 - sum * sum / nfin) / (nfin - 1))) : NAN;
    s->median_initial = synth_median(init, ninit);
    s->median_last = synth_median(last, nlast);
    s->median_warm_ms = synth_median(warm, nwarm);
  } else {
    cli_error("synth: out of memory");
  }
  free(best);
  free(init);
  free(last);
  free(warm);
  return bad;
}


// Print one engine's summary as JSON members (no braces); with_time: its total_s too.
static void ter_printSummary(const terEngine* e, const terResult* r, const terSummary* s,
                             const char* model, int with_time) {
  printf("\"engine\":\"%s\",\"model\":", e->name);
  cli_jsonString(stdout, model);
  printf(",\"h\":");
  cli_jsonNumber(stdout, e->h);
  printf(",\"steps\":%d,\"gradient\":", e->nstep);
  if (e->ostrich) {
    printf("\"adjoint, %s\"", e->truncate ? "truncated" : "complete");
  } else {
    printf("\"%s differences, eps %g rad/s, %d rollouts per iteration\"",
           e->central ? "central" : "forward", e->eps, 1 + (e->central ? 2 : 1) * TER_NVAR);
  }
  printf(",\"trials\":%d,\"successes\":%d,\"success_rate\":", r->trials, s->successes);
  cli_jsonNumber(stdout, (double)s->successes / r->trials);
  printf(",\"below_0.2m\":%d,\"median_best_rmse\":", s->good);
  cli_jsonNumber(stdout, s->median_best);
  printf(",\"mean_best_rmse\":");
  cli_jsonNumber(stdout, s->mean_best);
  printf(",\"std_best_rmse\":");
  cli_jsonNumber(stdout, s->std_best);
  printf(",\"median_initial_rmse\":");
  cli_jsonNumber(stdout, s->median_initial);
  printf(",\"median_last_rmse\":");
  cli_jsonNumber(stdout, s->median_last);
  printf(",\"median_warm_iter_ms\":");
  cli_jsonNumber(stdout, s->median_warm_ms);
  printf(",\"failed_trials\":%d,\"bad_rollouts\":%d", s->failed, r->bad_rollouts);
  if (!e->ostrich) {
    printf(",\"fd_fallbacks\":%ld", r->fd_fallback);
  }
  if (with_time) {
    printf(",\"total_s\":%.3f", r->total_s);
  }
}


//---------------------------------- Output files --------------------------------------------------

// Write the iteration CSV and the trajectory CSV (each atomically); return 0, else print why.
static int ter_writeCsv(const char* path, const terEngine* engines, const terResult* res,
                        int nengine) {
  char traj[CLI_PATH_SZ], tmp_f[CLI_PATH_SZ], tmp_g[CLI_PATH_SZ];
  synth_trajPath(path, traj, sizeof(traj));
  FILE* f = cli_openOutput(path, tmp_f, sizeof(tmp_f));
  FILE* g = f ? cli_openOutput(traj, tmp_g, sizeof(tmp_g)) : NULL;
  if (!f || !g) {
    if (f) {
      cli_discardOutput(f, tmp_f);
    }
    return 1;
  }
  fprintf(f, "engine,trial,iter,loss,rmse,time_ms\n");
  fprintf(g, "engine,trial,iter,t,x,y\n");
  for (int k = 0; k < nengine; k++) {
    const terResult* r = res + k;
    for (int t = 0; t < r->trials; t++) {
      for (int i = 0; i <= r->done[t]; i++) {
        const terEval* ev = i ? r->ev + t * r->iters + i - 1 : NULL;
        if (ev) {
          fprintf(f, "%s,%d,%d,%.10g,%.6g,%.3f\n", engines[k].name, t + 1, i, ev->loss,
                  ev->rmse, r->ms[t * r->iters + i - 1]);
        }
        const float* p = ter_path(r, t, i);
        for (int s = 0; s <= r->nsample && (!ev || isfinite(ev->loss)); s++) {
          fprintf(g, "%s,%d,%d,%.3f,%.6g,%.6g\n", engines[k].name, t + 1, i, s * TER_DT,
                  p[2 * s], p[2 * s + 1]);
        }
      }
    }
  }
  if (cli_commitOutput(f, tmp_f, path) | cli_commitOutput(g, tmp_g, traj)) {
    return 1;
  }
  fprintf(stderr, "ostrich: wrote %s and %s\n", path, traj);
  return 0;
}


// Write one path as gnuplot data lines (x y value), then a blank line.
static void ter_plotPath(FILE* p, const terResult* r, int t, int i, int value) {
  const float* q = ter_path(r, t, i);
  for (int s = 0; s <= r->nsample; s++) {
    fprintf(p, "%.4f %.4f %d\n", q[2 * s], q[2 * s + 1], value);
  }
  fprintf(p, "\n");
}


// Write the gnuplot script of the PNG: per engine, trial 1's paths over its terrain (target
// dashed red, guess grey, iterates by iteration, best-RMSE iterate blue), and the RMSE over the
// iterations across trials (median, interquartile band, median of the running best).
static void ter_plotScript(FILE* p, const char* terminal, const char* png,
                           const terEngine* engines, const terResult* res, int nengine,
                           const terTask* tasks, long seed) {
  fprintf(p, "set terminal %s size 1400,%d\nset output '", terminal, 600 * nengine);
  for (const char* c = png; *c; c++) {
    fputs(*c == '\'' ? "''" : (char[2]){*c, 0}, p);
  }
  fprintf(p, "'\n");

  // trial 1's terrain (the same instance on both engines): elevation on the grid, in cm
  float* data = (float*)malloc(sizeof(float) * TER_NGRID * TER_NGRID);
  if (data) {
    ter_heights(tasks, data);
    fprintf(p, "$H << EOD\n");
    for (int r = 0; r < TER_NGRID; r++) {
      for (int c = 0; c < TER_NGRID; c++) {
        fprintf(p, "%.3f %.3f %.2f\n", -TER_HALF + 2 * TER_HALF * c / (TER_NGRID - 1),
                -TER_HALF + 2 * TER_HALF * r / (TER_NGRID - 1),
                100 * (TER_ZLO + TER_SPAN * data[r * TER_NGRID + c]));
      }
      fprintf(p, "\n");
    }
    fprintf(p, "EOD\n");
    free(data);
  }
  for (int k = 0; k < nengine; k++) {
    const terResult* r = res + k;
    int best = r->done[0] > 0 ? ter_bestIter(r, 0) : -1;
    fprintf(p, "$T%d << EOD\n", k);
    if (!r->failed[0] || r->done[0] > 0) {
      ter_plotPath(p, r, 0, 0, 0);
    }
    fprintf(p, "EOD\n$I%d << EOD\n", k);
    for (int i = 1; i <= r->done[0]; i++) {
      if (isfinite(r->ev[i - 1].loss)) {
        ter_plotPath(p, r, 0, i, i);
      }
    }
    fprintf(p, "EOD\n$B%d << EOD\n", k);
    if (best >= 0) {
      ter_plotPath(p, r, 0, best + 1, best + 1);
    }
    fprintf(p, "EOD\n$G%d << EOD\n", k);
    if (r->done[0] > 0 && isfinite(r->ev[0].loss)) {
      ter_plotPath(p, r, 0, 1, 1);
    }
    // RMSE statistics per iteration over the trials with a good iterate there
    fprintf(p, "EOD\n$R%d << EOD\n", k);
    double* col = (double*)malloc(sizeof(double) * 2 * (size_t)r->trials);
    double* run = (double*)malloc(sizeof(double) * (size_t)r->trials);
    for (int t = 0; col && run && t < r->trials; t++) {
      run[t] = INFINITY;
    }
    for (int i = 0; col && run && i < r->iters; i++) {
      int n = 0;
      for (int t = 0; t < r->trials; t++) {
        double x = i < r->done[t] ? r->ev[t * r->iters + i].rmse : NAN;
        run[t] = isfinite(x) && x < run[t] ? x : run[t];
        if (isfinite(x)) {
          col[n++] = x;
        }
      }
      memcpy(col + r->trials, run, sizeof(double) * (size_t)r->trials);
      double med = synth_median(col, n), rb = synth_median(col + r->trials, r->trials);
      if (n > 0) {
        fprintf(p, "%d %.5g %.5g %.5g %.5g\n", i + 1, med, col[n / 4], col[(3 * n) / 4], rb);
      }
    }
    free(col);
    free(run);
    fprintf(p, "EOD\n");
  }

  // the map's view: trial 1's paths on every engine, 1.5 m around them, inside the terrain
  double lo[2] = {-1.5, -1.5}, hi[2] = {1.5, 1.5};
  for (int k = 0; k < nengine; k++) {
    for (int i = 0; i <= res[k].done[0]; i++) {
      const float* q = ter_path(res + k, 0, i);
      for (int s = 0; s <= res[k].nsample && (i == 0 || isfinite(res[k].ev[i - 1].loss)); s++) {
        for (int c = 0; c < 2; c++) {
          lo[c] = fmax(-TER_HALF, fmin(lo[c], q[2 * s + c] - 1.5));
          hi[c] = fmin(TER_HALF, fmax(hi[c], q[2 * s + c] + 1.5));
        }
      }
    }
  }

  // panels: a row per engine
  fprintf(p, "set multiplot layout %d,2\n", nengine);
  for (int k = 0; k < nengine; k++) {
    terSummary s;
    ter_summarize(res + k, &s);
    fprintf(p, "reset\nset size ratio -1\nset xlabel 'x (m)'\nset ylabel 'y (m)'\n"
               "set cblabel 'terrain z (cm)'\nset palette defined (0 '#3b6e3b', 1 '#e8e0b0')\n"
               "set key bottom right box opaque font ',9'\nset xrange [%.2f:%.2f]\n"
               "set yrange [%.2f:%.2f]\n", lo[0], hi[0], lo[1], hi[1]);
    fprintf(p, "set title '%s (%s, h = %g s), trial 1 (seed %ld)' noenhanced\n",
            engines[k].name, engines[k].ostrich ? "adjoint" : "finite differences", engines[k].h,
            seed);
    fprintf(p, "plot $H using 1:2:3 with image notitle, $G%d using 1:2 with lines lc rgb "
               "'#909090' lw 2 title 'guess', $I%d using 1:2 with lines lc rgb '#a0c8f0' lw 1 "
               "title 'iterates', $B%d using 1:2 with lines lc rgb '#1040c0' lw 3 title 'best "
               "iterate', $T%d using 1:2 with lines dt 2 lc rgb '#e02020' lw 3 title 'target'\n",
            k, k, k, k);
    fprintf(p, "reset\nset logscale y\nset xlabel 'iteration'\nset ylabel 'RMSE (m)'\n"
               "set grid\nset key top right box opaque\n");
    fprintf(p, "set title '%s: %d/%d trials best RMSE < 0.5 m, median %.3f m' noenhanced\n",
            engines[k].name, s.successes, res[k].trials, s.median_best);
    fprintf(p, "plot $R%d using 1:3:4 with filledcurves lc rgb '#c0d8f0' title 'interquartile', "
               "$R%d using 1:2 with lines lc rgb '#1040c0' lw 2 title 'median', $R%d using 1:5 "
               "with lines dt 2 lc rgb 'black' lw 2 title 'median of running best'\n", k, k, k);
  }
  fprintf(p, "unset multiplot\n");
}


// Draw the PNG with gnuplot (stdout sent to stderr); pngcairo, else the libgd png terminal.
// Return 0, else print why.
static int ter_writePlot(const char* png, const terEngine* engines, const terResult* res,
                         int nengine, const terTask* tasks, long seed) {
  const char* terminals[] = {"pngcairo", "png"};
  char tmp[CLI_PATH_SZ];
  if (cli_outputTemp(png, tmp, sizeof(tmp))) {
    return 1;
  }
  for (int i = 0; i < 2; i++) {
    fflush(stdout);
    FILE* p = popen("gnuplot 1>&2", "w");
    if (!p) {
      cli_error("cannot run gnuplot: %s", strerror(errno));
      return 1;
    }
    ter_plotScript(p, terminals[i], tmp, engines, res, nengine, tasks, seed);
    int status = pclose(p);
    if (status != -1 && WIFEXITED(status) && WEXITSTATUS(status) == 0) {
      if (cli_commitOutput(NULL, tmp, png)) {
        return 1;
      }
      fprintf(stderr, "ostrich: wrote %s (gnuplot, %s terminal)\n", png, terminals[i]);
      return 0;
    }
    if (status != -1 && WIFEXITED(status) && WEXITSTATUS(status) == 127) {
      cli_error("cannot run gnuplot (is it installed? Debian: gnuplot-nox)");
      cli_discardOutput(NULL, tmp);
      return 1;
    }
  }
  cli_error("gnuplot could not draw '%s' with the pngcairo or png terminal", png);
  cli_discardOutput(NULL, tmp);
  return 1;
}


//---------------------------------- synth --scene terrain -----------------------------------------

// The MuJoCo scene next to the Ostrich one: DIR/terrain_hfield.xml for DIR/NAME.xml.
static void ter_mujocoModel(const char* model, char* buf, size_t sz) {
  const char* slash = strrchr(model, '/');
  snprintf(buf, sz, "%.*sterrain_hfield.xml", slash ? (int)(slash - model + 1) : 0, model);
}


// Print the JSON line.
static void ter_report(const synthArgs* a, const char* const* models, const terEngine* engines,
                       const terResult* res, const terSummary* sums, int nengine, double total) {
  printf("{\"scene\":\"terrain\",");
  if (nengine == 1) {
    ter_printSummary(engines, res, sums, models[0], 0);
    printf(",");
  } else {
    printf("\"engine\":\"both\",\"trials\":%ld,", a->trials);
  }
  printf("\"iters\":%ld,\"seed\":%ld,\"lr\":", a->iters, a->seed);
  cli_jsonNumber(stdout, a->lr);
  if (nengine > 1) {
    for (int k = 0; k < nengine; k++) {
      printf(",\"%s\":{", engines[k].name);
      ter_printSummary(engines + k, res + k, sums + k, models[k], 1);
      printf("}");
    }
    printf(",\"warm_iter_ratio\":");
    cli_jsonNumber(stdout, sums[1].median_warm_ms / sums[0].median_warm_ms);
  }
  printf(",\"total_s\":%.3f}\n", total);
  fflush(stdout);
}


int synth_terrainMain(const synthArgs* a) {
  // engines: ostrich first when both; the same instances on each
  double start = cli_now();
  int both = !strcmp(a->engine, "both");
  int nengine = both ? 2 : 1;
  const char* names[2] = {both ? "ostrich" : a->engine, "mujoco"};
  char hfield[CLI_PATH_SZ];
  ter_mujocoModel(a->model, hfield, sizeof(hfield));
  const char* models[2];
  for (int k = 0; k < nengine; k++) {
    models[k] = strcmp(names[k], "ostrich") ? hfield : a->model;
  }
  terEngine engines[2];
  terResult res[2];
  terSummary sums[2];
  memset(engines, 0, sizeof(engines));
  memset(res, 0, sizeof(res));
  terTask* tasks = (terTask*)calloc((size_t)a->trials, sizeof(terTask));
  int status = tasks ? CLI_OK : CLI_USAGE;
  if (!tasks) {
    cli_error("synth: out of memory");
  }
  for (int k = 0; k < nengine && status == CLI_OK; k++) {
    if (ter_engineSetup(engines + k, names[k], models[k], a) ||
        ter_resultAlloc(res + k, (int)a->trials, (int)a->iters, engines[k].nsample)) {
      status = CLI_USAGE;
    }
  }
  if (status == CLI_OK) {
    // instance t from seed + t; knots bounded by the first engine's control range
    for (int t = 0; t < a->trials; t++) {
      ter_task((unsigned long long)(a->seed + t), engines[0].lo, engines[0].hi, tasks + t);
    }
    for (int k = 0; k < nengine; k++) {
      int ended = ter_run(engines + k, a, tasks, res + k);
      if (ter_summarize(res + k, sums + k) || ended || cli_mujocoError()) {
        status = CLI_FAIL;
      }
    }

    // outputs, then the summary
    if (a->csv && ter_writeCsv(a->csv, engines, res, nengine)) {
      status = CLI_FAIL;
    }
    if (a->plot && ter_writePlot(a->plot, engines, res, nengine, tasks, a->seed)) {
      status = CLI_FAIL;
    }
    ter_report(a, models, engines, res, sums, nengine, cli_now() - start);
  }
  for (int k = 0; k < nengine; k++) {
    ter_resultFree(res + k);
    ter_engineFree(engines + k);
  }
  free(tasks);
  return status;
}
