# find_package(HazardForgeRealism): HazardForge::realism, the appearance-metric and cut-out kit.
include(CMakeFindDependencyMacro)
find_dependency(HazardForgeSDK)
find_dependency(OpenCV)
include(${CMAKE_CURRENT_LIST_DIR}/HazardForgeRealismTargets.cmake)
