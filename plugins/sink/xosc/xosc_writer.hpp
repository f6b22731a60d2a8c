// OpenSCENARIO 1.2 export of a planned hazard on an OpenDRIVE road fitted to the ego's path.
#pragma once

#include <optional>
#include <string>

#include "hazardforge/hazard/ego_path.hpp"
#include "hazardforge/hazard/kinematics.hpp"
#include "hazardforge/road/opendrive.hpp"
#include "hazardforge/road/xml.hpp"
#include "hazardforge/types.hpp"

namespace hf {

struct XoscOptions {
  std::string author = "HazardForge";
  std::string description;  // empty: made from the spec and the plan
  std::string date;         // xsd:dateTime; empty: now (UTC)
  std::string ego_name = "Ego";
  std::string hazard_name = "Hazard";
  // Anchor frame -> world. Only its ground-plane translation and yaw are used: the plan is flat, and the
  // scenario's poses are yaw-only at z = 0. Without it the anchor frame is the scenario's world frame.
  std::optional<cv::Matx44d> T_world_anchor;
  // Performance of the ego and of a hazard vehicle; the sink fills both from hazard_limits.yaml.
  KinematicLimits ego_limits{"car", 60, 5, 10, 20, 4, 2, 45};
  KinematicLimits hazard_limits{"car", 60, 5, 10, 20, 4, 2, 45};
  cv::Vec3d ego_size_lwh{4.5, 1.85, 1.52};
  double ego_front = 3.4;  // rear axle (ego origin) to front bumper, m
  // The recorded ego path around the anchor time (tau = 0 at the anchor). Without it the plan's own ego
  // samples are used, continued straight at their end speeds.
  std::optional<hazard::EgoPath> ego_path;
  // The scene's road: lanes, driving side, sidewalks; and where pedestrians wait beyond the road edge.
  road::LaneLayout lanes;
  double kerb_offset = 0.5;
  // controlled: the ego only gets its Init lane position and speed (a default controller or a system under
  // test drives it); replay: it also follows its recorded speed profile along the road.
  std::string ego_mode = "controlled";
  double lead_in_s = 3.0;                   // before the hazard's manoeuvre starts
  double after_s = 3.0;                     // after the plan's critical moment
  std::string road_file = "scenario.xodr";  // LogicFile, relative to the .xosc
};

// What the story does, in scenario time (0 = start), for logs, docs and tests.
struct XoscSummary {
  std::string trigger;  // TimeToCollisionCondition | RelativeDistanceCondition | TraveledDistanceCondition
  double trigger_value = 0;
  double start_stream_time = 0;  // stream time of scenario time 0
  double trigger_time = 0;       // when the trigger fires for the recorded ego
  double critical_time = 0;      // the plan's minimum TTC
  double stop_distance = 0;      // the ego's travelled distance that ends the story
  double stop_time = 0;          // the latest end
  double plan_min_ttc = kInf;
  double ego_speed = 0;
  double hazard_speed = 0, hazard_end_speed = 0, deceleration = 0, lane_change_time = 0;
  double start_gap = 0;  // ds of the hazard's reference point from the ego's at the start
};

struct XoscExport {
  std::string xosc;  // the scenario
  std::string xodr;  // its road
  XoscSummary summary;
};

// The scenario and its road. Throws hf::Error for a trajectory with fewer than two samples, an object class
// with no OpenSCENARIO entity, or a plan the road cannot hold.
XoscExport export_scenario(const HazardTrajectory& traj, const XoscOptions& opt);

// The scenario text alone (export_scenario(...).xosc).
std::string write_xosc(const HazardTrajectory& traj, const XoscOptions& opt);

// An OpenSCENARIO catalog with one parameterised Maneuver per hazard kind (sudden_stop, cut_in,
// pedestrian_crossing), for users who compose their own scenarios.
std::string write_hazard_catalog(const std::string& date = {});

}  // namespace hf
