// compare_replay.c: placeholder, being written (issue 5).
#include <stdio.h>

#include "compare.h"

int compare_replay_main(int argc, char** argv) {
  fprintf(stderr, "ostrich: compare: not built yet\n");
  return 2;
}

int compare_identify_main(int argc, char** argv) {
  fprintf(stderr, "ostrich: compare: not built yet\n");
  return 2;
}

int compare_genlogs_main(int argc, char** argv) {
  fprintf(stderr, "ostrich: compare: not built yet\n");
  return 2;
}

