// ost_batch.cu: CUDA kernels and host launchers of the batch in the double build (declared in
// ost_batch_gpu.h; the dual-number kernel of the backward pass is ost_batch_adjoint.cu).
// Kernels are thin wrappers of core's per-world functions, the CPU batch's oracle, on the same
// layout: GPU thread l is lane l, stepping worlds l, l + nlane, .. (core/ost_batch.h), or in the
// backward pass world w0 + l of a wave (core/ost_batch_adjoint.h). Launchers check every CUDA
// call (OST_CUDA_CHECK) and return its message instead of exiting.
// Invariant: a thread reads the model and writes only its worlds' slices, its lane and its
// worlds' output rows; nothing is reduced across worlds, so results do not depend on scheduling.
#include <stdio.h>

#include <cuda_runtime.h>

#include "ost_batch_adjoint.h"
#include "ost_batch_gpu.h"

// blocks of OST_BLOCK threads for n threads
static int blocks(int n) {
  return (n + OST_BLOCK - 1) / OST_BLOCK;
}


__global__ void ost_batchRollout_kernel(ostModel m, ostBatchLayout L, char* worlds, char* lanes,
                                        ostStepSettings set, int nstep, const ostNum* ctrl,
                                        ostNum* qpos, ostNum* qvel, ostNum* act, char* kept,
                                        int every) {
  int l = blockIdx.x * blockDim.x + threadIdx.x;
  if (l >= L.nlane) {
    return;  // guard first
  }
  for (int i = l; i < L.nworld; i += L.nlane) {
    osti_batchRollout(&m, &L, worlds, lanes, i, l, &set, nstep, ctrl, qpos, qvel, act, kept,
                      every);
  }
}


__global__ void ost_adjointForward_kernel(ostModel m, ostBatchLayout L, ostAdjointLayout A,
                                          const char* start, char* lanes, int w0,
                                          ostStepSettings set, int T, const ostNum* ctrl,
                                          const double* gq, const double* gu) {
  int l = blockIdx.x * blockDim.x + threadIdx.x, i = w0 + l;
  if (l >= A.nlane || i >= L.nworld) {
    return;
  }
  osti_adjointForward(&m, &L, &A, start + (size_t)i * L.stride, lanes, l, i, &set, T, ctrl, gq,
                      gu);
}


__global__ void ost_adjointReplay_kernel(ostModel m, ostBatchLayout L, ostAdjointLayout A,
                                         char* lanes, int w0, ostStepSettings set, int T, int k,
                                         const ostNum* ctrl, const char* kept) {
  int l = blockIdx.x * blockDim.x + threadIdx.x, i = w0 + l;
  if (l >= A.nlane || i >= L.nworld) {
    return;
  }
  osti_adjointReplay(&m, &L, &A, lanes, l, i, &set, T, k, ctrl, kept);
}


__global__ void ost_adjointFinish_kernel(ostBatchLayout L, ostAdjointLayout A, char* lanes,
                                         char* worlds, int w0, int T, const double* gq,
                                         const double* gu, double* gctrl, double* gtheta,
                                         double* gq0, double* gu0) {
  int l = blockIdx.x * blockDim.x + threadIdx.x, i = w0 + l;
  if (l >= A.nlane || i >= L.nworld) {
    return;
  }
  ostBatchView v;
  ostu_batchView(&v, &L, worlds + (size_t)i * L.stride);
  osti_adjointFinish(&A, lanes, l, i, L.nworld, T, gq, gu, gctrl, gtheta, gq0, gu0, v.status);
}


__global__ void ost_recordSolve_kernel(ostAdjointLayout A, char* lanes, int w0, int nworld,
                                       int j, double* gctrl, double* gtheta) {
  int l = blockIdx.x * blockDim.x + threadIdx.x, i = w0 + l;
  if (l >= A.nlane || i >= nworld) {
    return;
  }
  osti_recordSolve(&A, lanes, l, i, nworld, j, gctrl, gtheta);
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
  OST_CUDA_CHECK(cudaDeviceSetLimit(cudaLimitStackSize, OST_STACK_BYTES));  // once, for all kernels
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
    ost_batchField_kernel<<<blocks(L->nworld), OST_BLOCK>>>(
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


extern "C" int ost_batchUpload_gpu(void** dev, const void* host, size_t bytes, char* err,
                                   int err_sz) {
  *dev = NULL;
  OST_CUDA_CHECK(cudaMalloc(dev, bytes));
  OST_CUDA_CHECK(cudaMemcpy(*dev, host, bytes, cudaMemcpyHostToDevice));
  return 0;
}


extern "C" int ost_batchDownload_gpu(void* host, const void* dev, size_t bytes, char* err,
                                     int err_sz) {
  OST_CUDA_CHECK(cudaMemcpy(host, dev, bytes, cudaMemcpyDeviceToHost));
  return 0;
}


extern "C" int ost_batchCopy_gpu(void* dst_dev, const void* src_dev, size_t bytes, char* err,
                                 int err_sz) {
  OST_CUDA_CHECK(cudaMemcpy(dst_dev, src_dev, bytes, cudaMemcpyDeviceToDevice));
  return 0;
}


extern "C" int ost_batchRollout_gpu(const ostModel* m_dev, const ostBatchLayout* L,
                                    char* worlds_dev, char* lanes_dev, const ostStepSettings* set,
                                    int nstep, const ostNum* ctrl_dev, ostNum* qpos, ostNum* qvel,
                                    ostNum* act, char* kept_dev, int every, char* err,
                                    int err_sz) {
  size_t nw = (size_t)L->nworld, T = (size_t)nstep;
  ostNum *qpos_dev = NULL, *qvel_dev = NULL, *act_dev = NULL;
  int bad = 0;
  act = L->s.na > 0 ? act : NULL;
  if (qpos) {
    bad = cudaMalloc(&qpos_dev, T * nw * L->s.nq * sizeof(ostNum)) != cudaSuccess;
  }
  if (!bad && qvel) {
    bad = cudaMalloc(&qvel_dev, T * nw * L->s.nv * sizeof(ostNum)) != cudaSuccess;
  }
  if (!bad && act) {
    bad = cudaMalloc(&act_dev, T * nw * L->s.na * sizeof(ostNum)) != cudaSuccess;
  }
  if (!bad) {
    ost_batchRollout_kernel<<<blocks(L->nlane), OST_BLOCK>>>(*m_dev, *L, worlds_dev, lanes_dev,
                                                             *set, nstep, ctrl_dev, qpos_dev,
                                                             qvel_dev, act_dev, kept_dev, every);
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
  if (!bad && act) {
    bad = cudaMemcpy(act, act_dev, T * nw * L->s.na * sizeof(ostNum), cudaMemcpyDeviceToHost)
          != cudaSuccess;
  }
  cudaError_t e = cudaGetLastError();
  cudaFree(qpos_dev);
  cudaFree(qvel_dev);
  cudaFree(act_dev);
  OST_CUDA_CHECK(bad ? (e != cudaSuccess ? e : cudaErrorUnknown) : cudaSuccess);
  return 0;
}


extern "C" int ost_adjointForward_gpu(const ostModel* m_dev, const ostBatchLayout* L,
                                      const ostAdjointLayout* A, const char* start_dev,
                                      char* lanes_dev, int w0, const ostStepSettings* set, int T,
                                      const ostNum* ctrl_dev, const double* gq_dev,
                                      const double* gu_dev, char* err, int err_sz) {
  ost_adjointForward_kernel<<<blocks(A->nlane), OST_BLOCK>>>(*m_dev, *L, *A, start_dev, lanes_dev,
                                                             w0, *set, T, ctrl_dev, gq_dev,
                                                             gu_dev);
  OST_CUDA_CHECK(cudaGetLastError());
  return 0;
}


extern "C" int ost_adjointReplay_gpu(const ostModel* m_dev, const ostBatchLayout* L,
                                     const ostAdjointLayout* A, char* lanes_dev, int w0,
                                     const ostStepSettings* set, int T, int k,
                                     const ostNum* ctrl_dev, const char* kept_dev, char* err,
                                     int err_sz) {
  ost_adjointReplay_kernel<<<blocks(A->nlane), OST_BLOCK>>>(*m_dev, *L, *A, lanes_dev, w0, *set,
                                                            T, k, ctrl_dev, kept_dev);
  OST_CUDA_CHECK(cudaGetLastError());
  return 0;
}


extern "C" int ost_recordSolve_gpu(const ostAdjointLayout* A, char* lanes_dev, int w0,
                                   int nworld, int j, double* gctrl_dev, double* gtheta_dev,
                                   char* err, int err_sz) {
  ost_recordSolve_kernel<<<blocks(A->nlane), OST_BLOCK>>>(*A, lanes_dev, w0, nworld, j,
                                                          gctrl_dev, gtheta_dev);
  OST_CUDA_CHECK(cudaGetLastError());
  return 0;
}


extern "C" int ost_adjointFinish_gpu(const ostBatchLayout* L, const ostAdjointLayout* A,
                                     char* lanes_dev, char* worlds_dev, int w0, int T,
                                     const double* gq_dev, const double* gu_dev,
                                     double* gctrl_dev, double* gtheta_dev, double* gq0_dev,
                                     double* gu0_dev, char* err, int err_sz) {
  ost_adjointFinish_kernel<<<blocks(A->nlane), OST_BLOCK>>>(*L, *A, lanes_dev, worlds_dev, w0, T,
                                                            gq_dev, gu_dev, gctrl_dev, gtheta_dev,
                                                            gq0_dev, gu0_dev);
  OST_CUDA_CHECK(cudaGetLastError());
  OST_CUDA_CHECK(cudaDeviceSynchronize());
  return 0;
}


extern "C" int ost_batchMemInfo_gpu(size_t* free_bytes, size_t* total_bytes) {
  return cudaMemGetInfo(free_bytes, total_bytes) != cudaSuccess;
}
