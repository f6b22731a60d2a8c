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
      "while the person is in its path; with target_ttc_s the person enters the path when the TTC equals it.";
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

  const double t_arrive = gap0 / ve;  // the ego's front reaches the crossing line
  const double half = req.path_half_width(wid);
  const hazard::SpeedProfile walk =
      hazard::SpeedProfile(0.0).change_speed(v, req.limits.max_accel_mps2, req.limits.max_jerk_mps3);
  auto walk_time = [&](double d) { return *walk.time_at_distance(d); };  // walk speed > 0: always reached
  const double d_in = std::max(0.0, std::abs(y_kerb) - half), d_out = std::abs(y_kerb) + half;
  double wait = 0, enter = 0;
  if (spec.target_ttc_s) {
    const double target = *spec.target_ttc_s;
    const double enter_at = t_arrive - target;  // TTC = t_arrive - t while in the path
    const double crossing = walk_time(d_out) - walk_time(d_in);
    if (target > crossing) {
      reasons.push_back("target_ttc_s " + num(target) + " is unreachable: at " + num(v) +
                        " m/s the person crosses "
                        "the ego path in " +
                        num(crossing) + " s, so it leaves the path before the ego arrives");
    } else if (walk_time(d_in) > enter_at) {
      reasons.push_back("target_ttc_s " + num(target) + " is unreachable: the person needs " +
                        num(walk_time(d_in)) +
                        " s to walk from the kerb into the ego path but would have to be in it after " +
                        num(enter_at) + " s (the ego reaches the crossing point in " + num(t_arrive) + " s)");
    }
    wait = enter_at - walk_time(d_in);
  } else {
    wait = t_arrive - walk_time(std::abs(y_kerb));
    if (wait < 0)
      reasons.push_back(
          "the person cannot reach the lane centre before the ego: walking from the kerb takes " +
          num(walk_time(std::abs(y_kerb))) + " s, the ego reaches the crossing point in " + num(t_arrive) +
          " s");
  }
  if (!reasons.empty()) return {};
  enter = wait + walk_time(d_in);

  hazard::SpeedProfile profile = hazard::SpeedProfile(0.0).hold(wait).change_speed(
      v, req.limits.max_accel_mps2, req.limits.max_jerk_mps3);
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
             {"walk_speed_mps", v}};
  return d;
}

}  // namespace hf
