// ost_batch_gpu.h: host launchers of the CUDA batch (cuda/ost_batch.cu), called by
// plugin/ost_batch.c when Ostrich is built with -DOSTRICH_CUDA=ON. The `_gpu` functions have
// the same meaning as the CPU batch's loops over core/ost_batch.h; all pointers named *_dev are
// device memory, everything else is host memory. Each returns 0 or 1 with the CUDA error in err.
// Invariant: no MuJoCo types cross this boundary, only core's.
#ifndef OSTRICH_CUDA_OST_BATCH_GPU_H_
#define OSTRICH_CUDA_OST_BATCH_GPU_H_

#include <stddef.h>

#include "ost_batch.h"

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

// copy n bytes of every world's array at `offset` to (to_device = 0) or from (1) the dense host
// array dense (nworld x n bytes)
int ost_batchField_gpu(const ostBatchLayout* L, char* worlds_dev, size_t offset, size_t n,
                       void* dense, int to_device, char* err, int err_sz);

// osti_batchRollout for every world, one thread each; ctrl, qpos, qvel as ost_batchRollout
int ost_batchRollout_gpu(const ostModel* m_dev, const ostBatchLayout* L, char* worlds_dev,
                         const ostStepSettings* set, int nstep, const ostNum* ctrl,
                         ostNum* qpos, ostNum* qvel, char* err, int err_sz);

// free and total device memory (bytes)
int ost_batchMemInfo_gpu(size_t* free_bytes, size_t* total_bytes);

#ifdef __cplusplus
}
#endif

#endif  // OSTRICH_CUDA_OST_BATCH_GPU_H_
