# find_package(HazardForgeFootage): HazardForge::footage, camera horizon and ego motion from monocular footage.
include(CMakeFindDependencyMacro)
find_dependency(HazardForgeSDK)
find_dependency(OpenCV COMPONENTS core imgproc video features2d calib3d)
include(${CMAKE_CURRENT_LIST_DIR}/HazardForgeFootageTargets.cmake)
