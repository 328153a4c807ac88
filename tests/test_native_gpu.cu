// test_native_gpu.cu: native geometry on the GPU equals the CPU (ctest label `gpu`).
// For each model given on the command line: pack it (plugin/ost_pack.c), copy the packed block
// to the device, run core's kinematics, mass matrix, bias forces and collision for a batch of
// random configurations in a kernel (one thread per world), and compare every output array and
// contact with the same core functions run on the CPU. Passes if all agree to 1e-12 (relative).
//   usage: test_native_gpu MODEL.xml... [--worlds N]
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <cuda_runtime.h>

#include "ost_collision.h"
#include "ost_kinematics.h"
#include "ost_model.h"

extern "C" {
#include "ostrich.h"
int ost_packModel(const mjModel* m, int ncon_max, ostModel* om, void** block, char* err,
                  int err_sz);
}

#define CHECK(expr)                                                                   \
  do {                                                                                \
    cudaError_t e_ = (expr);                                                          \
    if (e_ != cudaSuccess) {                                                          \
      fprintf(stderr, "%s:%d: %s: %s\n", __FILE__, __LINE__, #expr, cudaGetErrorString(e_)); \
      exit(2);                                                                        \
    }                                                                                 \
  } while (0)


// one world's geometry: kinematics, com frames, CRB, RNE, transmission and contacts
__host__ __device__ static void geometryWorld(const ostModel* m, ostKin* k, const ostNum* qpos,
                                              const ostNum* qvel) {
  osti_kinematics(m, k, qpos);
  for (int g = 0; g < m->s.ngeom; g++) {
    if (!m->geom_paired[g]) osti_kinGeom(m, k, g);  // compared too, though steps never read it
  }
  osti_comPos(m, k);
  osti_crb(m, k);
  osti_rne(m, k, qvel);
  osti_transmission(m, k, qpos);
  osti_collision(m, k);
}


__global__ void geometry_kernel(ostModel m, char* kin, size_t kinsz, const ostNum* qpos,
                                const ostNum* qvel, int* ncon, int nworld) {
  int w = blockIdx.x * blockDim.x + threadIdx.x;
  if (w >= nworld) {
    return;  // guard first
  }
  ostKin k;
  ostu_kinInit(&k, kin + (size_t)w * kinsz, m.s);
  geometryWorld(&m, &k, qpos + (size_t)w * m.s.nq, qvel + (size_t)w * m.s.nv);
  ncon[w] = k.ncon;
}


// uniform in [lo, hi]
static double uniform(unsigned* seed, double lo, double hi) {
  *seed = *seed * 1103515245u + 12345u;
  return lo + (hi - lo) * ((*seed >> 8) & 0xffffff) / (double)0xffffff;
}


// relative error |a - b| / max(1, |b|)
static double relErr(double a, double b) {
  return fabs(a - b) / (fabs(b) > 1 ? fabs(b) : 1);
}


// max relative error over the kinematics arrays and contacts of two worlds' blocks
static double compareKin(const ostKin* a, int na, const ostKin* b, int nb) {
  double e = na == nb ? 0 : INFINITY;
  ostSizes s = a->s;
#define X(type, name, r, c)                                                          \
  if (sizeof(type) == sizeof(ostNum)) {                                              \
    const ostNum* x = (const ostNum*)a->name;                                        \
    const ostNum* y = (const ostNum*)b->name;                                        \
    for (size_t i = 0; i < (size_t)(r) * (c); i++) e = fmax(e, relErr(x[i], y[i]));    \
  }
  X(ostNum, xpos, s.nbody, 3) X(ostNum, xmat, s.nbody, 9) X(ostNum, geom_xpos, s.ngeom, 3)
  X(ostNum, geom_xmat, s.ngeom, 9) X(ostNum, cdof, s.nv, 6) X(ostNum, qM, s.nv, s.nv)
  X(ostNum, qfrc_bias, s.nv, 1) X(ostNum, actuator_moment, s.nu, s.nv)
#undef X
  for (int i = 0; i < na && i < nb; i++) {
    const ostNum* x = &a->contact[i].dist;
    const ostNum* y = &b->contact[i].dist;
    for (int j = 0; j < 13; j++) e = fmax(e, relErr(x[j], y[j]));
    if (a->contact_pair[i] != b->contact_pair[i]) e = INFINITY;
  }
  return e;
}


static int runModel(const char* path, int nworld) {
  char err[1000] = "";
  mjModel* mm = mj_loadXML(path, NULL, err, sizeof(err));
  if (!mm) {
    fprintf(stderr, "cannot load %s: %s\n", path, err);
    return 2;
  }
  ostModel m;
  void* block;
  if (ost_packModel(mm, 200, &m, &block, err, sizeof(err))) {
    fprintf(stderr, "%s: %s\n", path, err);
    return 2;
  }
  int nq = m.s.nq, nv = m.s.nv;

  // random configurations near qpos0 (unit quaternions), velocities in [-1, 1]
  unsigned seed = 12345;
  ostNum* qpos = (ostNum*)malloc(sizeof(ostNum) * nq * nworld);
  ostNum* qvel = (ostNum*)malloc(sizeof(ostNum) * nv * nworld);
  for (int w = 0; w < nworld; w++) {
    ostNum* q = qpos + (size_t)w * nq;
    for (int i = 0; i < nq; i++) q[i] = mm->qpos0[i] + uniform(&seed, -0.2, 0.2);
    for (int j = 0; j < mm->njnt; j++) {
      int t = mm->jnt_type[j], a = mm->jnt_qposadr[j] + (t == mjJNT_FREE ? 3 : 0);
      if (t == mjJNT_FREE || t == mjJNT_BALL) mju_normalize4(q + a);
    }
    for (int i = 0; i < nv; i++) qvel[(size_t)w * nv + i] = uniform(&seed, -1, 1);
  }

  // device copies: the model block (re-pointed), states, one kinematics block per world
  size_t msz = ostu_modelSize(m.s), ksz = OST_ALIGN64(ostu_kinSize(m.s));
  void *dblock, *dkin;
  ostNum *dq, *dv;
  int* dncon;
  CHECK(cudaMalloc(&dblock, msz));
  CHECK(cudaMemcpy(dblock, block, msz, cudaMemcpyHostToDevice));
  ostModel dm = m;
  ostu_modelInit(&dm, dblock);
  CHECK(cudaMalloc(&dkin, ksz * nworld));
  CHECK(cudaMemset(dkin, 0xff, ksz * nworld));  // NaN poisoning
  CHECK(cudaMalloc(&dq, sizeof(ostNum) * nq * nworld));
  CHECK(cudaMalloc(&dv, sizeof(ostNum) * nv * nworld));
  CHECK(cudaMalloc(&dncon, sizeof(int) * nworld));
  CHECK(cudaMemcpy(dq, qpos, sizeof(ostNum) * nq * nworld, cudaMemcpyHostToDevice));
  CHECK(cudaMemcpy(dv, qvel, sizeof(ostNum) * nv * nworld, cudaMemcpyHostToDevice));
  CHECK(cudaDeviceSetLimit(cudaLimitStackSize, 64 * 1024));
  geometry_kernel<<<(nworld + 63) / 64, 64>>>(dm, (char*)dkin, ksz, dq, dv, dncon, nworld);
  CHECK(cudaGetLastError());
  CHECK(cudaDeviceSynchronize());
  char* hkin = (char*)aligned_alloc(64, ksz * nworld);
  int* hncon = (int*)malloc(sizeof(int) * nworld);
  CHECK(cudaMemcpy(hkin, dkin, ksz * nworld, cudaMemcpyDeviceToHost));
  CHECK(cudaMemcpy(hncon, dncon, sizeof(int) * nworld, cudaMemcpyDeviceToHost));

  // the CPU oracle: the same core functions, world by world
  char* cbuf = (char*)aligned_alloc(64, ksz);
  double worst = 0;
  long ncontact = 0;
  for (int w = 0; w < nworld; w++) {
    ostKin kc, kg;
    ostu_kinInit(&kc, cbuf, m.s);
    geometryWorld(&m, &kc, qpos + (size_t)w * nq, qvel + (size_t)w * nv);
    ostu_kinInit(&kg, hkin + (size_t)w * ksz, m.s);  // device pointers rebased on the host copy
    worst = fmax(worst, compareKin(&kc, kc.ncon, &kg, hncon[w]));
    ncontact += kc.ncon;
  }
  int ok = worst <= 1e-12;
  printf("{\"model\": \"%s\", \"worlds\": %d, \"contacts\": %ld, \"max_gpu_cpu_diff\": %.3g, "
         "\"ok\": %s}\n", path, nworld, ncontact, worst, ok ? "true" : "false");
  cudaFree(dblock);
  cudaFree(dkin);
  cudaFree(dq);
  cudaFree(dv);
  cudaFree(dncon);
  free(qpos);
  free(qvel);
  free(hkin);
  free(hncon);
  free(cbuf);
  free(block);
  mj_deleteModel(mm);
  return ok ? 0 : 1;
}


int main(int argc, char** argv) {
  int nworld = 1024, status = 0, nmodel = 0;
  for (int i = 1; i < argc; i++) {
    if (!strcmp(argv[i], "--worlds") && i + 1 < argc) {
      nworld = atoi(argv[++i]);
    }
  }
  int ndev = 0;
  if (cudaGetDeviceCount(&ndev) != cudaSuccess || ndev == 0) {
    fprintf(stderr, "test_native_gpu: no CUDA device\n");
    return 2;
  }
  for (int i = 1; i < argc; i++) {
    if (!strcmp(argv[i], "--worlds")) {
      i++;
      continue;
    }
    status |= runModel(argv[i], nworld);
    nmodel++;
  }
  return nmodel ? status : 2;
}
