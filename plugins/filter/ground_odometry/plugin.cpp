// Plugin entry: ego motion from the frames (ground-plane odometry).
#include "hazardforge/plugin.hpp"
#include "ground_odometry_stage.hpp"

HAZARDFORGE_PLUGIN("ground_odometry", "0.1.0", "Apache-2.0",
                   "ego speed and yaw rate from the frames' road view, for sources without ego motion") {
  reg.add<hf::filter::GroundOdometryStage>();
}
