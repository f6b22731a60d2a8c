// Plugin entry for the ttc_keypoints risk metric.
#include "hazardforge/plugin.hpp"
#include "ttc_keypoints_metric.hpp"

HAZARDFORGE_PLUGIN("ttc_keypoints", "0.1.0", "Apache-2.0",
                   "Time-to-collision from the scale change of keypoints inside the box") {
  reg.add<hf::TtcKeypointsMetric>();
}
