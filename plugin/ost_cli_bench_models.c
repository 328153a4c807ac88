// ost_cli_bench_models.c: `ostrich bench models`, Ostrich's ost_step against stock MuJoCo's
// mj_step on one core (both single-threaded). For each MJCF model on the command line, from the
// start state (qpos0, or --key K) over the same simulated duration: mj_step at h = opt.timestep,
// then ost_step at h and at each --h-scale multiple of h (ost_setOptions' timestep). Each run
// takes one untimed step and resets first, so allocation and model packing are not timed. With
// --scaling, models of N copies of MuJoCo's humanoid are generated on a grid into a temporary
// directory (mkdtemp, removed before returning), stepped by both engines at the same h, and
// log(time per step) is fitted against log(nv) by least squares for each engine. The timing
// loop mirrors MuJoCo's sample/testspeed.cc.
// Invariant: every figure printed was measured in this run; a refused model, a failed step and
// a run stopped by --max-wall are reported as such, never dropped.
#define _POSIX_C_SOURCE 200809L

#include <ctype.h>
#include <libgen.h>
#include <math.h>
#include <stddef.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include <mujoco/mujoco.h>

#include "ost_cli_util.h"
#include "ostrich.h"

#define MODELS_MAX_SCALES  16     // --h-scale entries
#define MODELS_MAX_COPIES  32     // --scaling entries
#define MODELS_MAX_BODIES  256    // top-level bodies of the --humanoid file
#define MODELS_SPACING     2.0    // grid spacing of generated copies (m)
#define MODELS_PROGRESS_S  2.0    // seconds between progress lines of one run

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

typedef enum modelsStatus_ {      // outcome of one run
  RUN_OK = 0,                     // every step taken
  RUN_STOPPED,                    // stopped by --max-wall (the steps taken are timed)
  RUN_REFUSED,                    // Ostrich refused the model (OST_ERR_MODEL)
  RUN_FAILED                      // a step failed; the run stopped there
} modelsStatus;

static const char* kStatusName[] = {"ok", "stopped", "refused", "failed"};

typedef struct modelsRow_ {       // one timed run: one engine at one step size on one model
  const char* kind;               // "model" or "scaling"
  char   label[128];              // model as printed (last two path parts, or humanoids_N)
  const char* path;               // model path ("" for generated models)
  int    copies;                  // humanoid copies (scaling), 0 otherwise
  int    nv;                      // degrees of freedom
  int    ostrich;                 // 1: ost_step, 0: mj_step
  double h;                       // step size (s)
  double scale;                   // h / opt.timestep
  long   steps;                   // timed steps taken
  double wall_s;                  // wall time of the timed steps
  long   converged;               // Ostrich steps that returned OST_OK
  int    status;                  // modelsStatus
  double ratio_step;              // us per step / MuJoCo's at opt.timestep (NaN: none)
  double ratio_sim;               // us per simulated second / MuJoCo's at opt.timestep
  char   msg[CLI_MSG_SZ];         // refusal, failure or note; "" if none
} modelsRow;


//---------------------------------- Timing --------------------------------------------------------

static double usPerStep(const modelsRow* r) {
  return r->steps > 0 ? 1e6 * r->wall_s / r->steps : NAN;
}


static double usPerSim(const modelsRow* r) {
  return r->steps > 0 ? 1e6 * r->wall_s / (r->steps * r->h) : NAN;
}


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

  // timed steps (mj_resetData clears MuJoCo's warning counts)
  if (nsettle <= 0) {
    cli_resetStart(m, d, key);
  }
  double t0 = cli_now(), shown = t0, now = t0;
  while (r->status == RUN_OK && r->steps < nstep) {
    status = r->ostrich ? ost_step(m, d) : (mj_step(m, d), OST_OK);
    if (stepFailed(status)) {
      snprintf(r->msg, sizeof(r->msg), "step %ld (t = %.6g s): status %d: %s", r->steps + 1,
               d->time, status, ost_lastError(d));
      r->status = RUN_FAILED;
      break;
    }
    now = cli_now();
    r->steps++;
    r->converged += (status == OST_OK);
    if (now - t0 > a->max_wall && r->steps < nstep) {
      snprintf(r->msg, sizeof(r->msg), "stopped by --max-wall %g s after %ld of %ld steps",
               a->max_wall, r->steps, nstep);
      r->status = RUN_STOPPED;
    }
    if (cli_progress() && now - shown > MODELS_PROGRESS_S) {
      fprintf(stderr, "ostrich: bench models: %s, %s h = %g s: %ld of %ld steps, %.0f s\n",
              r->label, r->ostrich ? "ostrich" : "mujoco", r->h, r->steps, nstep, now - t0);
      shown = now;
    }
  }
  r->wall_s = now - t0;

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


//---------------------------------- Humanoid copies -----------------------------------------------
// The generated model is the --humanoid file with each top-level <body> of its <worldbody> and
// the contents of its <actuator>, <tendon>, <sensor>, <contact> and <equality> sections repeated
// N times. Copy k prefixes "hk_" to every name and every name reference (joint=, body1=,
// target=, ...); assets and default classes are shared, so class=, material= and mesh= are
// not prefixed. The other <worldbody> children (floor, lights) appear once, their references
// pointing at copy 0. Copies sit on a square grid MODELS_SPACING apart (copy 0 of N = 1 at the
// source's place); <keyframe> is dropped (its sizes no longer fit) and a last <size> element
// sets nconmax and njmax.

static const char* kRefAttrs[] = {  // attributes that hold names (entry 0: the name itself)
  "name", "joint", "joint1", "joint2", "jointinparent", "body", "body1", "body2", "geom",
  "geom1", "geom2", "site", "tendon", "tendon1", "tendon2", "target", "objname", "refname",
  "actuator", "refsite", "slidersite", "cranksite", "sidesite"};

typedef struct xmlTag_ {          // one tag: text [start, end)
  const char* start;
  const char* end;
  char name[32];
  int  kind;                      // 1 open, 0 empty (<x/>), -1 close, 2 other (<?, <!)
} xmlTag;


// the next tag at or after p; 0 if none
static int xmlNext(const char* p, xmlTag* t) {
  const char* s = strchr(p, '<');
  const char* e = s ? strchr(s, '>') : NULL;
  if (!e) {
    return 0;
  }
  t->start = s;
  t->end = e + 1;
  const char* n = s + 1 + (s[1] == '/');
  size_t len = strcspn(n, " \t\r\n/>");
  snprintf(t->name, sizeof(t->name), "%.*s", (int)len, n);
  t->kind = s[1] == '/' ? -1 : (s[1] == '?' || s[1] == '!') ? 2 : e[-1] == '/' ? 0 : 1;
  return 1;
}


// the close tag that matches an open tag ending at p
static int xmlMatch(const char* p, xmlTag* close) {
  for (int depth = 1; xmlNext(p, close); p = close->end) {
    depth += close->kind == 1 ? 1 : close->kind == -1 ? -1 : 0;
    if (depth == 0) {
      return 1;
    }
  }
  return 0;
}


// write text [s, s + n) with prefix put before every name reference, and before every name
// if names
static void genRename(FILE* f, const char* s, size_t n, const char* prefix, int names) {
  for (size_t i = 0; i < n;) {
    size_t j = i;
    while (j < n && (isalnum((unsigned char)s[j]) || s[j] == '_')) {
      j++;
    }
    int attr = j > i && (i == 0 || isspace((unsigned char)s[i - 1])) && j + 1 < n
               && s[j] == '=' && (s[j + 1] == '"' || s[j + 1] == '\'');
    for (int k = names ? 0 : 1; attr && k < (int)(sizeof(kRefAttrs) / sizeof(char*)); k++) {
      if (strlen(kRefAttrs[k]) == j - i && !strncmp(s + i, kRefAttrs[k], j - i)) {
        fprintf(f, "%.*s%s", (int)(j + 2 - i), s + i, prefix);
        i = j + 2;
        attr = 2;
        break;
      }
    }
    if (attr != 2) {
      fwrite(s + i, 1, j > i ? j - i : 1, f);
      i = j > i ? j : i + 1;
    }
  }
}


// write a top-level body's open tag t with pos moved by (dx, dy), renamed for copy prefix
static void genBodyTag(FILE* f, const xmlTag* t, double dx, double dy, const char* prefix) {
  char tag[2048];
  double x = 0, y = 0, z = 0;
  const char* pos = NULL;
  for (const char* p = t->start; (p = strstr(p, "pos=")) && p < t->end; p++) {
    if (isspace((unsigned char)p[-1])) {
      pos = p;
      break;
    }
  }
  if (pos) {
    char* e;
    x = strtod(pos + 5, &e);
    y = strtod(e, &e);
    z = strtod(e, &e);
    const char* rest = strchr(pos + 5, pos[4]) + 1;
    snprintf(tag, sizeof(tag), "%.*spos=\"%.9g %.9g %.9g\"%.*s", (int)(pos - t->start), t->start,
             x + dx, y + dy, z, (int)(t->end - rest), rest);
  } else {
    size_t head = strlen(t->name) + 1;
    snprintf(tag, sizeof(tag), "%.*s pos=\"%.9g %.9g 0\"%.*s", (int)head, t->start, dx, dy,
             (int)(t->end - t->start - head), t->start + head);
  }
  genRename(f, tag, strlen(tag), prefix, 1);
}


// write the <worldbody> element whose open tag is t and close tag c, with ncopy copies
static int genWorld(FILE* f, const xmlTag* t, const xmlTag* c, int ncopy) {
  xmlTag body[MODELS_MAX_BODIES], bodyend[MODELS_MAX_BODIES], u, v;
  int nbody = 0;
  fwrite(t->start, 1, t->end - t->start, f);
  for (const char* p = t->end; xmlNext(p, &u) && u.start < c->start; p = v.end) {
    v = u;
    if (u.kind == 1 && !xmlMatch(u.end, &v)) {
      return 1;
    }
    if (!strcmp(u.name, "body") && u.kind == 1 && nbody < MODELS_MAX_BODIES) {
      body[nbody] = u;
      bodyend[nbody++] = v;
    } else if (u.kind != 2) {
      fputs("\n    ", f);
      genRename(f, u.start, v.end - u.start, "h0_", 0);
    }
  }
  int ncol = (int)ceil(sqrt(ncopy));
  for (int k = 0; k < ncopy; k++) {
    char prefix[16];
    snprintf(prefix, sizeof(prefix), "h%d_", k);
    double dx = MODELS_SPACING * (k % ncol - 0.5 * (ncol - 1));
    double dy = MODELS_SPACING * (k / ncol - 0.5 * ((ncopy - 1) / ncol));
    for (int b = 0; b < nbody; b++) {
      fputs("\n    ", f);
      genBodyTag(f, body + b, dx, dy, prefix);
      genRename(f, body[b].end, bodyend[b].end - body[b].end, prefix, 1);
    }
  }
  fputs("\n  ", f);
  fwrite(c->start, 1, c->end - c->start, f);
  return nbody == 0 || nbody == MODELS_MAX_BODIES;
}


// write N copies of the model text src (comments removed) to path; 0 on success
static int genHumanoids(const char* src, int ncopy, int nconmax, int njmax, const char* path) {
  static const char* repeat[] = {"actuator", "tendon", "sensor", "contact", "equality"};
  FILE* f = fopen(path, "w");
  int bad = !f, depth = 0;
  xmlTag t, c;
  const char* p = src;
  while (!bad && xmlNext(p, &t)) {
    fwrite(p, 1, t.start - p, f);
    p = t.end;
    int section = -1;
    for (int i = 0; i < 5; i++) {
      section = strcmp(t.name, repeat[i]) ? section : i;
    }
    if (depth == 1 && t.kind == 1 && (section >= 0 || !strcmp(t.name, "worldbody")
                                      || !strcmp(t.name, "keyframe"))) {
      bad = !xmlMatch(t.end, &c);
      if (!bad && section >= 0) {
        fwrite(t.start, 1, t.end - t.start, f);
        for (int k = 0; k < ncopy; k++) {
          char prefix[16];
          snprintf(prefix, sizeof(prefix), "h%d_", k);
          genRename(f, t.end, c.start - t.end, prefix, 1);
        }
        fwrite(c.start, 1, c.end - c.start, f);
      } else if (!bad && !strcmp(t.name, "worldbody")) {
        bad = genWorld(f, &t, &c, ncopy);
      }
      p = bad ? p : c.end;
      continue;
    }
    if (depth == 1 && t.kind == -1 && !strcmp(t.name, "mujoco")) {
      fprintf(f, "<size nconmax=\"%d\" njmax=\"%d\"/>\n", nconmax, njmax);
    }
    fwrite(t.start, 1, t.end - t.start, f);
    depth += t.kind == 1 ? 1 : t.kind == -1 ? -1 : 0;
  }
  if (f) {
    fputs(p, f);
    bad = fclose(f) || bad;
  }
  return bad;
}


// read a file into a string with <!-- --> comments removed; NULL if it cannot be read
static char* readWithoutComments(const char* path) {
  FILE* f = fopen(path, "rb");
  char* s = NULL;
  long n = -1;
  if (f && !fseek(f, 0, SEEK_END) && (n = ftell(f)) >= 0 && !fseek(f, 0, SEEK_SET)) {
    s = (char*)malloc(n + 1);
  }
  if (s && fread(s, 1, n, f) != (size_t)n) {
    free(s);
    s = NULL;
  }
  if (f) {
    fclose(f);
  }
  if (s) {
    s[n] = 0;
    char *out = s, *c;
    for (char* in = s; *in;) {
      if (!strncmp(in, "<!--", 4) && (c = strstr(in + 4, "-->"))) {
        in = c + 3;
      } else {
        *out++ = *in++;
      }
    }
    *out = 0;
  }
  return s;
}


//---------------------------------- Output --------------------------------------------------------

// the last two parts of a path ("humanoid/humanoid.xml")
static void modelLabel(char* out, int out_sz, const char* path) {
  const char* last = strrchr(path, '/');
  const char* start = path;
  for (const char* c = path; last && c < last; c++) {
    start = *c == '/' ? c + 1 : start;
  }
  snprintf(out, out_sz, "%s", start);
}


// x printed with fmt, or "-" if not finite
static const char* fmtNum(char* buf, const char* fmt, double x) {
  snprintf(buf, 32, isfinite(x) ? fmt : "-", x);
  return buf;
}


static void printHeader(const char* title) {
  printf("%s\n%-30s %6s %-8s %8s %5s %7s %12s %12s %10s %11s %9s  %s\n", title, "model", "nv",
         "engine", "h", "x_h", "steps", "us/step", "us/sim_s", "ratio/step", "ratio/sim_s",
         "converged", "status");
}


static void printRow(const modelsRow* r, int first) {
  char nv[16], b[5][32];
  double conv = r->ostrich && r->steps > 0 ? 100.0 * r->converged / r->steps : NAN;
  snprintf(nv, sizeof(nv), "%d", r->nv);
  printf("%-30s %6s %-8s %8.4g %5.3g %7ld %12s %12s %10s %11s %9s  %s\n", first ? r->label : "",
         first ? nv : "", r->ostrich ? "ostrich" : "mujoco", r->h, r->scale, r->steps,
         fmtNum(b[0], "%.1f", usPerStep(r)), fmtNum(b[1], "%.0f", usPerSim(r)),
         fmtNum(b[2], "%.3f", r->ratio_step), fmtNum(b[3], "%.3f", r->ratio_sim),
         fmtNum(b[4], "%.1f%%", conv), kStatusName[r->status]);
}


// each row's message, under the table it belongs to
static void printNotes(const modelsRow* rows, int nrow) {
  for (int r = 0; r < nrow; r++) {
    if (rows[r].msg[0]) {
      printf("  %s, %s h = %g: %s%s\n", rows[r].label, rows[r].ostrich ? "ostrich" : "mujoco",
             rows[r].h, rows[r].status == RUN_REFUSED ? "refused by Ostrich: " : "", rows[r].msg);
    }
  }
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


// write every row and the fits to path (path.tmp, then renamed); 0 on success
static int writeCsv(const char* path, const modelsRow* rows, int nrow, const double* slope,
                    const int* npoint, int fit) {
  char tmp[4096];
  snprintf(tmp, sizeof(tmp), "%s.tmp", path);
  FILE* f = fopen(tmp, "w");
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
  int bad = ferror(f);
  bad = fclose(f) || bad;
  bad = bad || rename(tmp, path);
  if (bad) {
    remove(tmp);
  }
  return bad;
}


// gnuplot: us per step against nv (scaling rows, log-log) and us per simulated second of each
// model and engine/h (a clustered histogram), one panel each, into png; data files in dir
static int writePlot(const char* png, const char* dir, const modelsRow* rows, int nrow,
                     const double* scale, int nscale) {
  char path[3][4096];
  const char* name[3] = {"scaling.dat", "models.dat", "plot.gp"};
  FILE* f[3];
  for (int i = 0; i < 3; i++) {
    snprintf(path[i], sizeof(path[i]), "%s/%s", dir, name[i]);
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
  if (!bad) {
    FILE* g = f[2];
    fprintf(g, "set terminal png size %d,650\nset output '%s'\nset termoption noenhanced\n"
            "set datafile missing '-'\nset multiplot layout 1,%d\n",
            (nscaling && nmodel) ? 1600 : 900, png, (nscaling && nmodel) ? 2 : 1);
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
  for (int i = 0; i < 3; i++) {
    bad = (f[i] && fclose(f[i])) || bad;
  }
  if (!bad) {
    char cmd[4200];
    snprintf(cmd, sizeof(cmd), "gnuplot '%s' 1>&2", path[2]);
    bad = system(cmd) != 0;
  }
  return bad;
}


//---------------------------------- Driver --------------------------------------------------------

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


// the output's directory is writable (checked before measuring)
static int outputWritable(const char* option, const char* path) {
  char* copy = strdup(path);
  int ok = copy && !access(dirname(copy), W_OK | X_OK);
  if (!ok) {
    cli_error("bench models: %s %s: the directory is not writable", option, path);
  }
  free(copy);
  return ok;
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


// ratios of rows [first + 1, last) to MuJoCo's row first
static void setRatios(modelsRow* rows, int first, int last) {
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


// time the N-copy humanoids; rows appended at rows + *nrow; 0 on success
static int runScaling(const modelsArgs* a, const char* src, int nv1, const double* copies,
                      int ncopy, const char* dir, modelsRow* rows, int* nrow) {
  int bad = 0;
  for (int i = 0; i < ncopy; i++) {
    // MuJoCo 2.2.2 sizes efc_AR as njmax^2 and efc_J as njmax x nv in one int-sized buffer
    int n = (int)copies[i], nconmax = 40 * n, njmax = 160 * n;
    while (12.0 * njmax * njmax + 24.0 * njmax * nv1 * n > 1.5e9) {
      njmax = njmax * 9 / 10;
    }
    char path[4096], label[64], err[CLI_MSG_SZ] = "";
    snprintf(path, sizeof(path), "%s/humanoids_%d.xml", dir, n);
    snprintf(label, sizeof(label), "humanoids_%d", n);
    mjModel* m = genHumanoids(src, n, nconmax, njmax, path) ? NULL
                 : mj_loadXML(path, NULL, err, sizeof(err));
    mjData* d = m ? mj_makeData(m) : NULL;
    if (!d || m->nconmax < nconmax || m->njmax < njmax) {
      cli_oneLine(err);
      cli_error("bench models: cannot make the model of %d copies of %s: %s", n, a->humanoid,
                err[0] ? err : m ? "nconmax/njmax not set, or out of memory" : "cannot write");
      mj_deleteData(d);
      mj_deleteModel(m);
      bad = 1;
      continue;
    }
    int first = *nrow;
    for (int e = 0; e < 2; e++) {
      modelsRow* r = newRow(rows + (*nrow)++, "scaling", label, "", n, m, e, 1);
      modelsMeasure(m, d, CLI_KEY_NONE, a->settle > 0 ? stepsFor(a->settle, r->h) : 0,
                    a->scaling_steps, a, r);
      bad = bad || r->status == RUN_FAILED;
    }
    setRatios(rows, first, *nrow);
    if (njmax < 160 * n && !rows[first].msg[0]) {
      snprintf(rows[first].msg, sizeof(rows[first].msg), "njmax %d (< 160 N: MuJoCo's buffer)",
               njmax);
    }
    for (int r = first; r < *nrow; r++) {
      printRow(rows + r, r == first);
    }
    fflush(stdout);
    ost_deleteData(d);
    mj_deleteModel(m);
    remove(path);
  }
  return bad;
}


// remove dir and the files written into it
static void removeDir(const char* dir, const double* copies, int ncopy) {
  const char* name[3] = {"scaling.dat", "models.dat", "plot.gp"};
  char path[4096];
  for (int i = 0; i < 3 + ncopy; i++) {
    if (i < 3) {
      snprintf(path, sizeof(path), "%s/%s", dir, name[i]);
    } else {
      snprintf(path, sizeof(path), "%s/humanoids_%d.xml", dir, (int)copies[i - 3]);
    }
    remove(path);
  }
  rmdir(dir);
}


static void modelsHelp(void) {
  printf("usage: ostrich bench models [options] MODEL.xml ...\n\n"
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
                  0, 20, 50, CLI_KEY_NONE, 0};
  const char** path = (const char**)calloc(argc + 1, sizeof(char*));
  int npath = 0;

  // options and model paths, in any order
  for (int i = 0; path && i < argc && !a.help; i++) {
    const cliOption* o = argv[i][0] == '-' && argv[i][1]
                         ? cli_findOption(kModelsOptions, kModelsNumOptions, argv[i]) : NULL;
    if (!strcmp(argv[i], "--help") || !strcmp(argv[i], "-h")) {
      a.help = 1;
    } else if (argv[i][0] != '-' || !argv[i][1]) {
      path[npath++] = argv[i];
    } else if (!o || i + 1 >= argc) {
      cli_error(o ? "bench models: %s: missing value"
                  : "bench models: unknown option '%s' (see ostrich bench models --help)",
                argv[i]);
      free(path);
      return CLI_USAGE;
    } else if (cli_storeOption(o, argv[++i], &a)) {
      free(path);
      return CLI_USAGE;
    }
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
  if (ok && (nscale < 0 || ncopy < 0 || a.scaling_steps < 1)) {
    cli_error("bench models: %s", nscale < 0 ? "--h-scale must be a list of positive numbers"
              : ncopy < 0 ? "--scaling must be a list of copy counts from 1 to 10000"
              : "--scaling-steps must be >= 1");
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
  ok = ok && (!a.csv || outputWritable("--csv", a.csv))
       && (!a.plot || outputWritable("--plot", a.plot));
  char* src = ok && ncopy ? readWithoutComments(a.humanoid) : NULL;
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
    printHeader("models: the same simulated duration per run");
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
    setRatios(rows, first, nrow);
    for (int r = first; r < nrow; r++) {
      printRow(rows + r, r == first);
    }
    fflush(stdout);
  }
  if (npath && rows) {
    printNotes(rows, nrow);
  }

  // the humanoid copies, and the fit of each engine
  int nmodelrow = nrow, npoint[2] = {0, 0};
  double slope[2] = {NAN, NAN};
  if (status != CLI_USAGE && rows && ncopy) {
    printHeader("\nscaling: copies of the humanoid, both engines at the same h");
    if (runScaling(&a, src, m1->nv, copies, ncopy, dir, rows, &nrow)) {
      status = CLI_FAIL;
    }
    printNotes(rows + nmodelrow, nrow - nmodelrow);
    for (int e = 0; e < 2; e++) {
      slope[e] = fitSlope(rows, nrow, e, npoint + e);
    }
    char b[3][32];
    printf("fit of log(us/step) on log(nv) over %d and %d sizes: slope mujoco %s, ostrich %s; "
           "difference (ostrich - mujoco) %s, ratio (ostrich / mujoco) %s\n", npoint[0],
           npoint[1], fmtNum(b[0], "%.3f", slope[0]), fmtNum(b[1], "%.3f", slope[1]),
           fmtNum(b[2], "%.3f", slope[1] - slope[0]),
           fmtNum(b[2] + 16, "%.3f", slope[1] / slope[0]));
  }

  // outputs
  if (status != CLI_USAGE && rows && a.csv && writeCsv(a.csv, rows, nrow, slope, npoint, ncopy)) {
    cli_error("bench models: cannot write %s", a.csv);
    status = CLI_FAIL;
  }
  if (status != CLI_USAGE && rows && a.plot && writePlot(a.plot, dir, rows, nrow, scale, nscale)) {
    cli_error("bench models: gnuplot could not draw %s", a.plot);
    status = CLI_FAIL;
  }
  if (have_dir) {
    removeDir(dir, copies, ncopy);
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
