// ost_python.h: what the two files of the Python package's flat C library share (ost_python.c:
// loading, arrays, names, options, stepping; ost_python_rollout.c: recorded rollouts and the
// batch's backward pass). Private: Python declares the functions it calls in ostrich/_lib.py.
#ifndef OSTRICH_PLUGIN_PYTHON_OST_PYTHON_H_
#define OSTRICH_PLUGIN_PYTHON_OST_PYTHON_H_

#include <mujoco/mujoco.h>

#include "ostrich.h"

#if defined(__GNUC__) || defined(__clang__)
  #define OSTPY_API __attribute__((visibility("default")))
#else
  #define OSTPY_API
#endif

#define OSTPY_MSG_SZ 1024  // bytes of a message buffer

typedef struct ostpyPhysics_ {    // one model and its data
  mjModel*   m;
  mjData*    d;
  ostOptions opt;                 // the options steps of d use (model's, then ostpy_setOptions)
  char       err[OSTPY_MSG_SZ];   // message of the last failure ("" if none)
} ostpyPhysics;

// MuJoCo's first error since it was last cleared (write [0] = 0 to clear), recorded per thread by
// the handler that ostpy_init installs.
char* ostpy_mujocoError(void);

// Set buf to msg as one line (at most OSTPY_MSG_SZ) and return status.
int ostpy_fail(char* buf, int status, const char* msg);

#endif  // OSTRICH_PLUGIN_PYTHON_OST_PYTHON_H_
