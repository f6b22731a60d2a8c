// stopped_vehicle: a vehicle standing in the ego lane; the ego's own motion closes the gap.
#include "stopped_vehicle_template.hpp"

#include <algorithm>
#include <cmath>

#include "hazardforge/hazard/proposal.hpp"
#include "hazardforge/number_text.hpp"

namespace hf {

HazardKindInfo StoppedVehicleTemplate::info() {
  HazardKindInfo k;
  k.kind = "stopped_vehicle";
  k.summary = "a vehicle stands still in the ego lane ahead (the end of a queue, a broken-down car)";
  k.play_out =
      "a vehicle standing in the ego lane (side center, y near 0) at initial_distance_m, speed_mps 0, aligned "
      "with the road; the ego closes in at its own speed, so the TTC is the gap over the ego speed.";
  k.object_classes = {"car", "truck", "bus", "motorcycle"};
  return k;
}

hazard::Design StoppedVehicleTemplate::design(const hazard::PlanRequest& req,
                                              std::vector<Refusal>& reasons) const {
  const HazardSpec& spec = req.spec;
  const hazard::Reasons refuse{reasons, spec.kind};
  const double x0 = spec.initial_distance_m, y0 = spec.lateral_offset_m;
  if (spec.track_id)
    refuse(refusal::kSpec, "track_id " + std::to_string(*spec.track_id) +
                               ": a stopped vehicle is inserted, it does not take over a tracked object");
  if (std::abs(spec.speed_mps) > 0.1)
    refuse(refusal::kSpec, "speed_mps " + num_text(spec.speed_mps) + ": a stopped vehicle stands (speed_mps 0)");
  const double half = req.path_half_width(req.size_lwh[1]);
  if (std::abs(y0) >= half)
    refuse(refusal::kPlacement, "the vehicle at y=" + num_text(y0) + " m is not in the ego path (|y| must be below " +
                                    num_text(half) + " m)");
  const double gap0 = req.gap(x0, req.size_lwh[0], 0.0);
  if (gap0 <= 0)
    refuse(refusal::kPlacement, "the vehicle at x=" + num_text(x0) + " m is not ahead of the ego's front bumper (gap " +
                                    num_text(gap0) + " m)");
  if (!reasons.empty()) return {};
  hazard::Design d;
  d.motion = [x0, y0](double) {
    hazard::ObjectMotion m;
    m.x = x0;
    m.y = y0;
    m.heading = 0.0;
    return m;
  };
  d.notes = {{"gap_m", gap0}};
  if (const std::optional<double> reached = req.ego_front_reaches(x0 - req.size_lwh[0] / 2))
    d.notes["ego_reaches_it_s"] = *reached;
  return d;
}

HazardProposal StoppedVehicleTemplate::propose(const ProposalRequest& request, RandomDraw& d) const {
  const hazard::ProposalScene sc = hazard::ProposalScene::of(request, *this);
  const std::string kind = kind_info().kind;
  const double latest = sc.horizon - std::min(0.7, 0.3 * sc.horizon);
  if (sc.ego_travel(0.0, latest) < 2.0)
    return {nullptr,
            {refusal::kEgoMotion,
             "the ego moves " + fixed_text(sc.ego_travel(0.0, latest), 1) +
                 " m within the horizon: it does not close in on a standing vehicle",
             kind}};
  // A car mostly; a truck or bus where one fits (first seen small farther off, it is reached later).
  return hazard::plan_some_class(kind, sc, {{"car", 4}, {"truck", 1}, {"bus", 1}}, d, [&](const std::string& cls) {
    return propose_as(cls, sc, request, d);
  });
}

HazardProposal StoppedVehicleTemplate::propose_as(const std::string& cls, const hazard::ProposalScene& sc,
                                                  const ProposalRequest& request, RandomDraw& d) const {
  using hazard::round_to;
  const std::string kind = kind_info().kind;
  const hazard::NoPlan refused{kind};
  const double ttc = request.aim * sc.target;
  const hazard::Footprint size = sc.size(cls);
  const double front = sc.ego_front + size.length / 2.0;
  // The latest the TTC may reach the target and still be watched falling below it.
  const double latest = sc.horizon - std::min(0.7, 0.3 * sc.horizon);
  // Where the TTC reaches the target a drawn share into the horizon, or, when it must be first seen small,
  // from that far (and a little more) on.
  const double t_hit = d.uniform(0.35, 0.6) * sc.horizon;
  double x0 = front + sc.ego_travel(0.0, t_hit) + ttc * sc.ego_speed_at(t_hit);
  const double small_from = sc.first_seen_small_from(cls);
  const double extra = d.uniform(0.0, 5.0);
  if (x0 < small_from) x0 = small_from + extra;
  const double reached = sc.time_ttc_falls_to(x0 - front, 0.0, ttc, sc.horizon);
  if (reached > latest)
    return refused(refusal::kTtcUnreachable,
                   "a " + cls + " standing " + fixed_text(x0 - front, 1) + " m ahead" +
                       (x0 >= small_from && small_from > 0 ? " (first seen small from " +
                                                                 fixed_text(small_from, 1) + " m)"
                                                           : std::string()) +
                       " is not reached at a TTC of " + fixed_text(ttc, 1) + " s within " + fixed_text(latest, 1) +
                       " s (the ego at " + fixed_text(sc.ego_speed, 1) + " m/s now" +
                       (sc.ego.is_recorded() ? ", as recorded after" : "") + ")");
  const double y0 = d.uniform(-0.3, 0.3);
  if (x0 > 150.0) return refused(refusal::kPlacement, "the vehicle would stand more than 150 m ahead");
  // A tracked road user driving in the ego lane short of that place would have to pass through it.
  if (const auto* o = sc.in_path_before(x0 + size.length / 2.0, 2.0))
    return refused(refusal::kTraffic, "a tracked " + o->label + " (track " + std::to_string(o->track_id) + ") " +
                                          fixed_text(o->x, 1) + " m ahead in the ego lane is short of where the " +
                                          cls + " would stand (" + fixed_text(x0, 1) + " m)");
  if (!sc.visible(x0, y0))
    return refused(refusal::kNotInView, "the place (" + fixed_text(x0, 1) + ", " + fixed_text(y0, 1) +
                                            ") m is outside the camera view");
  if (std::string p = sc.overlap_problem(x0, y0, size); !p.empty()) return refused(refusal::kTraffic, p);
  Json spec = hazard::proposal_spec(kind, cls, x0, y0, "center", 0.0, 0.0, "stands still in the ego lane ahead",
                                    sc.target);
  spec["rationale"] = "A " + cls + " standing in the ego lane " + fixed_text(x0 - front, 1) +
                      " m ahead (the end of a queue or a broken-down vehicle); the ego, at " +
                      fixed_text(sc.ego_speed, 1) + " m/s now" +
                      (sc.ego.is_recorded() ? " and as recorded after" : "") + ", reaches a TTC near " +
                      fixed_text(ttc, 1) + " s after " + fixed_text(round_to(reached, 0.1), 1) + " s.";
  return {spec, {}};
}

}  // namespace hf
