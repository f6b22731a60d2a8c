// sudden_stop: lead vehicle (inserted or tracked) cruising, then an S-curve stop with the spec's
// deceleration.
#include "sudden_stop_template.hpp"

#include <algorithm>
#include <cmath>

#include "hazardforge/hazard/proposal.hpp"
#include "hazardforge/number_text.hpp"

namespace hf {

namespace {
const SpecField<double> kBrakeDelay("brake_delay_s", "seconds the lead cruises before it brakes",
                                    {{"minimum", 0}, {"maximum", 30}});
}  // namespace

HazardKindInfo SuddenStopTemplate::info() {
  HazardKindInfo k;
  k.kind = "sudden_stop";
  k.summary = "a lead vehicle brakes hard to a stop";
  k.play_out =
      "a lead vehicle in the ego lane (side center, y near 0) at initial_distance_m driving at speed_mps, "
      "cruising for extra.brake_delay_s seconds and then braking at deceleration_mps2 to a standstill; "
      "where the rules allow taking over a detected object, track_id may name a detected vehicle to use as the "
      "lead instead.";
  k.object_classes = {"car", "truck", "bus", "motorcycle"};
  k.extra_fields = {kBrakeDelay.declaration()};
  return k;
}

ComponentInfo SuddenStopTemplate::describe() {
  ComponentInfo i = base_info(
      info(),
      "The lead is inserted at initial_distance_m (or taken from the tracked object spec.track_id), "
      "cruises for brake_delay_s, then brakes with deceleration_mps2 to a standstill (jerk-limited). The "
      "constant-speed ego closes in; the plan ends at contact.");
  i.params.push_back(hf::ParamSpec::number("brake_delay_s", 1.0)
                         .range(0, 60)
                         .describe("cruising time before braking, unless extra.brake_delay_s is given"));
  return i;
}

hazard::Design SuddenStopTemplate::design(const hazard::PlanRequest& req,
                                          std::vector<Refusal>& reasons) const {
  const HazardSpec& spec = req.spec;
  const hazard::Reasons refuse{reasons, spec.kind};
  cv::Vec3d size = req.size_lwh;
  double x0 = spec.initial_distance_m, y0 = spec.lateral_offset_m, v0 = spec.speed_mps;
  const std::optional<int64_t> track = spec.track_id;
  std::optional<double> delay_extra;
  try {
    delay_extra = kBrakeDelay.get(spec);
  } catch (const Error& e) {
    refuse(refusal::kSpec, e.what());
    return {};
  }
  if (track) {
    const ObjectState* found = nullptr;
    std::string ids;
    for (const ObjectState& s : req.scene.objects) {
      ids += (ids.empty() ? "" : ", ") + std::to_string(s.track_id);
      if (s.track_id == *track) found = &s;
    }
    if (!found) {
      refuse(refusal::kSpec, "track_id " + std::to_string(*track) + " is not among the tracked objects (" +
                                 (ids.empty() ? std::string("none are tracked") : "tracked: " + ids) + ")");
      return {};
    }
    if (!std::isfinite(found->distance_m)) {
      refuse(refusal::kTraffic, "tracked object " + std::to_string(found->track_id) + " has no distance estimate");
      return {};
    }
    if (found->length_m > 0) size[0] = found->length_m;
    if (found->width_m > 0) size[1] = found->width_m;
    // Estimators measure from the camera, the bumper or the rear axle (the states' distance_origin_x) to
    // the face they see, the lead's rear; the plan works with its centre, from the rear axle.
    const double x_anchor = found->distance_m + size[0] / 2.0 + req.scene.distance_origin_x;
    // Measured in the anchor frame; the plan works in road coordinates along the ego's path.
    const cv::Vec2d road = req.ego.to_road(x_anchor, found->lateral_m);
    x0 = road[0];
    y0 = road[1];
    if (found->velocity_rel)
      v0 = req.ego_speed + (*found->velocity_rel)[0];
    else if (found->speed_mps)
      v0 = *found->speed_mps;
  }
  const std::string who = track ? "tracked object " + std::to_string(*track) : std::string("the lead vehicle");
  if (v0 < 0.5)
    refuse(track ? refusal::kTraffic : refusal::kSpec, who + " moves at " + num_text(v0) +
                      " m/s: a sudden stop needs a moving lead (at least 0.5 m/s)");
  if (v0 > req.limits.max_speed_mps)
    refuse(refusal::kClassLimit, who + " moves at " + num_text(v0) + " m/s, above the " + req.limits.object_class +
                      " limit of " + num_text(req.limits.max_speed_mps) + " m/s");
  if (!spec.deceleration_mps2)
    refuse(refusal::kSpec, "deceleration_mps2 is missing: sudden_stop needs the braking deceleration");
  const double half = req.path_half_width(size[1]);
  if (std::abs(y0) >= half)
    refuse(refusal::kPlacement, who + " at y=" + num_text(y0) + " m is not in the ego path (|y| must be below " +
                      num_text(half) + " m)");
  const double gap0 = req.gap(x0, size[0], 0.0);
  if (gap0 <= 0)
    refuse(refusal::kPlacement, who + " at x=" + num_text(x0) + " m is not ahead of the ego's front bumper (gap " +
                      num_text(gap0) + " m)");
  if (!reasons.empty()) return {};

  const double delay = delay_extra.value_or(req.params.get_double("brake_delay_s"));
  if (delay < 0) {
    refuse(refusal::kSpec, "extra.brake_delay_s " + num_text(delay) + " is negative");
    return {};
  }
  const hazard::SpeedProfile profile = hazard::SpeedProfile(v0).hold(delay).change_speed(
      0.0, *spec.deceleration_mps2, req.limits.max_jerk_mps3);
  hazard::Design d;
  d.size_lwh = size;
  d.motion = [profile, x0, y0](double tau) {
    const auto st = profile.at(tau);
    hazard::ObjectMotion m;
    m.x = x0 + st.s;
    m.y = y0;
    m.vx = st.v;
    m.accel = st.a;
    m.heading = 0.0;
    return m;
  };
  d.notes = {{"brake_start_s", delay},
             {"standstill_s", profile.duration()},
             {"braking_distance_m", profile.end_distance() - v0 * delay},
             {"initial_speed_mps", v0}};
  if (track) d.notes["track_id"] = *track;
  return d;
}

namespace {

// First time (s) the TTC to a lead braking after `delay` falls to `ttc`, by a 20 ms replay against the ego's
// planned motion (its recorded speeds when the scene has a track: a queue that slows closes in less); kInf if
// never. A negative delay: braking began that long before (v0 is the speed before braking, gap0 the gap now).
double time_to_ttc(double gap0, const hazard::ProposalScene& sc, double v0, double delay, double decel,
                   double ttc, double horizon) {
  double gap = gap0, v = delay < 0 ? std::max(0.0, v0 + decel * delay) : v0;
  for (double t = 0; t <= horizon; t += 0.02) {
    const double ego = sc.ego_speed_at(t);
    const double closing = ego - v;
    if (gap <= 0 || (closing > 0.1 && gap / closing <= ttc)) return t;
    gap += (v - ego) * 0.02;
    if (t >= delay) v = std::max(0.0, v - decel * 0.02);
  }
  return kInf;
}

// Nothing, or why an inserted lead of footprint `size` cannot start at (x0, y0): 2 m short of the tracked
// lead's rear, in view, clear of the other tracked objects.
Refusal insert_problem(const hazard::ProposalScene& sc, const hazard::ProposalScene::Obj* lead, double x0,
                       double y0, const hazard::Footprint& size) {
  if (lead && x0 + size.length / 2.0 + 2.0 > lead->x - lead->length / 2.0)
    return {refusal::kTraffic,
            "no room to insert a lead vehicle before the " + lead->label + " at " + fixed_text(lead->x, 1) + " m",
            "sudden_stop"};
  if (!sc.visible(x0, y0))
    return {refusal::kNotInView,
            "the start point (" + fixed_text(x0, 1) + ", " + fixed_text(y0, 1) + ") m is outside the camera view",
            "sudden_stop"};
  if (std::string p = sc.overlap_problem(x0, y0, size); !p.empty()) return {refusal::kTraffic, p, "sudden_stop"};
  return {};
}

bool is_vehicle(const std::string& c) {
  const auto classes = SuddenStopTemplate::info().object_classes;
  return std::find(classes.begin(), classes.end(), c) != classes.end();
}

}  // namespace

// A tracked lead in the ego path brakes, or an inserted one if there is room.
HazardProposal SuddenStopTemplate::propose(const ProposalRequest& request, RandomDraw& d) const {
  using hazard::round_to;
  const hazard::ProposalScene sc = hazard::ProposalScene::of(request, *this);
  const std::string kind = kind_info().kind;
  const double ttc = request.aim * sc.target;
  const double delay = round_to(d.uniform(0.5, 1.5), 0.1);
  const hazard::ProposalScene::Obj* lead = nullptr;
  // Why the tracked lead could not be the one that brakes, told with whatever refuses an inserted lead.
  std::string lead_problem;
  // With the tracked lead's problem the refusal is that one's (its TTC), as it is what the scene offered.
  auto refuse = [&](const char* code, const std::string& why) -> HazardProposal {
    if (lead_problem.empty()) return {nullptr, {code, why, kind}};
    return {nullptr, {refusal::kTtcUnreachable, lead_problem + "; an inserted lead: " + why, kind}};
  };
  auto refuse_insert = [&](const Refusal& r) { return refuse(r.code.c_str(), r.text); };
  // The lead is the nearest object centred in the ego lane; the corridor also holds wide neighbours beside
  // it.
  for (const auto& o : sc.objects)
    if (o.in_path && o.x > 0 && std::abs(o.y) <= sc.path_half(0.0) && (!lead || o.x < lead->x)) lead = &o;
  const bool avoided = lead && std::find(request.avoid_tracks.begin(), request.avoid_tracks.end(),
                                         lead->track_id) != request.avoid_tracks.end();
  // A moving lead vehicle that brakes is the most natural sudden stop, where the renderer can remove the real
  // one.
  if (request.may_take_over && lead && !avoided && is_vehicle(lead->label) &&
      request.class_allowed(lead->label) && lead->speed && *lead->speed >= 0.5 &&
      sc.limits.has(lead->label)) {
    const double decel = round_to(d.uniform(0.6, 0.9) * sc.limits.at(lead->label).max_decel_mps2, 0.1);
    const double gap = lead->x - lead->length / 2.0 - sc.ego_front;
    // It brakes after the drawn delay, or at once when only that brings the TTC down in time (a queue that is
    // slowing leaves little time).
    auto in_time = [&](double after) {
      return gap > 0 && time_to_ttc(gap, sc, *lead->speed, after, decel, ttc, sc.horizon) < sc.horizon - 0.7;
    };
    const bool after_delay = in_time(delay);
    const double brake_after = after_delay ? delay : 0.0;
    const bool brakes_in_time = after_delay || in_time(0.0);
    if (!brakes_in_time)
      lead_problem = "the " + lead->label + " (track " + std::to_string(lead->track_id) + ") " +
                     fixed_text(gap, 1) + " m ahead at " + fixed_text(*lead->speed, 1) +
                     " m/s cannot bring the TTC to " + fixed_text(ttc, 1) + " s by braking within the " +
                     fixed_text(sc.horizon, 1) + " s horizon (the ego at " + fixed_text(sc.ego_speed, 1) +
                     " m/s now" + (sc.ego.is_recorded() ? ", as recorded after" : "") + ")";
    if (brakes_in_time) {
      Json spec = hazard::proposal_spec(kind, lead->label, lead->x, lead->y, "center", *lead->speed, 0.0,
                                        "the tracked lead brakes hard in the ego lane", sc.target);
      spec["side"] = std::abs(lead->y) <= sc.path_half(0.0) ? "center" : (lead->y > 0 ? "left" : "right");
      spec["deceleration_mps2"] = decel;
      kBrakeDelay.set(spec, brake_after);
      spec["track_id"] = lead->track_id;
      spec["rationale"] = "The " + lead->label + " (track " + std::to_string(lead->track_id) + ") " +
                          fixed_text(lead->x, 1) + " m ahead in the ego lane brakes at " +
                          fixed_text(decel, 1) + " m/s^2 after " + fixed_text(brake_after, 1) +
                          " s; the ego, at " + fixed_text(sc.ego_speed, 1) +
                          " m/s now, closes in to a TTC near " + fixed_text(ttc, 1) + " s.";
      return {spec, {}};
    }
  }
  // Which vehicle: mostly cars, among the classes the renderer can draw.
  std::string no_class;
  const std::optional<std::string> drawn =
      hazard::draw_class(sc, {{"car", 3}, {"truck", 1}, {"bus", 1}}, d, &no_class);
  if (!drawn) return refuse(refusal::kObjectClass, no_class);
  const std::string cls = *drawn;
  const hazard::Footprint size = sc.size(cls);
  const double speed = std::min(sc.ego_speed, sc.limits.at(cls).max_speed_mps);
  const double decel = round_to(d.uniform(0.6, 0.9) * sc.limits.at(cls).max_decel_mps2, 0.1);
  if (speed < 1.0) return refuse(refusal::kEgoMotion, "a lead vehicle cannot brake from standstill");
  const bool short_horizon = sc.max_under_way > 0 && delay + 1.0 > sc.horizon - 0.7;
  if (const double small_from = sc.first_seen_small_from(cls); small_from > 0) {
    // Appearing in the ego lane, it must be first seen small: a slower lead far ahead (the end of a queue, a
    // car slowing for something) that brakes soon after it appears, or is already braking when the horizon is
    // short.
    const double front = sc.ego_front + size.length / 2.0;
    const double x0 = std::max(small_from, front + 1.0) + d.uniform(0.0, 8.0);
    const double v_now = std::min(sc.limits.at(cls).max_speed_mps, sc.ego_speed * d.uniform(0.2, 0.7));
    const double y0 = d.uniform(-0.3, 0.3);
    const double b = short_horizon ? std::min(sc.max_under_way, d.uniform(0.3, 0.8)) : 0.0;
    const double v_start = v_now + decel * b;  // its speed when it began to brake
    const double gap_now = x0 - front;
    if (v_now < 0.5)
      return refuse(refusal::kEgoMotion, "the ego is too slow for a slower lead to brake in front of it");
    if (v_start > sc.limits.at(cls).max_speed_mps)
      return refuse(refusal::kClassLimit, "the lead would have braked from above its limit");
    const double t = time_to_ttc(gap_now, sc, v_start, b > 0 ? -b : delay, decel, ttc, sc.horizon);
    if (t > sc.horizon - std::min(0.7, 0.3 * sc.horizon))
      return refuse(refusal::kTtcUnreachable, "a lead first seen small (from " + fixed_text(small_from, 1) +
                    " m) cannot bring the TTC to " + fixed_text(ttc, 1) + " s within the horizon");
    if (const Refusal p = insert_problem(sc, lead, x0, y0, size); !p.empty()) return refuse_insert(p);
    // The spec states the manoeuvre's start: b s before, the gap was larger by what the ego closed since.
    const double gap_start = gap_now + sc.ego_speed * b - (v_start * b - decel * b * b / 2.0);
    Json spec = hazard::proposal_spec(kind, cls, front + gap_start, y0, "center", v_start, 0.0,
                                      "drives slower ahead in the ego lane, then brakes hard", sc.target);
    spec["deceleration_mps2"] = decel;
    kBrakeDelay.set(spec, b > 0 ? 0.0 : delay);
    spec["rationale"] = "A " + cls + " " + fixed_text(x0, 1) + " m ahead in the ego lane at " +
                        fixed_text(v_now, 1) + " m/s, slower than the ego, brakes at " +
                        fixed_text(decel, 1) + " m/s^2" +
                        (b > 0 ? " (braking for " + fixed_text(b, 1) + " s when it appears)"
                               : " after " + fixed_text(delay, 1) + " s") +
                        "; the TTC falls to about " + fixed_text(ttc, 1) + " s.";
    if (b > 0) spec["under_way_s"] = round_to(b, 0.05);
    return {spec, {}};
  }
  if (short_horizon) {
    // A horizon too short to watch a lead cruise and then brake: it has been braking for `b` s when it
    // appears, following at the ego's speed until then, and the TTC reaches the target `t_hit` s in.
    const double b = std::min(sc.max_under_way, d.uniform(0.3, 0.8));
    const double t_hit = d.uniform(0.3, 0.5) * sc.horizon;
    const double gap_now = decel * (b * t_hit + t_hit * t_hit / 2.0) + ttc * decel * (b + t_hit);
    const double gap_start = gap_now + decel * b * b / 2.0;  // the closing covered while braking before
    const double x0 = sc.ego_front + size.length / 2.0 + gap_start;
    const double y0 = d.uniform(-0.3, 0.3);
    if (time_to_ttc(gap_now, sc, speed, -b, decel, ttc, sc.horizon) > sc.horizon - 0.7)
      return refuse(refusal::kTtcUnreachable, "the stop would come too late within the horizon");
    if (const Refusal p = insert_problem(sc, lead, x0, y0, size); !p.empty()) return refuse_insert(p);
    Json spec = hazard::proposal_spec(kind, cls, x0, y0, "center", speed, 0.0,
                                      "follows in the ego lane and is already braking hard when it appears",
                                      sc.target);
    spec["deceleration_mps2"] = decel;
    kBrakeDelay.set(spec, 0.0);
    spec["under_way_s"] = round_to(b, 0.05);
    spec["rationale"] =
        "A " + cls + " following " + fixed_text(gap_start, 1) + " m ahead of the ego at the same " +
        fixed_text(speed, 1) + " m/s has been braking at " + fixed_text(decel, 1) + " m/s^2 for " +
        fixed_text(b, 1) + " s when it appears " + fixed_text(gap_now, 1) +
        " m ahead; the TTC falls to about " + fixed_text(ttc, 1) + " s " + fixed_text(t_hit, 1) + " s later.";
    return {spec, {}};
  }
  // Same speed as the ego: the gap holds until braking starts, then TTC = gap / closing falls.
  const double t_star = std::min(d.uniform(1.0, 2.5), 0.8 * speed / decel);
  const double gap = decel * t_star * t_star / 2.0 + decel * ttc * t_star;
  const double x0 = sc.ego_front + size.length / 2.0 + gap;
  const double y0 = d.uniform(-0.3, 0.3);
  if (x0 < 4.0 || x0 > 120.0) return refuse(refusal::kPlacement, "no start distance within [4, 120] m");
  if (time_to_ttc(gap, sc, speed, delay, decel, ttc, sc.horizon) > sc.horizon - 0.7)
    return refuse(refusal::kTtcUnreachable, "the stop would come too late within the horizon");
  if (const Refusal p = insert_problem(sc, lead, x0, y0, size); !p.empty()) return refuse_insert(p);
  Json spec = hazard::proposal_spec(kind, cls, x0, y0, "center", speed, 0.0,
                                    "drives ahead in the ego lane, then brakes hard", sc.target);
  spec["deceleration_mps2"] = decel;
  kBrakeDelay.set(spec, delay);
  spec["rationale"] = "A " + cls + " driving " + fixed_text(gap, 1) + " m ahead of the ego at the same " +
                      fixed_text(speed, 1) + " m/s brakes at " + fixed_text(decel, 1) + " m/s^2 after " +
                      fixed_text(delay, 1) + " s; the TTC falls to about " + fixed_text(ttc, 1) + " s.";
  return {spec, {}};
}

}  // namespace hf
