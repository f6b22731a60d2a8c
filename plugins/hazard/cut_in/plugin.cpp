// Plugin entry: the cut_in hazard template.
#include "cut_in_template.hpp"
#include "hazardforge/plugin.hpp"

HAZARDFORGE_PLUGIN("cut_in", "0.1.0", "Apache-2.0", "hazard template: a vehicle cutting in ahead of the ego") {
  reg.add<hf::CutInTemplate>();
}
