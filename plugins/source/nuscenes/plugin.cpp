// Plugin entry: the nuScenes dataset source.
#include "hazardforge/plugin.hpp"
#include "nuscenes_source.hpp"

HAZARDFORGE_PLUGIN("nuscenes", "0.1.0", "Apache-2.0",
                   "nuScenes keyframes with calibration, ego poses and annotations") {
  reg.add<hf::source::NuScenesSource>();
}
