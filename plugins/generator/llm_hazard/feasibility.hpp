// Physical feasibility of a hazard spec: class limits (share/hazard_limits.yaml), kind rules, road and
// sidewalk position, camera visibility, overlap with detected objects and whether the target TTC is reached.
#pragma once

#include <map>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include <hazardforge/geometry.hpp>
#include <hazardforge/stage.hpp>

namespace hf::llm_hazard {

struct ClassLimits {
  double max_speed_mps = 0.0;
  double max_decel_mps2 = 0.0;
};

// Rules for one built-in hazard kind; kinds without rules are left to their template's check().
struct KindRules {
  std::vector<std::string> classes;  // allowed object classes (empty = any)
  std::optional<std::pair<double, double>> abs_heading_deg;  // allowed |heading| range
  std::vector<std::string> sides;  // allowed values of `side` (empty = any)
  bool needs_deceleration = false;
  bool needs_crossing_from = false;
  bool needs_multi_lane = false;
};

struct HazardLimits {
  std::string file;
  std::map<std::string, ClassLimits> classes;
  std::map<std::string, KindRules> kinds;

  // Throws hf::Error "file:line:col: ..." for a missing or ill-typed field.
  static HazardLimits load(const std::string& path);
  Json to_json() const;
};

// What the road offers, resolved from params and the dataset's description.
struct RoadContext {
  bool sidewalks = false;
  bool intersection = false;
  bool multi_lane = false;
  double road_half_width_m = 5.25;  // drivable surface either side of the ego lane centre
  double sidewalk_width_m = 3.0;
};

struct FeasibilityConfig {
  HazardLimits limits;
  ClassPriors sizes;
  Corridor corridor;
  RoadContext road;
  double ego_front_m = 3.4;  // rear axle to front bumper
  double horizon_s = 8.0;
  double ttc_tolerance_s = 0.25;
  double threshold_s = 1.5;
  double trigger_time_s = 0.0;
  double ego_speed_mps = 0.0;
};

// The hazard replayed against an ego vehicle that keeps its speed and lane.
struct TtcSimulation {
  bool starts_in_collision = false;
  bool enters_path = false;
  double ttc_at_start = kInf;  // kInf when not in path or not closing at t = 0
  double min_ttc = kInf;
  double t_min_ttc = 0.0;          // seconds after start_time_s
  double closest_lateral_m = kInf;  // smallest distance outside the corridor edge (0 = inside)
};

TtcSimulation simulate_ttc(const HazardSpec& spec, const ClassSize& size, double ego_speed_mps,
                           const Corridor& corridor, double ego_front_m, double horizon_s, double dt = 0.02);

// Every problem found, each naming the field (JSON pointer), its value and the limit it breaks.
// Checks that cannot run (no camera model) are described in `skipped`.
std::vector<std::string> check_feasibility(const HazardSpec& spec, const SceneContext& scene,
                                           const FeasibilityConfig& cfg, std::vector<std::string>* skipped);

// "5.5", "3", "-0.25": numbers in messages without trailing zeros.
std::string num(double v);

}  // namespace hf::llm_hazard
