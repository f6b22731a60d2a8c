# Installs the SDK and the hazard kit into a scratch prefix, then configures, builds and tests the out-of-tree
# template in jaywalker_diagonal/ against that install, exactly as a third party would.
# cmake -DBINARY_DIR=<build> -DWORK_DIR=<scratch> -DEXAMPLE_DIR=<src> -DGENERATOR=<gen> -DSHARE_DIR=<share> -P this
file(REMOVE_RECURSE ${WORK_DIR})
function(run what)
  execute_process(COMMAND ${ARGN} RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE out)
  if(NOT rc EQUAL 0)
    message(FATAL_ERROR "${what} failed (${rc}):\n${out}")
  endif()
  message(STATUS "${what}: ok")
endfunction()
foreach(dir sdk plugins/hazard/common)
  run("install ${dir}" ${CMAKE_COMMAND} -DCMAKE_INSTALL_PREFIX=${WORK_DIR}/prefix -P ${BINARY_DIR}/${dir}/cmake_install.cmake)
endforeach()
run("configure" ${CMAKE_COMMAND} -S ${EXAMPLE_DIR} -B ${WORK_DIR}/build -G ${GENERATOR} -DCMAKE_BUILD_TYPE=Release
    -DCMAKE_PREFIX_PATH=${WORK_DIR}/prefix)
run("build" ${CMAKE_COMMAND} --build ${WORK_DIR}/build -j 2)
run("test" ${CMAKE_COMMAND} -E env HAZARDFORGE_SHARE=${SHARE_DIR} ${CMAKE_CTEST_COMMAND} --test-dir ${WORK_DIR}/build
    --output-on-failure)
