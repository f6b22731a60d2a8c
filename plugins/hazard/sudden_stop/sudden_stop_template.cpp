// sudden_stop: lead vehicle (inserted or tracked) cruising, then an S-curve stop with the spec's
// deceleration.
#include "sudden_stop_template.hpp"

#include <cmath>

namespace hf {

using hazard::num;

ComponentInfo SuddenStopTemplate::describe() {
  ComponentInfo i = base_info("sudden_stop", "a lead vehicle brakes hard to a stop");
  i.doc =
      "The lead is inserted at initial_distance_m (or taken from the tracked object spec.extra.track_id), "
      "cruises "
      "for brake_delay_s, then brakes with deceleration_mps2 to a standstill (jerk-limited). The "
      "constant-speed "
      "ego closes in; the plan ends at contact.";
  i.params.push_back(hf::ParamSpec::number("brake_delay_s", 1.0)
                         .range(0, 60)
                         .describe("cruising time before braking, unless extra.brake_delay_s is given"));
  i.params.push_back(hf::ParamSpec::string("track_distance_origin", "camera")
                         .one_of({"camera", "bumper", "ego_origin"})
                         .describe("where a tracked object's distance_m is measured from (the estimator's "
                                   "distance_origin)"));
  return i;
}

namespace {
// extra.<field> as a number: absent -> nullopt; present but not numeric -> a reason.
std::optional<double> extra_number(const HazardSpec& spec, const char* field,
                                   std::vector<std::string>& reasons) {
  if (!spec.extra.contains(field)) return std::nullopt;
  const Json& v = spec.extra[field];
  if (v.is_number()) return v.get<double>();
  if (v.is_string()) {
    try {
      size_t used = 0;
      const double d = std::stod(v.get<std::string>(), &used);
      if (used == v.get<std::string>().size()) return d;
    } catch (const std::exception&) {
    }
  }
  reasons.push_back(std::string("extra.") + field + " must be a number, got " + v.dump());
  return std::nullopt;
}
}  // namespace

hazard::Design SuddenStopTemplate::design(const hazard::PlanRequest& req,
                                          std::vector<std::string>& reasons) const {
  const HazardSpec& spec = req.spec;
  cv::Vec3d size = req.size_lwh;
  double x0 = spec.initial_distance_m, y0 = spec.lateral_offset_m, v0 = spec.speed_mps;
  const std::optional<double> track = extra_number(spec, "track_id", reasons);
  const std::optional<double> delay_extra = extra_number(spec, "brake_delay_s", reasons);
  if (!reasons.empty()) return {};
  if (track) {
    const ObjectState* found = nullptr;
    std::string ids;
    for (const ObjectState& s : req.scene.objects) {
      ids += (ids.empty() ? "" : ", ") + std::to_string(s.track_id);
      if (s.track_id == static_cast<int64_t>(*track)) found = &s;
    }
    if (!found) {
      reasons.push_back("extra.track_id " + num(*track, 0) + " is not among the tracked objects (" +
                        (ids.empty() ? std::string("none are tracked") : "tracked: " + ids) + ")");
      return {};
    }
    if (!std::isfinite(found->distance_m)) {
      reasons.push_back("tracked object " + std::to_string(found->track_id) + " has no distance estimate");
      return {};
    }
    // Estimators measure from the camera, the bumper or the rear axle (their distance_origin); the plan works
    // from the rear axle.
    const std::string origin = req.params.get_string("track_distance_origin");
    const double x_anchor = found->distance_m + (origin == "camera"   ? req.scene.camera.t_ego_cam[0]
                                                 : origin == "bumper" ? req.ttc.ego_front
                                                                      : 0.0);
    // Measured in the anchor frame; the plan works in road coordinates along the ego's path.
    const cv::Vec2d road = req.ego.to_road(x_anchor, found->lateral_m);
    x0 = road[0];
    y0 = road[1];
    if (found->length_m > 0) size[0] = found->length_m;
    if (found->width_m > 0) size[1] = found->width_m;
    if (found->velocity_rel)
      v0 = req.ego_speed + (*found->velocity_rel)[0];
    else if (found->speed_mps)
      v0 = *found->speed_mps;
  }
  const std::string who = track ? "tracked object " + num(*track, 0) : std::string("the lead vehicle");
  if (v0 < 0.5)
    reasons.push_back(who + " moves at " + num(v0) +
                      " m/s: a sudden stop needs a moving lead (at least 0.5 m/s)");
  if (v0 > req.limits.max_speed_mps)
    reasons.push_back(who + " moves at " + num(v0) + " m/s, above the " + req.limits.object_class +
                      " limit of " + num(req.limits.max_speed_mps) + " m/s");
  if (!spec.deceleration_mps2)
    reasons.push_back("deceleration_mps2 is missing: sudden_stop needs the braking deceleration");
  const double half = req.path_half_width(size[1]);
  if (std::abs(y0) >= half)
    reasons.push_back(who + " at y=" + num(y0) + " m is not in the ego path (|y| must be below " + num(half) +
                      " m)");
  const double gap0 = req.gap(x0, size[0], 0.0);
  if (gap0 <= 0)
    reasons.push_back(who + " at x=" + num(x0) + " m is not ahead of the ego's front bumper (gap " +
                      num(gap0) + " m)");
  if (!reasons.empty()) return {};

  const double delay = delay_extra.value_or(req.params.get_double("brake_delay_s"));
  if (delay < 0) {
    reasons.push_back("extra.brake_delay_s " + num(delay) + " is negative");
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
  if (track) d.notes["track_id"] = static_cast<int64_t>(*track);
  return d;
}

}  // namespace hf
