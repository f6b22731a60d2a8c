// pull_out hazard template: a vehicle parked at the roadside pulls out into the ego lane ahead (NHTSA pre-crash
// types "vehicle(s) parking" / "leaving a parking position": a parked car, a delivery van, a bus leaving its stop).
#pragma once

#include "hazardforge/hazard/kinematics.hpp"
#include "hazardforge/hazard/proposal.hpp"
#include "hazardforge/hazard/template_base.hpp"

namespace hf {

// The pull-out manoeuvre, x = 0 at the parking place: standing for `after` s, then driving off (jerk-limited)
// to `speed` while it steers from lateral offset y0 into the ego lane's centre (minimum-jerk shift once it rolls,
// stretched until its turn rate is within the class limit).
struct PullOutShape {
  hazard::SpeedProfile profile;
  double y0 = 0, after = 0, steer_start = 0, steer_s = 0;
  hazard::ObjectMotion at(double tau) const;
  // When its centre first comes within `half` of the ego lane's centre (the ego path's half width for its
  // width): nullopt if never.
  std::optional<double> enters(double half) const;
  // Where a vehicle of this width parks on a side (+1 left, -1 right): in the parking strip just beyond the
  // outermost lane there (the road edge plus half its width and 0.3 m).
  static double parking_offset(const RoadLayout& road, int side, double width);
  // The shape for a vehicle of class limits `lim`; empty with `why` set when the limits do not allow it.
  static std::optional<PullOutShape> make(double y0, double after, double speed, const KinematicLimits& lim,
                                          std::string& why);
};

// Kind hazard_template, name pull_out. The vehicle stands at x = initial_distance_m beside the road on `side`
// (lateral_offset_m, default PullOutShape::parking_offset), speed_mps 0, aligned with the road;
// after extra.pull_out_after_s (param pull_out_after_s) it drives off to extra.pull_out_speed_mps (param
// pull_out_speed_mps) at up to 2.5 m/s^2 (or 70 % of the class limit) while steering into the ego lane. Params: the
// shared template params plus those two.
// Proposals: a car (4 in 6 draws), truck or bus (another class when the drawn one does not fit) parked at a road
// edge the ego lane borders (the kerb, three times in four where the far edge of a one-way or divided road
// borders it too; hazard::ProposalScene::edge_sides), in view from the start like anything beside the road; it drives off after 0.3-1 s and
// is placed so that the TTC is the aimed one (ProposalRequest::aim x target) as it enters the ego path (already
// pulling out when it appears, under_way_s, where the horizon is too short for the whole manoeuvre); refused
// where a lane lies beside the ego lane on either side (the vehicle would merge into it), when it cannot enter the
// path within the horizon, when the ego is not faster than the vehicle once it pulls out, when a tracked road user drives in the ego lane
// short of the place, or when the place is out of view or taken.
class PullOutTemplate : public hazard::KindTemplate<PullOutTemplate> {
 public:
  static HazardKindInfo info();
  static ComponentInfo describe();
  HazardProposal propose(const ProposalRequest& request, RandomDraw& draw) const override;

 protected:
  hazard::Design design(const hazard::PlanRequest& req, std::vector<Refusal>& reasons) const override;

 private:
  HazardProposal propose_as(const std::string& cls, int side, const hazard::ProposalScene& sc,
                            const ProposalRequest& request, RandomDraw& d) const;
};

}  // namespace hf
