# compare_models.cmake: tests of `ostrich compare models` (compare/compare_models*.c), included by
# tests/CMakeLists.txt. compare_models_run: box_plane and cartpole, both engines and kinds of
# controls, h x 1,2,5,10 (the CSV's columns and physics); compare_models_refused: refusal, load
# failure and a failed step's exit status; compare_models_outputs: bad output paths rejected
# before work, a killed run keeps the previous CSV; compare_models_corpus: the sample models of
# Debian's libmujoco-samples that Ostrich accepts (OST_SAMPLE_MODELS), 0.2 s at h x 1 and 5.
foreach(mode run refused outputs)
  add_test(NAME compare_models_${mode}
           COMMAND bash ${CMAKE_CURRENT_SOURCE_DIR}/test_compare_models.sh
                   $<TARGET_FILE:ostrich_cli> ${OST_MODELS} ${CMAKE_CURRENT_SOURCE_DIR}/models
                   ${mode})
  set_tests_properties(compare_models_${mode} PROPERTIES ENVIRONMENT "OSTRICH_QUIET=1")
endforeach()

# the accepted sample models (relative to OST_SAMPLE_DIR). Left out: too slow for CI
# (22_humanoids: about 1 s per Ostrich step; particle: 0.2 s to 2 s per step; the hammock 0.5 s
# once the humanoid lands in it); see compare/results/compare_models.md
set(OST_SAMPLE_DIR /usr/share/mujoco/model CACHE PATH "Debian's libmujoco-samples models")
set(OST_SAMPLE_ACCEPTED composite/cloth.xml composite/loop.xml composite/rope.xml
    composite/scene.xml composite/softbox.xml flag/flag.xml hammock/humanoid_body.xml
    humanoid/humanoid.xml mug/mug.xml slider_crank/slider_crank.xml humanoid100/humanoid100.xml
    tendon_arm/arm26.xml composite/grid2pin.xml adhesion/active_adhesion.xml)
set(OST_SAMPLE_MODELS "")
foreach(f ${OST_SAMPLE_ACCEPTED})
  if(EXISTS ${OST_SAMPLE_DIR}/${f})
    list(APPEND OST_SAMPLE_MODELS ${OST_SAMPLE_DIR}/${f})
  endif()
endforeach()
add_test(NAME compare_models_corpus
         COMMAND bash ${CMAKE_CURRENT_SOURCE_DIR}/test_compare_models.sh
                 $<TARGET_FILE:ostrich_cli> ${OST_MODELS} ${CMAKE_CURRENT_SOURCE_DIR}/models
                 corpus ${OST_SAMPLE_MODELS})
set_tests_properties(compare_models_corpus PROPERTIES ENVIRONMENT "OSTRICH_QUIET=1" TIMEOUT 300)
