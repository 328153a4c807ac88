// compare_models.h: what the two files of `ostrich compare models` share: the result rows and the
// run's state (compare_models.c runs the models; compare_models_out.c writes the table, the CSV,
// the plot and the summary, and merges the rows of compare/mujoco3_models.py).
//
// Invariant: a row's text fields hold no line break (models_setText), only the reason may hold a
// comma (quoted in the CSV), and every numeric field the run did not measure is NaN (an empty
// CSV field).
#ifndef OSTRICH_COMPARE_COMPARE_MODELS_H_
#define OSTRICH_COMPARE_COMPARE_MODELS_H_

#include "compare_run.h"

#define MODELS_MAX_SCALE   16       // h-scales
#define MODELS_PATH_SZ     4096     // size of a path
#define MODELS_REASON_SZ   512      // size of a row's reason
#define MODELS_MAX_QVEL    1e6      // |qvel| (m/s or rad/s) above which a run diverged

// The CSV's columns, in order (compare/mujoco3_models.py writes the same).
#define MODELS_CSV_HEADER                                                                        \
  "model,engine,ctrl,h_scale,h,status,steps,simulated_s,converged_pct,unconverged_steps,"      \
  "failed_steps,max_penetration,wall_per_sim_s,error,reason"

typedef struct modelsRow_ {       // one (model, engine, controls, h-scale), or a refusal
  char   model[128];              // model name: its file name without .xml
  char   engine[40];              // ostrich, mujoco, mujoco3-implicitfast, ...
  char   ctrl[8];                 // zero or random ("" for a refusal or a load failure)
  double h_scale;                 // h / the model's opt.timestep
  double h;                       // step size (s)
  char   status[16];              // ok, diverged, failed, timeout, refused, load_failed,
                                  // setup_failed
  long   steps;                   // steps taken
  double simulated;               // simulated time reached (s)
  double converged_pct;           // Ostrich: steps that returned OST_OK, % of steps attempted
  long   unconverged;             // Ostrich: steps taken with OST_WARN_NOT_CONVERGED
  long   failed;                  // steps that returned an error (the run stops at the first)
  double max_penetration;         // deepest contact over the run (m)
  double wall_per_sim;            // wall time in the step calls per simulated second
  double error;                   // error against the reference (m, rad), NaN if none
  char   reason[MODELS_REASON_SZ];  // refusal, failure or divergence; "" if none
} modelsRow;

typedef struct modelsState_ {     // the whole command
  // arguments
  int         use[CMP_NENGINE];   // engines run
  int         ctrl_zero;          // run with zero controls
  int         ctrl_random;        // run with random controls
  double      scale[MODELS_MAX_SCALE];  // h-scales, ascending
  int         nscale;             // their count
  double      duration;           // simulated seconds per run
  double      max_wall;           // wall seconds after which a run stops (timeout)
  long        seed;               // random controls' seed
  long        key;                // keyframe + 1; 0: qpos0
  const char* csv;                // CSV path, NULL: none
  const char* plot;               // PNG path, NULL: none
  int         mujoco3;            // also run compare/mujoco3_models.py

  // models
  char**      path;               // model files, in order                          (nmodel)
  int         nmodel;             // their count

  // results
  modelsRow*  row;                // rows, model by model                           (nrow)
  int         nrow;               // rows
  int         cap;                // allocated rows
  int         nrefused;           // models Ostrich refused
  int         nload_failed;       // models MuJoCo could not load
  int         nbad;               // Ostrich runs that diverged or failed on accepted models
  int         ntimeout;           // runs stopped by --max-wall
  char        jobs_dir[MODELS_PATH_SZ];  // temporary directory for mujoco3, "" if none
  FILE*       jobs;               // its jobs.csv while the models run, NULL if none
} modelsState;

// A new row (zeroed, numbers NaN) appended to s, NULL if out of memory.
modelsRow* models_addRow(modelsState* s);

// Copy text into a row's field of size sz, each run of line breaks turned into "; " (so a list
// of refusals, one per line, stays a list), trailing spaces and separators dropped.
void models_setText(char* field, int sz, const char* text);

// Run compare/mujoco3_models.py on s->jobs_dir and append its rows; a missing python3 or mujoco
// package is a note, not an error.
void models_runMujoco3(modelsState* s);

// Print the table on stdout, then the summary.
void models_printTable(const modelsState* s);
void models_printSummary(const modelsState* s);

// Write the CSV (a temporary file, then renamed over the path); return 0 on success.
int models_writeCsv(const modelsState* s);

// Plot error against wall time per simulated second, one panel per model (gnuplot); a missing
// gnuplot is a note. Return 0 unless the plot was asked for and failed.
int models_writePlot(const modelsState* s);

#endif  // OSTRICH_COMPARE_COMPARE_MODELS_H_
