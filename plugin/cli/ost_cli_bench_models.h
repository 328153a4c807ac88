// ost_cli_bench_models.h: what crosses the three files of `ostrich bench models` (private to
// them): the row of one timed run, the humanoid copies (ost_cli_bench_humanoids.c) and the report
// (table, fit, CSV and plot; ost_cli_bench_report.c), called by the driver
// (ost_cli_bench_models.c, whose timing loop mirrors MuJoCo's sample/testspeed.cc).
//
// Invariant: a modelsRow holds only what its run measured (steps, wall_s, converged, status, msg)
// and what is derived from it (ratio_step, ratio_sim); nothing printed is kept elsewhere.
#ifndef OSTRICH_PLUGIN_CLI_OST_CLI_BENCH_MODELS_H_
#define OSTRICH_PLUGIN_CLI_OST_CLI_BENCH_MODELS_H_

#include <mujoco/mujoco.h>

#include "ost_cli_util.h"

#ifdef __cplusplus
extern "C" {
#endif

#define MODELS_SPACING     2.0    // grid spacing of generated copies (m)
#define MODELS_NJMAX_COPY  160    // njmax per copy, unless MuJoCo's buffer would not fit
#define MODELS_NSCRATCH    3      // files of the plot in the scratch directory

typedef enum modelsStatus_ {      // outcome of one run
  RUN_OK = 0,                     // every step taken
  RUN_STOPPED,                    // stopped by --max-wall (the steps taken are timed)
  RUN_REFUSED,                    // Ostrich refused the model (OST_ERR_MODEL)
  RUN_FAILED                      // a step failed; the run stopped there
} modelsStatus;

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


//---------------------------------- Humanoid copies (ost_cli_bench_humanoids.c) -------------------

// Read an MJCF file into a string with <!-- --> comments removed; NULL if it cannot be read.
char* bench_models_readSource(const char* path);

// Write the model of n copies of src (the text of the file named humanoid) to dir/humanoids_n.xml
// and load it, with nconmax 40 n and njmax MODELS_NJMAX_COPY n, or less where MuJoCo 2.2.2's
// buffer would not fit (nv1: nv of one copy). path receives the file's path and *njmax the njmax
// set. Return 0 with *m and *d made, else print why, leave *m and *d NULL and return 1 (the file
// is removed then).
int bench_models_makeHumanoids(const char* src, const char* humanoid, int n, int nv1,
                               const char* dir, char* path, int path_sz, mjModel** m, mjData** d,
                               int* njmax);


//---------------------------------- Report (ost_cli_bench_report.c) -------------------------------

// Names of the plot's files in the scratch directory (data, then the gnuplot script).
extern const char* const kBenchModelsScratch[MODELS_NSCRATCH];

// Ratios of rows [first + 1, last) to MuJoCo's row first.
void bench_models_setRatios(modelsRow* rows, int first, int last);

// Print a table's title and column names.
void bench_models_printHeader(const char* title);

// Print one row of the table; first: the row that names the model.
void bench_models_printRow(const modelsRow* r, int first);

// Print each row's message, under the table it belongs to.
void bench_models_printNotes(const modelsRow* rows, int nrow);

// Fit log(us per step) on log(nv) over each engine's scaling rows (0: mujoco, 1: ostrich) into
// slope and npoint (points used), and print the line of the fit.
void bench_models_printFit(const modelsRow* rows, int nrow, double slope[2], int npoint[2]);

// Write every row, and the fits if fit, to path (atomically: cli_openOutput); 0 on success.
int bench_models_writeCsv(const char* path, const modelsRow* rows, int nrow,
                          const double* slope, const int* npoint, int fit);

// Draw with gnuplot into png, its files in dir (kBenchModelsScratch); 0 on success.
int bench_models_writePlot(const char* png, const char* dir, const modelsRow* rows, int nrow,
                           const double* scale, int nscale);

#ifdef __cplusplus
}
#endif

#endif  // OSTRICH_PLUGIN_CLI_OST_CLI_BENCH_MODELS_H_
