// compare.h: `ostrich compare`, the A/B harness against stock MuJoCo 2.2.2. One
// subcommand per file: sweep and replay/identify (compare_sweep.c, compare_replay.c, sharing the
// engine runner and error metric of compare_run.c), hard cases (compare_hard.c), a user's own
// models (compare_models.c, its outputs in compare_models_out.c). compare_cli.c
// dispatches. Same conventions as the other subcommands (plugin/cli/ost_cli_util.h): one JSON line
// on stdout, diagnostics on stderr starting "ostrich:", exit 0 / 1 (run failed) / 2 (usage).
#ifndef OSTRICH_COMPARE_COMPARE_H_
#define OSTRICH_COMPARE_COMPARE_H_

#ifdef __cplusplus
extern "C" {
#endif

// `ostrich compare sweep|replay|identify|gen-logs|hard|models`; argv excludes "compare".
int compare_main(int argc, char** argv);

// Subcommands; argv excludes "compare" and the subcommand name.
int compare_sweep_main(int argc, char** argv);      // compare_sweep.c
int compare_replay_main(int argc, char** argv);     // compare_replay.c
int compare_identify_main(int argc, char** argv);   // compare_replay.c
int compare_genlogs_main(int argc, char** argv);    // compare_replay.c
int compare_hard_main(int argc, char** argv);       // compare_hard.c
int compare_models_main(int argc, char** argv);     // compare_models.c

#ifdef __cplusplus
}
#endif

#endif  // OSTRICH_COMPARE_COMPARE_H_
