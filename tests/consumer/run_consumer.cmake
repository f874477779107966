# Installs authalic's core into a temporary prefix, then configures, builds and runs the consumer
# project (tests/consumer) against that prefix alone. Script mode:
#   cmake -DBUILD_DIR=... -DSOURCE_DIR=... -DWORK_DIR=... -DGENERATOR=... -DCXX=... -P run_consumer.cmake
function(step what)
  execute_process(COMMAND ${ARGN} RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
  if(NOT rc EQUAL 0)
    message(FATAL_ERROR "consumer test: ${what} failed (${rc}):\n${out}\n${err}")
  endif()
  set(step_output "${out}" PARENT_SCOPE)
endfunction()

file(REMOVE_RECURSE ${WORK_DIR})
step("install of the core" ${CMAKE_COMMAND} --install ${BUILD_DIR} --prefix ${WORK_DIR}/prefix --component core)
if(NOT EXISTS ${WORK_DIR}/prefix/include/authalic/core/square_map.h OR NOT EXISTS ${WORK_DIR}/prefix/lib/cmake/authalic/authalicConfig.cmake)
  message(FATAL_ERROR "consumer test: the install did not write include/authalic/core/square_map.h and lib/cmake/authalic/authalicConfig.cmake")
endif()
set(launcher)
if(DEFINED ENV{CMAKE_CXX_COMPILER_LAUNCHER})
  set(launcher -DCMAKE_CXX_COMPILER_LAUNCHER=$ENV{CMAKE_CXX_COMPILER_LAUNCHER})
endif()
# A core built with the sanitizers (scripts/sanitize.sh) needs their runtime in the consumer too.
set(sanitize_flags)
if(SANITIZE)
  set(sanitize_flags "-DCMAKE_CXX_FLAGS=-fsanitize=address,undefined" "-DCMAKE_EXE_LINKER_FLAGS=-fsanitize=address,undefined")
endif()
step("configure" ${CMAKE_COMMAND} -S ${SOURCE_DIR}/tests/consumer -B ${WORK_DIR}/build -G ${GENERATOR}
     -DCMAKE_BUILD_TYPE=Release -DCMAKE_CXX_COMPILER=${CXX} -DCMAKE_PREFIX_PATH=${WORK_DIR}/prefix ${launcher} ${sanitize_flags})
step("build" ${CMAKE_COMMAND} --build ${WORK_DIR}/build)
# Passive OpenMP waiting, as the authalic executable sets for itself: on a loaded machine spinning
# threads slow a small map down by orders of magnitude.
step("run" ${CMAKE_COMMAND} -E env OMP_WAIT_POLICY=passive ${WORK_DIR}/build/consumer)
message(STATUS "consumer: ${step_output}")
file(REMOVE_RECURSE ${WORK_DIR})
