// pedestrian_dart_out hazard template: a person hidden behind a parked vehicle of the recording runs out into the
// ego path (NHTSA pre-crash type "pedestrian dart-out": a child between parked cars).
#pragma once

#include "hazardforge/hazard/proposal.hpp"
#include "hazardforge/hazard/template_base.hpp"

namespace hf {

// Kind hazard_template, name pedestrian_dart_out. The person stands at x = initial_distance_m, y =
// lateral_offset_m (outside the ego path on `side`), waits, then runs straight across at speed_mps
// (jerk-limited start within the person limits), timed so that it enters the ego path when the TTC equals
// target_ttc_s (default: the ego reaches it as it reaches the path's centre). Params: the shared template params.
// Proposals: behind a parked vehicle the recording tracks (standing, beside the ego path, 8-60 m ahead): just
// beyond its front end on its centre line, where at least half the person's box is behind the vehicle's tracked
// box, running at 2-3.5 m/s; refused where no such vehicle is tracked, or where the ego is already too near it
// to be reached at the target TTC after the person has come out.
class PedestrianDartOutTemplate : public hazard::KindTemplate<PedestrianDartOutTemplate> {
 public:
  static HazardKindInfo info();
  HazardProposal propose(const ProposalRequest& request, RandomDraw& draw) const override;

 protected:
  hazard::Design design(const hazard::PlanRequest& req, std::vector<Refusal>& reasons) const override;
};

}  // namespace hf
