// test_transition_preload.c: MuJoCo's own finite-difference Jacobians (mjd_transitionFD, which
// steps through mj_step) run under libostrich_preload.so, so that every step inside is an
// Ostrich step, must agree with ost_transition's exact Jacobians. Run by ctest with
// LD_PRELOAD set. Usage: test_transition_preload MODEL.xml NSTEP CTRL [MODEL NSTEP CTRL ...].
// Prints one line per case; exit status 1 on disagreement above 2e-4 (normwise relative).
#include <math.h>
#include <stdio.h>
#include <stdlib.h>

#include <mujoco/mujoco.h>

#include "ostrich.h"

// max |a - b| / max |b|
static double relErr(const mjtNum* a, const mjtNum* b, int n) {
  double e = 0, s = 1e-300;
  for (int i = 0; i < n; i++) {
    e = fmax(e, fabs(a[i] - b[i]));
    s = fmax(s, fabs(b[i]));
  }
  return e / s;
}

int main(int argc, char** argv) {
  int fail = 0;
  for (int a = 1; a + 2 < argc; a += 3) {
    char err[1000];
    mjModel* m = mj_loadXML(argv[a], NULL, err, sizeof(err));
    if (!m) {
      fprintf(stderr, "%s: %s\n", argv[a], err);
      return 1;
    }
    mjData* d = mj_makeData(m);
    int nx = 2 * m->nv, nu = m->nu;
    for (int k = 0; k < atoi(argv[a + 1]); k++) {
      for (int i = 0; i < nu; i++) d->ctrl[i] = atof(argv[a + 2]);
      mj_step(m, d);
    }
    if (!ost_stats(d)) {
      fprintf(stderr, "mj_step did not run Ostrich: is LD_PRELOAD=libostrich_preload.so set?\n");
      return 1;
    }
    mjtNum* A = calloc(nx * nx, sizeof(mjtNum));
    mjtNum* B = calloc(nx * nu + 1, sizeof(mjtNum));
    mjtNum* Afd = calloc(nx * nx, sizeof(mjtNum));
    mjtNum* Bfd = calloc(nx * nu + 1, sizeof(mjtNum));
    mjd_transitionFD(m, d, 1e-6, 1, Afd, Bfd, NULL, NULL);
    int status = ost_transition(m, d, A, B);
    double eA = relErr(A, Afd, nx * nx), eB = relErr(B, Bfd, nx * nu);
    printf("%s after %s steps: ost_transition vs mjd_transitionFD through Ostrich: A %.2e, "
           "B %.2e (x = %.3f m)\n", argv[a], argv[a + 1], eA, eB, d->qpos[0]);
    if (status || !(eA < 2e-4) || !(eB < 2e-4)) {
      fprintf(stderr, "FAIL %s: status %d %s\n", argv[a], status, ost_lastError(d));
      fail = 1;
    }
    free(A); free(B); free(Afd); free(Bfd);
    ost_deleteData(d);
    mj_deleteModel(m);
  }
  return fail;
}
