// ost_cli_bench_report.c: the report of `ostrich bench models` (the driver is
// ost_cli_bench_models.c): the figures derived from the timed rows (us per step and per simulated
// second, ratios to MuJoCo, the log-log fit against nv) and their forms: the table and its notes
// on stdout, the CSV (written to a temporary name, then renamed) and the gnuplot figure.
// Invariant: every form is computed from the same rows by the same functions, so the table, the
// CSV and the plot never disagree; a figure that was not measured prints as "-" (empty in CSV).
#define _POSIX_C_SOURCE 200809L

#include <math.h>
#include <stdio.h>
#include <stdlib.h>

#include "ost_cli_bench_models.h"
#include "ost_cli_util.h"

static const char* kStatusName[] = {"ok", "stopped", "refused", "failed"};

const char* const kBenchModelsScratch[MODELS_NSCRATCH] = {"scaling.dat", "models.dat", "plot.gp"};


//---------------------------------- Figures -------------------------------------------------------

static double usPerStep(const modelsRow* r) {
  return r->steps > 0 ? 1e6 * r->wall_s / r->steps : NAN;
}


static double usPerSim(const modelsRow* r) {
  return r->steps > 0 ? 1e6 * r->wall_s / (r->steps * r->h) : NAN;
}


void bench_models_setRatios(modelsRow* rows, int first, int last) {
  for (int r = first + 1; r < last; r++) {
    rows[r].ratio_step = usPerStep(rows + r) / usPerStep(rows + first);
    rows[r].ratio_sim = usPerSim(rows + r) / usPerSim(rows + first);
  }
}


// least-squares slope of log(us per step) against log(nv) over one engine's scaling rows
static double fitSlope(const modelsRow* rows, int nrow, int ostrich, int* npoint) {
  double n = 0, sx = 0, sy = 0, sxx = 0, sxy = 0;
  for (int r = 0; r < nrow; r++) {
    if (rows[r].copies && rows[r].ostrich == ostrich && rows[r].steps > 0
        && rows[r].status != RUN_FAILED && rows[r].status != RUN_REFUSED) {
      double x = log((double)rows[r].nv), y = log(usPerStep(rows + r));
      n++;
      sx += x;
      sy += y;
      sxx += x * x;
      sxy += x * y;
    }
  }
  *npoint = (int)n;
  double den = n * sxx - sx * sx;
  return n >= 2 && den > 1e-12 ? (n * sxy - sx * sy) / den : NAN;
}


//---------------------------------- Output --------------------------------------------------------

// x printed with fmt, or "-" if not finite
static const char* fmtNum(char* buf, const char* fmt, double x) {
  snprintf(buf, 32, isfinite(x) ? fmt : "-", x);
  return buf;
}


void bench_models_printHeader(const char* title) {
  printf("%s\n%-30s %6s %-8s %8s %5s %7s %12s %12s %10s %11s %9s  %s\n", title, "model", "nv",
         "engine", "h", "x_h", "steps", "us/step", "us/sim_s", "ratio/step", "ratio/sim_s",
         "converged", "status");
}


void bench_models_printRow(const modelsRow* r, int first) {
  char nv[16], b[5][32];
  double conv = r->ostrich && r->steps > 0 ? 100.0 * r->converged / r->steps : NAN;
  snprintf(nv, sizeof(nv), "%d", r->nv);
  printf("%-30s %6s %-8s %8.4g %5.3g %7ld %12s %12s %10s %11s %9s  %s\n", first ? r->label : "",
         first ? nv : "", r->ostrich ? "ostrich" : "mujoco", r->h, r->scale, r->steps,
         fmtNum(b[0], "%.1f", usPerStep(r)), fmtNum(b[1], "%.0f", usPerSim(r)),
         fmtNum(b[2], "%.3f", r->ratio_step), fmtNum(b[3], "%.3f", r->ratio_sim),
         fmtNum(b[4], "%.1f%%", conv), kStatusName[r->status]);
}


void bench_models_printNotes(const modelsRow* rows, int nrow) {
  for (int r = 0; r < nrow; r++) {
    if (rows[r].msg[0]) {
      printf("  %s, %s h = %g: %s%s\n", rows[r].label, rows[r].ostrich ? "ostrich" : "mujoco",
             rows[r].h, rows[r].status == RUN_REFUSED ? "refused by Ostrich: " : "", rows[r].msg);
    }
  }
}


void bench_models_printFit(const modelsRow* rows, int nrow, double slope[2], int npoint[2]) {
  for (int e = 0; e < 2; e++) {
    slope[e] = fitSlope(rows, nrow, e, npoint + e);
  }
  char b[4][32];
  printf("fit of log(us/step) on log(nv) over %d and %d sizes: slope mujoco %s, ostrich %s; "
         "difference (ostrich - mujoco) %s, ratio (ostrich / mujoco) %s\n", npoint[0],
         npoint[1], fmtNum(b[0], "%.3f", slope[0]), fmtNum(b[1], "%.3f", slope[1]),
         fmtNum(b[2], "%.3f", slope[1] - slope[0]),
         fmtNum(b[3], "%.3f", slope[1] / slope[0]));
}


// CSV fields: a number (empty if not finite), a quoted text
static void csvNumber(FILE* f, double x) {
  fprintf(f, isfinite(x) ? ",%.6g" : ",", x);
}


static void csvText(FILE* f, const char* s) {
  fputs(",\"", f);
  for (; *s; s++) {
    if (*s == '"') {
      fputc('"', f);
    }
    fputc(*s, f);
  }
  fputc('"', f);
}


int bench_models_writeCsv(const char* path, const modelsRow* rows, int nrow,
                          const double* slope, const int* npoint, int fit) {
  char tmp[CLI_PATH_SZ];
  FILE* f = cli_openOutput(path, tmp, sizeof(tmp));
  if (!f) {
    return 1;
  }
  fprintf(f, "kind,model,copies,nv,engine,h,h_scale,steps,sim_s,wall_s,us_per_step,"
          "us_per_sim_s,ratio_step,ratio_sim_s,converged_share,status,slope,message\n");
  for (int i = 0; i < nrow; i++) {
    const modelsRow* r = rows + i;
    fprintf(f, "%s", r->kind);
    csvText(f, r->copies ? r->label : r->path);
    fprintf(f, ",%d,%d,%s", r->copies, r->nv, r->ostrich ? "ostrich" : "mujoco");
    csvNumber(f, r->h);
    csvNumber(f, r->scale);
    fprintf(f, ",%ld", r->steps);
    csvNumber(f, r->steps * r->h);
    csvNumber(f, r->wall_s);
    csvNumber(f, usPerStep(r));
    csvNumber(f, usPerSim(r));
    csvNumber(f, r->ratio_step);
    csvNumber(f, r->ratio_sim);
    csvNumber(f, r->ostrich && r->steps ? (double)r->converged / r->steps : NAN);
    fprintf(f, ",%s,", kStatusName[r->status]);
    csvText(f, r->msg);
    fputc('\n', f);
  }
  for (int e = 0; fit && e < 2; e++) {
    char msg[128];
    snprintf(msg, sizeof(msg), "least squares of log(us_per_step) on log(nv), %d sizes",
             npoint[e]);
    fprintf(f, "fit,\"humanoids\",,,%s,,,,,,,,,,,%s", e ? "ostrich" : "mujoco",
            isfinite(slope[e]) ? "ok" : "failed");
    csvNumber(f, slope[e]);
    csvText(f, msg);
    fputc('\n', f);
  }
  return cli_commitOutput(f, tmp, path);
}


// gnuplot: us per step against nv (scaling rows, log-log) and us per simulated second of each
// model and engine/h (a clustered histogram), one panel each, into png; data files in dir
int bench_models_writePlot(const char* png, const char* dir, const modelsRow* rows, int nrow,
                           const double* scale, int nscale) {
  char path[MODELS_NSCRATCH][4096];
  FILE* f[MODELS_NSCRATCH];
  for (int i = 0; i < MODELS_NSCRATCH; i++) {
    snprintf(path[i], sizeof(path[i]), "%s/%s", dir, kBenchModelsScratch[i]);
    f[i] = fopen(path[i], "w");
  }
  int bad = !f[0] || !f[1] || !f[2], nscaling = 0, nmodel = 0;
  if (!bad) {
    fprintf(f[1], "model \"mujoco h\" \"ostrich h\"");
    for (int s = 0; s < nscale; s++) {
      fprintf(f[1], " \"ostrich %gh\"", scale[s]);
    }
  }
  for (int r = 0; !bad && r < nrow; r++) {
    if (rows[r].copies && !rows[r].ostrich && r + 1 < nrow) {
      fprintf(f[0], "%d %.6g %.6g\n", rows[r].nv, usPerStep(rows + r), usPerStep(rows + r + 1));
      nscaling++;
    } else if (!rows[r].copies && !rows[r].ostrich) {
      fprintf(f[1], "\n\"%s\"", rows[r].label);
      for (int s = 0; s <= nscale + 1; s++) {
        int j = r + s;
        int same = j < nrow && (s == 0 || rows[j].ostrich) && rows[j].path == rows[r].path;
        double us = same ? usPerSim(rows + j) : NAN;
        fprintf(f[1], isfinite(us) ? " %.6g" : " -", us);
      }
      nmodel++;
    }
  }
  // gnuplot draws into the PNG's temporary name, renamed once it succeeds
  char png_tmp[CLI_PATH_SZ];
  bad = bad || cli_outputTemp(png, png_tmp, sizeof(png_tmp));
  if (!bad) {
    FILE* g = f[2];
    fprintf(g, "set terminal png size %d,650\nset output '%s'\nset termoption noenhanced\n"
            "set datafile missing '-'\nset multiplot layout 1,%d\n",
            (nscaling && nmodel) ? 1600 : 900, png_tmp, (nscaling && nmodel) ? 2 : 1);
    if (nscaling) {
      fprintf(g, "set title 'N humanoids: time per step against nv (same h)'\n"
              "set logscale xy\nset xlabel 'nv'\nset ylabel 'us per step'\nset key top left\n"
              "plot '%s' using 1:2 with linespoints title 'mujoco mj_step', "
              "'' using 1:3 with linespoints title 'ostrich ost_step'\nunset logscale\n",
              path[0]);
    }
    if (nmodel) {
      fprintf(g, "set title 'us per simulated second (h = opt.timestep x factor)'\n"
              "set logscale y\nunset xlabel\nset ylabel 'us per simulated second'\n"
              "set style data histogram\nset style histogram clustered gap 1\n"
              "set style fill solid 0.8 border -1\nset xtics rotate by -30\n"
              "set bmargin 9\nset rmargin 8\n"
              "set key top left\nplot for [i=2:%d] '%s' using i:xtic(1) title columnheader(i)\n",
              nscale + 3, path[1]);
    }
    fprintf(g, "unset multiplot\n");
  }
  for (int i = 0; i < MODELS_NSCRATCH; i++) {
    bad = (f[i] && fclose(f[i])) || bad;
  }
  if (!bad) {
    char cmd[4200];
    snprintf(cmd, sizeof(cmd), "gnuplot '%s' 1>&2", path[2]);
    bad = system(cmd) != 0;
    if (bad) {
      cli_discardOutput(NULL, png_tmp);
    } else {
      bad = cli_commitOutput(NULL, png_tmp, png);
    }
  }
  return bad;
}
