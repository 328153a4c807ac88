// bench_geometry.c: native against mujoco geometry provider, time per Newton iterate, measured in
// the same run. For each scene it steps two copies of the same state with Ostrich,
// one per provider, and divides the wall time of the steps by the geometry evaluations (Newton
// iterates and line-search trials), so the figure is what one iterate costs a user.
// Prints a table and one JSON line per scene; exits non-zero if a step fails. The mesh terrain
// runs natively only (MuJoCo 2.2.2 collides a mesh as its convex hull): its mujoco column is nan
// in the table and null in the JSON line.
//   usage: bench_geometry [MODEL_DIR] [--steps N]
#define _POSIX_C_SOURCE 200809L
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "ost_cli_util.h"
#include "ostrich.h"

static double now(void) {
  struct timespec t;
  clock_gettime(CLOCK_MONOTONIC, &t);
  return t.tv_sec + 1e-9 * t.tv_nsec;
}


// run n steps of model m with the given provider; wall seconds and geometry evaluations
static int run(const mjModel* m, int geometry, double h, double margin, int n, double* wall,
               long* evals) {
  mjData* d = mj_makeData(m);
  ostOptions o;
  if (!d || ost_readOptions(m, &o, NULL, 0)) {
    return 1;
  }
  o.geometry = geometry;
  o.timestep = h;
  if (margin >= 0) {
    o.margin = margin;
  }
  if (ost_setOptions(m, d, &o)) {
    fprintf(stderr, "bench_geometry: %s\n", ost_lastError(d));
    return 1;
  }
  *wall = 0;
  *evals = 0;
  for (int k = 0; k < n; k++) {
    for (int i = 0; i < m->nu; i++) d->ctrl[i] = 3;
    double t0 = now();
    int status = ost_step(m, d);
    *wall += now() - t0;
    if (status) {
      fprintf(stderr, "bench_geometry: step %d failed: %s\n", k, ost_lastError(d));
      ost_deleteData(d);
      return 1;
    }
    *evals += ost_stats(d)->geometry_evals;
  }
  ost_deleteData(d);
  return 0;
}


int main(int argc, char** argv) {
  const char* dir = "mjcf_models";
  int nstep = 100;
  for (int i = 1; i < argc; i++) {
    if (!strcmp(argv[i], "--steps") && i + 1 < argc) {
      nstep = atoi(argv[++i]);
    } else {
      dir = argv[i];
    }
  }
  // the height field runs at look-ahead 0 with both providers: the mujoco provider needs it
  // there (MuJoCo 2.2.2's height-field distances ignore the margin); -1 keeps the default
  const struct { const char* file; double h, margin; } scenes[] = {
    {"wheeled_robot.xml", 0.05, -1}, {"robot_pallet.xml", 0.05, -1},
    {"terrain_hfield.xml", 0.05, 0}, {"terrain_mesh.xml", 0.05, 0}};
  printf("%-20s %6s %12s %12s %12s %12s %8s\n", "scene", "h", "mujoco us/it", "native us/it",
         "mujoco iters", "native iters", "ratio");
  int fail = 0;
  for (int s = 0; s < 4; s++) {
    char path[1024], err[1000] = "";
    snprintf(path, sizeof(path), "%s/%s", dir, scenes[s].file);
    mjModel* m = mj_loadXML(path, NULL, err, sizeof(err));
    if (!m) {
      fprintf(stderr, "bench_geometry: cannot load %s: %s\n", path, err);
      return 2;
    }
    // the mesh terrain exists only natively (MuJoCo collides meshes as convex hulls)
    int mesh = ost_terrainGeom(m) >= 0;
    double wm = NAN, wn = NAN;
    long em = 0, en = 0;
    // three repetitions; the median of each provider's time per iterate
    double tm[3], tn[3];
    for (int r = 0; r < 3; r++) {
      if (!mesh) {
        fail |= run(m, OST_GEOMETRY_MUJOCO, scenes[s].h, scenes[s].margin, nstep, &wm, &em);
        tm[r] = 1e6 * wm / em;
      } else {
        tm[r] = NAN;
      }
      fail |= run(m, OST_GEOMETRY_NATIVE, scenes[s].h, scenes[s].margin, nstep, &wn, &en);
      tn[r] = 1e6 * wn / en;
    }
#define MED3(a) (fmax(fmin((a)[0], (a)[1]), fmin(fmax((a)[0], (a)[1]), (a)[2])))
    double mm = MED3(tm), mn = MED3(tn);
    printf("%-20s %6.3f %12.1f %12.1f %12ld %12ld %8.2f\n", scenes[s].file, scenes[s].h, mm, mn,
           em, en, mm / mn);
    // JSON: a time that was not measured (the mesh terrain under MuJoCo) is null, not nan
    printf("{\"scene\": ");
    cli_jsonString(stdout, scenes[s].file);
    printf(", \"h\": %g, \"steps\": %d, \"mujoco_us_per_iterate\": ", scenes[s].h, nstep);
    cli_jsonNumber(stdout, mm);
    printf(", \"native_us_per_iterate\": ");
    cli_jsonNumber(stdout, mn);
    printf(", \"mujoco_iterates\": %ld, \"native_iterates\": %ld, \"speedup\": ", em, en);
    cli_jsonNumber(stdout, mm / mn);
    printf("}\n");
    mj_deleteModel(m);
  }
  return fail;
}
