// Plugin entry: the sudden_stop hazard template.
#include "hazardforge/plugin.hpp"
#include "sudden_stop_template.hpp"

HAZARDFORGE_PLUGIN("sudden_stop", "0.1.0", "Apache-2.0",
                   "hazard template: a lead vehicle braking hard to a stop") {
  reg.add<hf::SuddenStopTemplate>();
}
