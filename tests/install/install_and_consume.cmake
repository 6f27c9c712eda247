# Installs the build tree into a fresh prefix, then configures, builds and runs
# a consumer project (CONSUMER_SOURCE_DIR, its executable CONSUMER_EXE) against
# it. FORBIDDEN (a regex): no library the executable loads (ldd) may match it.
file(REMOVE_RECURSE ${WORK_DIR})
set(prefix ${WORK_DIR}/prefix)
execute_process(COMMAND ${CMAKE_COMMAND} --install ${MUCOSA_BUILD_DIR} --prefix ${prefix}
  RESULT_VARIABLE rc OUTPUT_QUIET)
if(rc)
  message(FATAL_ERROR "cmake --install failed: ${rc}")
endif()
execute_process(COMMAND ${CMAKE_COMMAND} -S ${CONSUMER_SOURCE_DIR} -B ${WORK_DIR}/build -G ${GENERATOR}
  -DCMAKE_PREFIX_PATH=${prefix} -DCMAKE_BUILD_TYPE=Release
  -DCMAKE_CXX_COMPILER=${CONSUMER_CXX_COMPILER} "-DCMAKE_CXX_FLAGS=${CONSUMER_CXX_FLAGS}"
  "-DCMAKE_EXE_LINKER_FLAGS=${CONSUMER_CXX_FLAGS}" RESULT_VARIABLE rc)
if(rc)
  message(FATAL_ERROR "configuring the consumer failed: ${rc}")
endif()
execute_process(COMMAND ${CMAKE_COMMAND} --build ${WORK_DIR}/build RESULT_VARIABLE rc)
if(rc)
  message(FATAL_ERROR "building the consumer failed: ${rc}")
endif()
if(FORBIDDEN)
  execute_process(COMMAND ldd ${WORK_DIR}/build/${CONSUMER_EXE} RESULT_VARIABLE rc OUTPUT_VARIABLE libs)
  if(rc)
    message(FATAL_ERROR "ldd ${CONSUMER_EXE} failed: ${rc}")
  endif()
  string(REGEX MATCHALL "[^\n\t ]*(${FORBIDDEN})[^\n\t ]*" bad "${libs}")
  if(bad)
    message(FATAL_ERROR "${CONSUMER_EXE} loads ${bad}:\n${libs}")
  endif()
  message("${CONSUMER_EXE} loads none of: ${FORBIDDEN}")
endif()
execute_process(COMMAND ${WORK_DIR}/build/${CONSUMER_EXE} RESULT_VARIABLE rc OUTPUT_VARIABLE out)
message("${out}")
if(rc)
  message(FATAL_ERROR "the consumer failed: ${rc}")
endif()
