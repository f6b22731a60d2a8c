// The in-path corridor along the ego's predicted (constant-curvature) path.
#include "hazardforge/corridor.hpp"

#include <algorithm>
#include <cmath>

namespace hf {

namespace {
constexpr double kStraight = 1e-6;  // 1/m: below this the arc is indistinguishable from a line over 1 km
}

EgoPath EgoPath::from_motion(const std::optional<double>& speed_mps, const std::optional<double>& yaw_rate,
                             double min_speed_mps, double max_curvature) {
  EgoPath p;
  if (!speed_mps || !yaw_rate || !std::isfinite(*speed_mps) || !std::isfinite(*yaw_rate) ||
      *speed_mps < min_speed_mps || *speed_mps <= 0.0)
    return p;
  p.curvature = std::clamp(*yaw_rate / *speed_mps, -max_curvature, max_curvature);
  return p;
}

EgoPath::Coordinates EgoPath::project(double x, double y) const {
  if (std::abs(curvature) < kStraight) return {x, y};
  // Centre of the turn at (0, R); the path is the circle of radius |R| through the origin.
  const double R = 1.0 / curvature;
  const double sign = curvature > 0 ? 1.0 : -1.0;
  const double rho = std::hypot(x, y - R);
  const double theta = std::atan2(x, sign * (R - y));  // angle swept from the origin, positive ahead
  return {std::abs(R) * theta, sign * (std::abs(R) - rho)};
}

cv::Vec3d EgoPath::at(double s) const {
  if (std::abs(curvature) < kStraight) return {s, 0.0, 0.0};
  const double phi = s * curvature;
  return {std::sin(phi) / curvature, (1.0 - std::cos(phi)) / curvature, phi};
}

bool Corridor::contains(double x, double y, double object_width, const EgoPath& path) const {
  const EgoPath::Coordinates c = follow_path ? path.project(x, y) : EgoPath{}.project(x, y);
  return c.s > 0 && std::abs(c.d) < half_width_for(object_width);
}

EgoPath Corridor::path_for(const std::optional<double>& speed_mps,
                           const std::optional<double>& yaw_rate) const {
  return follow_path ? EgoPath::from_motion(speed_mps, yaw_rate) : EgoPath{};
}

bool Corridor::contains(const ObjectStates& states, const ObjectState& s) const {
  return contains(s.distance_m + states.distance_origin_x, s.lateral_m, s.width_m,
                  path_for(states.ego_speed_mps, states.ego_yaw_rate));
}

std::vector<ParamSpec> Corridor::params(bool follow_path_by_default) {
  return {
      ParamSpec::number("corridor_half_width", 1.0).range(0, 10).describe("ego half-width (m)"),
      ParamSpec::number("corridor_margin", 0.5)
          .range(0, 10)
          .describe("extra lateral margin (m); in path when the offset from the ego's path is below "
                    "half_width + margin + object_width/2"),
      ParamSpec::string("corridor_path", follow_path_by_default ? "ego_path" : "straight")
          .one_of({"ego_path", "straight"})
          .describe("ego_path: the corridor follows the ego's predicted arc (curvature = yaw rate / speed, "
                    "straight when either is unknown); straight: along ego x whatever the ego does")};
}

Corridor Corridor::from(const Params& p) {
  Corridor c;
  if (p.has("corridor_half_width")) c.ego_half_width = p.get_double("corridor_half_width");
  if (p.has("corridor_margin")) c.margin = p.get_double("corridor_margin");
  if (p.has("corridor_path")) c.follow_path = p.get_string("corridor_path") == "ego_path";
  return c;
}

}  // namespace hf
