# ctest consumer_package: install the build tree into a fresh temporary prefix, then configure, build and run
# tests/consumer in a fresh build folder against that prefix only (the source tree is not on any path).
#   cmake -DLOOM_BUILD_DIR=... -DWORK_DIR=... -DCONSUMER_SOURCE=... [-DEXECUTABLE=consumer] [-DBUILD_TYPE=Release]
#         [-DARGS=arg1;arg2] -P run_consumer.cmake
foreach(v LOOM_BUILD_DIR WORK_DIR CONSUMER_SOURCE)
  if(NOT DEFINED ${v})
    message(FATAL_ERROR "run_consumer.cmake: -D${v}=... is required")
  endif()
endforeach()
if(NOT EXECUTABLE)
  set(EXECUTABLE consumer)
endif()
if(NOT BUILD_TYPE)
  set(BUILD_TYPE Release)
endif()
set(prefix ${WORK_DIR}/prefix)
set(build ${WORK_DIR}/build)
file(REMOVE_RECURSE ${prefix} ${build})

function(step what)
  execute_process(COMMAND ${ARGN} RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
  if(NOT rc EQUAL 0)
    message(FATAL_ERROR "consumer: ${what} failed (${rc}):\n${out}\n${err}")
  endif()
  message(STATUS "consumer: ${what}: ok")
  set(step_output "${out}" PARENT_SCOPE)
endfunction()

step("install" ${CMAKE_COMMAND} --install ${LOOM_BUILD_DIR} --prefix ${prefix})
foreach(f lib/cmake/loom/loomConfig.cmake lib/cmake/loom/loomConfigVersion.cmake lib/cmake/loom/loomTargets.cmake
          include/loom/cloth/Simulation.h lib/libloom_cloth.a)
  if(NOT EXISTS ${prefix}/${f})
    message(FATAL_ERROR "consumer: the install has no ${f}")
  endif()
endforeach()
step("configure" ${CMAKE_COMMAND} -S ${CONSUMER_SOURCE} -B ${build} -DCMAKE_BUILD_TYPE=${BUILD_TYPE}
     -DCMAKE_PREFIX_PATH=${prefix} -DCMAKE_FIND_PACKAGE_NO_PACKAGE_REGISTRY=ON)
step("build" ${CMAKE_COMMAND} --build ${build} -j2)
step("run" ${build}/${EXECUTABLE} ${ARGS})
message(STATUS "${step_output}")
