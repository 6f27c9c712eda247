# Fuzz.<target>.Brief: fuzzes for SECONDS from a copy of the seed corpus, so
# new inputs land in the build tree. A crash, timeout, OOM or leak makes
# libFuzzer exit non-zero, and so this test.
file(REMOVE_RECURSE ${WORK})
file(MAKE_DIRECTORY ${WORK}/corpus ${WORK}/artifacts)
file(GLOB seeds ${CORPUS}/*)
if(seeds)
  file(COPY ${seeds} DESTINATION ${WORK}/corpus)
endif()
execute_process(COMMAND ${CMAKE_COMMAND} -E env ${ENV}
    ${FUZZER} ${LIMITS} -max_total_time=${SECONDS} -print_final_stats=1
    -artifact_prefix=${WORK}/artifacts/ ${WORK}/corpus
  RESULT_VARIABLE rc)
if(NOT rc EQUAL 0)
  file(GLOB artifacts ${WORK}/artifacts/*)
  message(FATAL_ERROR "fuzzing failed (exit ${rc}); reproducer(s): ${artifacts}")
endif()
