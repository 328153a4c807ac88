// compare_models_out.c: the outputs of `ostrich compare models` (compare_models.c runs): the
// table and the summary on stdout, the CSV (written to a temporary file and renamed by
// cli_commitOutput, so a killed run leaves the previous file whole), the gnuplot panels, and the
// rows of MuJoCo 3 from compare/mujoco3_models.py, read back from the CSV it writes in the same
// columns.
#define _POSIX_C_SOURCE 200809L

#include <errno.h>
#include <fcntl.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

#include "compare_models.h"


#define MODELS_MAX_REASONS 256    // distinct refusal reasons ranked


//---------------------------------- Rows ----------------------------------------------------------

modelsRow* models_addRow(modelsState* s) {
  if (s->nrow == s->cap) {
    int cap = s->cap ? 2 * s->cap : 256;
    modelsRow* grown = realloc(s->row, sizeof(modelsRow) * (size_t)cap);
    if (!grown) {
      return NULL;
    }
    s->row = grown;
    s->cap = cap;
  }
  modelsRow* r = s->row + s->nrow++;
  *r = (modelsRow){.h_scale = NAN, .h = NAN, .simulated = NAN, .converged_pct = NAN,
                   .max_penetration = NAN, .wall_per_sim = NAN, .error = NAN};
  return r;
}


void models_setText(char* field, int sz, const char* text) {
  int n = 0;
  for (const char* c = text; *c && n < sz - 1; c++) {
    if (*c == '\n' || *c == '\r') {
      while (n > 0 && (field[n - 1] == ' ' || field[n - 1] == ';')) {
        n--;
      }
      if (n > 0 && n < sz - 3) {
        field[n++] = ';';
        field[n++] = ' ';
      }
      continue;
    }
    field[n++] = *c == '\t' ? ' ' : *c;
  }
  while (n > 0 && (field[n - 1] == ' ' || field[n - 1] == ';')) {
    n--;
  }
  field[n] = 0;
}


// Attempted and converged steps of an Ostrich row (a diverged or failed run's last step counts).
static void models_counts(const modelsRow* r, double* attempted, double* converged) {
  *attempted = (double)r->steps + (strcmp(r->status, "diverged") && strcmp(r->status, "failed")
                                   ? 0 : 1);
  *converged = isfinite(r->converged_pct) ? r->converged_pct * *attempted / 100 : 0;
}


//---------------------------------- CSV -----------------------------------------------------------

// Write a number, or nothing if it is not finite.
static void models_number(FILE* f, double x, const char* fmt) {
  if (isfinite(x)) {
    fprintf(f, fmt, x);
  }
}


// Write a CSV field in double quotes, quotes doubled.
static void models_quoted(FILE* f, const char* s) {
  fputc('"', f);
  for (; *s; s++) {
    if (*s == '"') {
      fputc('"', f);
    }
    fputc(*s, f);
  }
  fputc('"', f);
}


int models_writeCsv(const modelsState* s) {
  char tmp[CLI_PATH_SZ];
  FILE* f = cli_openOutput(s->csv, tmp, sizeof(tmp));
  if (!f) {
    return 1;
  }
  fprintf(f, "%s\n", MODELS_CSV_HEADER);
  for (int i = 0; i < s->nrow; i++) {
    const modelsRow* r = s->row + i;
    int ran = strcmp(r->status, "refused") && strcmp(r->status, "load_failed");
    fprintf(f, "%s,%s,%s,", r->model, r->engine, r->ctrl);
    models_number(f, r->h_scale, "%g");
    fputc(',', f);
    models_number(f, r->h, "%.10g");
    fprintf(f, ",%s,", r->status);
    if (ran) {
      fprintf(f, "%ld", r->steps);
    }
    fputc(',', f);
    models_number(f, r->simulated, "%.10g");
    fputc(',', f);
    models_number(f, r->converged_pct, "%.4g");
    fputc(',', f);
    if (ran && isfinite(r->converged_pct)) {
      fprintf(f, "%ld", r->unconverged);
    }
    fputc(',', f);
    if (ran) {
      fprintf(f, "%ld", r->failed);
    }
    fputc(',', f);
    models_number(f, r->max_penetration, "%.6g");
    fputc(',', f);
    models_number(f, r->wall_per_sim, "%.6g");
    fputc(',', f);
    models_number(f, r->error, "%.6g");
    fputc(',', f);
    models_quoted(f, r->reason);
    fputc('\n', f);
  }
  return cli_commitOutput(f, tmp, s->csv);
}


// Split one CSV line into at most cap fields in place (double quotes honoured); return the count.
static int models_splitCsv(char* line, char** field, int cap) {
  int n = 0;
  char* w = line;
  for (char* c = line; n < cap;) {
    field[n++] = w;
    int quoted = *c == '"';
    c += quoted;
    for (; *c && *c != '\n' && *c != '\r' && (quoted || *c != ','); c++) {
      if (quoted && *c == '"') {
        if (c[1] != '"') {
          quoted = 0;
          continue;
        }
        c++;
      }
      *w++ = *c;
    }
    char delim = *c;              // read before the terminator, which may overwrite it
    *w++ = 0;
    if (delim != ',') {
      break;
    }
    c++;
  }
  return n;
}


// Parse a number field ("" = NaN).
static double models_parse(const char* s) {
  double x;
  return *s && !cli_parseNumber(s, &x) ? x : NAN;
}


// Append the rows of a CSV in the columns of MODELS_CSV_HEADER; return 0 on success.
static int models_readRows(modelsState* s, const char* path) {
  FILE* f = fopen(path, "r");
  if (!f) {
    cli_error("mujoco3: no rows in '%s': %s", path, strerror(errno));
    return 1;
  }
  char line[4096];
  char* field[16];
  int status = !fgets(line, sizeof(line), f) ||
               strncmp(line, MODELS_CSV_HEADER, strlen(MODELS_CSV_HEADER));
  while (!status && fgets(line, sizeof(line), f)) {
    if (models_splitCsv(line, field, 16) != 15) {
      status = 1;
      break;
    }
    modelsRow* r = models_addRow(s);
    if (!r) {
      status = 1;
      break;
    }
    models_setText(r->model, sizeof(r->model), field[0]);
    models_setText(r->engine, sizeof(r->engine), field[1]);
    models_setText(r->ctrl, sizeof(r->ctrl), field[2]);
    r->h_scale = models_parse(field[3]);
    r->h = models_parse(field[4]);
    models_setText(r->status, sizeof(r->status), field[5]);
    r->steps = (long)models_parse(field[6]);
    r->simulated = models_parse(field[7]);
    r->converged_pct = models_parse(field[8]);
    r->failed = (long)models_parse(field[10]);
    r->max_penetration = models_parse(field[11]);
    r->wall_per_sim = models_parse(field[12]);
    r->error = models_parse(field[13]);
    models_setText(r->reason, sizeof(r->reason), field[14]);
  }
  fclose(f);
  if (status) {
    cli_error("mujoco3: '%s' is not a rows CSV (" MODELS_CSV_HEADER ")", path);
  }
  return status;
}


// Regroup the rows model by model (in order of first appearance), each model's rows in order.
static void models_groupRows(modelsState* s) {
  modelsRow* grouped = malloc(sizeof(modelsRow) * (size_t)(s->nrow ? s->nrow : 1));
  char* done = calloc((size_t)(s->nrow ? s->nrow : 1), 1);
  int n = 0;
  for (int i = 0; grouped && done && i < s->nrow; i++) {
    if (done[i]) {
      continue;
    }
    for (int j = i; j < s->nrow; j++) {
      if (!done[j] && !strcmp(s->row[j].model, s->row[i].model)) {
        grouped[n++] = s->row[j];
        done[j] = 1;
      }
    }
  }
  if (grouped && done) {
    memcpy(s->row, grouped, sizeof(modelsRow) * (size_t)n);
  }
  free(grouped);
  free(done);
}


void models_runMujoco3(modelsState* s) {
  char jobs[MODELS_PATH_SZ + 16], rows[MODELS_PATH_SZ + 16], script[MODELS_PATH_SZ];
  // the script beside this source file (CMake compiles it by its absolute path), unless the
  // environment names another
  const char* env = getenv("OSTRICH_MUJOCO3_SCRIPT");
  const char* slash = strrchr(__FILE__, '/');
  if (env && env[0]) {
    snprintf(script, sizeof(script), "%s", env);
  } else {
    snprintf(script, sizeof(script), "%.*smujoco3_models.py", slash ? (int)(slash - __FILE__ + 1)
             : 0, __FILE__);
  }
  snprintf(jobs, sizeof(jobs), "%s/jobs.csv", s->jobs_dir);
  snprintf(rows, sizeof(rows), "%s/rows.csv", s->jobs_dir);
  char* argv[] = {"python3", script, "--jobs", jobs, "--out", rows, NULL};
  int status = cmp_spawn(argv, "/dev/null", NULL);
  if (status == 127) {
    cli_error("note: --mujoco3 skipped: python3 not found");
  } else if (status == 3) {
    cli_error("note: --mujoco3 skipped: the python package mujoco (3.x) is not installed "
              "(pip install mujoco)");
  } else if (status) {
    cli_error("note: --mujoco3: %s failed (exit %d); its rows are left out", script, status);
  } else {
    int first = s->nrow;
    if (models_readRows(s, rows)) {
      s->nrow = first;
      return;
    }
    // keep a model's rows together: the MuJoCo 3 rows after the model's own
    models_groupRows(s);
  }
}


//---------------------------------- Table and summary ---------------------------------------------

void models_printTable(const modelsState* s) {
  printf("%-22s %-22s %-6s %6s %9s %-11s %6s %7s %10s %10s %10s  %s\n", "model", "engine",
         "ctrl", "h_x", "h", "status", "steps", "conv%", "max_pen", "wall/sim", "error",
         "reason");
  for (int i = 0; i < s->nrow; i++) {
    const modelsRow* r = s->row + i;
    char hx[16] = "-", h[16] = "-", steps[24] = "-", conv[16] = "-", pen[16] = "-",
         wall[16] = "-", err[16] = "-";
    if (isfinite(r->h_scale)) {
      snprintf(hx, sizeof(hx), "%g", r->h_scale);
      snprintf(h, sizeof(h), "%.4g", r->h);
      snprintf(steps, sizeof(steps), "%ld", r->steps);
    }
    if (isfinite(r->converged_pct)) {
      snprintf(conv, sizeof(conv), "%.1f", r->converged_pct);
    }
    if (isfinite(r->max_penetration)) {
      snprintf(pen, sizeof(pen), "%.3g", r->max_penetration);
    }
    if (isfinite(r->wall_per_sim)) {
      snprintf(wall, sizeof(wall), "%.3g", r->wall_per_sim);
    }
    if (isfinite(r->error)) {
      snprintf(err, sizeof(err), "%.3g", r->error);
    }
    printf("%-22s %-22s %-6s %6s %9s %-11s %6s %7s %10s %10s %10s  %s\n", r->model, r->engine,
           r->ctrl[0] ? r->ctrl : "-", hx, h, r->status, steps, conv, pen, wall, err, r->reason);
  }
}


// Reduce one refused feature to its kind, "<element>: <feature>": from ost_checkModel's entries
// "joint 'a': frictionloss (...)" and "44 geoms ('a', 'b' and 42 more): condim 6 (...)" the
// element type (singular) and the text after the names; any other text with names in quotes
// and numbers after '#' turned into '*'.
static void models_reasonKind(const char* part, char* kind, int sz) {
  const char* c = part + strspn(part, "0123456789");
  int counted = c > part && *c == ' ';
  c += counted;
  int type_len = (int)strcspn(c, " ");
  const char* colon = strstr(c, ": ");
  const char* names = c + type_len;
  if (colon && type_len > 0 && (names[0] == ' ' && (names[1] == '\'' || names[1] == '(' ||
                                                    names[1] == '#'))) {
    int singular = counted && type_len > 1 && c[type_len - 1] == 's';
    snprintf(kind, (size_t)sz, "%.*s: %s", type_len - singular, c, colon + 2);
    return;
  }
  int n = 0;
  for (c = part; *c && n < sz - 2; c++) {
    if (*c == '\'' && strchr(c + 1, '\'')) {
      kind[n++] = '*';
      c = strchr(c + 1, '\'');
      continue;
    }
    kind[n++] = *c;
    if (*c == '#') {
      kind[n++] = '*';
      while (c[1] >= '0' && c[1] <= '9') {
        c++;
      }
    }
  }
  kind[n] = 0;
}


// Split a refusal into its features in place: after the "unsupported by Ostrich (N features): "
// prefix, at each "; " outside parentheses and quotes. Return the count (at most cap).
static int models_splitReason(char* reason, char** part, int cap) {
  char* c = strstr(reason, "): ");
  c = c && !strncmp(reason, "unsupported by", 14) ? c + 3 : reason;
  int n = 0, depth = 0, quoted = 0;
  part[n++] = c;
  for (; *c && n < cap; c++) {
    quoted ^= *c == '\'';
    depth += !quoted && *c == '(';
    depth -= !quoted && *c == ')' && depth > 0;
    if (!quoted && !depth && c[0] == ';' && c[1] == ' ') {
      *c = 0;
      part[n++] = c + 2;
      c++;
    }
  }
  return n;
}


// Print the refusal reasons ranked by how many models each blocks (a model counts once per kind).
static void models_rankReasons(const modelsState* s) {
  static char kind[MODELS_MAX_REASONS][MODELS_REASON_SZ];
  int count[MODELS_MAX_REASONS] = {0}, last[MODELS_MAX_REASONS], nkind = 0;
  for (int i = 0; i < s->nrow; i++) {
    if (strcmp(s->row[i].status, "refused")) {
      continue;
    }
    char buf[MODELS_REASON_SZ], *part[64];
    snprintf(buf, sizeof(buf), "%s", s->row[i].reason);
    int npart = models_splitReason(buf, part, 64);
    for (int p = 0; p < npart; p++) {
      char k[MODELS_REASON_SZ];
      models_reasonKind(part[p], k, sizeof(k));
      if (!k[0] || !strncmp(k, "...", 3)) {
        continue;
      }
      int j = 0;
      while (j < nkind && strcmp(kind[j], k)) {
        j++;
      }
      if (j == nkind && nkind < MODELS_MAX_REASONS) {
        snprintf(kind[nkind++], MODELS_REASON_SZ, "%s", k);
        last[j] = -1;
      }
      if (j < nkind && last[j] != i) {
        count[j]++;
        last[j] = i;
      }
    }
  }
  printf("refusal reasons, by models blocked (%d refused):\n", s->nrefused);
  for (int printed = 0; printed < nkind; printed++) {
    int best = -1;
    for (int j = 0; j < nkind; j++) {
      best = count[j] > 0 && (best < 0 || count[j] > count[best]) ? j : best;
    }
    printf("  %3d  %s\n", count[best], kind[best]);
    count[best] = 0;
  }
}


void models_printSummary(const modelsState* s) {
  printf("\nsummary: %d models, %d refused by Ostrich, %d failed to load in MuJoCo; "
         "Ostrich runs that diverged or failed: %d; runs stopped by --max-wall: %d\n",
         s->nmodel, s->nrefused, s->nload_failed, s->nbad, s->ntimeout);
  printf("Ostrich converged steps (OST_OK / steps attempted), per model and h-scale; "
         "wall ratio = mujoco / ostrich wall time at x%g:\n", s->scale[0]);
  double all_att = 0, all_conv = 0;
  for (int i = 0; i < s->nrow; i++) {
    // the first row of each model that Ostrich ran
    const char* name = s->row[i].model;
    int seen = 0;
    for (int j = 0; j < i && !seen; j++) {
      seen = !strcmp(s->row[j].model, name);
    }
    if (seen) {
      continue;
    }
    double att_m = 0, conv_m = 0, wall[CMP_NENGINE] = {0};
    char line[1024];
    int n = 0;
    for (int k = 0; k < s->nscale; k++) {
      double att = 0, conv = 0;
      for (int j = i; j < s->nrow; j++) {
        const modelsRow* r = s->row + j;
        if (strcmp(r->model, name) || r->h_scale != s->scale[k]) {
          continue;
        }
        for (int e = 0; e < CMP_NENGINE && k == 0; e++) {
          wall[e] += !strcmp(r->engine, kCmpEngineNames[e]) ? r->wall_per_sim : 0;
        }
        if (!strcmp(r->engine, "ostrich")) {
          double a, c;
          models_counts(r, &a, &c);
          att += a;
          conv += c;
        }
      }
      att_m += att;
      conv_m += conv;
      if (att > 0 && n < (int)sizeof(line) - 32) {
        n += snprintf(line + n, sizeof(line) - (size_t)n, "  x%g %5.1f%%", s->scale[k],
                      100 * conv / att);
      }
    }
    all_att += att_m;
    all_conv += conv_m;
    if (att_m > 0) {
      printf("  %-22s %5.1f%% |%s", name, 100 * conv_m / att_m, line);
      if (wall[CMP_MUJOCO] > 0 && wall[CMP_OSTRICH] > 0) {
        printf("  | wall ratio %.3g", wall[CMP_MUJOCO] / wall[CMP_OSTRICH]);
      }
      printf("\n");
    }
  }
  if (all_att > 0) {
    printf("  %-22s %5.1f%% of %.0f steps\n", "all models", 100 * all_conv / all_att, all_att);
  }
  models_rankReasons(s);
}


//---------------------------------- Plot ----------------------------------------------------------

int models_writePlot(const modelsState* s) {
  char dat[MODELS_PATH_SZ + 8], gp[MODELS_PATH_SZ + 8], log[MODELS_PATH_SZ + 8];
  char tmp[CLI_PATH_SZ], png_tmp[CLI_PATH_SZ];
  snprintf(dat, sizeof(dat), "%s.dat", s->plot);
  snprintf(gp, sizeof(gp), "%s.gp", s->plot);
  snprintf(log, sizeof(log), "%s.log", s->plot);
  if (strchr(s->plot, '\'')) {
    cli_error("note: plot skipped: its path contains a quote");
    return 0;
  }

  // data: model index, engine index, error, wall per simulated second, h-scale
  static const char* color[] = {"#1f5fbf", "#e07b00", "#2a9d3a", "#b02a8a", "#555555"};
  const char* engine[5];
  const char* model[1024];
  int nengine = 0, nmodel = 0;
  FILE* f = cli_openOutput(dat, tmp, sizeof(tmp));
  if (!f) {
    return 1;
  }
  for (int i = 0; i < s->nrow; i++) {
    const modelsRow* r = s->row + i;
    if (!(r->error > 0) || !(r->wall_per_sim > 0)) {
      continue;
    }
    int e = 0, m = 0;
    while (e < nengine && strcmp(engine[e], r->engine)) {
      e++;
    }
    while (m < nmodel && strcmp(model[m], r->model)) {
      m++;
    }
    if ((e == nengine && nengine == 5) || (m == nmodel && nmodel == 1024)) {
      continue;
    }
    engine[e] = r->engine;
    model[m] = r->model;
    nengine += e == nengine;
    nmodel += m == nmodel;
    fprintf(f, "%d %d %.6g %.6g %g\n", m, e, r->error, r->wall_per_sim, r->h_scale);
  }
  if (cli_commitOutput(f, tmp, dat)) {
    return 1;
  }

  // one panel per model, points coloured by engine and labelled with the h-scale
  int cols = (int)ceil(sqrt((double)(nmodel ? nmodel : 1)));
  int rows = (nmodel + cols - 1) / cols;
  if (!(f = cli_openOutput(gp, tmp, sizeof(tmp)))) {
    return 1;
  }
  // the PNG's name is a gnuplot variable: this run draws into its temporary name
  fprintf(f, "# written by `ostrich compare models`; rerun with: gnuplot %s\n"
          "if (!exists('out')) out = '%s'\n"
          "set terminal pngcairo size %d,%d font 'Sans,9'\nset output out\n"
          "set logscale xy\nset grid\nset format x '%%.0e'\nset format y '%%.0e'\n"
          "set key top left font ',7'\nset xlabel 'error against MuJoCo at h/4'\n"
          "set ylabel 'wall s per simulated s'\nset multiplot layout %d,%d\n", gp, s->plot,
          380 * cols, 300 * (rows ? rows : 1), rows ? rows : 1, cols);
  for (int m = 0; m < nmodel; m++) {
    fprintf(f, "set title '");
    for (const char* c = model[m]; *c; c++) {
      fputc(*c == '\'' ? '_' : *c, f);
    }
    fprintf(f, "' noenhanced\nplot ");
    for (int e = 0; e < nengine; e++) {
      fprintf(f, "%s'%s' using ($1 == %d && $2 == %d ? $3 : 1/0):4 with points pt 7 "
              "lc rgb '%s' title '%s' noenhanced, '' using ($1 == %d && $2 == %d ? $3 : 1/0):4:"
              "(sprintf('x%%g', $5)) with labels offset 0.8,0.5 font ',7' tc rgb '%s' notitle",
              e ? ", " : "", dat, m, e, color[e], engine[e], m, e, color[e]);
    }
    fprintf(f, "\n");
  }
  fprintf(f, "unset multiplot\n");
  if (cli_commitOutput(f, tmp, gp)) {
    return 1;
  }
  if (!nmodel) {
    cli_error("note: plot skipped: no run has a finite error and wall time");
    return 0;
  }
  char vars[CLI_PATH_SZ + 16];
  cli_outputTemp(s->plot, png_tmp, sizeof(png_tmp));
  snprintf(vars, sizeof(vars), "out = '%s'", png_tmp);
  char* argv[] = {"gnuplot", "-e", vars, gp, NULL};
  int status = cmp_spawn(argv, log, log);
  if (status) {
    cli_discardOutput(NULL, png_tmp);
  }
  if (status == 127) {
    cli_error("note: plot skipped: gnuplot not found (install gnuplot-nox); script in %s", gp);
    return 0;
  }
  if (status) {
    cli_error("plot failed: gnuplot exit %d, see %s", status, log);
    return 1;
  }
  return cli_commitOutput(NULL, png_tmp, s->plot);
}
