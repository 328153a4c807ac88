// ost_cli_util.c: helpers shared by the subcommands of the `ostrich` tool (see ost_cli_util.h):
// messages, MuJoCo's error handlers, parsing, the option table and its deprecated spellings, the
// output files (checked first, written atomically), JSON, the clock, the random stream, model
// loading, Ostrich's option set-up and acceptance test, and the start state.
//
// Invariant: nothing here writes to stdout or exits; a rejected input gives one "ostrich:" line
// on stderr and a nonzero return.
#define _POSIX_C_SOURCE 200809L

#include "ost_cli_util.h"

#include <errno.h>
#include <fcntl.h>
#include <math.h>
#include <stdarg.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <time.h>
#include <unistd.h>

#include "ostrich.h"


//---------------------------------- Messages ------------------------------------------------------

static char mj_error_text[CLI_MSG_SZ];  // first MuJoCo error of this process ("" if none)


void cli_oneLine(char* msg) {
  for (char* c = msg; *c; c++) {
    if (*c == '\n' || *c == '\r') {
      *c = ' ';
    }
  }
  for (size_t n = strlen(msg); n > 0 && msg[n - 1] == ' '; n--) {
    msg[n - 1] = 0;
  }
}


void cli_error(const char* fmt, ...) {
  char msg[2 * CLI_MSG_SZ];
  va_list args;
  va_start(args, fmt);
  vsnprintf(msg, sizeof(msg), fmt, args);
  va_end(args);
  cli_oneLine(msg);
  fprintf(stderr, "ostrich: %s\n", msg);
}


void cli_onMujocoError(const char* msg) {
  if (!mj_error_text[0]) {
    snprintf(mj_error_text, sizeof(mj_error_text), "%s", msg);
  }
}


void cli_onMujocoWarning(const char* msg) {
  char line[CLI_MSG_SZ];
  snprintf(line, sizeof(line), "%s", msg);
  cli_oneLine(line);
  fprintf(stderr, "mujoco warning: %s\n", line);
}


const char* cli_mujocoError(void) {
  return mj_error_text[0] ? mj_error_text : NULL;
}


int cli_progress(void) {
  const char* quiet = getenv("OSTRICH_QUIET");
  return !(quiet && quiet[0] && strcmp(quiet, "0"));
}


//---------------------------------- Parsing -------------------------------------------------------

int cli_parseNumber(const char* s, double* value) {
  char* end = NULL;
  errno = 0;
  double v = strtod(s, &end);
  if (end == s || *end || errno == ERANGE || !isfinite(v)) {
    return 1;
  }
  *value = v;
  return 0;
}


int cli_parseCount(const char* s, long* value) {
  char* end = NULL;
  errno = 0;
  long v = strtol(s, &end, 10);
  if (end == s || *end || errno == ERANGE || v < 0 || v > 2147483647L) {
    return 1;
  }
  *value = v;
  return 0;
}


int cli_parseList(const char* option, const char* s, mjtNum* values, int n) {
  // an empty list has no items; items are separated by commas
  int count = 0;
  int more = (*s != 0);
  while (more) {
    char item[64];
    double v;
    int len = (int)strcspn(s, ",");
    snprintf(item, sizeof(item), "%.*s", len, s);
    if (len >= (int)sizeof(item) || cli_parseNumber(item, &v)) {
      cli_error("%s: '%.*s' is not a number", option, len, s);
      return 1;
    }
    if (count < n) {
      values[count] = v;
    }
    count++;
    more = (s[len] == ',');
    s += len + 1;
  }
  if (count != n) {
    cli_error("%s: got %d values, the model has nu = %d", option, count, n);
    return 1;
  }
  return 0;
}


//---------------------------------- Option table --------------------------------------------------

void cli_printOptions(FILE* f, const cliOption* options, int noption) {
  for (int i = 0; i < noption; i++) {
    char left[64];
    snprintf(left, sizeof(left), "%s %s", options[i].name, options[i].metavar);
    fprintf(f, "  %-26s ", left);
    for (const char* c = options[i].help; *c; c++) {
      fputc(*c, f);
      if (*c == '\n') {
        fprintf(f, "  %-26s ", "");
      }
    }
    fputc('\n', f);
  }
}


void cli_printHelpOption(FILE* f) {
  fprintf(f, "  %-26s print this help and exit\n", "-h, --help");
}


const cliOption* cli_findOption(const cliOption* options, int noption, const char* name) {
  for (int i = 0; i < noption; i++) {
    if (!strcmp(options[i].name, name)) {
      return options + i;
    }
  }
  return NULL;
}


int cli_storeOption(const cliOption* o, const char* text, void* args) {
  char* field = (char*)args + o->offset;
  if (o->kind == CLI_ARG_FLAG) {
    *(int*)field = 1;
    return 0;
  }
  if (o->kind == CLI_ARG_STRING) {
    *(const char**)field = text;
    return 0;
  }
  if (o->kind == CLI_ARG_POSITIVE) {
    double v;
    if (cli_parseNumber(text, &v) || v <= 0) {
      cli_error("%s: '%s' is not a positive number", o->name, text);
      return 1;
    }
    *(double*)field = v;
    return 0;
  }
  long v;
  if (cli_parseCount(text, &v)) {
    cli_error("%s: '%s' is not a non-negative integer", o->name, text);
    return 1;
  }
  *(long*)field = v;
  return 0;
}


//---------------------------------- Deprecated spellings ------------------------------------------

// the previous release's spellings and the commands that had them; empty in the next release
static const cliAlias kAliases[] = {
  {"--engines", "--engine", "compare sweep,compare replay,compare identify,compare hard"},
  {"--repeats", "--repeat", "compare sweep"},
  {"--out", "--csv", "sim,compare identify"},  // the one CSV they write
  {"--model", NULL, "synth,bench scale,compare gen-logs"},  // the model is positional
};

static const int kNumAliases = (int)(sizeof(kAliases) / sizeof(kAliases[0]));


// 1 if command is an item of the comma list list.
static int cli_inList(const char* list, const char* command) {
  size_t n = strlen(command);
  for (const char* c = list; c; c = strchr(c, ',') ? strchr(c, ',') + 1 : NULL) {
    if (!strncmp(c, command, n) && (c[n] == ',' || !c[n])) {
      return 1;
    }
  }
  return 0;
}


const cliAlias* cli_findAlias(const char* command, const cliOption* options, int noption,
                              int takes_positional, const char* name) {
  for (int i = 0; i < kNumAliases; i++) {
    const cliAlias* a = kAliases + i;
    if (strcmp(a->old, name) || !cli_inList(a->commands, command)) {
      continue;
    }
    if (a->now ? cli_findOption(options, noption, a->now) != NULL : takes_positional) {
      return a;
    }
  }
  return NULL;
}


//---------------------------------- Argument parsing ----------------------------------------------

// Store positional argument arg; return 0, else print why.
static int cli_storePositional(const char* command, const char* arg, const char** positional,
                               int cap, int* n) {
  if (*n < cap) {
    positional[(*n)++] = arg;
    return 0;
  }
  if (cap == 0) {
    cli_error("%s: unexpected argument '%s' (see ostrich %s --help)", command, arg, command);
  } else if (cap == 1) {
    cli_error("%s: unexpected argument '%s' (the model is '%s')", command, arg, positional[0]);
  } else {
    cli_error("%s: unexpected argument '%s' (at most %d; see ostrich %s --help)", command, arg,
              cap, command);
  }
  return 1;
}


int cli_parseArgsList(const char* command, int argc, char** argv, const cliOption* options,
                      int noption, void* args, const char** positional, int cap, int* npos,
                      int* help) {
  int n = 0;
  for (int i = 0; i < argc; i++) {
    const char* arg = argv[i];
    if (!strcmp(arg, "--help") || !strcmp(arg, "-h")) {
      *help = 1;
      break;
    }

    // a positional argument ("-" alone is one too)
    if (arg[0] != '-' || !arg[1]) {
      if (cli_storePositional(command, arg, positional, cap, &n)) {
        return 1;
      }
      continue;
    }

    // an option, possibly in a deprecated spelling, and its value
    const cliOption* o = cli_findOption(options, noption, arg);
    const cliAlias* alias = o ? NULL : cli_findAlias(command, options, noption, cap > 0, arg);
    if (!o && !alias) {
      cli_error("%s: unknown option '%s' (see ostrich %s --help)", command, arg, command);
      return 1;
    }
    if (alias) {
      cli_error("%s: '%s' is deprecated and will be removed in the next release; use '%s'",
                command, alias->old, alias->now ? alias->now : "MODEL.xml (positional)");
      o = alias->now ? cli_findOption(options, noption, alias->now) : NULL;
    }
    if (o && o->kind == CLI_ARG_FLAG) {
      cli_storeOption(o, NULL, args);
      continue;
    }
    if (i + 1 >= argc) {
      cli_error("%s: missing value (%s)", arg, o ? o->metavar : "MODEL.xml");
      return 1;
    }
    i++;
    if (o ? cli_storeOption(o, argv[i], args)
          : cli_storePositional(command, argv[i], positional, cap, &n)) {
      return 1;
    }
  }
  if (npos) {
    *npos = n;
  }
  return 0;
}


int cli_parseArgs(const char* command, int argc, char** argv, const cliOption* options,
                  int noption, void* args, const char** positional, int* help) {
  return cli_parseArgsList(command, argc, argv, options, noption, args, positional,
                           positional ? 1 : 0, NULL, help);
}


//---------------------------------- Output files --------------------------------------------------

int cli_checkOutput(const char* option, const char* path) {
  struct stat st;
  if (!path[0] || (!stat(path, &st) && S_ISDIR(st.st_mode))) {
    cli_error("%s: '%s' is %s", option, path, path[0] ? "a directory" : "empty");
    return 1;
  }
  // the final write is a rename of a new file next to path: try one now
  char tmp[CLI_PATH_SZ];
  if (cli_outputTemp(path, tmp, sizeof(tmp))) {
    return 1;
  }
  int fd = open(tmp, O_WRONLY | O_CREAT | O_EXCL, 0644);
  if (fd < 0) {
    cli_error("%s: cannot write '%s': %s", option, path, strerror(errno));
    return 1;
  }
  close(fd);
  remove(tmp);
  return 0;
}


int cli_checkOutputDir(const char* option, const char* dir) {
  struct stat st;
  if (!dir[0] || (mkdir(dir, 0755) && errno != EEXIST)) {
    cli_error("%s: cannot create directory '%s': %s", option, dir,
              dir[0] ? strerror(errno) : "empty name");
    return 1;
  }
  if (stat(dir, &st) || !S_ISDIR(st.st_mode)) {
    cli_error("%s: '%s' is not a directory", option, dir);
    return 1;
  }
  char probe[CLI_PATH_SZ];
  if (snprintf(probe, sizeof(probe), "%s/.ostrich", dir) >= (int)sizeof(probe)) {
    cli_error("%s: path too long: '%s'", option, dir);
    return 1;
  }
  return cli_checkOutput(option, probe);
}


int cli_outputTemp(const char* path, char* tmp, int tmp_sz) {
  if (snprintf(tmp, (size_t)tmp_sz, "%s.tmp%ld", path, (long)getpid()) >= tmp_sz) {
    cli_error("path too long: '%s'", path);
    return 1;
  }
  return 0;
}


FILE* cli_openOutput(const char* path, char* tmp, int tmp_sz) {
  if (cli_outputTemp(path, tmp, tmp_sz)) {
    return NULL;
  }
  FILE* f = fopen(tmp, "w");
  if (!f) {
    cli_error("cannot write '%s': %s", path, strerror(errno));
  }
  return f;
}


int cli_commitOutput(FILE* f, const char* tmp, const char* path) {
  // no fsync: the rename protects against a killed process, which is what this is for
  int bad = f && (ferror(f) | fclose(f));
  if (bad || rename(tmp, path)) {
    cli_error("cannot write '%s': %s", path, bad ? "write error" : strerror(errno));
    remove(tmp);
    return 1;
  }
  return 0;
}


void cli_discardOutput(FILE* f, const char* tmp) {
  if (f) {
    fclose(f);
  }
  remove(tmp);
}


//---------------------------------- JSON and time -------------------------------------------------

void cli_jsonNumber(FILE* f, double x) {
  if (isfinite(x)) {
    fprintf(f, "%.10g", x);
  } else {
    fputs("null", f);
  }
}


void cli_jsonString(FILE* f, const char* s) {
  fputc('"', f);
  for (const unsigned char* c = (const unsigned char*)s; *c; c++) {
    if (*c == '"' || *c == '\\') {
      fprintf(f, "\\%c", *c);
    } else if (*c < 0x20) {
      fprintf(f, "\\u%04x", *c);
    } else {
      fputc(*c, f);
    }
  }
  fputc('"', f);
}


double cli_now(void) {
  struct timespec t;
  clock_gettime(CLOCK_MONOTONIC, &t);
  return (double)t.tv_sec + 1e-9 * (double)t.tv_nsec;
}


static int compareDouble(const void* a, const void* b) {
  double x = *(const double*)a, y = *(const double*)b;
  return (x > y) - (x < y);
}


double cli_median(double* v, int n) {
  qsort(v, n, sizeof(double), compareDouble);
  return v[n / 2];
}


//---------------------------------- Random stream -------------------------------------------------

void cli_rngSeed(cliRng* rng, unsigned long long seed) {
  rng->state = seed;
}


double cli_uniform(cliRng* rng, double lo, double hi) {
  // splitmix64 (Steele, Lea, Flood 2014); the top 53 bits give a double in [0, 1)
  unsigned long long z = (rng->state += 0x9E3779B97F4A7C15ULL);
  z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ULL;
  z = (z ^ (z >> 27)) * 0x94D049BB133111EBULL;
  z ^= z >> 31;
  return lo + (hi - lo) * ((double)(z >> 11) * 0x1.0p-53);
}


//---------------------------------- Models --------------------------------------------------------

int cli_loadModel(const char* path, mjModel** m, mjData** d) {
  char err[CLI_MSG_SZ] = "";
  *m = NULL;
  *d = NULL;

  // a missing file gets its own message (MuJoCo's is vague)
  FILE* f = fopen(path, "r");
  if (!f) {
    cli_error("cannot open model '%s': %s", path, strerror(errno));
    return 1;
  }
  fclose(f);

  // compile; MuJoCo returns NULL and the reason for malformed XML
  *m = mj_loadXML(path, NULL, err, sizeof(err));
  if (!*m) {
    const char* why = err[0] ? err : cli_mujocoError();
    cli_error("cannot load model '%s': %s", path, why ? why : "unknown error");
    return 1;
  }
  if (err[0]) {
    cli_onMujocoWarning(err);
  }
  *d = mj_makeData(*m);
  if (!*d || cli_mujocoError()) {
    const char* why = cli_mujocoError();
    cli_error("cannot allocate mjData for '%s': %s", path, why ? why : "out of memory");
    return 1;
  }
  return 0;
}


int cli_ostrichOptions(const mjModel* m, double h, long newton, long pcr, const char* geometry,
                       ostOptions* opt, char* err, int err_sz) {
  // options: defaults < model <custom> ostrich/* < command line
  ost_defaultOptions(opt);
  if (ost_readOptions(m, opt, err, err_sz) != OST_OK) {
    return 1;
  }
  if (h > 0) {
    opt->timestep = h;
  }
  if (newton >= 0) {
    opt->newton_iter = (int)newton;
  }
  if (pcr >= 0) {
    opt->pcr_iter = (int)pcr;
  }
  if (geometry) {
    opt->geometry = strcmp(geometry, "native") ? OST_GEOMETRY_MUJOCO : OST_GEOMETRY_NATIVE;
  }

  // refuse models with features Ostrich (or the chosen geometry provider) does not model
  return ost_checkStep(m, opt, err, err_sz) != OST_OK;
}


int cli_setupOstrich(const mjModel* m, mjData* d, double h, long newton, long pcr,
                     const char* geometry, double* h_out) {
  char err[CLI_MSG_SZ] = "";
  ostOptions opt;
  if (cli_ostrichOptions(m, h, newton, pcr, geometry, &opt, err, sizeof(err))) {
    cli_error("%s", err);
    return 1;
  }
  int status = ost_setOptions(m, d, &opt);
  if (status != OST_OK) {
    cli_error("options refused (status %d): %s", status, ost_lastError(d));
    return 1;
  }

  // options timestep 0 means opt.timestep
  *h_out = opt.timestep > 0 ? opt.timestep : m->opt.timestep;
  return 0;
}


//---------------------------------- Start state ---------------------------------------------------

int cli_checkKey(const mjModel* m, long key) {
  if (key == CLI_KEY_NONE || (key >= 0 && key < m->nkey)) {
    return 0;
  }
  if (m->nkey == 0) {
    cli_error("--key %ld: the model has no keyframes", key);
  } else {
    cli_error("--key %ld: the model has %d keyframe%s (0 to %d)", key, m->nkey,
              m->nkey > 1 ? "s" : "", m->nkey - 1);
  }
  return 1;
}


void cli_resetState(const mjModel* m, mjData* d) {
  d->time = 0;
  mju_copy(d->qpos, m->qpos0, m->nq);
  mju_zero(d->qvel, m->nv);
  mju_zero(d->act, m->na);
  mju_zero(d->ctrl, m->nu);
  mju_zero(d->qfrc_applied, m->nv);
  mju_zero(d->xfrc_applied, 6 * m->nbody);
  mju_zero(d->qacc_warmstart, m->nv);
  mju_zero(d->qacc, m->nv);
  for (int b = 0; b < m->nbody; b++) {
    int k = m->body_mocapid[b];
    if (k >= 0) {
      mju_copy3(d->mocap_pos + 3 * k, m->body_pos + 3 * b);
      mju_copy4(d->mocap_quat + 4 * k, m->body_quat + 4 * b);
    }
  }
  memset(d->warning, 0, sizeof(d->warning));
}


void cli_resetStart(const mjModel* m, mjData* d, long key) {
  mj_resetData(m, d);
  if (key != CLI_KEY_NONE) {
    mj_resetDataKeyframe(m, d, (int)key);
  }
}


int cli_hasNan(const mjModel* m, const mjData* d) {
  for (int i = 0; i < m->nq; i++) {
    if (!isfinite(d->qpos[i])) {
      return 1;
    }
  }
  for (int i = 0; i < m->nv; i++) {
    if (!isfinite(d->qvel[i])) {
      return 1;
    }
  }
  if (d->warning[mjWARN_BADQPOS].number || d->warning[mjWARN_BADQVEL].number ||
      d->warning[mjWARN_BADQACC].number) {
    return 2;
  }
  return 0;
}
