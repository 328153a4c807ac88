// ost_cli_util.h: helpers shared by the subcommands of the `ostrich` command-line tool
// (ost_cli.c dispatches; ost_cli_synth.c, ost_cli_gradcheck.c): messages and MuJoCo's error
// handlers, number and option-table parsing (with the deprecated spellings), output files
// (checked before work, written atomically), JSON printing, the clock, a seeded random stream,
// model loading, Ostrich's option set-up and acceptance test, and the start state (--key).
// Mirrors the shared part of MuJoCo's sample programs.
//
// Invariant: every helper that rejects its input prints exactly one "ostrich: ..." line on stderr
// and returns nonzero; none writes to stdout (each subcommand prints its one JSON line itself),
// and none exits.
#ifndef OSTRICH_PLUGIN_CLI_OST_CLI_UTIL_H_
#define OSTRICH_PLUGIN_CLI_OST_CLI_UTIL_H_

#include <stddef.h>
#include <stdio.h>

#include <mujoco/mujoco.h>

#include "ostrich.h"

#ifdef __cplusplus
extern "C" {
#endif

enum {
  CLI_OK    = 0,                  // success
  CLI_FAIL  = 1,                  // the run failed (simulation, check or output)
  CLI_USAGE = 2                   // bad usage or unusable input
};

#define CLI_MSG_SZ 1024           // size of message buffers
#define CLI_PATH_SZ 4096          // size of path buffers


//---------------------------------- Subcommands ---------------------------------------------------

// `ostrich sim` and `ostrich check` (ost_cli.c); argv excludes the subcommand name.
int sim_main(int argc, char** argv);
int check_main(int argc, char** argv);

// `ostrich synth`: control synthesis on the wheeled robot (ost_cli_synth.c).
int synth_main(int argc, char** argv);

// `ostrich gradcheck`: adjoint gradients against finite differences (ost_cli_gradcheck.c).
int gradcheck_main(int argc, char** argv);

// `ostrich bench scale`: world scaling of the batched API (ost_cli_bench.c).
int bench_main(int argc, char** argv);

// `ostrich bench models`: ost_step against mj_step per model and against nv
// (ost_cli_bench_models.c); called by bench_main.
int bench_models_main(int argc, char** argv);

// `ostrich bench adjoint`: the backward pass against the forward step and against
// mjd_transitionFD, one core (ost_cli_bench_adjoint.c); called by bench_main.
int bench_adjoint_main(int argc, char** argv);


//---------------------------------- Messages ------------------------------------------------------

// Turn line breaks into spaces and drop trailing spaces (MuJoCo's XML errors span lines).
void cli_oneLine(char* msg);

// Print "ostrich: <message>" on stderr, as one line.
void cli_error(const char* fmt, ...) __attribute__((format(printf, 1, 2)));

// MuJoCo error handler: record the first message and return (no longjmp, no exit); callers
// check cli_mujocoError after each MuJoCo call that can fail. Installed by main.
void cli_onMujocoError(const char* msg);

// MuJoCo warning handler: print on stderr as "mujoco warning: ...", one line. Installed by main.
void cli_onMujocoWarning(const char* msg);

// Message of the first MuJoCo error of this process, NULL if none.
const char* cli_mujocoError(void);

// 1 unless the environment sets OSTRICH_QUIET to a value other than "" or "0".
int cli_progress(void);


//---------------------------------- Parsing -------------------------------------------------------

// Parse a finite number that fills the whole string; return 0 on success.
int cli_parseNumber(const char* s, double* value);

// Parse a non-negative decimal integer that fills the whole string; return 0 on success.
int cli_parseCount(const char* s, long* value);

// Parse a comma list of exactly n numbers (n = nu) into values; return 0 on success, else print
// why, naming option.
int cli_parseList(const char* option, const char* s, mjtNum* values, int n);


//---------------------------------- Option table --------------------------------------------------

typedef enum cliArg_ {            // kind of value an option takes
  CLI_ARG_STRING,                 // any string (const char*)
  CLI_ARG_POSITIVE,               // finite number > 0 (double)
  CLI_ARG_COUNT,                  // integer >= 0 (long)
  CLI_ARG_FLAG                    // no value; the int field is set to 1
} cliArg;

typedef struct cliOption_ {       // one command-line option
  const char* name;               // "--name"
  cliArg      kind;               // value kind
  size_t      offset;             // offset of the value field in the argument struct
  const char* metavar;            // placeholder in the usage text ("" for a flag)
  const char* help;               // usage text; '\n' starts a new indented line
} cliOption;

// Print an option table as aligned usage lines.
void cli_printOptions(FILE* f, const cliOption* options, int noption);

// Print the usage line of -h, --help (after an option table).
void cli_printHelpOption(FILE* f);

// Find an option by name, NULL if unknown.
const cliOption* cli_findOption(const cliOption* options, int noption, const char* name);

// Store the value text of option o into the argument struct args; return 0 on success.
int cli_storeOption(const cliOption* o, const char* text, void* args);

// Parse the arguments of `ostrich COMMAND` against an option table into args. Options and
// positional arguments come in any order; positional receives the positional arguments in order
// (at most cap; cap 0: the command takes none) and *npos their count (npos may be NULL). On -h
// or --help, set *help and stop. A deprecated spelling (cli_findAlias) is accepted with a note on
// stderr. Return 0 on success, else print why and return 1.
int cli_parseArgsList(const char* command, int argc, char** argv, const cliOption* options,
                      int noption, void* args, const char** positional, int cap, int* npos,
                      int* help);

// cli_parseArgsList for commands with at most one positional argument (the model path), stored
// in *positional; positional NULL: the command takes none.
int cli_parseArgs(const char* command, int argc, char** argv, const cliOption* options,
                  int noption, void* args, const char** positional, int* help);


//---------------------------------- Deprecated spellings ------------------------------------------
// One table of the spellings that the previous release accepted, each with the commands that had
// it. An option that a command's table does not have is looked up here; if the command had it and
// its new spelling is in the command's table (or, for "--model FILE", the command takes a
// positional model), the option is taken as the new spelling and a note
// "ostrich: COMMAND: 'OLD' is deprecated and will be removed in the next release; use 'NEW'" goes
// to stderr. The table is empty again in the next release.

typedef struct cliAlias_ {        // a deprecated spelling
  const char* old;                // as the previous release spelled it
  const char* now;                // the canonical option; NULL: the positional model argument
  const char* commands;           // comma list of the commands that had it ("compare sweep,...")
} cliAlias;

// The alias of a deprecated option name for command (as named in its messages, "compare sweep")
// with this option table, NULL if none. takes_positional: the command takes a positional argument.
const cliAlias* cli_findAlias(const char* command, const cliOption* options, int noption,
                              int takes_positional, const char* name);


//---------------------------------- Output files --------------------------------------------------
// Every file a subcommand writes is checked before any work (cli_checkOutput, cli_checkOutputDir)
// and written atomically: into "PATH.tmp<pid>" next to it, then renamed over PATH
// (cli_commitOutput). A killed run leaves the previous PATH whole (and at most a stale .tmp file).

// Check before any work that the file path can be written: it is not a directory and a new file
// can be created next to it (one is created with O_EXCL and removed). Return 0, else print why
// (naming option and path) and return 1.
int cli_checkOutput(const char* option, const char* path);

// Check before any work that the directory dir can receive outputs: create it if missing (its
// parent must exist), then create and remove a file in it. Return 0, else print why and return 1.
int cli_checkOutputDir(const char* option, const char* dir);

// The temporary name of output path ("PATH.tmp<pid>") into tmp (tmp_sz bytes); return 0, or 1 if
// it does not fit (message printed). For files another program writes (gnuplot's PNG).
int cli_outputTemp(const char* path, char* tmp, int tmp_sz);

// Open the temporary file of output path for writing; its name goes to tmp (tmp_sz bytes).
// Return the stream, or NULL after printing why.
FILE* cli_openOutput(const char* path, char* tmp, int tmp_sz);

// Close f (NULL: tmp was written by another program) and rename tmp over path. Return 0, else
// print why, remove tmp and return 1; path is then untouched.
int cli_commitOutput(FILE* f, const char* tmp, const char* path);

// Close f (if not NULL) and remove tmp: the output is abandoned and path is untouched.
void cli_discardOutput(FILE* f, const char* tmp);


//---------------------------------- JSON and time -------------------------------------------------

// Print a JSON number (%.10g; null if not finite).
void cli_jsonNumber(FILE* f, double x);

// Print a JSON string with escapes.
void cli_jsonString(FILE* f, const char* s);

// Seconds on the monotonic clock.
double cli_now(void);

// The median of v (n > 0 entries, sorted in place; the upper middle one when n is even).
double cli_median(double* v, int n);


//---------------------------------- Random stream -------------------------------------------------

typedef struct cliRng_ {          // splitmix64 stream: the same numbers on every platform
  unsigned long long state;       // advanced by every draw
} cliRng;

// Start a stream from a seed.
void cli_rngSeed(cliRng* rng, unsigned long long seed);

// Uniform draw in [lo, hi).
double cli_uniform(cliRng* rng, double lo, double hi);


//---------------------------------- Models --------------------------------------------------------

// Load an MJCF model and make its mjData; return 0 on success, else print why (missing file,
// malformed XML, MuJoCo error) and return 1. *m and *d are NULL or valid either way.
int cli_loadModel(const char* path, mjModel** m, mjData** d);

// Ostrich's options for m: defaults < the model's <custom> ostrich/* < overrides h > 0
// (timestep), newton >= 0, pcr >= 0, geometry "mujoco" | "native" (NULL: the model's); then the
// acceptance test of ost_step with them (ost_checkStep: every unsupported feature, model and
// geometry provider). Return 0 if accepted, else 1 with the reason in err; prints nothing. This
// is the one acceptance test of every subcommand (`sim` and `check` refuse with its message).
int cli_ostrichOptions(const mjModel* m, double h, long newton, long pcr, const char* geometry,
                       ostOptions* opt, char* err, int err_sz);

// Configure Ostrich on (m, d): cli_ostrichOptions, then ost_setOptions. Sets *h_out to the step
// size. Return 0 on success, else print why and return 1.
int cli_setupOstrich(const mjModel* m, mjData* d, double h, long newton, long pcr,
                     const char* geometry, double* h_out);


//---------------------------------- Start state ---------------------------------------------------
// Every subcommand that steps one model from a start state takes --key K with the same meaning
// (MuJoCo's convention): no --key starts from qpos0 (mj_resetData), --key K from keyframe K
// (mj_resetDataKeyframe: time, qpos, qvel, act, ctrl, mocap). Keyframes are never used
// implicitly; `--key 0` is how to start from a model's first keyframe.

#define CLI_KEY_NONE -1L          // --key not given: start from qpos0

// The --key entry of an option table whose argument struct has a `long key` field.
#define CLI_KEY_OPTION(type)                                                          \
  {"--key", CLI_ARG_COUNT, offsetof(type, key), "K",                                 \
   "start from keyframe K (mj_resetDataKeyframe: time, qpos, qvel, act,\n"          \
   "ctrl, mocap); default: qpos0 and zero velocity (mj_resetData)"}

// Check --key against m before any work: CLI_KEY_NONE, or 0 <= key < m->nkey. Return 0 if
// valid, else print why and return 1.
int cli_checkKey(const mjModel* m, long key);

// Reset d to the start state: mj_resetData, then keyframe key unless key is CLI_KEY_NONE
// (checked by cli_checkKey first).
void cli_resetStart(const mjModel* m, mjData* d, long key);

// The state mj_resetData sets (time 0, qpos0, zero velocities, activations, controls, applied
// forces and warm start, mocap bodies at their model poses, warnings cleared), without clearing
// MuJoCo's whole buffer as mj_resetData does (1.6 MB for the wheeled robot: 4 % of an Ostrich
// synth iteration). For rollouts repeated from one start: every output field is recomputed by
// the next step.
void cli_resetState(const mjModel* m, mjData* d);

// Return 1 if qpos or qvel has a non-finite entry, 2 if MuJoCo found one and reset the state
// (mj_checkPos/Vel/Acc warn and reset, so the bad values never reach the caller), else 0.
int cli_hasNan(const mjModel* m, const mjData* d);

#ifdef __cplusplus
}
#endif

#endif  // OSTRICH_PLUGIN_CLI_OST_CLI_UTIL_H_
