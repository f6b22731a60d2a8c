// Plugin entry for the lidar TTC risk metric.
#include "hazardforge/plugin.hpp"
#include "lidar_ttc_metric.hpp"

HAZARDFORGE_PLUGIN("lidar_ttc", "0.1.0", "Apache-2.0",
                   "Lead-vehicle range and TTC from Velodyne points inside camera boxes (KITTI raw)") {
  reg.add<hf::LidarTtcMetric>();
}
