# find_package(HazardForgeSDK): the SDK library target HazardForge::sdk and hazardforge_add_plugin().
include(CMakeFindDependencyMacro)
find_dependency(OpenCV 4 COMPONENTS core)
find_dependency(nlohmann_json 3)
include(${CMAKE_CURRENT_LIST_DIR}/HazardForgeSDKTargets.cmake)
include(${CMAKE_CURRENT_LIST_DIR}/HazardForgePlugin.cmake)
# Where an installed host looks for plugins, relative to its prefix.
get_filename_component(HAZARDFORGE_PREFIX "${CMAKE_CURRENT_LIST_DIR}/../../.." ABSOLUTE)
