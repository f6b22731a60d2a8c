// Plugin entry: the pedestrian_dart_out hazard template.
#include "hazardforge/plugin.hpp"
#include "pedestrian_dart_out_template.hpp"

HAZARDFORGE_PLUGIN("pedestrian_dart_out", "0.1.0", "Apache-2.0",
                   "hazard template: a person darts out from behind a parked vehicle") {
  reg.add<hf::PedestrianDartOutTemplate>();
}
