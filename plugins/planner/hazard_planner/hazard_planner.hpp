// hazard_planner stage: turns the generator's hazard spec into a trajectory with the template for its kind.
#pragma once

#include <string>

#include "hazardforge/stage.hpp"

namespace hf {

// Stage hazard_planner (kind planner).
// Inputs: `hazard` (HazardSpec, sticky), `frames` (Frame), `states` (ObjectStates, optional: tracked objects
// a template may build on, e.g. sudden_stop with track_id). Output: `trajectory` (HazardTrajectory),
// emitted once per distinct spec at the first frame whose timestamp is
// >= spec.start_time_s; that frame is the anchor (the trajectory's frame of reference) and stamps the packet.
// Also writes <output>/trajectory.json atomically (trajectory_<n>.json for the n-th spec of a run).
// Params: templates (kind -> that template's params), ego_speed_mps (used when neither the frame nor the
// states carry the ego speed; -1 = none), on_infeasible (error | skip), file.
class HazardPlanner : public Stage {
 public:
  static ComponentInfo describe();
  void open(StageContext& ctx) override;
  void process(StageContext& ctx, const Inputs& in, Outputs& out) override;

 private:
  Json templates_ = Json::object();
  double ego_speed_param_ = -1;
  bool skip_infeasible_ = false;
  std::string file_;
  std::string last_spec_;
  int planned_ = 0;
};

}  // namespace hf
