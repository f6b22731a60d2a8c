// Plugin entry: the pedestrian_along_road hazard template.
#include "hazardforge/plugin.hpp"
#include "pedestrian_along_road_template.hpp"

HAZARDFORGE_PLUGIN("pedestrian_along_road", "0.1.0", "Apache-2.0",
                   "hazard template: a person walking along the road's edge in the ego lane") {
  reg.add<hf::PedestrianAlongRoadTemplate>();
}
