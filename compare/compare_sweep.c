// compare_sweep.c: placeholder, being written (issue 5).
#include <stdio.h>

#include "compare.h"

int compare_sweep_main(int argc, char** argv) {
  fprintf(stderr, "ostrich: compare: not built yet\n");
  return 2;
}

