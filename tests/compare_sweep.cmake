# compare_sweep.cmake: tests of the sweep / replay / identify half of `ostrich compare`,
# included by tests/CMakeLists.txt. test_compare_metric: the error metric, angle helpers, zero-
# order hold and CSV reader of compare/compare_run.c against hand-made answers (Check).
# test_compare_sweep: the subcommands end to end (bad inputs, a reduced sweep, gen-logs and
# replay round trip, replay of a shipped log, a small identify), a few seconds.
ost_check_test(test_compare_metric)
target_sources(test_compare_metric PRIVATE ${CMAKE_SOURCE_DIR}/compare/compare_run.c
               ${CMAKE_SOURCE_DIR}/plugin/cli/ost_cli_util.c)
target_include_directories(test_compare_metric PRIVATE ${CMAKE_SOURCE_DIR}/compare
                           ${CMAKE_SOURCE_DIR}/plugin/cli)

add_test(NAME test_compare_sweep COMMAND bash ${CMAKE_CURRENT_SOURCE_DIR}/test_compare_sweep.sh
         $<TARGET_FILE:ostrich_cli> ${OST_MODELS} ${CMAKE_SOURCE_DIR}/compare)
set_tests_properties(test_compare_sweep PROPERTIES ENVIRONMENT "OSTRICH_QUIET=1")
