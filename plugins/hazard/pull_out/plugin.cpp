// Plugin entry: the pull_out hazard template.
#include "hazardforge/plugin.hpp"
#include "pull_out_template.hpp"

HAZARDFORGE_PLUGIN("pull_out", "0.1.0", "Apache-2.0",
                   "hazard template: a vehicle parked at the roadside pulls out into the ego lane") {
  reg.add<hf::PullOutTemplate>();
}
