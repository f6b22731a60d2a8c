// Plugin entry: the pedestrian_crossing hazard template.
#include "hazardforge/plugin.hpp"
#include "pedestrian_crossing_template.hpp"

HAZARDFORGE_PLUGIN("pedestrian_crossing", "0.1.0", "Apache-2.0",
                   "hazard template: a pedestrian crossing the ego lane") {
  reg.add<hf::PedestrianCrossingTemplate>();
}
