// Plugin entry for the ttc_scale risk metric.
#include "hazardforge/plugin.hpp"
#include "ttc_scale_metric.hpp"

HAZARDFORGE_PLUGIN("ttc_scale", "0.1.0", "Apache-2.0", "Time-to-collision from the box's image scale rate") {
  reg.add<hf::TtcScaleMetric>();
}
