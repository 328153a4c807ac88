// compare_run.h: what the A/B subcommands share (sweep, replay, identify, gen-logs; usable by
// compare_hard.c): CSV tables and zero-order-hold command files, trajectories and the error
// metric between two of them, the engine runner that steps one model with Ostrich (ost_step) or
// stock MuJoCo (mj_step) on given commands, the robot's pallet-traversal command profile, and
// argument helpers. Mirrors the run loop of `ostrich sim` (plugin/cli/ost_cli.c).
//
// Invariant: like plugin/cli/ost_cli_util.h, a function that rejects its input prints one
// "ostrich:" line on stderr and returns nonzero; nothing here writes to stdout or exits. Every
// table and trajectory owns its arrays; its free function may be called on a zeroed or failed one.
#ifndef OSTRICH_COMPARE_COMPARE_RUN_H_
#define OSTRICH_COMPARE_COMPARE_RUN_H_

#include <stdio.h>

#include <mujoco/mujoco.h>

#include "ost_cli_util.h"

#ifdef __cplusplus
extern "C" {
#endif

#define CMP_SAMPLE_DT   0.01      // metric samples every 10 ms (the logs' 100 Hz)
#define CMP_YAW_LENGTH  0.5       // L (m): a yaw error of 1 rad counts as 0.5 m
#define CMP_NAME_SZ     64        // size of a column name


//---------------------------------- CSV tables ----------------------------------------------------

// A numeric CSV file: lines starting with '#' are comments, then one header line of column
// names, then rows of finite numbers, all with the header's column count.
typedef struct cmpTable_ {
  int     nrow;                   // data rows
  int     ncol;                   // columns
  char    (*name)[CMP_NAME_SZ];   // column names                                  (ncol)
  double* data;                   // values, row-major                             (nrow x ncol)
} cmpTable;

// Read a CSV table; the first column must be "time", strictly increasing. Return 0 on success,
// else print why (missing file, bad number, NaN, wrong column count; file and line named).
int cmp_readTable(const char* path, cmpTable* t);

// Column index of name, -1 if absent.
int cmp_tableColumn(const cmpTable* t, const char* name);

// Free a table's arrays.
void cmp_freeTable(cmpTable* t);


//---------------------------------- Commands ------------------------------------------------------

// Controls under a zero-order hold: row i holds from time[i] until time[i + 1]; before the
// first row the first row holds, after the last row the last row.
typedef struct cmpCommands_ {
  int     nrow;                   // rows
  int     nu;                     // controls per row
  double* time;                   // row times, increasing                         (nrow)
  double* ctrl;                   // controls                                      (nrow x nu)
} cmpCommands;

// Allocate nrow rows of nu controls (zeroed); return 0 on success.
int cmp_allocCommands(cmpCommands* c, int nrow, int nu);

// Commands from columns [first, first + nu) of a table; return 0 on success.
int cmp_commandsFromTable(const cmpTable* t, int first, int nu, cmpCommands* c);

// Read a command file: header time,<nu names>, one row per change; return 0 on success, else
// print why (also when the column count is not 1 + nu).
int cmp_readCommands(const char* path, int nu, cmpCommands* c);

// Write commands as CSV with the given nu column names (atomically: cli_openOutput); return 0 on
// success.
int cmp_writeCommands(const char* path, const cmpCommands* c, const char* const* names);

// The controls in force at time t (zero-order hold), into ctrl (nu).
void cmp_commandAt(const cmpCommands* c, double t, mjtNum* ctrl);

// Free the arrays.
void cmp_freeCommands(cmpCommands* c);


//---------------------------------- Pallet traversal ----------------------------------------------

// A traversal of the pallet scene by the three-wheeled robot (wheeled_robot_body.xml): rest,
// cosine ramp to the cruise speed, straight over the pallet until the base is past x_turn, a
// turn at constant yaw rate, a short straight, a cosine ramp down, rest.
typedef struct cmpTraversal_ {
  double speed;                   // cruise speed (m/s)
  double turn;                    // heading change (rad, + = left)
} cmpTraversal;

// The default traversal (1 m/s, a 90 deg left turn; compare/pallet_commands.csv).
extern const cmpTraversal kCmpDefaultTraversal;

// Wheel commands (rad/s; v_left, v_right, v_rear) of a traversal sampled at rate Hz.
int cmp_traversalCommands(const cmpTraversal* p, double rate, cmpCommands* c);

// 1 if the model's actuators are exactly v_left, v_right, v_rear (the robot), else 0.
int cmp_isRobot(const mjModel* m);

// Actuator names of the robot's command columns (cmd_left, cmd_right, cmd_rear).
extern const char* const kCmpRobotColumns[3];


//---------------------------------- Trajectories and the error metric -----------------------------

typedef enum cmpKind_ {           // what a trajectory sample holds
  CMP_POSE = 0,                   // floating base: x, y, z, yaw (yaw unwrapped, continuous)
  CMP_QPOS = 1                    // fixed base: qpos (nq)
} cmpKind;

typedef struct cmpTrajectory_ {
  int     kind;                   // cmpKind
  int     ncoord;                 // coordinates per sample (4 or nq)
  int     n;                      // samples
  int     cap;                    // allocated samples
  double* time;                   // sample times, increasing                      (n)
  double* coord;                  // coordinates, row-major                        (n x ncoord)
} cmpTrajectory;

// Kind of trajectory for model m: CMP_POSE if joint 0 is a free joint at qpos 0, else CMP_QPOS.
int cmp_modelKind(const mjModel* m);

// Start an empty trajectory; return 0 on success.
int cmp_initTrajectory(cmpTrajectory* tr, int kind, int ncoord);

// Append a sample; a pose's yaw is unwrapped to within pi of the previous one. Return 0 on
// success, 1 if out of memory.
int cmp_appendSample(cmpTrajectory* tr, double t, const double* coord);

// Append the current state of d (pose of the free joint, or qpos).
int cmp_appendState(cmpTrajectory* tr, const mjModel* m, const mjData* d);

// Coordinates at time t, linearly interpolated (clamped to the ends), into coord (ncoord).
void cmp_sampleAt(const cmpTrajectory* tr, double t, double* coord);

// Yaw (rad) of a unit quaternion (w, x, y, z), the rotation about z in ZYX order.
double cmp_yaw(const mjtNum* quat);

// Wrap an angle to (-pi, pi].
double cmp_wrapAngle(double a);

// Error of trajectory a against ref over their common time span, sampled every dt:
//   pose: sqrt(<|dp|^2> + (L * RMS(dyaw))^2), dp the 3-D base position difference, dyaw the yaw
//         difference wrapped to (-pi, pi], L = CMP_YAW_LENGTH;
//   qpos: sqrt(<|dq|^2>), |dq| the Euclidean norm over the nq coordinates.
// <.> is the mean over the samples t0, t0 + dt, ... <= t1 of [t0, t1] = the intersection of the
// two time spans. NaN if the kinds differ or the spans do not overlap.
double cmp_trajectoryError(const cmpTrajectory* a, const cmpTrajectory* ref, double dt);

// Trajectory of the given kind from a table: a pose from the columns x, y, z, yaw (a log), or
// either kind from qpos_0 .. qpos_<nq-1> (`ostrich sim --out`); times are column 0 minus
// t_shift. Return 0 on success, else print why (naming path).
int cmp_tableTrajectory(const char* path, const cmpTable* t, int kind, int nq, double t_shift,
                        cmpTrajectory* tr);

// Write a trajectory as CSV: time,x,y,z,yaw (yaw wrapped to (-pi, pi]) or time,qpos_0,..,
// atomically (cli_openOutput); return 0 on success.
int cmp_writeTrajectory(const char* path, const cmpTrajectory* tr);

// Free the arrays.
void cmp_freeTrajectory(cmpTrajectory* tr);


//---------------------------------- Engine runner -------------------------------------------------

typedef enum cmpEngine_ {         // time steppers
  CMP_MUJOCO = 0,                 // stock mj_step
  CMP_OSTRICH = 1,                // ost_step
  CMP_NENGINE
} cmpEngine;

extern const char* const kCmpEngineNames[CMP_NENGINE];  // "mujoco", "ostrich"

typedef enum cmpOutcome_ {        // how a run ended
  CMP_COMPLETED = 0,              // every step taken, state finite
  CMP_NAN,                        // non-finite qpos/qvel, or MuJoCo reset a diverged state
  CMP_STEP_FAILED,                // ost_step returned an error, or MuJoCo reported one
  CMP_SETUP_FAILED,               // Ostrich refused the model or its options
  CMP_TIMEOUT                     // stopped after max_wall seconds in the step calls
} cmpOutcome;

extern const char* const kCmpOutcomeNames[];  // "completed", "nan", "step_failed", ...

typedef struct cmpRunSpec_ {      // one run
  int                engine;      // cmpEngine
  double             h;           // step size (s)
  double             duration;    // simulated time (s); steps = round(duration / h)
  const cmpCommands* commands;    // controls (zero-order hold); NULL: all 0
  const mjtNum*      qpos0;       // start configuration (nq); NULL: the model's qpos0
  int                key;         // start from keyframe key - 1 (state and controls); 0: none
  double             max_qvel;    // |qvel| above which the run stops as diverged; 0: no limit
  double             max_wall;    // seconds in the step calls after which the run stops
                                  // (CMP_TIMEOUT); 0: no limit
} cmpRunSpec;

typedef struct cmpRunResult_ {    // what a run measured
  int    outcome;                 // cmpOutcome
  long   steps;                   // steps completed
  double simulated;               // simulated time reached (s)
  double wall;                    // seconds spent in the step calls
  double mean_iter;               // mean Newton (ostrich) or solver (mujoco) iterations
  double max_penetration;         // deepest contact over all steps (m)
  long   unconverged;             // Ostrich steps taken with a warning (OST_IS_WARNING: the
                                  // state advanced, not to tolerance); counted in steps
  long   failed;                  // steps that failed (0 or 1: a failure ends the run)
  char   why[CLI_MSG_SZ];         // the failure, "" if completed
} cmpRunResult;

// Run one engine on m (opt.timestep is set to h for the run and restored). The trajectory
// gets the start state and the state after every step, up to the first non-finite one. An
// Ostrich warning status (OST_IS_WARNING) is a step taken, counted in res->unconverged. Return
// 0 if the run could be made (its outcome may still be a failure), 1 on out of memory.
int cmp_run(mjModel* m, const cmpRunSpec* spec, cmpTrajectory* tr, cmpRunResult* res);


//---------------------------------- Arguments -----------------------------------------------------

// cli_parseArgsList for commands with up to npos positional arguments, stored in order; missing
// ones stay NULL. Return 0 on success.
int cmp_parseArgs(const char* command, int argc, char** argv, const cliOption* options,
                  int noption, void* args, const char** positional, int npos, int* help);

// Parse a comma list of positive numbers (at most cap) into values, sorted ascending and without
// duplicates if sort; return the count, or -1 after printing why (naming option).
int cmp_parsePositiveList(const char* option, const char* s, double* values, int cap, int sort);

// Parse a comma list of engine names into the flags use[CMP_NENGINE]; return 0 on success.
int cmp_parseEngines(const char* s, int* use);

// Split a comma list of paths into at most cap pointers into buf (a copy of s); return the count,
// or -1 after printing why (naming option).
int cmp_splitList(const char* option, const char* s, char* buf, int buf_sz, const char** items,
                  int cap);

// Run a program (found on PATH) with its stdout written to out_path and its stderr to err_path
// (NULL: inherited); return its exit status, 127 if it could not be started.
int cmp_spawn(char* const* argv, const char* out_path, const char* err_path);

// Print a JSON array of n numbers.
void cmp_jsonArray(FILE* f, const double* x, int n);

#ifdef __cplusplus
}
#endif

#endif  // OSTRICH_COMPARE_COMPARE_RUN_H_
