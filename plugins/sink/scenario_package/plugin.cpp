// Plugin entry for the scenario package sink.
#include "hazardforge/plugin.hpp"
#include "scenario_package_sink.hpp"

HAZARDFORGE_PLUGIN(
    "scenario_package", "0.1.0", "Apache-2.0",
    "scenario_package: a hazard run's frames and labels, for testing a system and dataset export") {
  reg.add<hf::sinks::ScenarioPackageSink>();
}
