// pedestrian_crossing: kerb position, wait time solved from the ego's arrival and the target TTC.
#include "pedestrian_crossing_template.hpp"

#include <algorithm>

#include <cmath>
#include <numbers>

#include "hazardforge/hazard/proposal.hpp"
#include "hazardforge/number_text.hpp"

namespace hf {

namespace {

const SpecField<std::string> kCrossingFrom("crossing_from",
                                           "the road edge the person steps off from (equals side)",
                                           {{"enum", {"left", "right"}}});

const hazard::NoPlan refused{"pedestrian_crossing"};

}  // namespace

HazardKindInfo PedestrianCrossingTemplate::info() {
  HazardKindInfo k;
  k.kind = "pedestrian_crossing";
  k.summary = "a person steps off the kerb and crosses the ego lane";
  k.play_out =
      "waits on the kerb just beyond the road edge (|y| a little above the edge) at x = initial_distance_m, "
      "then "
      "walks across at speed_mps with heading about -90 (from the left) or +90 (from the right); "
      "extra.crossing_from equals side. The walk is timed so the person enters the ego path at the target "
      "TTC.";
  k.object_classes = {"person"};
  k.needs = {scene_condition::kSidewalks};
  k.extra_fields = {kCrossingFrom.declaration()};
  return k;
}

ComponentInfo PedestrianCrossingTemplate::describe() {
  ComponentInfo i = base_info(
      info(),
      "The person waits at the kerb on `side` at x = initial_distance_m, then walks straight across at "
      "speed_mps (jerk-limited start). The start of the walk is timed so the constant-speed ego reaches the "
      "crossing point while the person is in its path; with target_ttc_s the person enters the path when the "
      "TTC "
      "equals it. With stop_in_path the person stops in the ego path (a pedestrian who freezes in the lane) "
      "instead of walking on, so the hazard stays in the path until the ego reaches it.");
  i.params.push_back(ParamSpec::boolean("stop_in_path", false)
                         .describe("the person stops in the ego path at stop_offset_m and stays there"));
  i.params.push_back(ParamSpec::number("stop_offset_m", 0.0)
                         .range(-1.5, 1.5)
                         .describe("with stop_in_path: where the person stops, as the offset from the ego "
                                   "path's centre line towards the kerb it came from (m)"));
  return i;
}

hazard::Design PedestrianCrossingTemplate::design(const hazard::PlanRequest& req,
                                                  std::vector<Refusal>& reasons) const {
  const HazardSpec& spec = req.spec;
  const hazard::Reasons refuse{reasons, spec.kind};
  try {
    if (const std::optional<std::string> from = kCrossingFrom.get(spec); from && *from != spec.side)
      refuse(refusal::kSpec, "extra.crossing_from \"" + *from + "\" contradicts side \"" + spec.side + "\"");
  } catch (const Error& e) {
    refuse(refusal::kSpec, e.what());
  }
  const double len = req.size_lwh[0], wid = req.size_lwh[1];
  const int side = req.side_sign();
  if (side == 0) {
    refuse(refusal::kSpec,
           "side must be 'left' or 'right' (or lateral_offset_m non-zero) for pedestrian_crossing, got '" +
               spec.side + "'");
    return {};
  }
  const std::string side_name = side > 0 ? "left" : "right";
  const double edge = req.road.edge(side);
  const double y_kerb =
      std::abs(spec.lateral_offset_m) > 0.01 ? spec.lateral_offset_m : side * (edge + req.road.kerb_offset_m);
  const int dir = -side;  // walks towards the other side
  if (std::abs(y_kerb) < edge)
    refuse(refusal::kPlacement, "the start point y=" + num_text(y_kerb) + " m is on the road (the road edge on the " +
                      side_name + " is at " + num_text(edge) +
                      " m): a crossing pedestrian starts on the kerb");
  if (spec.heading_deg != 0 && std::abs(spec.heading_deg - dir * 90.0) > 45.0)
    refuse(refusal::kSpec, "heading_deg " + num_text(spec.heading_deg) + " does not cross the road from the " +
                      side_name + " (expected about " + num_text(dir * 90.0) + ")");
  const double v = spec.speed_mps;
  if (v < 0.5) refuse(refusal::kSpec, "speed_mps " + num_text(v) + " is too slow to cross (at least 0.5 m/s)");
  const double ve = req.ego_speed;
  if (ve <= req.ttc.min_closing)
    refuse(refusal::kEgoMotion, "the ego is not moving (" + num_text(ve) + " m/s): a crossing cannot close in on it");
  const double x = spec.initial_distance_m;
  const double gap0 = req.gap(x, len, 0.0);
  if (gap0 <= 0)
    refuse(refusal::kPlacement, "initial_distance_m " + num_text(x) +
                      " puts the crossing behind the ego's front bumper (gap " + num_text(gap0) + " m)");
  if (!reasons.empty()) return {};

  const std::optional<double> arrive = req.ego.time_at(gap0);  // the ego's front reaches the crossing line
  if (!arrive) {
    refuse(refusal::kEgoMotion, "the ego never reaches the crossing line " + num_text(gap0) +
                      " m ahead of its front bumper (its planned motion stops before)");
    return {};
  }
  const double t_arrive = *arrive;
  const double half = req.path_half_width(wid);
  const bool stop = req.params.get_bool("stop_in_path");
  const double stop_offset = req.params.get_double("stop_offset_m");
  if (stop && std::abs(stop_offset) >= half) {
    refuse(refusal::kSpec, "stop_offset_m " + num_text(stop_offset) +
                      " is outside the ego path (|offset| must be below " + num_text(half) + " m for a " +
                      num_text(wid) + " m wide person)");
    return {};
  }
  // Distance walked from the kerb: across the road, or to the stop point.
  const double d_walk = stop ? std::abs(y_kerb) - stop_offset : kInf;
  const double accel = req.limits.max_accel_mps2, decel = req.limits.max_decel_mps2,
               jerk = req.limits.max_jerk_mps3;
  // Waits, speeds up to `peak`; with stop_in_path cruises and brakes to stand exactly d_walk from the kerb.
  auto walk_profile = [&](double wait_s, double peak) {
    hazard::SpeedProfile w = hazard::SpeedProfile(0.0).hold(wait_s).change_speed(peak, accel, jerk);
    if (!stop) return w;
    const double speed_up = hazard::SpeedProfile(0.0).change_speed(peak, accel, jerk).end_distance();
    const double brake = hazard::SpeedProfile(peak).change_speed(0.0, decel, jerk).end_distance();
    return w.hold(std::max(0.0, (d_walk - speed_up - brake) / peak)).change_speed(0.0, decel, jerk);
  };
  double v_peak = v;
  if (stop && walk_profile(0.0, v).end_distance() > d_walk + 1e-6) {
    // Too short a walk to reach speed_mps and stop again: a slower walk (bisection on the peak speed).
    double lo = 0.0, hi = v;
    for (int i = 0; i < 60; ++i) {
      const double mid = (lo + hi) / 2;
      (walk_profile(0.0, mid).end_distance() > d_walk ? hi : lo) = mid;
    }
    v_peak = lo;
    if (v_peak < 0.5) {
      refuse(refusal::kPlacement, "the stop point is only " + num_text(d_walk) + " m from the kerb: too short a walk");
      return {};
    }
  }
  const hazard::SpeedProfile walk = walk_profile(0.0, v_peak);
  auto walk_time = [&](double d) { return walk.time_at_distance(d); };
  const double d_in = std::max(0.0, std::abs(y_kerb) - half), d_out = std::abs(y_kerb) + half;
  double wait = 0, enter = 0;
  if (spec.target_ttc_s) {
    const double target = *spec.target_ttc_s;
    const double enter_at = t_arrive - target;  // TTC = t_arrive - t while in the path
    const double t_in = *walk_time(d_in);       // the path is entered before any stop point inside it
    if (!stop && target > *walk_time(d_out) - t_in) {
      refuse(refusal::kTtcUnreachable, "target_ttc_s " + num_text(target) + " is unreachable: at " + num_text(v) +
                        " m/s the person crosses "
                        "the ego path in " +
                        num_text(*walk_time(d_out) - t_in) +
                        " s, so it leaves the path before the ego arrives");
    } else if (t_in > enter_at) {
      refuse(refusal::kTtcUnreachable,
          "target_ttc_s " + num_text(target) + " is unreachable: the person needs " + num_text(t_in) +
          " s to walk from the kerb into the ego path but would have to be in it after " +
          num_text(enter_at) + " s (the ego reaches the crossing point in " + num_text(t_arrive) + " s)");
    }
    wait = enter_at - t_in;
  } else {
    const double to_centre = stop ? walk.duration() : *walk_time(std::abs(y_kerb));
    wait = t_arrive - to_centre;
    if (wait < 0)
      refuse(refusal::kTtcUnreachable, "the person cannot reach the " + std::string(stop ? "stop point" : "lane centre") +
                        " before the ego: walking from the kerb takes " + num_text(to_centre) +
                        " s, the ego reaches the crossing point in " + num_text(t_arrive) + " s");
  }
  if (!reasons.empty()) return {};
  enter = wait + *walk_time(d_in);

  const hazard::SpeedProfile profile = walk_profile(wait, v_peak);
  hazard::Design d;
  d.motion = [profile, x, y_kerb, dir](double tau) {
    const auto st = profile.at(tau);
    hazard::ObjectMotion m;
    m.x = x;
    m.y = y_kerb + dir * st.s;
    m.vy = dir * st.v;
    m.accel = st.a;
    m.heading = dir * std::numbers::pi / 2;
    return m;
  };
  d.notes = {{"kerb_y_m", y_kerb},
             {"wait_s", wait},
             {"enters_path_s", enter},
             {"ego_arrives_s", t_arrive},
             {"walk_speed_mps", v_peak}};
  if (stop) {
    d.notes["stops_at_y_m"] = y_kerb + dir * d_walk;
    d.notes["stands_from_s"] = profile.duration();
  }
  return d;
}

namespace {

// Time for a start from rest to cover d at walking speed v (acceleration phase plus a jerk allowance).
double walk_time(double d, double v, double accel) {
  return d / v + v / (2.0 * accel) + 0.3;
}

}  // namespace

// Waits on the kerb, walks across; the ego arrives `enter + target` after the start.
HazardProposal PedestrianCrossingTemplate::propose(const ProposalRequest& request, RandomDraw& d) const {
  const hazard::ProposalScene sc = hazard::ProposalScene::of(request, *this);
  const double aim = request.aim;
  if (!sc.sidewalks && !sc.on_shoulder) return refused(refusal::kSceneLacks, "the scene has no sidewalks");
  std::string no_class;
  const std::optional<std::string> drawn = hazard::draw_class(sc, {{"person", 1}}, d, &no_class);
  if (!drawn) return refused(refusal::kObjectClass, no_class);
  const std::string cls = *drawn;
  const KinematicLimits& lim = sc.limits.at(cls);
  const hazard::Footprint size = sc.size(cls);
  const bool left = d.coin();
  const int sign = left ? 1 : -1;
  const double y0 = sign * (sc.edge(sign) + sc.road.kerb_offset_m + d.uniform(0.0, std::min(0.5, sc.sidewalk)));
  const double speed = d.uniform(1.6, std::min(2.5, lim.max_speed_mps));
  const double d_in = std::abs(y0) - sc.path_half(size.width);
  // Waits a moment before stepping off; within a short horizon only as long as still leaves time to be seen.
  const double walk = walk_time(d_in, speed, lim.max_accel_mps2);
  const double ttc = aim * sc.target;
  // The template times the walk for the spec's target (sc.target), the position is planned for `ttc`: the
  // wait must cover the difference, or the person would have to enter the path before it can.
  const double min_wait = sc.target - ttc + 0.1;
  const double enter =
      walk + std::max(min_wait, std::min(d.uniform(0.3, 1.0), std::max(0.0, sc.horizon - 0.5 - walk)));
  // A horizon too short to watch the whole walk: when allowed, the person is already on the way when the
  // hazard appears and enters the path a little into the horizon.
  double under_way = 0;
  if (enter > sc.horizon - 0.5) {
    if (sc.max_under_way <= 0)
      return refused(refusal::kTtcUnreachable, "walking into the ego path takes longer than the horizon");
    under_way = enter - d.uniform(0.3, 0.5) * sc.horizon;
    if (under_way > sc.max_under_way)
      return refused(refusal::kTtcUnreachable, "the walk would have to be under way for " +
                                                   fixed_text(under_way, 1) + " s (max_under_way_s " +
                                                   fixed_text(sc.max_under_way, 1) + ")");
  }
  // Placed where the ego's front is when the person has been in its path for `ttc`: along the ego's planned
  // motion (a recorded queue slows, a constant-speed ego does not), from the walk's start, `under_way` s
  // before the hazard appears.
  const double arrive = enter + ttc - under_way;  // s after the hazard appears
  const double x0 = sc.ego_front + size.length / 2.0 + sc.ego_travel(-under_way, arrive);
  const double x_seen = x0 - sc.ego_travel(-under_way, 0.0);  // where it is when the hazard appears
  // Where it steps into the path, seen from where the ego is then: the critical moment must be in the
  // picture, at least the person's upper half (a slowing ego reaches a TTC below the threshold only with the
  // person close to its bumper; a box cut at the bottom still gives the detector and the estimator's bearing
  // a hold).
  const double x_enter = x0 - sc.ego_travel(-under_way, enter - under_way);
  if (!sc.visible(x_enter, sign * sc.path_half(size.width), sc.sizes.at(cls).height / 2.0))
    return refused(refusal::kNotInView, "the person would step into the ego path " +
                                            fixed_text(x_enter - sc.ego_front - size.length / 2.0, 1) +
                                            " m ahead of the ego (at " +
                                            fixed_text(sc.ego_speed_at(enter - under_way), 1) +
                                            " m/s then), where not even its upper half is in the picture");
  if (x0 > 120.0) return refused(refusal::kPlacement, "the crossing would be more than 120 m ahead");
  if (!sc.visible(x_seen, y0))
    return refused(refusal::kNotInView, "the kerb point (" + fixed_text(x_seen, 1) + ", " +
                                            fixed_text(y0, 1) + ") m is outside the camera view");
  if (std::string p = sc.overlap_problem(x_seen, y0, size); !p.empty()) return refused(refusal::kTraffic, p);
  const std::string from = left ? "left" : "right";
  Json spec = hazard::proposal_spec(
      kind_info().kind, cls, x0, y0, from, speed, -sign * 90.0,
      "steps off the " + from + " kerb and crosses to the " + (left ? "right" : "left"), sc.target);
  kCrossingFrom.set(spec, from);
  const std::string where =
      sc.sidewalks ? "The scene has sidewalks, so a pedestrian stepping off the " + from + " kerb "
                   : "Edge case (no sidewalks; people on the road allowed explicitly): a person who left a "
                     "broken-down vehicle on the " +
                         from + " shoulder steps into the road ";
  spec["rationale"] =
      where + fixed_text(x0, 1) + " m ahead and crossing at " + fixed_text(speed, 1) +
      " m/s is realistic; with the ego at " + fixed_text(sc.ego_speed, 1) + " m/s now" +
      (sc.ego.is_recorded() ? " (" + fixed_text(sc.ego_speed_at(arrive), 1) + " m/s as recorded then)" : "") +
      " they are in its path about " + fixed_text(enter, 1) + " s later, TTC near " + fixed_text(ttc, 1) +
      " s.";
  if (under_way > 0) {
    spec["under_way_s"] = hazard::round_to(under_way, 0.05);
    spec["rationale"] = spec["rationale"].get<std::string>() + " The hazard appears " +
                        fixed_text(under_way, 1) + " s after the start, " + fixed_text(x_seen, 1) +
                        " m ahead, as the person sets off.";
  }
  return {spec, {}};
}

}  // namespace hf
