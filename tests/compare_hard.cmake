# compare_hard.cmake: tests of `ostrich compare hard` (compare/compare_hard*.c), included by
# tests/CMakeLists.txt. compare_hard_run runs the incline pair, the fast ball and the stack at
# h = 0.01 and 0.1 s with both engines and checks the JSON line, the CSV and Ostrich's physics
# (about 1 s); compare_hard_usage checks that bad input exits 2.
foreach(mode run usage)
  add_test(NAME compare_hard_${mode}
           COMMAND bash ${CMAKE_CURRENT_SOURCE_DIR}/test_compare_hard.sh
                   $<TARGET_FILE:ostrich_cli> ${OST_MODELS} ${mode})
endforeach()
