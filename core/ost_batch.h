// ost_batch.h: the memory layout of a batch of worlds of one model and the per-world rollout
// that the CPU batch (plugin/ost_batch.c, threads) and the CUDA batch (cuda/ost_batch.cu) both
// run. Mirrors engine_io.c (mj_makeData's one allocation) and MuJoCo Warp's leading world
// dimension.
// Layout contract: a world is only what persists between steps (state, controls, outcome, the
// warm start: OST_BATCH_ARRAYS); what a step works in (kinematics, contacts, Newton's arrays:
// OST_LANE_ARRAYS) belongs to a lane, and a lane steps one world at a time. Worlds and lanes are
// each one 64-byte-aligned allocation, i * stride apart; within one, every array sits at its own
// 64-byte-aligned offset. The tables are the only description of the layout: they drive the
// sizes, the pointer setup and the host<->device copies of states and controls.
// Invariant: the code stepping world i reads the model and writes only world i's slice and its
// lane's.
#ifndef OSTRICH_CORE_OST_BATCH_H_
#define OSTRICH_CORE_OST_BATCH_H_

#include <stddef.h>

#include "ost_hd.h"
#include "ost_model.h"
#include "ost_solver.h"
#include "ost_step.h"

#ifdef __cplusplus
extern "C" {
#endif

// one world's slice (type, name, count); sizes from an ostSizes s and the row capacity nrow_max
#define OST_BATCH_ARRAYS(X)                                                                     \
  X(ostNum, qpos,        s.nq)                        /* generalized coordinates            */ \
  X(ostNum, qvel,        s.nv)                        /* generalized velocities             */ \
  X(ostNum, act,         s.na)                        /* actuator activations               */ \
  X(ostNum, ctrl,        s.nu)                        /* controls of the next step          */ \
  X(ostNum, qacc_warm,   s.nv)                        /* last step's (u+ - u-) / h          */ \
  X(ostNum, time,        1)                           /* simulated time (s)                 */ \
  X(ostNum, residual,    1)                           /* last step's largest best merit     */ \
  X(int,    status,      1)                           /* last step's OST_STEP_* bits        */ \
  X(int,    warm,        1)                           /* 1: rows_warm belong to this state  */ \
  X(int,    nrow_warm,   1)                           /* rows of the last result            */ \
  X(int,    substeps,    1)                           /* last step's substeps               */ \
  X(int,    unconverged, 1)                           /* steps NOT_CONVERGED since set      */ \
  X(ostRow, rows_warm,   nrow_max)                    /* rows of the last result            */ \
  X(ostNum, lambda_warm, nrow_max)                    /* their multipliers                  */

// one lane's work arrays
#define OST_LANE_ARRAYS(X)                                                                      \
  X(ostNum, scratch,   OST_STEP_SCRATCH(s))           /* osti_stepNative's scratch          */ \
  X(char,   kin,       ostu_kinSize(s))               /* kinematics and contacts (ostKin)   */ \
  X(char,   world,     ostu_worldSize(s.nv, s.ncol, nrow_max)) /* Newton's arrays (ostWorld)         */

typedef struct ostBatchLayout_ {  // where each array of a world and of a lane sits
  ostSizes s;                     // the model's sizes
  int    nrow_max;                // row capacity of a world
  int    nworld;                  // worlds
  int    nlane;                   // lanes
  int    pad;
  size_t stride;                  // bytes from one world to the next (64-byte multiple)
  size_t total;                   // bytes of all worlds (nworld x stride)
  size_t lane_stride;             // bytes from one lane to the next (64-byte multiple)
  size_t lane_total;              // bytes of all lanes (nlane x lane_stride)
#define X(type, name, n) size_t name;  // offset of the array within a world or lane (bytes)
  OST_BATCH_ARRAYS(X)
  OST_LANE_ARRAYS(X)
#undef X
} ostBatchLayout;

typedef struct ostBatchView_ {    // world i's arrays
#define X(type, name, n) type* name;
  OST_BATCH_ARRAYS(X)
#undef X
} ostBatchView;

typedef struct ostLaneView_ {     // lane l's arrays
#define X(type, name, n) type* name;
  OST_LANE_ARRAYS(X)
#undef X
} ostLaneView;


// the layout of nworld worlds and nlane lanes of a model with sizes s, row capacity nrow_max
OST_HD void ostu_batchLayout(ostBatchLayout* L, ostSizes s, int nrow_max, int nworld, int nlane) {
  L->s = s;
  L->nrow_max = nrow_max;
  L->nworld = nworld;
  L->nlane = nlane;
  L->pad = 0;
  size_t off = 0;
#define X(type, name, n)                                     \
  L->name = off;                                             \
  off += OST_ALIGN64((size_t)(n) * sizeof(type));
  OST_BATCH_ARRAYS(X)
  L->stride = off;
  off = 0;
  OST_LANE_ARRAYS(X)
#undef X
  L->lane_stride = off;
  L->total = L->stride * (size_t)nworld;
  L->lane_total = L->lane_stride * (size_t)nlane;
}


// the arrays of the world slice at p
OST_HD void ostu_batchView(ostBatchView* v, const ostBatchLayout* L, char* p) {
#define X(type, name, n) v->name = (type*)(p + L->name);
  OST_BATCH_ARRAYS(X)
#undef X
}


// the arrays of the lane slice at p
OST_HD void ostu_laneView(ostLaneView* v, const ostBatchLayout* L, char* p) {
#define X(type, name, n) v->name = (type*)(p + L->name);
  OST_LANE_ARRAYS(X)
#undef X
}


// copy n bytes (a multiple of 8, both 8-byte aligned: whole world or lane slices) word by word
OST_HD void ostu_copyWords(char* dst, const char* src, size_t n) {
  unsigned long long* d = (unsigned long long*)dst;
  const unsigned long long* s = (const unsigned long long*)src;
  for (size_t k = 0; k < n / 8; k++) d[k] = s[k];
}


// 1 if the n numbers are finite
OST_HD int osti_allFinite(const ostNum* x, int n) {
  for (int i = 0; i < n; i++) {
    if (!isfinite(x[i])) {
      return 0;
    }
  }
  return 1;
}


// steps [t0, t1) of the world slice `world` (world i of nworld), working in the lane slice
// `lane`. Sequences are step-major, world-minor (T x nworld x n): before step t the world's
// controls are ctrl_seq[(t nworld + i) nu ..] (NULL: keep the world's ctrl); after step t its
// qpos and qvel go to qpos_out[(t nworld + i) nq ..] and qvel_out[(t nworld + i) nv ..] (NULL:
// not kept), and its act to act_out[(t nworld + i) na ..] (NULL: not kept). A world whose
// status has a failure bit is not stepped (its outputs repeat its state) until its state is set
// again; a step with non-finite state or controls is not taken and sets OST_STEP_NAN. sink (or
// NULL) records the committed substeps.
OST_HD void osti_worldRollout(const ostModel* m, const ostBatchLayout* L, char* world, char* lane,
                              int i, const ostStepSettings* set, int t0, int t1,
                              const ostNum* ctrl_seq, ostNum* qpos_out, ostNum* qvel_out,
                              ostNum* act_out, ostRecordSink* sink) {
  ostSizes s = L->s;
  size_t nw = (size_t)L->nworld;
  ostBatchView v;
  ostLaneView lv;
  ostKin k;
  ostWorld w;
  ostu_batchView(&v, L, world);
  ostu_laneView(&lv, L, lane);
  ostu_kinInit(&k, lv.kin, s);
  ostu_worldInit(&w, lv.world, s.nv, s.ncol, L->nrow_max, set->h);
  w.rows_warm = v.rows_warm;  // the warm start persists with the world, not the lane
  w.lambda_warm = v.lambda_warm;
  w.nrow_warm = *v.nrow_warm;
  for (int t = t0; t < t1; t++) {
    if (ctrl_seq) {
      for (int a = 0; a < s.nu; a++) v.ctrl[a] = ctrl_seq[(t * nw + i) * s.nu + a];
    }
    if (!(*v.status & OST_STEP_FAILED)) {
      if (!osti_allFinite(v.qpos, s.nq) || !osti_allFinite(v.qvel, s.nv)
          || !osti_allFinite(v.act, s.na) || !osti_allFinite(v.ctrl, s.nu)) {
        *v.status = OST_STEP_NAN;
      } else {
        if (sink) {
          sink->step = t;
        }
        *v.status = osti_stepNative(m, &k, &w, v.qpos, v.qvel, v.act, v.ctrl, v.qacc_warm,
                                    v.warm, lv.scratch, set, v.substeps, v.residual, sink);
        if (!(*v.status & OST_STEP_FAILED)) {
          *v.time += set->h;
        }
        *v.unconverged += (*v.status & OST_STEP_NOT_CONVERGED) != 0;
      }
    }
    if (qpos_out) {
      for (int a = 0; a < s.nq; a++) qpos_out[(t * nw + i) * s.nq + a] = v.qpos[a];
    }
    if (qvel_out) {
      for (int a = 0; a < s.nv; a++) qvel_out[(t * nw + i) * s.nv + a] = v.qvel[a];
    }
    if (act_out) {
      for (int a = 0; a < s.na; a++) act_out[(t * nw + i) * s.na + a] = v.act[a];
    }
  }
  *v.nrow_warm = w.nrow_warm;
}


// T steps of world i of the batch, in lane l (osti_worldRollout from step 0). kept (or NULL):
// world i's slice is copied to kept + (k nworld + i) stride at each step k `every` (k = 0, 1, ..
// while k every < T), the checkpoints of a backward pass (core/ost_batch_adjoint.h)
OST_HD void osti_batchRollout(const ostModel* m, const ostBatchLayout* L, char* worlds,
                              char* lanes, int i, int l, const ostStepSettings* set, int T,
                              const ostNum* ctrl_seq, ostNum* qpos_out, ostNum* qvel_out,
                              ostNum* act_out, char* kept, int every) {
  char* world = worlds + (size_t)i * L->stride;
  char* lane = lanes + (size_t)l * L->lane_stride;
  int seg = kept && every > 0 ? every : T;
  for (int k = 0; k * seg < T; k++) {
    if (kept) {
      ostu_copyWords(kept + ((size_t)k * L->nworld + i) * L->stride, world, L->stride);
    }
    int t1 = (k + 1) * seg < T ? (k + 1) * seg : T;
    osti_worldRollout(m, L, world, lane, i, set, k * seg, t1, ctrl_seq, qpos_out, qvel_out,
                      act_out, NULL);
  }
}

#ifdef __cplusplus
}
#endif

#endif  // OSTRICH_CORE_OST_BATCH_H_
