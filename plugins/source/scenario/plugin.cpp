// Plugin entry for the scenario source.
#include "hazardforge/plugin.hpp"
#include "scenario_source.hpp"

HAZARDFORGE_PLUGIN("scenario_source", "0.1.0", "Apache-2.0",
                   "scenario: the frames of a scenario package, augmented or original") {
  reg.add<hf::source::ScenarioSource>();
}
