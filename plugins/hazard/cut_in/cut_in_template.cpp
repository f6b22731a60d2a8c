// cut_in: overtaking phase, braking S-curve and min-jerk lane change, solved for the gap that gives the
// target TTC.
#include "cut_in_template.hpp"

#include <cmath>
#include <numbers>

#include "hazardforge/hazard/proposal.hpp"
#include "hazardforge/number_text.hpp"

namespace hf {

namespace {
// The class's jerk limit shared between braking and the lane change: |(0.8, 0.6)| = 1.
constexpr double kLongitudinalJerkShare = 0.8, kLateralJerkShare = 0.6;

const SpecField<double> kFinalSpeed("final_speed_mps",
                                    "speed after braking in front of the ego (below the ego speed)",
                                    {{"minimum", 0}, {"maximum", 50}});

const hazard::NoPlan refused{"cut_in"};
}  // namespace

HazardKindInfo CutInTemplate::info() {
  HazardKindInfo k;
  k.kind = "cut_in";
  k.summary = "a vehicle overtakes in the adjacent lane and cuts in close ahead";
  k.play_out =
      "starts beside or behind the ego in the adjacent lane (y about one lane width, x between -10 and 3 m), "
      "faster than the ego (speed_mps above the ego speed), overtakes, then changes into the ego lane while "
      "braking (deceleration_mps2, or null for the default) to extra.final_speed_mps, below the ego speed.";
  k.object_classes = {"car", "truck", "bus", "motorcycle"};
  k.needs = {scene_condition::kSameDirectionLane};
  k.extra_fields = {kFinalSpeed.declaration()};
  return k;
}

ComponentInfo CutInTemplate::describe() {
  ComponentInfo i = base_info(
      info(),
      "Starts beside or behind the ego in the adjacent lane, passes, then changes into the ego lane "
      "(minimum-jerk lateral shift within the class's lateral speed/acceleration/jerk and turn-rate limits) "
      "while braking to a final speed below the ego's. At the end of the lane change the TTC equals "
      "target_ttc_s "
      "and the gap is inside the ego's stopping distance.");
  i.params.push_back(
      hf::ParamSpec::number("closing_speed_mps", 3.0)
          .range(0.2, 30)
          .describe("final speed = ego speed minus this, unless extra.final_speed_mps is given"));
  i.params.push_back(hf::ParamSpec::number("cut_in_decel_mps2", 3.0)
                         .range(0.1, 15)
                         .describe("braking during the cut-in, unless the spec gives deceleration_mps2"));
  i.params.push_back(hf::ParamSpec::number("default_target_ttc_s", 1.2)
                         .range(0.1, 10)
                         .describe("TTC at the end of the lane change when the spec gives no target_ttc_s"));
  i.params.push_back(
      hf::ParamSpec::number("ego_reaction_s", 1.0).range(0, 5).describe("ego reaction time (s)"));
  i.params.push_back(hf::ParamSpec::number("ego_max_decel_mps2", 7.0)
                         .range(1, 15)
                         .describe("ego braking for its stopping distance"));
  i.params.push_back(hf::ParamSpec::number("lane_change_s", 0.0)
                         .range(0, 20)
                         .describe("lane-change duration (s); 0 = the shortest the class limits allow"));
  return i;
}

hazard::Design CutInTemplate::design(const hazard::PlanRequest& req,
                                     std::vector<Refusal>& reasons) const {
  const HazardSpec& spec = req.spec;
  const hazard::Reasons refuse{reasons, spec.kind};
  const Params& p = req.params;
  const KinematicLimits& lim = req.limits;
  const double len = req.size_lwh[0], wid = req.size_lwh[1];
  const int side = req.side_sign();
  if (side == 0) {
    refuse(refusal::kSpec,
           "side must be 'left' or 'right' (or lateral_offset_m non-zero) for cut_in, got '" + spec.side + "'");
    return {};
  }
  const std::string side_name = side > 0 ? "left" : "right";
  const double y0 =
      std::abs(spec.lateral_offset_m) > 0.01 ? spec.lateral_offset_m : side * req.road.lane_width_m;
  const double half = req.path_half_width(wid);
  if (std::abs(y0) < half)
    refuse(refusal::kPlacement, "the start point y=" + num_text(y0) + " m is already in the ego path (|y| < " +
                      num_text(half) + " m)");
  const double edge = req.road.edge(side);
  if (std::abs(y0) + wid / 2 > edge)
    refuse(refusal::kPlacement, "the start point y=" + num_text(y0) + " m is off the road (the road edge on the " +
                      side_name + " is at " + num_text(edge) + " m with lanes_" + side_name + "=" +
                      std::to_string(side > 0 ? req.road.lanes_left : req.road.lanes_right) + ")");
  const double x0 = spec.initial_distance_m;
  const hazard::BoxView start = hazard::view_of(req.scene.camera, req.ego, x0, y0, 0.0, req.size_lwh);
  if (start.in_front && start.inside_fraction > 0.999)
    refuse(refusal::kNotInView, "the vehicle starts fully in view (x=" + num_text(x0) + " m, y=" + num_text(y0) +
                      " m): a cut-in starts beside or behind the ego, out of view or at the image edge");
  const double ve = req.ego_speed, v0 = spec.speed_mps;
  if (v0 <= ve)
    refuse(refusal::kSpec, "speed_mps " + num_text(v0) + " does not exceed the ego speed " + num_text(ve) +
                      " m/s: a cut-in vehicle must overtake");
  double v1 = std::max(0.0, ve - p.get_double("closing_speed_mps"));
  try {
    if (const std::optional<double> given = kFinalSpeed.get(spec)) v1 = *given;
  } catch (const Error& e) {
    refuse(refusal::kSpec, e.what());
    return {};
  }
  if (v1 < 0) refuse(refusal::kSpec, "extra.final_speed_mps " + num_text(v1) + " is negative");
  if (v1 >= ve)
    refuse(refusal::kSpec, "the final speed " + num_text(v1) + " m/s is not below the ego speed " + num_text(ve) +
                      " m/s: the cut-in would never close in");
  if (!reasons.empty()) return {};

  const double decel = spec.deceleration_mps2.value_or(p.get_double("cut_in_decel_mps2"));
  const double target = spec.target_ttc_s.value_or(p.get_double("default_target_ttc_s"));
  const double jerk_long = kLongitudinalJerkShare * lim.max_jerk_mps3,
               jerk_lat = kLateralJerkShare * lim.max_jerk_mps3;
  const double gap_end = target * (ve - v1);
  const double reaction = p.get_double("ego_reaction_s"), ego_decel = p.get_double("ego_max_decel_mps2");
  const double stopping = ve * reaction + ve * ve / (2 * ego_decel);
  if (gap_end >= stopping)
    refuse(refusal::kTtcUnreachable, "the cut-in would end " + num_text(gap_end) +
                      " m ahead, beyond the ego's stopping distance " + num_text(stopping) + " m (reaction " +
                      num_text(reaction) + " s, braking " + num_text(ego_decel) + " m/s^2)");

  // Solve the overtaking time t_b so the braking ends exactly gap_end ahead of the ego. The gap at the end
  // grows with t_b while the vehicle outpaces the ego (v0 > ego speed), so bisection finds it; on a
  // constant-speed ego this is the closed form (gap_end + front + l/2 + ve T - x0 - s_slow) / (v0 - ve).
  const hazard::SpeedProfile slow = hazard::SpeedProfile(v0).change_speed(v1, decel, jerk_long);
  auto end_gap = [&](double tb) {
    return req.gap(x0 + v0 * tb + slow.end_distance(), len, tb + slow.duration()) - gap_end;
  };
  double t_brake = 0;
  if (end_gap(0.0) > 0) {
    // Negative: how long before the hazard starts it would have had to brake (constant-speed estimate).
    t_brake = -end_gap(0.0) / (v0 - ve);
  } else {
    double lo = 0, hi = std::max(1.0, req.duration);
    for (int i = 0; i < 8 && end_gap(hi) < 0; ++i) hi *= 2;
    if (end_gap(hi) < 0) {
      refuse(refusal::kEgoMotion, "at " + num_text(v0) + " m/s the vehicle never gets " + num_text(gap_end) +
                        " m ahead of the ego (which reaches " + num_text(req.ego.at(hi).speed) +
                        " m/s): it cannot overtake");
      return {};
    }
    for (int i = 0; i < 80; ++i) {
      const double mid = (lo + hi) / 2;
      (end_gap(mid) < 0 ? lo : hi) = mid;
    }
    t_brake = (lo + hi) / 2;
  }
  if (t_brake < 0)
    refuse(refusal::kPlacement, "the vehicle cannot end " + num_text(gap_end) + " m in front of the ego: from x=" +
                      num_text(x0) + " m at " + num_text(v0) + " m/s it would have to start braking " +
                      num_text(-t_brake) + " s before the hazard starts");
  if (!reasons.empty()) return {};
  const hazard::SpeedProfile profile =
      hazard::SpeedProfile(v0).hold(t_brake).change_speed(v1, decel, jerk_long);
  const double t_end = profile.duration();

  auto motion_with = [profile, x0, y0](double lane_start, double lane_dur) {
    return [=](double tau) {
      const auto st = profile.at(tau);
      const hazard::Shift sh = hazard::min_jerk_shift(-y0, lane_dur, tau - lane_start);
      hazard::ObjectMotion m;
      m.x = x0 + st.s;
      m.y = y0 + sh.p;
      m.vx = st.v;
      m.vy = sh.v;
      m.accel = st.a;
      return m;
    };
  };
  // Shortest lane change the lateral limits allow, stretched until the turn rate (which grows as the vehicle
  // slows) is within the class limit too.
  const double shortest =
      hazard::min_jerk_duration(y0, lim.max_lateral_speed_mps, lim.max_lateral_accel_mps2, jerk_lat);
  double lane_dur = std::max(shortest, p.get_double("lane_change_s"));
  if (p.get_double("lane_change_s") > 0 && p.get_double("lane_change_s") < shortest)
    refuse(refusal::kClassLimit, "lane_change_s " + num_text(p.get_double("lane_change_s")) + " is shorter than the " +
                      num_text(shortest) + " s the " + lim.object_class + " lateral limits allow");
  for (int iter = 0; iter < 40; ++iter) {
    const auto m = motion_with(t_end - lane_dur, lane_dur);
    double peak = 0, prev = 0;
    const int steps = 200;
    const double dt = lane_dur / steps;
    for (int k = 0; k <= steps; ++k) {
      const auto s = m(t_end - lane_dur + k * dt);
      const double h = std::atan2(s.vy, s.vx);
      if (k > 0) peak = std::max(peak, std::abs(h - prev) / dt);
      prev = h;
    }
    if (peak * 180 / std::numbers::pi <= 0.95 * lim.max_yaw_rate_dps) break;
    lane_dur *= 1.1;
  }
  const double lane_start = t_end - lane_dur;
  if (lane_start < 0)
    refuse(refusal::kPlacement, "the lane change needs " + num_text(lane_dur) +
                      " s but the vehicle reaches its cut-in point " + num_text(t_end) +
                      " s after the hazard starts: start it further behind");
  if (!reasons.empty()) return {};
  const hazard::MotionFn motion = motion_with(lane_start, lane_dur);

  // It must have passed before it enters the ego path, or this is a side swipe, not a cut-in.
  double lo = lane_start, hi = t_end;
  for (int i = 0; i < 60; ++i) {
    const double mid = (lo + hi) / 2;
    (std::abs(motion(mid).y) < half ? hi : lo) = mid;
  }
  const double t_enter = hi;
  const double gap_enter = req.gap(motion(t_enter).x, len, t_enter);
  if (gap_enter <= 0)
    refuse(refusal::kPlacement, "the vehicle would enter the ego path beside the ego (gap " + num_text(gap_enter) +
                      " m at " + num_text(t_enter) + " s): it has not passed yet");
  const hazard::ObjectMotion end = motion(t_end);
  if (!hazard::view_from_anchor(req, end.x, end.y, 0.0, req.size_lwh).centre_inside)
    refuse(refusal::kNotInView, "the cut-in point (x=" + num_text(end.x) + " m at " + num_text(t_end) +
                      " s) is out of the camera's view");
  if (!reasons.empty()) return {};

  hazard::Design d;
  d.motion = motion;
  d.notes = {{"brake_start_s", t_brake},  {"lane_change_start_s", lane_start},
             {"lane_change_s", lane_dur}, {"enters_path_s", t_enter},
             {"cut_in_end_s", t_end},     {"gap_at_end_m", gap_end},
             {"final_speed_mps", v1},     {"ego_stopping_distance_m", stopping},
             {"target_ttc_s", target}};
  return d;
}

// Whether the plan of this cut-in, under way for `under_way` s when it appears, starts with the vehicle at
// the image border (partly out of view), i.e. coming into view rather than appearing in it.
bool CutInTemplate::enters_from_border(const ProposalRequest& request, const std::string& cls, double x0,
                                       double y0, double v0, double v1, double decel,
                                       double under_way) const {
  if (under_way <= 0) return true;
  HazardSpec spec;
  spec.kind = kind_info().kind;
  spec.object_class = cls;
  spec.initial_distance_m = x0;
  spec.lateral_offset_m = y0;
  spec.side = y0 > 0 ? "left" : "right";
  spec.speed_mps = v0;
  spec.start_time_s = request.scene.timestamp;
  spec.deceleration_mps2 = decel;
  spec.target_ttc_s = request.target_ttc_s;
  spec.extra = {{kFinalSpeed.name(), v1}};
  spec.under_way_s = under_way;
  const hazard::PlanOutcome plan = evaluate(spec, request.scene);
  if (!plan.reasons.empty() || plan.trajectory.points.empty()) return false;
  const TrajectoryPoint& p = plan.trajectory.points.front();
  const hazard::BoxView v =
      hazard::view_of(request.scene.camera, p.x, p.y, p.heading, plan.trajectory.size_lwh);
  return !v.in_front || v.inside_fraction < 0.98;
}

// Overtakes from beside/behind at v0 > ego, then brakes to v1 < ego while changing lanes. In slow traffic
// (the ego below 5 m/s: a queue) a vehicle from the next lane squeezes into the gap ahead of the ego and
// stops there.
HazardProposal CutInTemplate::propose(const ProposalRequest& request, RandomDraw& d) const {
  const hazard::ProposalScene sc = hazard::ProposalScene::of(request, *this);
  if (!sc.multi_lane) return refused(refusal::kSceneLacks, "the road has a single lane");
  if (sc.ego_speed < 1.0)
    return refused(refusal::kEgoMotion, "the ego is (nearly) standing: nothing cuts in ahead of it");
  const bool queue = sc.ego_speed < 5.0;
  // Which vehicle: mostly cars, among the classes the renderer can draw.
  std::string no_class;
  const std::optional<std::string> drawn =
      hazard::draw_class(sc, {{"car", 3}, {"motorcycle", 1}, {"truck", 1}}, d, &no_class);
  if (!drawn) return refused(refusal::kObjectClass, no_class);
  const std::string cls = *drawn;
  const KinematicLimits& lim = sc.limits.at(cls);
  const hazard::Footprint size = sc.size(cls);
  // A side has room when its adjacent lane exists and goes the ego's way.
  auto room = [&](int side) {
    return sc.edge(side) >= sc.road.lane_width_m + size.width / 2.0 && sc.road.same_direction_lanes(side) > 0;
  };
  bool left = d.coin();
  if (!room(left ? 1 : -1)) left = !left;
  const int sign = left ? 1 : -1;
  if (!room(sign)) return refused(refusal::kSceneLacks, "there is no lane going the ego's way beside the ego lane");
  const double y0 = sign * sc.road.lane_width_m;
  // In a queue it keeps rolling slower than the ego at the end (a vehicle cannot move sideways while
  // standing), and brakes gently so that the long, slow lane change fits. The numbers as the spec states them
  // (its precision), so that the plan of the spec is the one timed here. Faster than the ego all along: than
  // the fastest it goes from the earliest start of a manoeuvre already under way to the end of the horizon.
  double ego_fastest = sc.ego_speed;
  for (double t = -sc.max_under_way; t <= sc.horizon; t += 0.25)
    ego_fastest = std::max(ego_fastest, sc.ego_speed_at(t));
  const double v0 = hazard::round_to(
      std::min(ego_fastest + (queue ? d.uniform(2.0, 3.5) : d.uniform(3.0, 5.0)), lim.max_speed_mps), 0.05);
  const double v1 = hazard::round_to(
      queue ? sc.ego_speed * d.uniform(0.3, 0.5) : std::max(0.0, sc.ego_speed - d.uniform(2.0, 4.0)), 0.05);
  const double decel =
      hazard::round_to(std::min(queue ? d.uniform(0.8, 1.5) : d.uniform(2.5, 4.0), lim.max_decel_mps2), 0.1);
  if (v0 <= ego_fastest + 1.0) return refused(refusal::kClassLimit, "a " + cls + " cannot overtake the ego here");
  // The plan ends the braking at the spec's target TTC, after which the TTC keeps falling (the vehicle is
  // slower).
  const double ttc = sc.target;
  const double gap_end = ttc * (sc.ego_speed - v1);
  // Braking from v0 to v1 with the plan's jerk-limited profile, then the lane change must fit between the
  // start and the end of braking.
  const hazard::SpeedProfile slow =
      hazard::SpeedProfile(v0).change_speed(v1, decel, kLongitudinalJerkShare * lim.max_jerk_mps3);
  const double t_slow = slow.duration();
  const double s_slow = slow.end_distance();
  const double lane_change = 1.15 * 1.875 * sc.road.lane_width_m / std::max(0.5, lim.max_lateral_speed_mps);
  const double t_brake = std::max(0.5, lane_change - t_slow + 0.5) + d.uniform(0.0, 1.0);
  const double manoeuvre = t_brake + t_slow;
  // Where it starts, ahead of the ego at the manoeuvre's start (`start` s from now; before now for a hazard
  // already under way) so that its braking ends gap_end ahead: the ego's travel meanwhile is its planned
  // motion's (a recorded track that slows or speeds up changes it), as the plan will measure it.
  auto start_x = [&](double start) {
    return gap_end + sc.ego_front + size.length / 2.0 + sc.ego_travel(start, start + manoeuvre) - s_slow -
           v0 * t_brake;
  };
  auto fits = [](double x) { return x >= -25.0 && x <= 3.0; };
  auto no_start = [&](double x) {
    return refused(refusal::kPlacement, "no start beside or behind the ego fits (x " + fixed_text(x, 1) + " m)");
  };
  double x0 = start_x(0.0);
  // A horizon too short for the whole manoeuvre: when allowed, it is already under way when it appears and
  // the lane change ends a little into the horizon — later when it must come into view plausibly, so that it
  // is still beside the ego, at the image border, when it appears.
  double under_way = 0;
  if (manoeuvre > sc.horizon - 0.5) {
    if (sc.max_under_way <= 0) return refused(refusal::kTtcUnreachable, "the cut-in takes longer than the horizon");
    double end =
        (request.first_seen_max_height > 0 ? d.uniform(0.55, 0.8) : d.uniform(0.3, 0.5)) * sc.horizon;
    if (request.first_seen_max_height > 0) {
      // It must come into view from the image border: the lane change ends later (the vehicle is further back
      // when it appears) until the plan starts with the vehicle at the border, still beside the ego.
      for (; end <= sc.horizon - 0.2; end += 0.05 * sc.horizon) {
        x0 = start_x(end - manoeuvre);
        if (fits(x0) && enters_from_border(request, cls, x0, y0, v0, v1, decel, manoeuvre - end)) break;
      }
      if (end > sc.horizon - 0.2)
        return fits(x0) ? refused(refusal::kNotInView,
                                  "no start already under way comes into view from the image border")
                        : no_start(x0);
    }
    under_way = manoeuvre - end;
    x0 = start_x(-under_way);
    if (under_way > sc.max_under_way)
      return refused(refusal::kTtcUnreachable, "the cut-in would have to be under way for " +
                                                   fixed_text(under_way, 1) + " s (max_under_way_s " +
                                                   fixed_text(sc.max_under_way, 1) + ")");
  }
  if (!fits(x0)) return no_start(x0);
  if (under_way == 0)
    if (std::string p = sc.overlap_problem(x0, y0, size); !p.empty()) return refused(refusal::kTraffic, p);
  const std::string side = left ? "left" : "right";
  Json spec = hazard::proposal_spec(kind_info().kind, cls, x0, y0, side, v0, 0.0,
                                    "overtakes in the " + side + " lane and cuts in, braking", sc.target);
  spec["deceleration_mps2"] = decel;
  kFinalSpeed.set(spec, v1);
  spec["rationale"] =
      queue ? "In slow traffic a " + cls + " in the " + side + " lane, moving at " + fixed_text(v0, 1) +
                  " m/s, squeezes into the gap ahead of the ego, slowing to " + fixed_text(v1, 1) +
                  " m/s, about " + fixed_text(gap_end, 1) + " m ahead; TTC near " + fixed_text(ttc, 1) + " s."
            : "On a multi-lane road a " + cls + " overtakes in the " + side + " lane at " +
                  fixed_text(v0, 1) + " m/s and cuts in ahead of the ego, braking to " + fixed_text(v1, 1) +
                  " m/s; it ends about " + fixed_text(gap_end, 1) + " m ahead, TTC near " +
                  fixed_text(ttc, 1) + " s.";
  if (under_way > 0) {
    spec["under_way_s"] = hazard::round_to(under_way, 0.05);
    spec["rationale"] = spec["rationale"].get<std::string>() + " It appears " + fixed_text(under_way, 1) +
                        " s into the manoeuvre, already changing lanes beside-ahead of the ego.";
  }
  return {spec, {}};
}

}  // namespace hf
