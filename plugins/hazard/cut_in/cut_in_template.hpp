// cut_in hazard template: a faster vehicle overtakes in the adjacent lane and cuts in close ahead of the ego.
#pragma once

#include "hazardforge/hazard/template_base.hpp"

namespace hf {

// Kind hazard_template, name cut_in. The vehicle starts beside or behind the ego in the adjacent lane on
// `side` (or at lateral_offset_m), x = initial_distance_m, at speed_mps (faster than the ego). It passes,
// then changes into the ego lane with a minimum-jerk lateral shift while braking (jerk-limited) to its final
// speed (extra.final_speed_mps, else ego speed - closing_speed_mps). Timed so that at the end of the lane
// change the gap to the ego is target_ttc_s x closing speed, i.e. the TTC equals target_ttc_s, and that gap
// is inside the ego's stopping distance. Params: the shared template params plus closing_speed_mps,
// cut_in_decel_mps2, default_target_ttc_s, ego_reaction_s, ego_max_decel_mps2, lane_change_s.
// Proposals: a car (3 in 5 draws), motorcycle or truck in a random side's same-direction lane, 3-5 m/s faster
// than the ego, braking to 2-4 m/s below it; already under way when the horizon is too short for it, and then,
// where hazards must come into view plausibly, still beside the ego at the image border when it appears.
class CutInTemplate : public hazard::KindTemplate<CutInTemplate> {
 public:
  static HazardKindInfo info();
  static ComponentInfo describe();
  HazardProposal propose(const ProposalRequest& request, RandomDraw& draw) const override;

 protected:
  bool start_must_be_visible() const override { return false; }
  bool enters_from_border(const ProposalRequest& request, const std::string& cls, double x0, double y0, double v0,
                          double v1, double decel, double under_way) const;
  hazard::Design design(const hazard::PlanRequest& req, std::vector<Refusal>& reasons) const override;
};

}  // namespace hf
