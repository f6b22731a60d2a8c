// sudden_stop hazard template: a lead vehicle in the ego path brakes hard to a stop.
#pragma once

#include "hazardforge/hazard/template_base.hpp"

namespace hf {

// Kind hazard_template, name sudden_stop. The lead is inserted at x = initial_distance_m, y =
// lateral_offset_m with speed_mps, or is an existing tracked object when spec.extra.track_id names one (its
// distance, lateral offset, size and speed then come from the ObjectState). It cruises for brake_delay_s (or
// extra.brake_delay_s), then brakes with deceleration_mps2 to a stop (jerk-limited onset and release).
// Params: the shared template params plus brake_delay_s and track_distance_origin (camera | bumper |
// ego_origin: what a tracked distance is measured from).
class SuddenStopTemplate : public hazard::TemplateBase {
 public:
  static ComponentInfo describe();
  std::string hazard_kind() const override { return "sudden_stop"; }

 protected:
  std::vector<std::string> allowed_classes() const override { return {"car", "truck", "bus", "motorcycle"}; }
  hazard::Design design(const hazard::PlanRequest& req, std::vector<std::string>& reasons) const override;
};

}  // namespace hf
