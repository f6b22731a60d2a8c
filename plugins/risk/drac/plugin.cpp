// Plugin entry for the drac risk metric.
#include "hazardforge/plugin.hpp"
#include "drac_metric.hpp"

HAZARDFORGE_PLUGIN("drac", "0.1.0", "Apache-2.0", "Deceleration rate to avoid collision") {
  reg.add<hf::DracMetric>();
}
