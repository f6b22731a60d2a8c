// Plugin entry: the hazard_planner stage.
#include "hazard_planner.hpp"
#include "hazardforge/plugin.hpp"

HAZARDFORGE_PLUGIN("hazard_planner", "0.1.0", "Apache-2.0", "plans hazard trajectories with hazard templates") {
  reg.add<hf::HazardPlanner>();
}
