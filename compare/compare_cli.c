// compare_cli.c: dispatch of `ostrich compare SUBCOMMAND` (see compare.h).
#include <stdio.h>
#include <string.h>

#include "compare.h"

typedef struct compareCommand_ {  // one subcommand
  const char* name;               // as typed
  const char* summary;            // one line of usage
  int (*run)(int argc, char** argv);
} compareCommand;

static const compareCommand kCompareCommands[] = {
  {"sweep", "run engines over a timestep grid: error and wall time, plateaus, plots",
   compare_sweep_main},
  {"replay", "replay a logged run (wheel commands, measured pose) with each engine",
   compare_replay_main},
  {"identify", "fit each engine's dominant parameters on training logs, score held-out",
   compare_identify_main},
  {"gen-logs", "write the synthetic pallet-traversal logs (a fine-step reference + noise)",
   compare_genlogs_main},
  {"hard", "hard cases at several timesteps with both engines; a table",
   compare_hard_main},
  {"models", "judge Ostrich on your models: acceptance, divergence, convergence, speed, error",
   compare_models_main},
};

static const int kNumCompareCommands =
    (int)(sizeof(kCompareCommands) / sizeof(kCompareCommands[0]));


// Print the usage of `ostrich compare`.
static void compare_usage(FILE* f) {
  fprintf(f,
    "usage: ostrich compare SUBCOMMAND [arguments]\n"
    "       ostrich compare SUBCOMMAND --help\n"
    "\n"
    "A/B tests of Ostrich against stock MuJoCo on the same MJCF and commands.\n"
    "\n"
    "subcommands:\n");
  for (int i = 0; i < kNumCompareCommands; i++) {
    fprintf(f, "  %-9s %s\n", kCompareCommands[i].name, kCompareCommands[i].summary);
  }
}


int compare_main(int argc, char** argv) {
  if (argc < 1) {
    compare_usage(stderr);
    return 2;
  }
  if (!strcmp(argv[0], "-h") || !strcmp(argv[0], "--help")) {
    compare_usage(stdout);
    return 0;
  }
  for (int i = 0; i < kNumCompareCommands; i++) {
    if (!strcmp(argv[0], kCompareCommands[i].name)) {
      return kCompareCommands[i].run(argc - 1, argv + 1);
    }
  }
  fprintf(stderr, "ostrich: unknown compare subcommand '%s' (try: ostrich compare --help)\n",
          argv[0]);
  return 2;
}
