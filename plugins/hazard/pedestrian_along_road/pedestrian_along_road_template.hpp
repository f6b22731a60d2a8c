// pedestrian_along_road hazard template: a person walking along the edge of the road in the ego lane, where there
// is no pavement or it is not used (NHTSA pre-crash type "pedestrian walking along the roadway": a rural road, a
// jogger, someone walking back to a broken-down car).
#pragma once

#include "hazardforge/hazard/proposal.hpp"
#include "hazardforge/hazard/template_base.hpp"

namespace hf {

// Kind hazard_template, name pedestrian_along_road. The person walks at speed_mps along the road from x =
// initial_distance_m, y = lateral_offset_m (inside the ego path, near the ego lane's edge), heading_deg 0 (the
// ego's way, back to the ego) or 180 (towards it); the ego closes in at its own speed minus (or plus) the
// person's. Params: the shared template params.
// Proposals: a person 0.3-0.6 m inside the ego path's edge at a road edge the ego lane borders (the kerb, three
// times in four where the far edge of a one-way or divided road borders it too), walking the ego's way at 1.1-1.7
// m/s (or towards it, 1 in 4 draws), placed where the TTC reaches the target 35-60 % into the horizon or from where
// a person is first seen small; refused where a lane lies beside the ego lane on either side (the person would
// walk in another lane), where the ego does not close in within the horizon, or where a tracked road user drives
// in the ego lane short of the person.
class PedestrianAlongRoadTemplate : public hazard::KindTemplate<PedestrianAlongRoadTemplate> {
 public:
  static HazardKindInfo info();
  HazardProposal propose(const ProposalRequest& request, RandomDraw& draw) const override;

 protected:
  hazard::Design design(const hazard::PlanRequest& req, std::vector<Refusal>& reasons) const override;
};

}  // namespace hf
