# Test fixture: harvests the nuScenes appearance assets the shipped scenario configs name (scene.assets.dir =
# $HAZARDFORGE_ASSETS), exactly as the README's main job does, into a folder of the build tree.
#   cmake -DEXE=<hazardforge> -DCONFIG=<configs/harvest_assets.yaml> -DOUT=<folder> -DSHARED=<default shared> -P
if(DEFINED ENV{HAZARDFORGE_SHARED} AND NOT "$ENV{HAZARDFORGE_SHARED}" STREQUAL "")
  set(SHARED "$ENV{HAZARDFORGE_SHARED}")
endif()
file(REMOVE_RECURSE "${OUT}")
execute_process(COMMAND ${CMAKE_COMMAND} -E env "HAZARDFORGE_SHARED=${SHARED}"
                        "${EXE}" assets harvest -o "${OUT}" --config "${CONFIG}"
                RESULT_VARIABLE rc)
if(NOT rc EQUAL 0 OR NOT EXISTS "${OUT}/assets.yaml")
  message(FATAL_ERROR "harvesting the test assets into ${OUT} failed (exit ${rc})")
endif()
