# Install the build, build the example plugin against that install, run it with the installed host.
function(step)
  execute_process(COMMAND ${ARGN} RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
  if(NOT rc EQUAL 0)
    message(FATAL_ERROR "step failed (${rc}): ${ARGN}\n${out}\n${err}")
  endif()
  set(STEP_OUT "${out}${err}" PARENT_SCOPE)
endfunction()

file(REMOVE_RECURSE ${WORK_DIR})
set(prefix ${WORK_DIR}/install)
step(${CMAKE_COMMAND} --install ${BUILD_DIR} --prefix ${prefix})
step(${CMAKE_COMMAND} -S ${SOURCE_DIR}/sdk/examples/frame_stats -B ${WORK_DIR}/example -G ${GENERATOR}
     -DCMAKE_BUILD_TYPE=Release -DCMAKE_PREFIX_PATH=${prefix})
step(${CMAKE_COMMAND} --build ${WORK_DIR}/example)
if(NOT EXISTS ${WORK_DIR}/example/libframe_stats.so)
  message(FATAL_ERROR "the example plugin was not built")
endif()

# The installed host lists the example next to the installed in-tree plugins.
step(${prefix}/bin/hazardforge --plugin-path ${WORK_DIR}/example plugins)
foreach(expect "sink/frame_stats" "detector/yolo" "${prefix}/lib/hazardforge/plugins")
  string(FIND "${STEP_OUT}" "${expect}" pos)
  if(pos EQUAL -1)
    message(FATAL_ERROR "'hazardforge plugins' does not show ${expect}:\n${STEP_OUT}")
  endif()
endforeach()

file(WRITE ${WORK_DIR}/graph.yaml "name: example
nodes:
  - id: source
    stage: video
    params: {path: \"\${HAZARDFORGE_SHARED}/data/udacity-highway/test_video.mp4\", max_frames: 12}
  - id: stats
    stage: frame_stats
    inputs: {frames: source.frames}
    params: {precision: 2}
")
step(${prefix}/bin/hazardforge --plugin-path ${WORK_DIR}/example run ${WORK_DIR}/graph.yaml -o ${WORK_DIR}/run -q)
file(STRINGS ${WORK_DIR}/run/frame_stats.csv rows)
list(LENGTH rows n)
if(NOT n EQUAL 13)
  message(FATAL_ERROR "expected a header and 12 rows in frame_stats.csv, got ${n}")
endif()
list(GET rows 1 first)
if(NOT first MATCHES "^0,0\\.00,[0-9]+\\.[0-9][0-9],-1$")
  message(FATAL_ERROR "unexpected first row: ${first}")
endif()
message(STATUS "example plugin built out of tree and ran: ${first}")
