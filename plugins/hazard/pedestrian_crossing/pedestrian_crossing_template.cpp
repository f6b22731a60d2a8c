// pedestrian_crossing: kerb position, wait time solved from the ego's arrival and the target TTC.
#include "pedestrian_crossing_template.hpp"

#include <cmath>
#include <numbers>

namespace hf {

using hazard::num;

ComponentInfo PedestrianCrossingTemplate::describe() {
  ComponentInfo i = base_info("pedestrian_crossing", "a person steps off the kerb and crosses the ego lane");
  i.doc =
      "The person waits at the kerb on `side` at x = initial_distance_m, then walks straight across at "
      "speed_mps "
      "(jerk-limited start). The start of the walk is timed so the constant-speed ego reaches the crossing "
      "point "
      "while the person is in its path; with target_ttc_s the person enters the path when the TTC equals it. "
      "With stop_in_path the person stops in the ego path (a pedestrian who freezes in the lane) instead of "
      "walking on, so the hazard stays in the path until the ego reaches it.";
  i.params.push_back(ParamSpec::boolean("stop_in_path", false)
                         .describe("the person stops in the ego path at stop_offset_m and stays there"));
  i.params.push_back(ParamSpec::number("stop_offset_m", 0.0)
                         .range(-1.5, 1.5)
                         .describe("with stop_in_path: where the person stops, as the offset from the ego "
                                   "path's centre line towards the kerb it came from (m)"));
  return i;
}

hazard::Design PedestrianCrossingTemplate::design(const hazard::PlanRequest& req,
                                                  std::vector<std::string>& reasons) const {
  const HazardSpec& spec = req.spec;
  const double len = req.size_lwh[0], wid = req.size_lwh[1];
  const int side = req.side_sign();
  if (side == 0) {
    reasons.push_back(
        "side must be 'left' or 'right' (or lateral_offset_m non-zero) for pedestrian_crossing, got '" +
        spec.side + "'");
    return {};
  }
  const std::string side_name = side > 0 ? "left" : "right";
  const double edge = req.road.edge(side);
  const double y_kerb =
      std::abs(spec.lateral_offset_m) > 0.01 ? spec.lateral_offset_m : side * (edge + req.road.kerb_offset);
  const int dir = -side;  // walks towards the other side
  if (std::abs(y_kerb) < edge)
    reasons.push_back("the start point y=" + num(y_kerb) + " m is on the road (the road edge on the " +
                      side_name + " is at " + num(edge) + " m): a crossing pedestrian starts on the kerb");
  if (spec.heading_deg != 0 && std::abs(spec.heading_deg - dir * 90.0) > 45.0)
    reasons.push_back("heading_deg " + num(spec.heading_deg) + " does not cross the road from the " +
                      side_name + " (expected about " + num(dir * 90.0) + ")");
  const double v = spec.speed_mps;
  if (v < 0.5) reasons.push_back("speed_mps " + num(v) + " is too slow to cross (at least 0.5 m/s)");
  const double ve = req.ego_speed;
  if (ve <= req.ttc.min_closing)
    reasons.push_back("the ego is not moving (" + num(ve) + " m/s): a crossing cannot close in on it");
  const double x = spec.initial_distance_m;
  const double gap0 = req.gap(x, len, 0.0);
  if (gap0 <= 0)
    reasons.push_back("initial_distance_m " + num(x) +
                      " puts the crossing behind the ego's front bumper (gap " + num(gap0) + " m)");
  if (!reasons.empty()) return {};

  const std::optional<double> arrive = req.ego.time_at(gap0);  // the ego's front reaches the crossing line
  if (!arrive) {
    reasons.push_back("the ego never reaches the crossing line " + num(gap0) +
                      " m ahead of its front bumper (its planned motion stops before)");
    return {};
  }
  const double t_arrive = *arrive;
  const double half = req.path_half_width(wid);
  const bool stop = req.params.get_bool("stop_in_path");
  const double stop_offset = req.params.get_double("stop_offset_m");
  if (stop && std::abs(stop_offset) >= half) {
    reasons.push_back("stop_offset_m " + num(stop_offset) +
                      " is outside the ego path (|offset| must be below " + num(half) + " m for a " +
                      num(wid) + " m wide person)");
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
      reasons.push_back("the stop point is only " + num(d_walk) + " m from the kerb: too short a walk");
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
      reasons.push_back("target_ttc_s " + num(target) + " is unreachable: at " + num(v) +
                        " m/s the person crosses "
                        "the ego path in " +
                        num(*walk_time(d_out) - t_in) + " s, so it leaves the path before the ego arrives");
    } else if (t_in > enter_at) {
      reasons.push_back("target_ttc_s " + num(target) + " is unreachable: the person needs " + num(t_in) +
                        " s to walk from the kerb into the ego path but would have to be in it after " +
                        num(enter_at) + " s (the ego reaches the crossing point in " + num(t_arrive) + " s)");
    }
    wait = enter_at - t_in;
  } else {
    const double to_centre = stop ? walk.duration() : *walk_time(std::abs(y_kerb));
    wait = t_arrive - to_centre;
    if (wait < 0)
      reasons.push_back("the person cannot reach the " + std::string(stop ? "stop point" : "lane centre") +
                        " before the ego: walking from the kerb takes " + num(to_centre) +
                        " s, the ego reaches the crossing point in " + num(t_arrive) + " s");
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

}  // namespace hf
