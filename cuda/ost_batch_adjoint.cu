// ost_batch_adjoint.cu: the dual-number half of the CUDA batch's backward pass (declared in
// ost_batch_gpu.h): core/ compiled with ostNum = ostDual<OSTX_CHUNK>, as plugin/ost_adjoint_dual.cc
// is for the CPU, and a kernel of GPU thread per world running core/ost_adjoint_jacobian.h's
// phases 3a and 3b of the backward pass (core/ost_adjoint_jacobian.h): a record's structure
// pass, one thread per world, then the units of its split passes spread over A->njac threads
// per world, so that a few thousand worlds still fill the GPU. The double half (replay,
// checkpoints, records, the assembly and solve of phase 3c) is ost_batch.cu.
// Invariant: a thread reads the shared dual model and writes only its lane (3b: its own dual
// work and its units' columns of the lane's G, Rq and T); parameters are seeded in the work's
// own copy of them (ostx_jacOwnParams), so the shared model is never written.
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <cuda_runtime.h>

#include "ost_dual.h"

// directions of one dual pass: 4 (measured on an H100 at 8,192 worlds of the robot, the
// backward pass took 25.2 s with 4 and 24.7 s with 2, the CPU's width; 8 would need a 76 KB
// stack, over OST_STACK_BYTES); the derivatives do not depend on it (each direction is computed
// on its own), so the gradients equal the CPU's bit for bit
#define OSTX_CHUNK 4
#define OST_NUM_TYPE ostDual<OSTX_CHUNK>

#include "ost_adjoint_jacobian.h"
#include "ost_batch_gpu.h"

__global__ void ost_recordStructure_kernel(ostModel* m, ostAdjointLayout A, char* lanes, int w0,
                                           int nworld, int j, ostAdjointSettings as,
                                           const double* gq, const double* gu) {
  int l = blockIdx.x * blockDim.x + threadIdx.x, i = w0 + l;
  if (l >= A.nlane || i >= nworld) {
    return;
  }
  ostx_recordStructure(m, &A, lanes, l, i, nworld, j, &as, gq, gu);
}


// thread x is column thread x % njac of lane l0 + x / njac, in dual work x of the pool: a warp
// holds few worlds, which evaluate the same record geometry with different seeds
__global__ void ost_recordColumns_kernel(ostModel* m, ostAdjointLayout A, char* lanes, int w0,
                                         int nworld, int j, ostAdjointSettings as, int l0,
                                         int nl, char* pool) {
  int x = blockIdx.x * blockDim.x + threadIdx.x;
  int l = l0 + x / A.njac, t = x % A.njac;
  if (x >= nl * A.njac || l >= A.nlane || w0 + l >= nworld) {
    return;
  }
  ostx_recordColumns(m, &A, lanes, l, t, j, &as, pool + (size_t)x * A.jac_size);
}


extern "C" int ost_adjointModel_gpu(const void* model, void** dual_dev, char* err, int err_sz) {
  const ostModelDouble* src = (const ostModelDouble*)model;
  size_t head = OST_ALIGN64(sizeof(ostModel)), bytes = ostx_dualModelSize(src->s);
  void* block = aligned_alloc(64, OST_ALIGN64(bytes) + 64);
  if (!block) {
    snprintf(err, err_sz, "ost_adjointModel_gpu: out of host memory");
    return 1;
  }
  memset(block, 0, bytes);
  ostModel host;
  ostx_dualModel(&host, block, src);
  char* dev = NULL;
  cudaError_t e = cudaMalloc(&dev, head + bytes);
  if (e == cudaSuccess) {
    e = cudaMemcpy(dev + head, block, bytes, cudaMemcpyHostToDevice);
  }
  if (e == cudaSuccess) {
    ostModel m_dev = host;
    ostu_modelInit(&m_dev, dev + head);  // pointer arithmetic only: valid for a device base
    e = cudaMemcpy(dev, &m_dev, sizeof(ostModel), cudaMemcpyHostToDevice);
  }
  free(block);
  if (e != cudaSuccess) {
    cudaFree(dev);
  }
  OST_CUDA_CHECK(e);
  *dual_dev = dev;
  return 0;
}


extern "C" size_t ost_adjointJacSize_gpu(const void* model, int nrow_max) {
  return ostx_jacWorkSize(((const ostModelDouble*)model)->s, nrow_max);
}


extern "C" int ost_adjointColumnSlots_gpu(void) {
  int dev = 0, nsm = 0, per_sm = 0;
  if (cudaGetDevice(&dev) != cudaSuccess
      || cudaDeviceGetAttribute(&nsm, cudaDevAttrMultiProcessorCount, dev) != cudaSuccess
      || cudaOccupancyMaxActiveBlocksPerMultiprocessor(&per_sm, ost_recordColumns_kernel,
                                                       OST_BLOCK, 0) != cudaSuccess) {
    return 0;
  }
  return nsm * per_sm * OST_BLOCK;
}


extern "C" int ost_adjointRecord_gpu(void* dual_dev, const ostAdjointLayout* A, char* lanes_dev,
                                     int w0, int nworld, int j, const ostAdjointSettings* as,
                                     const double* gq_dev, const double* gu_dev, char* pool_dev,
                                     int pool_n, char* err, int err_sz) {
  ost_recordStructure_kernel<<<(A->nlane + OST_BLOCK - 1) / OST_BLOCK, OST_BLOCK>>>(
      (ostModel*)dual_dev, *A, lanes_dev, w0, nworld, j, *as, gq_dev, gu_dev);
  OST_CUDA_CHECK(cudaGetLastError());
  int nl = pool_n / A->njac > 0 ? pool_n / A->njac : 1;  // lanes per launch
  for (int l0 = 0; l0 < A->nlane && w0 + l0 < nworld; l0 += nl) {
    int n = nl * A->njac;
    ost_recordColumns_kernel<<<(n + OST_BLOCK - 1) / OST_BLOCK, OST_BLOCK>>>(
        (ostModel*)dual_dev, *A, lanes_dev, w0, nworld, j, *as, l0, nl, pool_dev);
    OST_CUDA_CHECK(cudaGetLastError());
  }
  return 0;
}
