// Plugin entry for the footage harvester sink.
#include "footage_harvester.hpp"
#include "hazardforge/plugin.hpp"

HAZARDFORGE_PLUGIN("footage_harvester", "0.1.0", "Apache-2.0",
                   "footage_harvester: appearances cut from a recording's own tracked road users") {
  reg.add<hf::render::FootageHarvester>();
}
