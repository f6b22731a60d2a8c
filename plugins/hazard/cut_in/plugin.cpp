// Plugin entry: the cut_in hazard template.
#include "hazardforge/plugin.hpp"
#include "cut_in_template.hpp"

HAZARDFORGE_PLUGIN("cut_in", "0.1.0", "Apache-2.0",
                   "hazard template: a vehicle cutting in ahead of the ego") {
  reg.add<hf::CutInTemplate>();
}
