// The in-path corridor: the band the ego sweeps along its predicted path — the project's one in-path rule.
#pragma once

#include <optional>
#include <vector>

#include "hazardforge/abi.hpp"
#include "hazardforge/params.hpp"
#include "hazardforge/types.hpp"

HF_SDK_BEGIN
namespace hf {

// The ego's predicted path over the next seconds: a circular arc of constant curvature through the ego
// origin, tangent to ego x (the constant-speed, constant-yaw-rate prediction of ADAS path predictors).
// Coordinates are the ego frame (x forward, y left, origin below the rear axle).
struct EgoPath {
  double curvature = 0.0;  // 1/m, positive = turning left; 0 = straight ahead

  // curvature = yaw_rate / speed. Straight when either is unknown or the speed is below `min_speed_mps` (the
  // yaw rate of a near-standing car says little about where it will drive); |curvature| is capped at
  // `max_curvature` (1/m; 0.2 = a 5 m radius, tighter than any car turns).
  static EgoPath from_motion(const std::optional<double>& speed_mps, const std::optional<double>& yaw_rate,
                             double min_speed_mps = 1.0, double max_curvature = 0.2);

  // Path coordinates of an ego-frame point: `s` the arc length from the ego origin to the point's foot on the
  // path (m, negative behind the ego; on a curve the half circle ahead has s in (0, pi R]), `d` the signed
  // lateral offset from the path (m, positive = left of it). Straight: s = x, d = y.
  struct Coordinates {
    double s = 0.0;
    double d = 0.0;
  };
  Coordinates project(double x, double y) const;
  // Ego-frame point at arc length s along the path and the path's heading there: (x, y, heading rad).
  cv::Vec3d at(double s) const;
};

// An object is in path when its foot on the ego's path is ahead (s > 0) and its lateral offset from the path
// is below ego_half_width + margin + object_width / 2. With follow_path = false the path is straight ahead
// whatever the ego's motion (the protocol the paper's labels use).
struct Corridor {
  double ego_half_width = 1.0;
  double margin = 0.5;
  bool follow_path = true;

  double half_width_for(double object_width) const { return ego_half_width + margin + object_width / 2.0; }
  // (x, y) in the ego frame (origin below the rear axle).
  bool contains(double x, double y, double object_width, const EgoPath& path = {}) const;
  // An estimated object: its ego-frame x is distance_m + states.distance_origin_x; the path comes from the
  // states' ego speed and yaw rate (when follow_path).
  bool contains(const ObjectStates& states, const ObjectState& s) const;
  EgoPath path_for(const std::optional<double>& speed_mps, const std::optional<double>& yaw_rate) const;

  // Params "corridor_half_width", "corridor_margin" and "corridor_path" (ego_path | straight): the one
  // spelling every stage and template that tests in-path declares. Reference protocols that must reproduce a
  // published straight-corridor rule default to straight.
  static std::vector<ParamSpec> params(bool follow_path_by_default = true);
  static Corridor from(const Params& p);
};

}  // namespace hf
HF_SDK_END
