// ost_batch_internal.h: what the batch's two halves share: the batch itself, a CPU thread's
// share of the worlds, and the helpers of plugin/ost_batch.c (creation, state, forward) used by
// plugin/ost_batch_backward.c (the backward pass).
// Invariant: only ost_batch*.c include this.
#ifndef OSTRICH_PLUGIN_OST_BATCH_INTERNAL_H_
#define OSTRICH_PLUGIN_OST_BATCH_INTERNAL_H_

#include "ost_adjoint_dual.h"
#include "ost_batch.h"
#include "ost_batch_adjoint.h"
#include "ost_internal.h"

#ifdef OSTRICH_HAVE_CUDA
#include "ost_batch_gpu.h"
#endif

#define OST_BATCH_MAX_THREADS 256

// lanes of the cuda batch's forward kernels: GPU threads, each stepping worlds l, l + nlane, ..
#define OST_CUDA_LANES 32768

// most lanes of the cuda batch's backward pass (fewer if the GPU's memory is short)
#define OST_CUDA_ADJOINT_LANES 16384

// GPU threads per record's Jacobian (phase 3b), each in a dual work of the pool (as many works
// as the device holds threads of that kernel), sharing the units of the split passes
// (core/ost_adjoint_jacobian.h, ostx_jacColumnsSplit; each thread also makes the step's values
// once). One: measured on an H100 at 8,192 worlds, 6 threads per world gave 243 world-iterations
// per second in 64.7 GB against 247 in 55.6 GB for one (the extra threads' own step values
// cancel what they share). On the CPU a world's records stay on its thread.
#define OST_CUDA_JAC_THREADS 1

// substeps a backward segment of S steps may record: 2 S + 8 + deep_splits (a step split once
// takes 2, a step split to its bound 8 + deep_splits: core/ost_step.h OST_SPLIT_FREE)
#define OST_RECORDS_PER_STEP 2
#define OST_RECORDS_EXTRA 8

struct ostBatch_ {
  int             cuda;           // 1: worlds live on the GPU
  int             nthread;        // CPU threads (cpu device)
  int             nq, nv, nu, na; // the model's sizes
  ostStepSettings set;            // solver settings from the model's options
  ostOptions      opt;            // the model's options
  ostModel        model;          // packed model (host)
  void*           model_block;    // its allocation
  size_t          model_bytes;    // its size
  ostModel        model_dev;      // the device copy (cuda)
  void*           model_dev_block;
  ostBatchLayout  L;              // world and lane layout
  char*           worlds;         // L.total bytes: host (cpu) or device (cuda)
  char*           lanes;          // L.lane_total bytes, same place
  ostNum*         qpos0;          // the model's qpos0 (nq)
  int             fresh;          // 1: no step since ost_batchSetState
  int             rec_nstep;      // steps of the last rollout from a set state (0: none)
  char*           rec_start;      // its start: a copy of the worlds (host or device)
  ostNum*         rec_ctrl;       // its controls, rec_nstep x nworld x nu (NULL: the worlds')
  int             keep_every;     // rollouts from a set state keep checkpoints this often (0: no)
  int             kept_every;     // the recorded rollout's interval (0: it kept none)
  char*           kept;           // its checkpoints: nseg x L.total bytes (host or device)
  size_t          kept_bytes;     // their allocation
  void*           adj_work;       // dual model for the backward pass (ostd_workCreate; cuda:
                                  // its device copy)
  void*           adj_dev_block;  // cuda: the device dual model's block
  char*           adj_lanes;      // adjoint lanes (host or device)
  size_t          adj_bytes;      // their size
  char*           adj_pool;       // cuda: dual works of the column threads
  int             adj_pool_n;     // their count
  int             nparam;         // entries of theta (ost_nparam)
  int             param_adr[OST_PARAM_ADR]; // its groups' offsets (ost_paramAddress)
  signed char*    param_diff;     // per theta entry: 1 differentiated, 0 not read, -1 not
                                  // differentiated (ost_paramDifferentiable)
  int*            fric_geom;      // the friction map (ost_paramFrictionMap): geoms, then
  mjtNum*         fric_weight;    // weights, 2 per candidate pair (host)
  char*           fric_dev;       // cuda: both on the device (geoms, then weights at an
                                  // 8-byte boundary)
  char            err[1000];      // last failure
};


typedef struct cpuChunk_ {        // one thread's share: worlds [w0, w1) in lane `lane`
  const ostBatch*       b;
  int                   lane;
  int                   w0, w1;
  int                   nstep;
  const ostNum*         ctrl;
  ostNum*               qpos;
  ostNum*               qvel;
  // backward pass only
  const ostAdjointLayout*   A;
  const ostAdjointSettings* as;
  const ostNum*         gq;
  const ostNum*         gu;
  ostNum*               gctrl;
  ostNum*               gtheta;
  ostNum*               gq0;
  ostNum*               gu0;
  ostNum*               act;      // forward: the activations after each step (or NULL)
} cpuChunk;


// record a failure message in the batch and return status
int ost_batchFail(ostBatch* b, int status, const char* msg);

// free host (cpu) or device (cuda) memory of the batch (NULL is ignored)
void ost_batchFreeMem(const ostBatch* b, void* p);

// make *p (host or device, as the batch) hold at least `bytes` zeroed bytes; a larger block is
// kept as it is. *have: its size. Returns OST_OK or OST_ERR_MEMORY (then *p is NULL).
int ost_batchGrow(ostBatch* b, char** p, size_t* have, size_t bytes);

// the parameters' offsets, derivative mask and friction map of the batch's packed model
// (ost_batch_backward.c); OST_OK or OST_ERR_MEMORY
int ost_batchParamsPrepare(ostBatch* b, const mjModel* m);

// fn on every world: nthread threads, contiguous chunks, thread t in lane t
void ost_batchRunChunks(ostBatch* b, void* (*fn)(void*), cpuChunk proto);

#endif  // OSTRICH_PLUGIN_OST_BATCH_INTERNAL_H_
