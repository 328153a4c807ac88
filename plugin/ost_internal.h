// ost_internal.h: Ostrich's per-mjData context, shared by the plugin/ files (not public).
// A context holds what Ostrich keeps beside an mjData: options, statistics, the last error, a
// private model copy with look-ahead margins, and the one allocation of the core world.
// Invariant: a context belongs to exactly one (mjData, d->buffer, mjModel) triple; if any of
// them changes the context is rebuilt.
#ifndef OSTRICH_PLUGIN_OST_INTERNAL_H_
#define OSTRICH_PLUGIN_OST_INTERNAL_H_

#include <mujoco/mujoco.h>

#include "ost_model.h"
#include "ost_solver.h"
#include "ostrich.h"

typedef struct ostContext_ {
  const mjData*  d;               // the mjData this context serves
  const void*    d_buffer;        // d->buffer when created (detects pointer reuse)
  const mjModel* m;               // the user's model
  mjModel*       mo;              // private copy of m with margins widened by opt.margin
  ostOptions     opt;             // options in use
  int            opt_user;        // 1 if set by ost_setOptions (not re-read from the model)
  ostStats       stats;           // statistics of the last step
  char           err[512];        // message of the last failure
  int*           servo;           // 1 if actuator i is an implicit servo row     (nu)
  mjtNum*        qpos_prev;       // q- of the current step                        (nq)
  mjtNum*        state_start;     // state at ost_step2 entry          (1 + nq + 2 nv)
  mjtNum*        state_end;       // state after the last step         (1 + nq + 2 nv)
  int            warm_valid;      // 1 if state_end and the world's warm rows are valid
  mjtNum*        jac;             // contact Jacobian scratch                      (6 x nv)
  void*          world_buf;       // the core world's single allocation
  ostModel       native;          // native provider: packed model (geometry option 1)
  void*          native_block;    // its single allocation
  void*          native_key;      // copy of the user's m->buffer when packed (change detection)
  size_t         native_key_sz;   // its size in bytes
  mjOption       native_opt;      // the user's m->opt when packed
  int            native_nconmax;  // the user's m->nconmax when packed
  double         native_margin;   // the look-ahead margin when packed
  void*          kin_buf;         // its kinematics' single allocation
  ostKin         kin;             // native kinematics, pointers into kin_buf
  ostWorld       world;           // core solver state, pointers into world_buf
  struct ostContext_* next;       // registry list
} ostContext;

// find or create the context of (m, d); NULL only if allocation fails
ostContext* ost_context(const mjModel* m, const mjData* d);

// look up the context of d without creating one
ostContext* ost_findContext(const mjData* d);

// record a failure message on the context and return status
int ost_fail(ostContext* c, int status, const char* fmt, ...);

// fill the world's rows and Jacobians at the configuration in d->qpos using MuJoCo's own
// kinematics and collision on the private model (the `mujoco` geometry provider)
int ost_rowsMujoco(ostContext* c, mjData* d, mjtNum h);

// the `native` provider's rows at the configuration in d->qpos (core/ost_rows_native.h)
int ost_rowsNative(ostContext* c, mjData* d, mjtNum h);

// the `native` provider's start of a step at d's (q-, u-): Mt and f into the world
void ost_startNative(ostContext* c, const mjData* d, mjtNum h);

// matching key of a contact: its position in the frame of a moving body of the pair (geom2's
// body unless that is the world), so that contacts keep their keys while the bodies move
void ost_contactKey(const mjModel* m, const mjData* d, const mjContact* con, mjtNum key[3]);

// pack m into om (arrays in *block, 64-byte aligned, caller frees) with a contact capacity
int ost_packModel(const mjModel* m, int ncon_max, ostModel* om, void** block, char* err,
                  int err_sz);

// classify actuator i: 1 implicit servo, 0 explicit force, -1 unsupported (message in err)
int ost_actuatorKind(const mjModel* m, int i, char* err, int err_sz);

#endif  // OSTRICH_PLUGIN_OST_INTERNAL_H_
