// stopped_vehicle hazard template: a vehicle standing still in the ego lane ahead (NHTSA pre-crash type "lead
// vehicle stopped": the end of a queue, a broken-down or turning car waiting in the lane).
#pragma once

#include "hazardforge/hazard/proposal.hpp"
#include "hazardforge/hazard/template_base.hpp"

namespace hf {

// Kind hazard_template, name stopped_vehicle. The vehicle stands at x = initial_distance_m, y =
// lateral_offset_m (in the ego path), speed_mps 0, aligned with the road; the ego closes in at its own (recorded
// or constant) speed. Params: the shared template params.
// Proposals: a car (4 in 6 draws), truck or bus (another class when the drawn one does not fit) centred in the ego lane, placed so that the TTC (gap over the
// ego's speed) reaches the target 35-60 % into the horizon, or further out when it must be first seen small
// (ProposalRequest::first_seen_max_height); refused when the ego does not close in within the horizon (it
// stands or crawls), when a tracked vehicle drives in the ego lane before that place (it would have to pass
// through it), or when the place is out of view or taken.
class StoppedVehicleTemplate : public hazard::KindTemplate<StoppedVehicleTemplate> {
 public:
  static HazardKindInfo info();
  HazardProposal propose(const ProposalRequest& request, RandomDraw& draw) const override;

 protected:
  hazard::Design design(const hazard::PlanRequest& req, std::vector<Refusal>& reasons) const override;

 private:
  HazardProposal propose_as(const std::string& cls, const hazard::ProposalScene& sc,
                            const ProposalRequest& request, RandomDraw& d) const;
};

}  // namespace hf
