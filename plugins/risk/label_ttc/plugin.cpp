// Plugin entry for the label TTC risk metric.
#include "hazardforge/plugin.hpp"
#include "label_ttc_metric.hpp"

HAZARDFORGE_PLUGIN("label_ttc", "0.1.0", "Apache-2.0",
                   "Reference TTC per track from KITTI tracking labels (camera-relative motion)") {
  reg.add<hf::LabelTtcMetric>();
}
