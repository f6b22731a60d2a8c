# find_package(HazardForgeHazardCommon): HazardForge::hazard_common, the kinematics kit for hazard templates.
include(CMakeFindDependencyMacro)
find_dependency(HazardForgeSDK)
include(${CMAKE_CURRENT_LIST_DIR}/HazardForgeHazardCommonTargets.cmake)
