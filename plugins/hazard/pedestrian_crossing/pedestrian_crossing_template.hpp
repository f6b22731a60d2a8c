// pedestrian_crossing hazard template: a person steps off the kerb and walks across the ego lane.
#pragma once

#include "hazardforge/hazard/template_base.hpp"

namespace hf {

// Kind hazard_template, name pedestrian_crossing. The person waits at the kerb on `side` (or at
// lateral_offset_m) at x = initial_distance_m, then accelerates (jerk-limited) to speed_mps and walks
// straight across (or, with stop_in_path, stops in the ego path and stays there). The wait is timed so the
// planned ego (its recorded track, else constant speed) reaches the crossing point while the person is in its
// path: with target_ttc_s the person enters the path when the TTC equals it; without, the person is on the
// lane centre (at the stop point) when the ego arrives. Params: the shared template params (see
// TemplateBase::base_info), stop_in_path, stop_offset_m.
// Proposals: the person waits just beyond the road edge on a random side (1.6-2.5 m/s), timed to enter the path
// at aim x target TTC; already walking when the horizon is too short to watch the wait.
class PedestrianCrossingTemplate : public hazard::KindTemplate<PedestrianCrossingTemplate> {
 public:
  static HazardKindInfo info();
  static ComponentInfo describe();
  HazardProposal propose(const ProposalRequest& request, RandomDraw& draw) const override;

 protected:
  hazard::Design design(const hazard::PlanRequest& req, std::vector<Refusal>& reasons) const override;
};

}  // namespace hf
