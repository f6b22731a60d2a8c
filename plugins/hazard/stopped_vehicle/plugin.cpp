// Plugin entry: the stopped_vehicle hazard template.
#include "hazardforge/plugin.hpp"
#include "stopped_vehicle_template.hpp"

HAZARDFORGE_PLUGIN("stopped_vehicle", "0.1.0", "Apache-2.0",
                   "hazard template: a vehicle standing still in the ego lane ahead") {
  reg.add<hf::StoppedVehicleTemplate>();
}
