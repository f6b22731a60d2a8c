// sudden_stop hazard template: a lead vehicle in the ego path brakes hard to a stop.
#pragma once

#include "hazardforge/hazard/template_base.hpp"

namespace hf {

// Kind hazard_template, name sudden_stop. The lead is inserted at x = initial_distance_m, y =
// lateral_offset_m with speed_mps, or is an existing tracked object when spec.track_id names one (its
// distance, lateral offset, size and speed then come from the ObjectState). It cruises for brake_delay_s (or
// extra.brake_delay_s), then brakes with deceleration_mps2 to a stop (jerk-limited onset and release).
// Params: the shared template params plus brake_delay_s. A tracked distance counts from the scene's
// distance_origin_x (the estimator's origin).
// Proposals: where tracked objects may be taken over, the nearest tracked moving vehicle in the ego path
// brakes (track_id) when its stop reaches the target within the horizon; else an inserted car (3 in 5
// draws), truck or bus where there is room in front of the nearest in-path object: far enough ahead to be
// first seen small and slower than the ego when the request says how small
// (ProposalRequest::first_seen_max_height), else at the ego's speed; already braking when the horizon is too
// short to watch it cruise.
class SuddenStopTemplate : public hazard::KindTemplate<SuddenStopTemplate> {
 public:
  static HazardKindInfo info();
  static ComponentInfo describe();
  HazardProposal propose(const ProposalRequest& request, RandomDraw& draw) const override;

 protected:
  hazard::Design design(const hazard::PlanRequest& req, std::vector<Refusal>& reasons) const override;
};

}  // namespace hf
