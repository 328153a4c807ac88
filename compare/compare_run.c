// compare_run.c: the shared part of the A/B subcommands (see compare_run.h): CSV tables and
// command files, the pallet-traversal profile, trajectories and their error metric, the engine
// runner, argument helpers and a process launcher. The runner mirrors sim_loop in
// plugin/cli/ost_cli.c.
//
// Invariant: nothing here writes to stdout or exits; a rejected input gives one "ostrich:" line
// on stderr and a nonzero return. The runner leaves the model as it found it (opt.timestep).
#define _POSIX_C_SOURCE 200809L

#include "compare_run.h"

#include <errno.h>
#include <fcntl.h>
#include <math.h>
#include <spawn.h>
#include <stdlib.h>
#include <string.h>
#include <sys/wait.h>

#include "ostrich.h"

const char* const kCmpEngineNames[CMP_NENGINE] = {"mujoco", "ostrich"};
const char* const kCmpOutcomeNames[] = {"completed", "nan", "step_failed", "setup_failed",
                                        "timeout"};
const char* const kCmpRobotColumns[3] = {"cmd_left", "cmd_right", "cmd_rear"};


//---------------------------------- CSV tables ----------------------------------------------------

// Drop the line break and surrounding blanks of s in place; return s.
static char* cmp_trim(char* s) {
  while (*s == ' ' || *s == '\t') {
    s++;
  }
  size_t n = strlen(s);
  while (n > 0 && strchr(" \t\r\n", s[n - 1])) {
    s[--n] = 0;
  }
  return s;
}


// Number of comma-separated fields of a line.
static int cmp_countFields(const char* line) {
  int n = 1;
  for (const char* c = line; *c; c++) {
    n += (*c == ',');
  }
  return n;
}


// Store the header line's names into t; return 0 on success.
static int cmp_readHeader(const char* path, long lineno, char* line, cmpTable* t) {
  t->ncol = cmp_countFields(line);
  t->name = calloc((size_t)t->ncol, sizeof(*t->name));
  if (!t->name) {
    cli_error("%s: out of memory", path);
    return 1;
  }
  char* field = line;
  for (int j = 0; j < t->ncol; j++) {
    char* comma = strchr(field, ',');
    if (comma) {
      *comma = 0;
    }
    snprintf(t->name[j], CMP_NAME_SZ, "%s", cmp_trim(field));
    field = comma ? comma + 1 : field;
  }
  if (strcmp(t->name[0], "time")) {
    cli_error("%s:%ld: the header's first column must be 'time', got '%s'", path, lineno,
              t->name[0]);
    return 1;
  }
  return 0;
}


// Parse one data line into row (ncol values); return 0 on success, else print why.
static int cmp_readRow(const char* path, long lineno, char* line, const cmpTable* t,
                       double* row) {
  int nfield = cmp_countFields(line);
  if (nfield != t->ncol) {
    cli_error("%s:%ld: %d columns, the header has %d", path, lineno, nfield, t->ncol);
    return 1;
  }
  char* field = line;
  for (int j = 0; j < t->ncol; j++) {
    char* comma = strchr(field, ',');
    if (comma) {
      *comma = 0;
    }
    char* text = cmp_trim(field);
    if (cli_parseNumber(text, row + j)) {
      cli_error("%s:%ld: column '%s': '%s' is not a finite number", path, lineno, t->name[j],
                text);
      return 1;
    }
    field = comma ? comma + 1 : field;
  }
  return 0;
}


// Append one row to t, growing its data array; return 0 on success.
static int cmp_growTable(cmpTable* t, int* cap) {
  if (t->nrow < *cap) {
    return 0;
  }
  int grown = *cap ? 2 * *cap : 256;
  double* data = realloc(t->data, sizeof(double) * (size_t)grown * (size_t)t->ncol);
  if (!data) {
    return 1;
  }
  t->data = data;
  *cap = grown;
  return 0;
}


int cmp_readTable(const char* path, cmpTable* t) {
  *t = (cmpTable){0};
  FILE* f = fopen(path, "r");
  if (!f) {
    cli_error("cannot open '%s': %s", path, strerror(errno));
    return 1;
  }

  // comments and blank lines are skipped; the first other line is the header
  char* line = NULL;
  size_t line_sz = 0;
  long lineno = 0;
  int cap = 0, status = 0;
  while (!status && getline(&line, &line_sz, f) >= 0) {
    lineno++;
    char* text = cmp_trim(line);
    if (!text[0] || text[0] == '#') {
      continue;
    }
    if (!t->name) {
      status = cmp_readHeader(path, lineno, text, t);
      continue;
    }
    if (cmp_growTable(t, &cap)) {
      cli_error("%s: out of memory", path);
      status = 1;
      break;
    }
    double* row = t->data + (size_t)t->nrow * (size_t)t->ncol;
    status = cmp_readRow(path, lineno, text, t, row);

    // time must increase strictly, so that the zero-order hold and interpolation are defined
    if (!status && t->nrow > 0 && row[0] <= row[-t->ncol]) {
      cli_error("%s:%ld: time %g does not increase (previous %g)", path, lineno, row[0],
                row[-t->ncol]);
      status = 1;
    }
    t->nrow += !status;
  }
  free(line);
  fclose(f);
  if (!status && !t->nrow) {
    cli_error("%s: no data rows (expected a header line, then rows of numbers)", path);
    status = 1;
  }
  if (status) {
    cmp_freeTable(t);
  }
  return status;
}


int cmp_tableColumn(const cmpTable* t, const char* name) {
  for (int j = 0; j < t->ncol; j++) {
    if (!strcmp(t->name[j], name)) {
      return j;
    }
  }
  return -1;
}


void cmp_freeTable(cmpTable* t) {
  free(t->name);
  free(t->data);
  *t = (cmpTable){0};
}


//---------------------------------- Commands ------------------------------------------------------

int cmp_allocCommands(cmpCommands* c, int nrow, int nu) {
  *c = (cmpCommands){.nrow = nrow, .nu = nu};
  c->time = calloc((size_t)nrow, sizeof(double));
  c->ctrl = calloc((size_t)nrow * (size_t)(nu > 0 ? nu : 1), sizeof(double));
  if (!c->time || !c->ctrl) {
    cli_error("out of memory for %d command rows", nrow);
    cmp_freeCommands(c);
    return 1;
  }
  return 0;
}


int cmp_commandsFromTable(const cmpTable* t, int first, int nu, cmpCommands* c) {
  if (cmp_allocCommands(c, t->nrow, nu)) {
    return 1;
  }
  for (int i = 0; i < t->nrow; i++) {
    const double* row = t->data + (size_t)i * (size_t)t->ncol;
    c->time[i] = row[0];
    memcpy(c->ctrl + (size_t)i * (size_t)nu, row + first, sizeof(double) * (size_t)nu);
  }
  return 0;
}


int cmp_readCommands(const char* path, int nu, cmpCommands* c) {
  cmpTable t;
  *c = (cmpCommands){0};
  if (cmp_readTable(path, &t)) {
    return 1;
  }
  int status = 1;
  if (t.ncol != 1 + nu) {
    cli_error("%s: %d columns, expected time and nu = %d controls", path, t.ncol, nu);
  } else {
    status = cmp_commandsFromTable(&t, 1, nu, c);
  }
  cmp_freeTable(&t);
  return status;
}


int cmp_writeCommands(const char* path, const cmpCommands* c, const char* const* names) {
  char tmp[CLI_PATH_SZ];
  FILE* f = cli_openOutput(path, tmp, sizeof(tmp));
  if (!f) {
    return 1;
  }
  fprintf(f, "time");
  for (int j = 0; j < c->nu; j++) {
    fprintf(f, ",%s", names[j]);
  }
  fputc('\n', f);
  // %.17g: reading the file back gives the same doubles (the pallet edge amplifies 1e-10)
  for (int i = 0; i < c->nrow; i++) {
    fprintf(f, "%.17g", c->time[i]);
    for (int j = 0; j < c->nu; j++) {
      fprintf(f, ",%.17g", c->ctrl[(size_t)i * (size_t)c->nu + j]);
    }
    fputc('\n', f);
  }
  return cli_commitOutput(f, tmp, path);
}


void cmp_commandAt(const cmpCommands* c, double t, mjtNum* ctrl) {
  // the last row whose time is <= t (binary search), the first row before it
  int lo = 0, hi = c->nrow - 1;
  while (lo < hi) {
    int mid = (lo + hi + 1) / 2;
    if (c->time[mid] <= t) {
      lo = mid;
    } else {
      hi = mid - 1;
    }
  }
  for (int j = 0; j < c->nu; j++) {
    ctrl[j] = c->ctrl[(size_t)lo * (size_t)c->nu + j];
  }
}


void cmp_freeCommands(cmpCommands* c) {
  free(c->time);
  free(c->ctrl);
  *c = (cmpCommands){0};
}


//---------------------------------- Pallet traversal ----------------------------------------------

#define CMP_WHEEL_RADIUS 0.35     // m, wheeled_robot_body.xml
#define CMP_HALF_TRACK   0.35     // m, lateral offset of the two front wheels
#define CMP_REST         0.3      // s at rest at the start and at the end
#define CMP_RAMP         0.8      // s of each cosine speed ramp
#define CMP_TURN_AT      3.4      // m travelled before the turn: the rear wheel is off the pallet
#define CMP_YAW_RATE     0.8      // rad/s during the turn
#define CMP_AFTER_TURN   0.5      // s straight after the turn

const cmpTraversal kCmpDefaultTraversal = {1.0, 0.5 * 3.14159265358979323846};


// Phase boundaries of a traversal: end of rest, ramp up, cruise, turn, straight, ramp down, rest.
static void cmp_traversalPhases(const cmpTraversal* p, double* end) {
  double cruise = (CMP_TURN_AT - 0.5 * p->speed * CMP_RAMP) / p->speed;
  double phase[7] = {CMP_REST, CMP_RAMP, cruise > 0 ? cruise : 0, fabs(p->turn) / CMP_YAW_RATE,
                     CMP_AFTER_TURN, CMP_RAMP, CMP_REST};
  double t = 0;
  for (int i = 0; i < 7; i++) {
    t += phase[i];
    end[i] = t;
  }
}


// Forward speed (m/s) and yaw rate (rad/s) of a traversal at time t.
static void cmp_traversalAt(const cmpTraversal* p, const double* end, double t, double* v,
                            double* yaw_rate) {
  const double pi = 3.14159265358979323846;
  *yaw_rate = 0;
  if (t < end[0] || t >= end[5]) {
    *v = 0;
  } else if (t < end[1]) {
    *v = p->speed * 0.5 * (1 - cos(pi * (t - end[0]) / CMP_RAMP));
  } else if (t < end[4]) {
    *v = p->speed;
    if (t >= end[2] && t < end[3]) {
      *yaw_rate = p->turn >= 0 ? CMP_YAW_RATE : -CMP_YAW_RATE;
    }
  } else {
    *v = p->speed * 0.5 * (1 + cos(pi * (t - end[4]) / CMP_RAMP));
  }
}


int cmp_traversalCommands(const cmpTraversal* p, double rate, cmpCommands* c) {
  double end[7];
  cmp_traversalPhases(p, end);
  int nrow = (int)ceil(end[6] * rate) + 1;
  if (cmp_allocCommands(c, nrow, 3)) {
    return 1;
  }

  // differential drive of the front wheels; the fixed rear wheel rolls at v and skids sideways
  for (int i = 0; i < nrow; i++) {
    double t = i / rate, v, w;
    cmp_traversalAt(p, end, t, &v, &w);
    c->time[i] = t;
    c->ctrl[3 * i + 0] = (v - w * CMP_HALF_TRACK) / CMP_WHEEL_RADIUS;
    c->ctrl[3 * i + 1] = (v + w * CMP_HALF_TRACK) / CMP_WHEEL_RADIUS;
    c->ctrl[3 * i + 2] = v / CMP_WHEEL_RADIUS;
  }
  return 0;
}


int cmp_isRobot(const mjModel* m) {
  static const char* names[3] = {"v_left", "v_right", "v_rear"};
  if (m->nu != 3) {
    return 0;
  }
  for (int i = 0; i < 3; i++) {
    const char* name = mj_id2name(m, mjOBJ_ACTUATOR, i);
    if (!name || strcmp(name, names[i])) {
      return 0;
    }
  }
  return 1;
}


//---------------------------------- Trajectories and the error metric -----------------------------

int cmp_modelKind(const mjModel* m) {
  int free_base = m->njnt > 0 && m->jnt_type[0] == mjJNT_FREE && m->jnt_qposadr[0] == 0;
  return free_base ? CMP_POSE : CMP_QPOS;
}


int cmp_initTrajectory(cmpTrajectory* tr, int kind, int ncoord) {
  *tr = (cmpTrajectory){.kind = kind, .ncoord = ncoord};
  return 0;
}


int cmp_appendSample(cmpTrajectory* tr, double t, const double* coord) {
  if (tr->n == tr->cap) {
    int grown = tr->cap ? 2 * tr->cap : 1024;
    double* time = realloc(tr->time, sizeof(double) * (size_t)grown);
    if (time) {
      tr->time = time;
    }
    double* c = realloc(tr->coord, sizeof(double) * (size_t)grown * (size_t)tr->ncoord);
    if (c) {
      tr->coord = c;
    }
    if (!time || !c) {
      return 1;
    }
    tr->cap = grown;
  }
  double* row = tr->coord + (size_t)tr->n * (size_t)tr->ncoord;
  memcpy(row, coord, sizeof(double) * (size_t)tr->ncoord);

  // a continuous yaw, so that interpolation between samples never crosses the +-pi cut
  if (tr->kind == CMP_POSE && tr->n > 0) {
    double prev = row[3 - tr->ncoord];
    row[3] = prev + cmp_wrapAngle(row[3] - prev);
  }
  tr->time[tr->n++] = t;
  return 0;
}


double cmp_yaw(const mjtNum* q) {
  return atan2(2 * (q[0] * q[3] + q[1] * q[2]), 1 - 2 * (q[2] * q[2] + q[3] * q[3]));
}


double cmp_wrapAngle(double a) {
  const double pi = 3.14159265358979323846;
  double w = fmod(a + pi, 2 * pi);
  if (w <= 0) {
    w += 2 * pi;
  }
  return w - pi;
}


int cmp_appendState(cmpTrajectory* tr, const mjModel* m, const mjData* d) {
  if (tr->kind == CMP_QPOS) {
    return cmp_appendSample(tr, d->time, d->qpos);
  }
  double pose[4] = {d->qpos[0], d->qpos[1], d->qpos[2], cmp_yaw(d->qpos + 3)};
  return cmp_appendSample(tr, d->time, pose);
}


void cmp_sampleAt(const cmpTrajectory* tr, double t, double* coord) {
  // the interval [time[lo], time[lo + 1]] that holds t (binary search), clamped at both ends
  int lo = 0, hi = tr->n - 1;
  while (hi - lo > 1) {
    int mid = (lo + hi) / 2;
    if (tr->time[mid] <= t) {
      lo = mid;
    } else {
      hi = mid;
    }
  }
  const double* a = tr->coord + (size_t)lo * (size_t)tr->ncoord;
  const double* b = tr->coord + (size_t)hi * (size_t)tr->ncoord;
  double span = tr->time[hi] - tr->time[lo];
  double s = span > 0 ? (t - tr->time[lo]) / span : 0;
  s = s < 0 ? 0 : (s > 1 ? 1 : s);
  for (int j = 0; j < tr->ncoord; j++) {
    coord[j] = a[j] + s * (b[j] - a[j]);
  }
}


double cmp_trajectoryError(const cmpTrajectory* a, const cmpTrajectory* ref, double dt) {
  if (a->kind != ref->kind || a->ncoord != ref->ncoord || !a->n || !ref->n || !(dt > 0)) {
    return NAN;
  }

  // common span [t0, t1]; samples t0 + k dt (a 1e-9 slack keeps t1 itself despite round-off)
  double t0 = fmax(a->time[0], ref->time[0]);
  double t1 = fmin(a->time[a->n - 1], ref->time[ref->n - 1]);
  if (t1 < t0) {
    return NAN;
  }
  long nsample = (long)floor((t1 - t0) / dt + 1e-9) + 1;
  double* ca = malloc(sizeof(double) * 2 * (size_t)a->ncoord);
  if (!ca) {
    return NAN;
  }
  double* cr = ca + a->ncoord;

  // sums of squared differences: position (or qpos) and yaw
  double sum_pos = 0, sum_yaw = 0;
  int npos = a->kind == CMP_POSE ? 3 : a->ncoord;
  for (long k = 0; k < nsample; k++) {
    double t = t0 + (double)k * dt;
    cmp_sampleAt(a, t, ca);
    cmp_sampleAt(ref, t, cr);
    for (int j = 0; j < npos; j++) {
      sum_pos += (ca[j] - cr[j]) * (ca[j] - cr[j]);
    }
    if (a->kind == CMP_POSE) {
      double dyaw = cmp_wrapAngle(ca[3] - cr[3]);
      sum_yaw += dyaw * dyaw;
    }
  }
  free(ca);

  // sqrt(<|dp|^2> + (L RMS(dyaw))^2)
  double n = (double)nsample;
  return sqrt(sum_pos / n + CMP_YAW_LENGTH * CMP_YAW_LENGTH * sum_yaw / n);
}


int cmp_tableTrajectory(const char* path, const cmpTable* t, int kind, int nq, double t_shift,
                        cmpTrajectory* tr) {
  // columns of the coordinates: x, y, z, yaw for a pose log, else qpos_0 ..
  int col[4] = {cmp_tableColumn(t, "x"), cmp_tableColumn(t, "y"), cmp_tableColumn(t, "z"),
                cmp_tableColumn(t, "yaw")};
  int from_log = kind == CMP_POSE && col[0] >= 0 && col[1] >= 0 && col[2] >= 0 && col[3] >= 0;
  int qpos0 = cmp_tableColumn(t, "qpos_0");
  for (int j = 0; !from_log && j < nq; j++) {
    char name[CMP_NAME_SZ];
    snprintf(name, sizeof(name), "qpos_%d", j);
    if (qpos0 < 0 || qpos0 + j >= t->ncol || strcmp(t->name[qpos0 + j], name)) {
      cli_error("%s: expected the columns %s", path, kind == CMP_POSE ?
                "x,y,z,yaw or qpos_0..qpos_6 of the free joint" : "qpos_0..qpos_<nq-1>");
      return 1;
    }
  }

  // one sample per row
  int ncoord = kind == CMP_POSE ? 4 : nq;
  cmp_initTrajectory(tr, kind, ncoord);
  for (int i = 0; i < t->nrow; i++) {
    const double* row = t->data + (size_t)i * (size_t)t->ncol;
    double pose[4];
    const double* coord = row + qpos0;
    if (from_log) {
      for (int j = 0; j < 4; j++) {
        pose[j] = row[col[j]];
      }
      coord = pose;
    } else if (kind == CMP_POSE) {
      pose[0] = row[qpos0];
      pose[1] = row[qpos0 + 1];
      pose[2] = row[qpos0 + 2];
      pose[3] = cmp_yaw(row + qpos0 + 3);
      coord = pose;
    }
    if (cmp_appendSample(tr, row[0] - t_shift, coord)) {
      cli_error("%s: out of memory", path);
      cmp_freeTrajectory(tr);
      return 1;
    }
  }
  return 0;
}


int cmp_writeTrajectory(const char* path, const cmpTrajectory* tr) {
  char tmp[CLI_PATH_SZ];
  FILE* f = cli_openOutput(path, tmp, sizeof(tmp));
  if (!f) {
    return 1;
  }
  if (tr->kind == CMP_POSE) {
    fprintf(f, "time,x,y,z,yaw\n");
  } else {
    fprintf(f, "time");
    for (int j = 0; j < tr->ncoord; j++) {
      fprintf(f, ",qpos_%d", j);
    }
    fputc('\n', f);
  }
  for (int i = 0; i < tr->n; i++) {
    const double* c = tr->coord + (size_t)i * (size_t)tr->ncoord;
    fprintf(f, "%.10g", tr->time[i]);
    for (int j = 0; j < tr->ncoord; j++) {
      int yaw = tr->kind == CMP_POSE && j == 3;
      fprintf(f, ",%.10g", yaw ? cmp_wrapAngle(c[j]) : c[j]);
    }
    fputc('\n', f);
  }
  return cli_commitOutput(f, tmp, path);
}


void cmp_freeTrajectory(cmpTrajectory* tr) {
  free(tr->time);
  free(tr->coord);
  *tr = (cmpTrajectory){0};
}


//---------------------------------- Engine runner -------------------------------------------------

static char cmp_mujoco_error[CLI_MSG_SZ];  // first MuJoCo error of the current run ("" if none)


// MuJoCo error handler during a run: record the first message and return (no exit).
static void cmp_onMujocoError(const char* msg) {
  if (!cmp_mujoco_error[0]) {
    snprintf(cmp_mujoco_error, sizeof(cmp_mujoco_error), "%s", msg);
  }
}


// Take one step of the run; return 0 on success, else set the outcome and reason.
static int cmp_stepOnce(const mjModel* m, mjData* d, const cmpRunSpec* spec, cmpRunResult* res) {
  if (spec->commands) {
    cmp_commandAt(spec->commands, d->time, d->ctrl);
  }
  double start = cli_now();
  int status = OST_OK;
  if (spec->engine == CMP_OSTRICH) {
    status = ost_step(m, d);
  } else {
    mj_step(m, d);
  }
  res->wall += cli_now() - start;

  // a warning: the step was taken, not to tolerance
  if (OST_IS_WARNING(status)) {
    res->unconverged++;
    status = OST_OK;
  }
  if (status != OST_OK || cmp_mujoco_error[0]) {
    res->outcome = CMP_STEP_FAILED;
    res->failed = 1;
    snprintf(res->why, sizeof(res->why), "step %ld failed: %.960s", res->steps + 1,
             status != OST_OK ? ost_lastError(d) : cmp_mujoco_error);
    return 1;
  }
  if (cli_hasNan(m, d)) {
    res->outcome = CMP_NAN;
    snprintf(res->why, sizeof(res->why), "non-finite or diverged state after step %ld",
             res->steps + 1);
    return 1;
  }
  for (int i = 0; spec->max_qvel > 0 && i < m->nv; i++) {
    if (fabs(d->qvel[i]) > spec->max_qvel) {
      res->outcome = CMP_NAN;
      snprintf(res->why, sizeof(res->why), "|qvel[%d]| = %.3g > %g after step %ld", i,
               fabs(d->qvel[i]), spec->max_qvel, res->steps + 1);
      return 1;
    }
  }
  return 0;
}


// Add the solver statistics of the last step to res (the sum of iterations in mean_iter).
static void cmp_accumulate(const mjModel* m, const mjData* d, int engine, cmpRunResult* res) {
  if (engine == CMP_OSTRICH) {
    const ostStats* s = ost_stats(d);
    res->mean_iter += s ? s->newton_iter : 0;
  } else {
    res->mean_iter += d->solver_iter;
  }
  res->max_penetration = fmax(res->max_penetration, ost_maxPenetration(m, d));
}


int cmp_run(mjModel* m, const cmpRunSpec* spec, cmpTrajectory* tr, cmpRunResult* res) {
  *res = (cmpRunResult){0};
  int kind = cmp_modelKind(m);
  cmp_initTrajectory(tr, kind, kind == CMP_POSE ? 4 : m->nq);
  mjData* d = mj_makeData(m);
  if (!d) {
    return 1;
  }
  if (spec->key > 0 && spec->key <= m->nkey) {
    mj_resetDataKeyframe(m, d, spec->key - 1);
  }
  if (spec->qpos0) {
    mju_copy(d->qpos, spec->qpos0, m->nq);
  }

  // stock stages read opt.timestep; Ostrich gets the same h through its options
  double saved_timestep = m->opt.timestep;
  m->opt.timestep = spec->h;
  void (*saved_handler)(const char*) = mju_user_error;
  mju_user_error = cmp_onMujocoError;
  cmp_mujoco_error[0] = 0;
  int oom = 0;
  double h;
  if (spec->engine == CMP_OSTRICH && cli_setupOstrich(m, d, spec->h, -1, -1, NULL, &h)) {
    res->outcome = CMP_SETUP_FAILED;
    snprintf(res->why, sizeof(res->why), "Ostrich refused the model or its options");
  } else {
    // step, recording the state after each step until the first failure
    long nstep = lround(spec->duration / spec->h);
    oom = cmp_appendState(tr, m, d);
    for (long k = 0; k < nstep && !oom; k++) {
      if (cmp_stepOnce(m, d, spec, res)) {
        break;
      }
      res->steps++;
      cmp_accumulate(m, d, spec->engine, res);
      oom = cmp_appendState(tr, m, d);
      if (spec->max_wall > 0 && res->wall > spec->max_wall && k + 1 < nstep) {
        res->outcome = CMP_TIMEOUT;
        snprintf(res->why, sizeof(res->why), "stopped after %.3g s wall at step %ld of %ld",
                 res->wall, k + 1, nstep);
        break;
      }
    }
  }
  res->simulated = tr->n ? tr->time[tr->n - 1] : 0;  // the last finite state
  res->mean_iter /= res->steps > 0 ? (double)res->steps : 1.0;

  mju_user_error = saved_handler;
  m->opt.timestep = saved_timestep;
  ost_deleteData(d);
  return oom;
}


//---------------------------------- Arguments -----------------------------------------------------

int cmp_parseArgs(const char* command, int argc, char** argv, const cliOption* options,
                  int noption, void* args, const char** positional, int npos, int* help) {
  return cli_parseArgsList(command, argc, argv, options, noption, args, positional, npos, NULL,
                           help);
}


int cmp_parsePositiveList(const char* option, const char* s, double* values, int cap, int sort) {
  // items separated by commas, each a positive number
  int n = 0;
  while (*s) {
    char item[64];
    int len = (int)strcspn(s, ",");
    snprintf(item, sizeof(item), "%.*s", len, s);
    double v;
    if (len >= (int)sizeof(item) || cli_parseNumber(item, &v) || v <= 0) {
      cli_error("%s: '%.*s' is not a positive number", option, len, s);
      return -1;
    }
    if (n == cap) {
      cli_error("%s: more than %d values", option, cap);
      return -1;
    }
    values[n++] = v;
    s += len + (s[len] == ',');
  }
  if (!n) {
    cli_error("%s: empty list", option);
    return -1;
  }
  if (!sort) {
    return n;
  }

  // insertion sort, then drop duplicates
  for (int i = 1; i < n; i++) {
    for (int j = i; j > 0 && values[j] < values[j - 1]; j--) {
      double swap = values[j];
      values[j] = values[j - 1];
      values[j - 1] = swap;
    }
  }
  int unique = 1;
  for (int i = 1; i < n; i++) {
    if (values[i] != values[unique - 1]) {
      values[unique++] = values[i];
    }
  }
  return unique;
}


int cmp_parseEngines(const char* s, int* use) {
  char buf[256];
  const char* items[8];
  int n = cmp_splitList("--engine", s, buf, sizeof(buf), items, 8);
  if (n < 0) {
    return 1;
  }
  for (int e = 0; e < CMP_NENGINE; e++) {
    use[e] = 0;
  }
  for (int i = 0; i < n; i++) {
    int found = 0;
    for (int e = 0; e < CMP_NENGINE; e++) {
      if (!strcmp(items[i], kCmpEngineNames[e])) {
        use[e] = found = 1;
      }
    }
    if (!found) {
      cli_error("--engine: '%s' is not ostrich or mujoco", items[i]);
      return 1;
    }
  }
  return 0;
}


int cmp_splitList(const char* option, const char* s, char* buf, int buf_sz, const char** items,
                  int cap) {
  if ((int)strlen(s) >= buf_sz) {
    cli_error("%s: list too long", option);
    return -1;
  }
  snprintf(buf, (size_t)buf_sz, "%s", s);
  int n = 0;
  for (char* item = buf; item;) {
    char* comma = strchr(item, ',');
    if (comma) {
      *comma = 0;
    }
    if (!item[0]) {
      cli_error("%s: empty item in '%s'", option, s);
      return -1;
    }
    if (n == cap) {
      cli_error("%s: more than %d items", option, cap);
      return -1;
    }
    items[n++] = item;
    item = comma ? comma + 1 : NULL;
  }
  return n;
}


int cmp_spawn(char* const* argv, const char* out_path, const char* err_path) {
  posix_spawn_file_actions_t actions;
  posix_spawn_file_actions_init(&actions);
  posix_spawn_file_actions_addopen(&actions, 1, out_path, O_WRONLY | O_CREAT | O_TRUNC, 0644);
  if (err_path && !strcmp(err_path, out_path)) {
    posix_spawn_file_actions_adddup2(&actions, 1, 2);
  } else if (err_path) {
    posix_spawn_file_actions_addopen(&actions, 2, err_path, O_WRONLY | O_CREAT | O_TRUNC, 0644);
  }
  pid_t pid;
  extern char** environ;
  int status = 127;
  if (!posix_spawnp(&pid, argv[0], &actions, NULL, argv, environ)) {
    int wstatus = 0;
    waitpid(pid, &wstatus, 0);
    status = WIFEXITED(wstatus) ? WEXITSTATUS(wstatus) : 1;
  }
  posix_spawn_file_actions_destroy(&actions);
  return status;
}


void cmp_jsonArray(FILE* f, const double* x, int n) {
  fputc('[', f);
  for (int i = 0; i < n; i++) {
    if (i) {
      fputc(',', f);
    }
    cli_jsonNumber(f, x[i]);
  }
  fputc(']', f);
}
