// Physical feasibility of a hazard spec against the scene: the prompt's scene rules, road/sidewalk position,
// overlap with detected objects, timing and target TTC; plus, for kinds without a registered hazard template,
// class limits (share/hazard_limits.yaml), camera visibility and a constant-velocity TTC replay.
#pragma once

#include <map>
#include <optional>
#include <string>
#include <vector>

#include <hazardforge/geometry.hpp>
#include <hazardforge/hazard/kinematics.hpp>
#include <hazardforge/hazard/template_base.hpp>
#include <hazardforge/stage.hpp>

#include "scene_rules.hpp"

namespace hf::llm_hazard {

struct FeasibilityConfig {
  const LimitsTable* limits = nullptr;  // the table the hazard templates plan with
  ClassPriors sizes;
  hazard::TtcConventions ttc;  // in-path corridor and gap conventions, shared with the templates
  hazard::RoadModel road;      // lanes either side of the ego lane, shared with the templates
  double sidewalk_width_m = 3.0;
  bool sidewalks = false;
  bool pedestrians_without_sidewalks = false;  // edge-case tests: a person on the shoulder (sidewalk_width_m)
  bool intersection = false;
  bool multi_lane = false;
  double horizon_s = 6.0;
  double ttc_tolerance_s = 0.25;
  double threshold_s = 1.5;
  double trigger_time_s = 0.0;
  double ego_speed_mps = 0.0;
  std::optional<double> ego_yaw_rate;  // rad/s; with the corridor's ego_path the replayed ego follows its arc
  // Drawable classes, takeovers, clearance, entry into view (scene_rules.hpp).
  SceneRules rules;
  // The scene conditions (hf::scene_condition) each kind needs (HazardKindInfo::needs).
  std::map<std::string, std::vector<std::string>> kind_needs;
  // Class limits, start visibility and the TTC replay. Off when the kind's template checks the spec: it plans
  // the real motion (a cut-in starting beside the ego, a lead cruising before it brakes), which a generic
  // straight-line replay would misjudge.
  bool kinematics = true;
};

// The hazard replayed against an ego vehicle that keeps its speed and its yaw rate (the arc its corridor
// follows; a straight line when the yaw rate is unknown or the corridor is straight).
struct TtcSimulation {
  bool starts_in_collision = false;
  bool enters_path = false;
  double ttc_at_start = kInf;  // kInf when not in path or not closing at t = 0
  double min_ttc = kInf;
  double t_min_ttc = 0.0;  // seconds after start_time_s
  double closest_lateral_m =
      kInf;  // smallest distance outside the corridor edge, across the path (0 = inside)
};

// Straight-line motion at speed_mps along heading_deg, braking at deceleration_mps2 when given.
TtcSimulation simulate_ttc(const HazardSpec& spec, const ClassSize& size, double ego_speed_mps,
                           std::optional<double> ego_yaw_rate, const hazard::TtcConventions& ttc,
                           double horizon_s, double dt = 0.02);

// Every problem found, each naming the field (JSON pointer), its value and the limit it breaks.
// Checks that cannot run (no camera model) are described in `skipped`.
std::vector<Refusal> check_feasibility(const HazardSpec& spec, const SceneContext& scene,
                                       const FeasibilityConfig& cfg, std::vector<std::string>* skipped);

// The scene conditions a kind may need (hf::scene_condition): whether the generator knows one, what it means
// ("a lane beside the ego lane going its way"), and why it does not hold in this scene ("" = it holds).
bool known_condition(const std::string& condition);
std::string condition_text(const std::string& condition);
std::string unmet_condition(const std::string& condition, const FeasibilityConfig& cfg,
                            const SceneContext& scene);
// Every unmet condition of `needs`, as "<what it means>: <why not>".
std::vector<std::string> unmet_needs(const std::vector<std::string>& needs, const FeasibilityConfig& cfg,
                                     const SceneContext& scene);

}  // namespace hf::llm_hazard
