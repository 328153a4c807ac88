// ost_batch_gpu.h: host launchers of the CUDA batch (cuda/ost_batch.cu, double build, and
// cuda/ost_batch_adjoint.cu, dual numbers), called by plugin/ost_batch.c when Ostrich is built
// with -DOSTRICH_CUDA=ON. The `_gpu` functions have the same meaning as the CPU batch's loops
// over core/ost_batch.h and core/ost_batch_adjoint.h; all pointers named *_dev are device
// memory, everything else is host memory. Each returns 0 or 1 with the CUDA error in err.
// Kernels of one batch run in order on the default stream.
// Invariant: no MuJoCo types cross this boundary, only core's.
#ifndef OSTRICH_CUDA_OST_BATCH_GPU_H_
#define OSTRICH_CUDA_OST_BATCH_GPU_H_

#include <stddef.h>

#include "ost_adjoint.h"
#include "ost_batch.h"

// threads per block of the batch's kernels
#define OST_BLOCK 64

// per-thread stack of every batch kernel, set once (the largest, ost_batch_adjoint.cu's, needs
// 46 KB by ptxas; the device reserves it for each resident thread)
#define OST_STACK_BYTES (48 * 1024)

// run a CUDA call; on failure write file, line and message into err and return 1
#define OST_CUDA_CHECK(expr)                                                              \
  do {                                                                                    \
    cudaError_t e_ = (expr);                                                              \
    if (e_ != cudaSuccess) {                                                              \
      if (err) snprintf(err, err_sz, "%s:%d: %s: %s", __FILE__, __LINE__, #expr,           \
                        cudaGetErrorString(e_));                                          \
      return 1;                                                                           \
    }                                                                                     \
  } while (0)

#ifdef __cplusplus
extern "C" {
#endif

// copy the packed model (block of `bytes`) to the device; *m_dev points into *block_dev
int ost_batchModel_gpu(const ostModel* m, const void* block, size_t bytes, ostModel* m_dev,
                       void** block_dev, char* err, int err_sz);

// allocate `bytes` of zeroed device memory
int ost_batchAlloc_gpu(void** p_dev, size_t bytes, char* err, int err_sz);

// free device memory (NULL is ignored)
void ost_batchFree_gpu(void* p_dev);

// allocate *dev and copy `bytes` of host memory there; copy device memory to the host; copy
// device memory on the device
int ost_batchUpload_gpu(void** dev, const void* host, size_t bytes, char* err, int err_sz);
int ost_batchDownload_gpu(void* host, const void* dev, size_t bytes, char* err, int err_sz);
int ost_batchCopy_gpu(void* dst_dev, const void* src_dev, size_t bytes, char* err, int err_sz);

// copy n bytes of every world's array at `offset` to (to_device = 0) or from (1) the dense host
// array dense (nworld x n bytes)
int ost_batchField_gpu(const ostBatchLayout* L, char* worlds_dev, size_t offset, size_t n,
                       void* dense, int to_device, char* err, int err_sz);

// osti_batchRollout for every world, L->nlane GPU threads; ctrl_dev (device, or NULL), qpos,
// qvel (host, or NULL) as ost_batchRollout; kept_dev (device, or NULL) receives the checkpoints
// every `every` steps
int ost_batchRollout_gpu(const ostModel* m_dev, const ostBatchLayout* L, char* worlds_dev,
                         char* lanes_dev, const ostStepSettings* set, int nstep,
                         const ostNum* ctrl_dev, ostNum* qpos, ostNum* qvel, ostNum* act,
                         char* kept_dev, int every, char* err, int err_sz);

// the backward pass's phases 1, 2 and 4 (core/ost_batch_adjoint.h) for worlds [w0, w0 +
// A->nlane), one GPU thread each; the last one waits for the device
int ost_adjointForward_gpu(const ostModel* m_dev, const ostBatchLayout* L,
                           const ostAdjointLayout* A, const char* start_dev, char* lanes_dev,
                           int w0, const ostStepSettings* set, int T, const ostNum* ctrl_dev,
                           const double* gq_dev, const double* gu_dev, char* err, int err_sz);
int ost_adjointReplay_gpu(const ostModel* m_dev, const ostBatchLayout* L,
                          const ostAdjointLayout* A, char* lanes_dev, int w0,
                          const ostStepSettings* set, int T, int k, const ostNum* ctrl_dev,
                          const char* kept_dev, char* err, int err_sz);
int ost_adjointFinish_gpu(const ostBatchLayout* L, const ostAdjointLayout* A, char* lanes_dev,
                          char* worlds_dev, int w0, int T, const double* gq_dev,
                          const double* gu_dev, double* gctrl_dev, double* gtheta_dev,
                          double* gq0_dev, double* gu0_dev, char* err, int err_sz);

// the dual-number model of the packed double model `model` (an ostModel) on the device, in one allocation
// *dual_dev (the struct first, then its arrays)
int ost_adjointModel_gpu(const void* model, void** dual_dev, char* err, int err_sz);

// bytes of one dual work of the GPU's dual build (ostx_jacWorkSize with ostDual<OSTX_CHUNK>)
size_t ost_adjointJacSize_gpu(const void* model, int nrow_max);

// threads of the column kernel (phase 3b) the device holds at once: the size of its pool of
// dual works (0 if the query fails)
int ost_adjointColumnSlots_gpu(void);

// phases 3a and 3b (ostx_recordStructure, then ostx_recordColumns over A->njac threads per lane,
// in launches of at most pool_n threads, each with its dual work of pool_dev) for worlds
// [w0, w0 + A->nlane): record j from the end of each world's segment
int ost_adjointRecord_gpu(void* dual_dev, const ostAdjointLayout* A, char* lanes_dev, int w0,
                          int nworld, int j, const ostAdjointSettings* as, const double* gq_dev,
                          const double* gu_dev, char* pool_dev, int pool_n, char* err,
                          int err_sz);

// phase 3c (osti_recordSolve) for the same worlds and record (gtheta_dev: NULL without
// parameter gradients)
int ost_recordSolve_gpu(const ostAdjointLayout* A, char* lanes_dev, int w0, int nworld, int j,
                        double* gctrl_dev, double* gtheta_dev, char* err, int err_sz);

// free and total device memory (bytes)
int ost_batchMemInfo_gpu(size_t* free_bytes, size_t* total_bytes);

#ifdef __cplusplus
}
#endif

#endif  // OSTRICH_CUDA_OST_BATCH_GPU_H_
