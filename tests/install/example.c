// example.c: load a MuJoCo model, take 10 steps with Ostrich and print the height of its body
// "box". Exits 0 if every step was taken (OST_OK, or a warning: the step was taken but not to
// tolerance) and the height is finite.
//   cc example.c $(pkg-config --cflags --libs ostrich) -o example && ./example box_plane.xml
#include <math.h>
#include <stdio.h>

#include <mujoco/mujoco.h>
#include <ostrich/ostrich.h>

int main(int argc, char** argv) {
  if (argc != 2) {
    fprintf(stderr, "usage: %s MODEL.xml\n", argv[0]);
    return 2;
  }
  char err[1000] = "";
  mjModel* m = mj_loadXML(argv[1], NULL, err, sizeof(err));
  if (!m) {
    fprintf(stderr, "cannot load %s: %s\n", argv[1], err);
    return 1;
  }
  int box = mj_name2id(m, mjOBJ_BODY, "box");
  if (box < 0) {
    fprintf(stderr, "%s has no body named 'box'\n", argv[1]);
    mj_deleteModel(m);
    return 1;
  }
  mjData* d = mj_makeData(m);

  int status = OST_OK;
  for (int i = 0; i < 10; i++) {
    status = ost_step(m, d);  // as mj_step, with Ostrich's solver
    if (status != OST_OK && !OST_IS_WARNING(status)) {
      fprintf(stderr, "step %d failed (status %d): %s\n", i, status, ost_lastError(d));
      break;
    }
  }
  double z = d->xpos[3*box + 2];
  printf("status %d, time %.3f s, box height %.6f m\n", status, d->time, z);
  int ok = (status == OST_OK || OST_IS_WARNING(status)) && isfinite(z);

  ost_deleteData(d);  // Ostrich's state of d, then mj_deleteData
  mj_deleteModel(m);
  return ok ? 0 : 1;
}
