// ASAM OpenSCENARIO 1.2 export of a planned hazard: the hazard and the ego follow their timed polylines.
#pragma once

#include <optional>
#include <string>

#include "hazardforge/hazard/kinematics.hpp"
#include "hazardforge/types.hpp"

namespace hf {

struct XoscOptions {
  std::string author = "HazardForge";
  std::string description;  // empty: made from the spec
  std::string date;         // xsd:dateTime; empty: now (UTC)
  std::string ego_name = "Ego";
  std::string hazard_name = "Hazard";
  // Anchor frame -> world. Without it the anchor frame is the scenario's world frame.
  std::optional<cv::Matx44d> T_world_anchor;
  // Performance of the ego and of a hazard vehicle; the sink fills both from hazard_limits.yaml.
  hazard::KinematicLimits ego_limits{"car", 60, 5, 10, 20, 4, 2, 45};
  hazard::KinematicLimits hazard_limits{"car", 60, 5, 10, 20, 4, 2, 45};
  cv::Vec3d ego_size_lwh{4.5, 1.85, 1.52};
  double ego_front = 3.4;  // rear axle (ego origin) to front bumper, m
};

// The .xosc text. Throws hf::Error for a trajectory with fewer than two samples or an object class with no
// OpenSCENARIO entity.
std::string write_xosc(const HazardTrajectory& traj, const XoscOptions& opt);

// Escapes &, <, >, " and ' and drops characters XML 1.0 cannot carry.
std::string xml_escape(const std::string& text);

}  // namespace hf
