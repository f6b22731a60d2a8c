// Plugin entry for the thw risk metric.
#include "hazardforge/plugin.hpp"
#include "time_headway_metric.hpp"

HAZARDFORGE_PLUGIN("thw", "0.1.0", "Apache-2.0", "Time headway d / v_ego") {
  reg.add<hf::TimeHeadwayMetric>();
}
