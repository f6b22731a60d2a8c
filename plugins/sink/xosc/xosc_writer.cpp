// OpenSCENARIO 1.2 text for a hazard trajectory: header, parameters, entities, Init teleports, timed
// polylines.
#include "xosc_writer.hpp"

#include <cmath>
#include <cstdio>
#include <ctime>
#include <utility>
#include <vector>

namespace hf {

std::string xml_escape(const std::string& text) {
  std::string out;
  out.reserve(text.size());
  for (unsigned char c : text) {
    switch (c) {
      case '&':
        out += "&amp;";
        break;
      case '<':
        out += "&lt;";
        break;
      case '>':
        out += "&gt;";
        break;
      case '"':
        out += "&quot;";
        break;
      case '\'':
        out += "&apos;";
        break;
      default:
        // XML 1.0 allows no control characters but tab, newline and carriage return.
        if (c < 0x20 && c != '\t' && c != '\n' && c != '\r') break;
        out += static_cast<char>(c);
    }
  }
  return out;
}

namespace {

using Attrs = std::vector<std::pair<std::string, std::string>>;

// Indented element writer; every attribute value goes through xml_escape.
class Xml {
 public:
  void open(const std::string& tag, const Attrs& attrs = {}) {
    line("<" + tag + attrs_str(attrs) + ">");
    stack_.push_back(tag);
  }
  void empty(const std::string& tag, const Attrs& attrs = {}) { line("<" + tag + attrs_str(attrs) + "/>"); }
  void close() {
    const std::string tag = stack_.back();
    stack_.pop_back();
    line("</" + tag + ">");
  }
  std::string str() const { return "<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n" + out_; }

 private:
  static std::string attrs_str(const Attrs& attrs) {
    std::string s;
    for (const auto& [k, v] : attrs) s += " " + k + "=\"" + xml_escape(v) + "\"";
    return s;
  }
  void line(const std::string& s) { out_ += std::string(2 * stack_.size(), ' ') + s + "\n"; }
  std::string out_;
  std::vector<std::string> stack_;
};

// xsd:double text: fixed decimals, INF for infinities.
std::string d(double v, int decimals = 4) {
  if (std::isnan(v)) return "NaN";
  if (std::isinf(v)) return v > 0 ? "INF" : "-INF";
  return hazard::num(v, decimals);
}

std::string now_utc() {
  const std::time_t t = std::time(nullptr);
  std::tm tm{};
  gmtime_r(&t, &tm);
  char buf[32];
  std::strftime(buf, sizeof buf, "%Y-%m-%dT%H:%M:%S", &tm);
  return buf;
}

struct Pose {
  double x, y, z, h;
};

struct EntityShape {
  bool pedestrian = false;
  std::string category;  // vehicleCategory / pedestrianCategory
  double wheelbase = 0;  // vehicles: rear axle (reference point) to front axle
};

EntityShape shape_for(const std::string& object_class, const cv::Vec3d& size) {
  EntityShape s;
  if (object_class == "person" || object_class == "pedestrian") {
    s.pedestrian = true;
    s.category = "pedestrian";
    return s;
  }
  static const std::pair<const char*, const char*> kVehicles[] = {
      {"car", "car"}, {"truck", "truck"},          {"bus", "bus"},
      {"van", "van"}, {"motorcycle", "motorbike"}, {"bicycle", "bicycle"}};
  for (const auto& [cls, cat] : kVehicles)
    if (object_class == cls) s.category = cat;
  if (s.category.empty())
    throw Error("xosc: object_class '" + object_class + "' has no OpenSCENARIO entity type");
  s.wheelbase = 0.6 * size[0];
  return s;
}

void vehicle(Xml& x, const std::string& name, const std::string& category, const cv::Vec3d& size,
             double bbox_center_x, double wheelbase, const hazard::KinematicLimits& lim,
             const std::string& role, const std::string& spec_json = {}) {
  x.open("Vehicle", {{"name", name}, {"vehicleCategory", category}});
  x.open("BoundingBox");
  x.empty("Center", {{"x", d(bbox_center_x)}, {"y", "0"}, {"z", d(size[2] / 2)}});
  x.empty("Dimensions", {{"width", d(size[1])}, {"length", d(size[0])}, {"height", d(size[2])}});
  x.close();
  x.empty("Performance", {{"maxSpeed", d(lim.max_speed_mps)},
                          {"maxAcceleration", d(lim.max_accel_mps2)},
                          {"maxDeceleration", d(lim.max_decel_mps2)},
                          {"maxAccelerationRate", d(lim.max_jerk_mps3)},
                          {"maxDecelerationRate", d(lim.max_jerk_mps3)}});
  const double wheel = category == "truck" || category == "bus" ? 1.0 : category == "bicycle" ? 0.7 : 0.65;
  const double track = std::max(0.1, size[1] - 0.25);
  x.open("Axles");
  x.empty("FrontAxle", {{"maxSteering", "0.5"},
                        {"wheelDiameter", d(wheel)},
                        {"trackWidth", d(track)},
                        {"positionX", d(wheelbase)},
                        {"positionZ", d(wheel / 2)}});
  x.empty("RearAxle", {{"maxSteering", "0"},
                       {"wheelDiameter", d(wheel)},
                       {"trackWidth", d(track)},
                       {"positionX", "0"},
                       {"positionZ", d(wheel / 2)}});
  x.close();
  x.open("Properties");
  x.empty("Property", {{"name", "role"}, {"value", role}});
  if (!spec_json.empty()) x.empty("Property", {{"name", "hazard_spec"}, {"value", spec_json}});
  x.close();
  x.close();
}

void world_position(Xml& x, const Pose& p) {
  x.empty("WorldPosition",
          {{"x", d(p.x)}, {"y", d(p.y)}, {"z", d(p.z)}, {"h", d(p.h, 6)}, {"p", "0"}, {"r", "0"}});
}

void sim_time_trigger(Xml& x, const std::string& tag, const std::string& name, const std::string& value,
                      const std::string& rule) {
  x.open(tag);
  x.open("ConditionGroup");
  x.open("Condition",
         {{"name", name}, {"delay", "0"}, {"conditionEdge", rule == "greaterOrEqual" ? "none" : "rising"}});
  x.open("ByValueCondition");
  x.empty("SimulationTimeCondition", {{"value", value}, {"rule", rule}});
  x.close();
  x.close();
  x.close();
  x.close();
}

void follow_trajectory(Xml& x, const std::string& actor,
                       const std::vector<std::pair<double, Pose>>& vertices) {
  x.open("ManeuverGroup", {{"maximumExecutionCount", "1"}, {"name", actor + "ManeuverGroup"}});
  x.open("Actors", {{"selectTriggeringEntities", "false"}});
  x.empty("EntityRef", {{"entityRef", actor}});
  x.close();
  x.open("Maneuver", {{"name", actor + "Maneuver"}});
  x.open("Event",
         {{"name", actor + "FollowsTrajectory"}, {"priority", "override"}, {"maximumExecutionCount", "1"}});
  x.open("Action", {{"name", actor + "FollowTrajectoryAction"}});
  x.open("PrivateAction");
  x.open("RoutingAction");
  x.open("FollowTrajectoryAction");
  x.open("TrajectoryRef");
  x.open("Trajectory", {{"name", actor + "Trajectory"}, {"closed", "false"}});
  x.open("Shape");
  x.open("Polyline");
  for (const auto& [t, p] : vertices) {
    x.open("Vertex", {{"time", d(t, 3)}});
    x.open("Position");
    world_position(x, p);
    x.close();
    x.close();
  }
  x.close();  // Polyline
  x.close();  // Shape
  x.close();  // Trajectory
  x.close();  // TrajectoryRef
  x.open("TimeReference");
  // Vertex times count from the start of the action, which starts with the simulation.
  x.empty("Timing", {{"domainAbsoluteRelative", "relative"}, {"scale", "1"}, {"offset", "0"}});
  x.close();
  x.empty("TrajectoryFollowingMode", {{"followingMode", "position"}});
  x.close();  // FollowTrajectoryAction
  x.close();  // RoutingAction
  x.close();  // PrivateAction
  x.close();  // Action
  sim_time_trigger(x, "StartTrigger", actor + "Starts", "0", "greaterOrEqual");
  x.close();  // Event
  x.close();  // Maneuver
  x.close();  // ManeuverGroup
}

void init_private(Xml& x, const std::string& actor, const Pose& p, const std::string& speed_param) {
  x.open("Private", {{"entityRef", actor}});
  x.open("PrivateAction");
  x.open("TeleportAction");
  x.open("Position");
  world_position(x, p);
  x.close();
  x.close();
  x.close();
  x.open("PrivateAction");
  x.open("LongitudinalAction");
  x.open("SpeedAction");
  x.empty("SpeedActionDynamics", {{"dynamicsShape", "step"}, {"value", "0"}, {"dynamicsDimension", "time"}});
  x.open("SpeedActionTarget");
  x.empty("AbsoluteTargetSpeed", {{"value", speed_param}});
  x.close();
  x.close();
  x.close();
  x.close();
  x.close();
}

}  // namespace

std::string write_xosc(const HazardTrajectory& traj, const XoscOptions& opt) {
  if (traj.points.size() < 2 || traj.ego.size() < 2)
    throw Error("xosc: the trajectory needs at least two samples for the hazard and the ego (has " +
                std::to_string(traj.points.size()) + " and " + std::to_string(traj.ego.size()) + ")");
  const EntityShape shape = shape_for(traj.object_class, traj.size_lwh);
  const cv::Matx44d T = opt.T_world_anchor.value_or(cv::Matx44d::eye());
  const double yaw = std::atan2(T(1, 0), T(0, 0));
  auto to_world = [&](double x, double y, double h) {
    const cv::Vec4d w = T * cv::Vec4d(x, y, 0, 1);
    return Pose{w[0], w[1], w[2], std::remainder(h + yaw, 2 * CV_PI)};
  };
  const double t0 = traj.points.front().t;
  std::vector<std::pair<double, Pose>> hazard_v, ego_v;
  for (const TrajectoryPoint& p : traj.points) {
    // Vehicles are placed by their rear axle (OpenSCENARIO's reference point); the plan tracks the box
    // centre.
    const double back = shape.pedestrian ? 0.0 : shape.wheelbase / 2;
    hazard_v.emplace_back(
        p.t - t0, to_world(p.x - back * std::cos(p.heading), p.y - back * std::sin(p.heading), p.heading));
  }
  for (const TrajectoryPoint& p : traj.ego) ego_v.emplace_back(p.t - t0, to_world(p.x, p.y, p.heading));
  const double stop_time = std::max(hazard_v.back().first, ego_v.back().first);

  std::string description = opt.description;
  if (description.empty()) {
    description = "HazardForge " + traj.kind + " hazard (" + traj.object_class + ")";
    if (!traj.spec.rationale.empty()) description += ": " + traj.spec.rationale;
  }

  Xml x;
  x.open("OpenSCENARIO");
  x.empty("FileHeader", {{"revMajor", "1"},
                         {"revMinor", "2"},
                         {"date", opt.date.empty() ? now_utc() : opt.date},
                         {"description", description},
                         {"author", opt.author}});
  x.open("ParameterDeclarations");
  const std::pair<std::string, std::pair<std::string, std::string>> params[] = {
      {"HazardKind", {"string", traj.kind}},
      {"EgoSpeed", {"double", d(traj.ego.front().speed)}},
      {"HazardInitialSpeed", {"double", d(traj.points.front().speed)}},
      {"IntendedMinTtc", {"double", d(traj.intended_min_ttc_s)}},
      {"AnchorTime", {"double", d(traj.anchor_time, 3)}},
      {"StopTime", {"double", d(stop_time, 3)}}};
  for (const auto& [name, tv] : params)
    x.empty("ParameterDeclaration", {{"name", name}, {"parameterType", tv.first}, {"value", tv.second}});
  x.close();
  x.empty("CatalogLocations");
  x.empty("RoadNetwork");

  x.open("Entities");
  x.open("ScenarioObject", {{"name", opt.ego_name}});
  vehicle(x, "ego_vehicle", "car", opt.ego_size_lwh, opt.ego_front - opt.ego_size_lwh[0] / 2,
          0.6 * opt.ego_size_lwh[0], opt.ego_limits, "ego");
  x.close();
  x.open("ScenarioObject", {{"name", opt.hazard_name}});
  if (shape.pedestrian) {
    x.open("Pedestrian",
           {{"name", traj.object_class}, {"mass", "75"}, {"pedestrianCategory", shape.category}});
    x.open("BoundingBox");
    x.empty("Center", {{"x", "0"}, {"y", "0"}, {"z", d(traj.size_lwh[2] / 2)}});
    x.empty(
        "Dimensions",
        {{"width", d(traj.size_lwh[1])}, {"length", d(traj.size_lwh[0])}, {"height", d(traj.size_lwh[2])}});
    x.close();
    x.open("Properties");
    x.empty("Property", {{"name", "role"}, {"value", "hazard"}});
    x.empty("Property", {{"name", "hazard_spec"}, {"value", Json(traj.spec).dump()}});
    x.close();
    x.close();
  } else {
    vehicle(x, traj.object_class, shape.category, traj.size_lwh, shape.wheelbase / 2, shape.wheelbase,
            opt.hazard_limits, "hazard", Json(traj.spec).dump());
  }
  x.close();
  x.close();  // Entities

  x.open("Storyboard");
  x.open("Init");
  x.open("Actions");
  init_private(x, opt.ego_name, ego_v.front().second, "$EgoSpeed");
  init_private(x, opt.hazard_name, hazard_v.front().second, "$HazardInitialSpeed");
  x.close();
  x.close();
  x.open("Story", {{"name", traj.kind + "Story"}});
  x.open("Act", {{"name", traj.kind + "Act"}});
  follow_trajectory(x, opt.ego_name, ego_v);
  follow_trajectory(x, opt.hazard_name, hazard_v);
  sim_time_trigger(x, "StartTrigger", "ActStarts", "0", "greaterOrEqual");
  x.close();  // Act
  x.close();  // Story
  sim_time_trigger(x, "StopTrigger", "ScenarioEnds", "$StopTime", "greaterThan");
  x.close();  // Storyboard
  x.close();  // OpenSCENARIO
  return x.str();
}

}  // namespace hf
