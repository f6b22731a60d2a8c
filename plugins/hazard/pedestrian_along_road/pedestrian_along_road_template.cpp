// pedestrian_along_road: a person walking along the road's edge inside the ego path; the ego closes in.
#include "pedestrian_along_road_template.hpp"

#include <algorithm>
#include <cmath>

#include "hazardforge/angles.hpp"
#include "hazardforge/number_text.hpp"

namespace hf {

namespace {

// +1 walking the ego's way, -1 towards the ego, 0 neither (within 20 deg of the road's direction).
int walking_direction(double heading_deg) {
  const double h = std::abs(wrap_deg(heading_deg));
  return h <= 20.0 ? 1 : h >= 160.0 ? -1 : 0;
}


}  // namespace

HazardKindInfo PedestrianAlongRoadTemplate::info() {
  HazardKindInfo k;
  k.kind = "pedestrian_along_road";
  k.summary = "a person walks along the edge of the road in the ego lane";
  k.play_out =
      "a person walking along the road at its edge, inside the ego path (lateral_offset_m on the side of the "
      "road edge the ego lane borders, |y| about 1 m), from initial_distance_m at speed_mps (a walk, 1-2 m/s), "
      "heading_deg 0 (the ego's way, back to the ego) or 180 (towards the ego); the ego closes in.";
  k.object_classes = {"person"};
  return k;
}

hazard::Design PedestrianAlongRoadTemplate::design(const hazard::PlanRequest& req,
                                                   std::vector<Refusal>& reasons) const {
  const HazardSpec& spec = req.spec;
  const hazard::Reasons refuse{reasons, spec.kind};
  const double x0 = spec.initial_distance_m, y0 = spec.lateral_offset_m, v = spec.speed_mps;
  const int dir = walking_direction(spec.heading_deg);
  if (dir == 0)
    refuse(refusal::kSpec, "heading_deg " + num_text(spec.heading_deg) +
                               ": a person walking along the road heads 0 (the ego's way) or 180 (towards it)");
  if (spec.track_id)
    refuse(refusal::kSpec, "track_id " + std::to_string(*spec.track_id) +
                               ": the walking person is inserted, it does not take over a tracked object");
  if (v < 0) refuse(refusal::kSpec, "speed_mps " + num_text(v) + " is negative");
  const double half = req.path_half_width(req.size_lwh[1]);
  if (std::abs(y0) >= half)
    refuse(refusal::kPlacement, "the person at y=" + num_text(y0) + " m is not in the ego path (|y| must be below " +
                                    num_text(half) + " m)");
  const int side = y0 >= 0 ? 1 : -1;
  if (std::abs(y0) + req.size_lwh[1] / 2 > req.road.edge(side))
    refuse(refusal::kPlacement, "the person at y=" + num_text(y0) + " m is off the road (its edge on the " +
                                    (side > 0 ? "left" : "right") + " is at " + num_text(req.road.edge(side)) +
                                    " m)");
  const double gap0 = req.gap(x0, req.size_lwh[0], 0.0);
  if (gap0 <= 0)
    refuse(refusal::kPlacement, "the person at x=" + num_text(x0) + " m is not ahead of the ego's front bumper (gap " +
                                    num_text(gap0) + " m)");
  if (!reasons.empty()) return {};
  hazard::Design d;
  const double heading = dir > 0 ? 0.0 : kPi;
  d.motion = [x0, y0, v, dir, heading](double tau) {
    hazard::ObjectMotion m;
    m.x = x0 + dir * v * tau;
    m.y = y0;
    m.vx = dir * v;
    m.heading = heading;
    return m;
  };
  d.notes = {{"gap_m", gap0}, {"walking", dir > 0 ? "the ego's way" : "towards the ego"}};
  return d;
}

HazardProposal PedestrianAlongRoadTemplate::propose(const ProposalRequest& request, RandomDraw& d) const {
  const hazard::ProposalScene sc = hazard::ProposalScene::of(request, *this);
  const std::string kind = kind_info().kind;
  const hazard::NoPlan refused{kind};
  std::string no_class;
  const std::optional<std::string> drawn = hazard::draw_class(sc, {{"person", 1}}, d, &no_class);
  if (!drawn) return refused(refusal::kObjectClass, no_class);
  const std::string cls = *drawn;
  // At a road edge the ego lane borders (the kerb, or a one-way or divided road's far edge): elsewhere a person
  // walking at the edge is not in the ego path.
  const int sign = sc.draw_edge_side(d);
  if (sign == 0)
    return refused(refusal::kSceneLacks,
                   sc.no_edge_side() + ": a person walking at the road's edge would not be in the ego path");
  const std::string side = sign > 0 ? "left" : "right";
  const hazard::Footprint size = sc.size(cls);
  const double half = sc.path_half(size.width);
  const double y0 = sign * std::min(half - d.uniform(0.3, 0.6), sc.edge(sign) - size.width / 2.0 - 0.2);
  if (sign * y0 <= 0) return refused(refusal::kPlacement, "the ego lane leaves no room to walk at its edge");
  const int dir = d.index(4) == 0 ? -1 : 1;
  const double v = std::min(sc.limits.at(cls).max_speed_mps, d.uniform(1.1, 1.7));
  const double ttc = request.aim * sc.target;
  const double front = sc.ego_front + size.length / 2.0;
  const double latest = sc.horizon - std::min(0.7, 0.3 * sc.horizon);
  if (sc.ego_speed_at(0.0) - dir * v < 0.5 && sc.ego_speed_at(latest) - dir * v < 0.5)
    return refused(refusal::kEgoMotion, "the ego (" + fixed_text(sc.ego_speed, 1) +
                                            " m/s) is not faster than a person walking its way");
  // Where the TTC reaches the target a drawn share into the horizon, or from where a person is first seen small.
  const double t_hit = d.uniform(0.35, 0.6) * sc.horizon;
  double x0 = front + sc.ego_travel(0.0, t_hit) - dir * v * t_hit + ttc * (sc.ego_speed_at(t_hit) - dir * v);
  const double small_from = sc.first_seen_small_from(cls);
  const double extra = d.uniform(0.0, 5.0);
  if (x0 < small_from) x0 = small_from + extra;
  const double reached = sc.time_ttc_falls_to(x0 - front, dir * v, ttc, sc.horizon);
  if (reached > latest)
    return refused(refusal::kTtcUnreachable,
                   "a person walking " + std::string(dir > 0 ? "the ego's way " : "towards the ego ") +
                       fixed_text(x0 - front, 1) + " m ahead is not reached at a TTC of " + fixed_text(ttc, 1) +
                       " s within " + fixed_text(latest, 1) + " s (the ego at " + fixed_text(sc.ego_speed, 1) +
                       " m/s now" + (sc.ego.is_recorded() ? ", as recorded after" : "") + ")");
  if (x0 > 120.0) return refused(refusal::kPlacement, "the person would be more than 120 m ahead");
  if (const auto* o = sc.in_path_before(x0, 2.0))
    return refused(refusal::kTraffic, "a tracked " + o->label + " (track " + std::to_string(o->track_id) + ") " +
                                          fixed_text(o->x, 1) + " m ahead in the ego lane is short of the person (" +
                                          fixed_text(x0, 1) + " m)");
  if (!sc.visible(x0, y0))
    return refused(refusal::kNotInView, "the person's place (" + fixed_text(x0, 1) + ", " + fixed_text(y0, 1) +
                                            ") m is outside the camera view");
  if (std::string p = sc.overlap_problem(x0, y0, size); !p.empty()) return refused(refusal::kTraffic, p);
  const std::string walking = dir > 0 ? "walks along the " + side + " edge of the road, the ego's way"
                                      : "walks along the " + side + " edge of the road towards the ego";
  Json spec = hazard::proposal_spec(kind, cls, x0, y0, side, v, dir > 0 ? 0.0 : 180.0, walking, sc.target);
  spec["rationale"] = "A person " + walking + " at " + fixed_text(v, 1) + " m/s, " + fixed_text(x0 - front, 1) +
                      " m ahead inside the ego path (the ego lane borders the road edge there); the ego at " +
                      fixed_text(sc.ego_speed, 1) + " m/s now reaches a TTC near " + fixed_text(ttc, 1) + " s after " +
                      fixed_text(hazard::round_to(reached, 0.1), 1) + " s.";
  return {spec, {}};
}

}  // namespace hf
