// ost_batch.cu: CUDA kernels and host launchers of the batch (declared in ost_batch_gpu.h).
// Kernels are thin wrappers of core's per-world functions: a thread per world runs
// osti_batchRollout, the CPU batch's oracle, on the same layout (core/ost_batch.h). Launchers
// check every CUDA call (OST_CUDA_CHECK) and return its message instead of exiting.
// Invariant: thread i reads the model and writes only world i's slice and its output rows;
// nothing is reduced across worlds, so results do not depend on scheduling.
#include <stdio.h>

#include <cuda_runtime.h>

#include "ost_batch_gpu.h"

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

// threads per block of the world kernels
#define OST_BLOCK 64

// per-thread stack of the rollout kernel (collision and Newton locals; measured by ptxas)
#define OST_STACK_BYTES (32 * 1024)


__global__ void ost_batchRollout_kernel(ostModel m, ostBatchLayout L, char* worlds,
                                        ostStepSettings set, int nstep, const ostNum* ctrl,
                                        ostNum* qpos, ostNum* qvel) {
  int i = blockIdx.x * blockDim.x + threadIdx.x;
  if (i >= L.nworld) {
    return;  // guard first
  }
  osti_batchRollout(&m, &L, worlds, i, &set, nstep, ctrl, qpos, qvel);
}


__global__ void ost_batchField_kernel(ostBatchLayout L, char* worlds, size_t offset, size_t n,
                                      char* dense, int to_worlds) {
  int i = blockIdx.x * blockDim.x + threadIdx.x;
  if (i >= L.nworld) {
    return;
  }
  char* w = worlds + (size_t)i * L.stride + offset;
  char* x = dense + (size_t)i * n;
  for (size_t k = 0; k < n; k++) {
    if (to_worlds) {
      w[k] = x[k];
    } else {
      x[k] = w[k];
    }
  }
}


extern "C" int ost_batchModel_gpu(const ostModel* m, const void* block, size_t bytes,
                                  ostModel* m_dev, void** block_dev, char* err, int err_sz) {
  OST_CUDA_CHECK(cudaMalloc(block_dev, bytes));
  OST_CUDA_CHECK(cudaMemcpy(*block_dev, block, bytes, cudaMemcpyHostToDevice));
  *m_dev = *m;
  ostu_modelInit(m_dev, *block_dev);  // pointer arithmetic only: valid for a device base
  return 0;
}


extern "C" int ost_batchAlloc_gpu(void** p_dev, size_t bytes, char* err, int err_sz) {
  OST_CUDA_CHECK(cudaMalloc(p_dev, bytes));
  OST_CUDA_CHECK(cudaMemset(*p_dev, 0, bytes));
  return 0;
}


extern "C" void ost_batchFree_gpu(void* p_dev) {
  if (p_dev) {
    cudaFree(p_dev);
  }
}


extern "C" int ost_batchField_gpu(const ostBatchLayout* L, char* worlds_dev, size_t offset,
                                  size_t n, void* dense, int to_device, char* err, int err_sz) {
  size_t bytes = n * (size_t)L->nworld;
  char* stage;
  OST_CUDA_CHECK(cudaMalloc(&stage, bytes));
  int bad = 0;
  if (to_device) {
    bad = cudaMemcpy(stage, dense, bytes, cudaMemcpyHostToDevice) != cudaSuccess;
  }
  if (!bad) {
    ost_batchField_kernel<<<(L->nworld + OST_BLOCK - 1) / OST_BLOCK, OST_BLOCK>>>(
        *L, worlds_dev, offset, n, stage, to_device);
    bad = cudaGetLastError() != cudaSuccess || cudaDeviceSynchronize() != cudaSuccess;
  }
  if (!bad && !to_device) {
    bad = cudaMemcpy(dense, stage, bytes, cudaMemcpyDeviceToHost) != cudaSuccess;
  }
  cudaError_t e = cudaGetLastError();
  cudaFree(stage);
  OST_CUDA_CHECK(bad ? (e != cudaSuccess ? e : cudaErrorUnknown) : cudaSuccess);
  return 0;
}


// a device copy of a host array of n numbers (NULL stays NULL)
static int upload(ostNum** dev, const ostNum* host, size_t n, char* err, int err_sz) {
  *dev = NULL;
  if (!host || n == 0) {
    return 0;
  }
  OST_CUDA_CHECK(cudaMalloc(dev, n * sizeof(ostNum)));
  OST_CUDA_CHECK(cudaMemcpy(*dev, host, n * sizeof(ostNum), cudaMemcpyHostToDevice));
  return 0;
}


extern "C" int ost_batchRollout_gpu(const ostModel* m_dev, const ostBatchLayout* L,
                                    char* worlds_dev, const ostStepSettings* set, int nstep,
                                    const ostNum* ctrl, ostNum* qpos, ostNum* qvel, char* err,
                                    int err_sz) {
  size_t nw = (size_t)L->nworld, T = (size_t)nstep;
  ostNum *ctrl_dev = NULL, *qpos_dev = NULL, *qvel_dev = NULL;
  int bad = upload(&ctrl_dev, ctrl, T * nw * L->s.nu, err, err_sz);
  if (!bad && qpos) {
    bad = cudaMalloc(&qpos_dev, T * nw * L->s.nq * sizeof(ostNum)) != cudaSuccess;
  }
  if (!bad && qvel) {
    bad = cudaMalloc(&qvel_dev, T * nw * L->s.nv * sizeof(ostNum)) != cudaSuccess;
  }
  if (!bad) {
    bad = cudaDeviceSetLimit(cudaLimitStackSize, OST_STACK_BYTES) != cudaSuccess;
  }
  if (!bad) {
    ost_batchRollout_kernel<<<(L->nworld + OST_BLOCK - 1) / OST_BLOCK, OST_BLOCK>>>(
        *m_dev, *L, worlds_dev, *set, nstep, ctrl_dev, qpos_dev, qvel_dev);
    bad = cudaGetLastError() != cudaSuccess || cudaDeviceSynchronize() != cudaSuccess;
  }
  if (!bad && qpos) {
    bad = cudaMemcpy(qpos, qpos_dev, T * nw * L->s.nq * sizeof(ostNum), cudaMemcpyDeviceToHost)
          != cudaSuccess;
  }
  if (!bad && qvel) {
    bad = cudaMemcpy(qvel, qvel_dev, T * nw * L->s.nv * sizeof(ostNum), cudaMemcpyDeviceToHost)
          != cudaSuccess;
  }
  cudaError_t e = cudaGetLastError();
  cudaFree(ctrl_dev);
  cudaFree(qpos_dev);
  cudaFree(qvel_dev);
  OST_CUDA_CHECK(bad ? (e != cudaSuccess ? e : cudaErrorUnknown) : cudaSuccess);
  return 0;
}


extern "C" int ost_batchMemInfo_gpu(size_t* free_bytes, size_t* total_bytes) {
  return cudaMemGetInfo(free_bytes, total_bytes) != cudaSuccess;
}
