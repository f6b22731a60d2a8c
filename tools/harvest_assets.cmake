# Harvests the shared nuScenes scene's annotated road users into an asset folder, as the README's main job does:
# at set-up, the photographic default appearances (OPTIONAL: skipped with a message when the shared data is
# absent), and for the tests, the folder the shipped scenario configs name (scene.assets.dir = $HAZARDFORGE_ASSETS).
#   cmake -DEXE=<hazardforge> -DCONFIG=<configs/harvest_assets.yaml> -DOUT=<folder> -DSHARED=<default shared>
#         [-DOPTIONAL=ON -DSTAMP=<file touched on success>] -P harvest_assets.cmake
if(DEFINED ENV{HAZARDFORGE_SHARED} AND NOT "$ENV{HAZARDFORGE_SHARED}" STREQUAL "")
  set(SHARED "$ENV{HAZARDFORGE_SHARED}")
endif()
if(OPTIONAL AND NOT EXISTS "${SHARED}/data/nuscenes/v1.0-mini/scene.json")
  message(STATUS "No shared nuScenes data at ${SHARED}: the photographic default appearances are not built "
                 "(the generated default set stands in)")
  return()
endif()
file(REMOVE_RECURSE "${OUT}")
execute_process(COMMAND ${CMAKE_COMMAND} -E env "HAZARDFORGE_SHARED=${SHARED}"
                        "${EXE}" assets harvest -o "${OUT}" --config "${CONFIG}"
                RESULT_VARIABLE rc)
if(NOT rc EQUAL 0 OR NOT EXISTS "${OUT}/assets.yaml")
  message(FATAL_ERROR "harvesting the assets into ${OUT} failed (exit ${rc})")
endif()
if(DEFINED STAMP)
  file(TOUCH "${STAMP}")
endif()
