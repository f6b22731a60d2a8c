// Plugin entry: the hazard_planner stage.
#include "hazardforge/plugin.hpp"
#include "hazard_planner.hpp"

HAZARDFORGE_PLUGIN("hazard_planner", "0.1.0", "Apache-2.0",
                   "plans hazard trajectories with hazard templates") {
  reg.add<hf::HazardPlanner>();
}
