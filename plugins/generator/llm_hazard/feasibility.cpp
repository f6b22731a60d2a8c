// Feasibility checks for hazard specs and the constant-speed ego replay for kinds without a template.
#include "feasibility.hpp"

#include <hazardforge/json_text.hpp>

#include <algorithm>
#include <cmath>
#include <cstdio>

#include <hazardforge/angles.hpp>
#include <hazardforge/error.hpp>
#include <hazardforge/hazard/proposal.hpp>
#include <hazardforge/number_text.hpp>

namespace hf::llm_hazard {

namespace {

bool is_motor_vehicle(const std::string& cls) {
  return cls == "car" || cls == "truck" || cls == "bus" || cls == "motorcycle";
}

struct Extent {
  double lateral_half, longitudinal_half;
};
Extent extent(const ClassSize& size, double heading_rad) {
  double c = std::abs(std::cos(heading_rad)), s = std::abs(std::sin(heading_rad));
  return {(size.length * s + size.width * c) / 2.0, (size.length * c + size.width * s) / 2.0};
}

}  // namespace

bool known_condition(const std::string& c) {
  return !condition_text(c).empty();
}

std::string condition_text(const std::string& c) {
  namespace sc = scene_condition;
  if (c == sc::kSidewalks) return "sidewalks";
  if (c == sc::kSameDirectionLane) return "a lane beside the ego lane going its way";
  if (c == sc::kOncomingLane) return "a lane with oncoming traffic beside the ego lane";
  if (c == sc::kIntersection) return "an intersection";
  if (c == sc::kTrackedLead) return "a tracked vehicle ahead in the ego path";
  return {};
}

std::string unmet_condition(const std::string& c, const FeasibilityConfig& cfg, const SceneContext& scene) {
  namespace sc = scene_condition;
  const hazard::RoadModel& road = cfg.road;
  auto lanes = [&] {
    return "lanes_left " + std::to_string(road.lanes_left) + ", lanes_right " +
           std::to_string(road.lanes_right) + ", oncoming_lanes " + std::to_string(road.oncoming_lanes) +
           ", traffic keeps " + road.driving_side;
  };
  if (c == sc::kSidewalks)
    return cfg.sidewalks || cfg.pedestrians_without_sidewalks ? "" : "the scene has none (sidewalks = no)";
  if (c == sc::kSameDirectionLane) {
    if (!cfg.multi_lane) return "this road has one lane in the ego's direction (multi_lane = no)";
    if (road.same_direction_lanes(1) + road.same_direction_lanes(-1) == 0)
      return "no lane beside the ego lane goes its way (" + lanes() + ")";
    return "";
  }
  if (c == sc::kOncomingLane)
    return road.oncoming_lanes > 0 ? "" : "no lane carries oncoming traffic (" + lanes() + ")";
  if (c == sc::kIntersection) return cfg.intersection ? "" : "the scene has none (intersection = no)";
  if (c == sc::kTrackedLead) {
    for (const ObjectState& o : scene.objects)
      if (o.in_path && std::isfinite(o.distance_m) && o.distance_m > 0 && is_motor_vehicle(o.label))
        return "";
    return "no vehicle is tracked ahead in the ego path";
  }
  return "'" + c + "', a condition the generator does not know";
}

std::vector<std::string> unmet_needs(const std::vector<std::string>& needs, const FeasibilityConfig& cfg,
                                     const SceneContext& scene) {
  std::vector<std::string> out;
  for (const std::string& n : needs)
    if (std::string why = unmet_condition(n, cfg, scene); !why.empty())
      out.push_back((known_condition(n) ? condition_text(n) : n) + ": " + why);
  return out;
}

TtcSimulation simulate_ttc(const HazardSpec& spec, const ClassSize& size, double ego_speed_mps,
                           std::optional<double> ego_yaw_rate, const hazard::TtcConventions& conv,
                           double horizon_s, double dt) {
  TtcSimulation sim;
  const double h = spec.heading_deg * kPi / 180.0;
  const double decel = spec.deceleration_mps2.value_or(0.0);
  // Constant speed and yaw rate keep the ego on one arc, so the path predicted from any later pose is that
  // same arc: one EgoPath serves every step.
  const EgoPath path = conv.corridor.path_for(ego_speed_mps, ego_yaw_rate);
  double x = spec.initial_distance_m, y = spec.lateral_offset_m, v = spec.speed_mps;
  const int steps = static_cast<int>(std::ceil(horizon_s / dt));
  for (int i = 0; i <= steps; ++i) {
    const double t = i * dt;
    const cv::Vec3d ego = path.at(ego_speed_mps * t);  // x, y, heading in the spec's (start) ego frame
    const double c = std::cos(ego[2]), s = std::sin(ego[2]);
    const double xr = c * (x - ego[0]) + s * (y - ego[1]), yr = -s * (x - ego[0]) + c * (y - ego[1]);
    const Extent ext = extent(size, h - ego[2]);
    const bool in_path = conv.corridor.contains(xr, yr, 2.0 * ext.lateral_half, path);
    const double across =
        std::abs(path.project(xr, yr).d) - conv.corridor.half_width_for(2.0 * ext.lateral_half);
    sim.closest_lateral_m = std::min(sim.closest_lateral_m, std::max(0.0, across));
    if (in_path) {
      sim.enters_path = true;
      const double gap = xr - conv.ego_front - ext.longitudinal_half;
      const double closing = ego_speed_mps - v * std::cos(h - ego[2]);
      double ttc = kInf;
      if (gap <= 0.0)
        ttc = 0.0;
      else if (closing > conv.min_closing)
        ttc = gap / closing;
      if (i == 0) {
        sim.starts_in_collision = gap <= 0.0;
        sim.ttc_at_start = ttc;
      }
      if (ttc < sim.min_ttc) {
        sim.min_ttc = ttc;
        sim.t_min_ttc = t;
      }
      if (gap <= 0.0) break;  // contact: the constant-speed ego would drive through the object
    }
    x += v * std::cos(h) * dt;
    y += v * std::sin(h) * dt;
    v = std::max(0.0, v - decel * dt);
  }
  return sim;
}

namespace {

// A tracked object's footprint as the templates place objects: centre x (hazard::centre_x), lateral offset,
// measured size or its class's prior.
struct Footprint2d {
  double x, y, length, width;
};

Footprint2d tracked_footprint(const ObjectState& o, const SceneContext& scene, const ClassPriors& sizes) {
  const ClassSize prior = sizes.has(o.label) ? sizes.at(o.label) : ClassSize{};
  return {hazard::centre_x(o, scene.distance_origin_x, sizes), o.lateral_m,
          o.length_m > 0 ? o.length_m : prior.length, o.width_m > 0 ? o.width_m : prior.width};
}

}  // namespace

std::vector<Refusal> check_feasibility(const HazardSpec& spec, const SceneContext& scene,
                                       const FeasibilityConfig& cfg, std::vector<std::string>* skipped) {
  std::vector<Refusal> errs;
  auto refuse = [&](const char* code, std::string text) { errs.push_back({code, std::move(text), spec.kind}); };
  const std::string& cls = spec.object_class;
  const double y = spec.lateral_offset_m;

  // The prompt's scene rules. (People without sidewalks: a kind that needs them says so, HazardKindInfo::needs; a
  // person beyond the road edge is refused below; one walking on the road's edge is a kind of its own.)
  // Across the road (not along it either way: oncoming vehicles head about 180 degrees).
  if (is_motor_vehicle(cls) && std::abs(spec.heading_deg) > 45.0 && std::abs(spec.heading_deg) < 135.0 &&
      !cfg.intersection)
    refuse(refusal::kSceneLacks,
           "/heading_deg = " + num_text(spec.heading_deg) +
               " makes a vehicle cross the ego path, which needs an intersection (intersection = no)");
  if (auto needs = cfg.kind_needs.find(spec.kind); needs != cfg.kind_needs.end())
    for (const std::string& why : unmet_needs(needs->second, cfg, scene))
      refuse(refusal::kSceneLacks, "/kind = \"" + spec.kind + "\" needs " + why);

  // Side, crossing side and lateral position agree.
  const double lane_half = cfg.ttc.corridor.half_width_for(0.0);
  if (spec.side == "left" && y <= 0.0)
    refuse(refusal::kSpec, "/side = \"left\" contradicts /lateral_offset_m = " + num_text(y) +
                   " (left of the ego means y > 0)");
  if (spec.side == "right" && y >= 0.0)
    refuse(refusal::kSpec, "/side = \"right\" contradicts /lateral_offset_m = " + num_text(y) +
                   " (right of the ego means y < 0)");
  if (spec.side == "center" && std::abs(y) > lane_half)
    refuse(refusal::kSpec, "/side = \"center\" contradicts /lateral_offset_m = " + num_text(y) +
                   " (center means |y| <= " + num_text(lane_half) + " m)");

  // On the road, or on a sidewalk for people and bicycles.
  const int side_sign = y >= 0 ? 1 : -1;
  // Beyond the road edge: a sidewalk, or the shoulder when people on roads without sidewalks are allowed.
  const bool may_use_sidewalk = ((cls == "person" || cls == "bicycle") && cfg.sidewalks) ||
                                (cls == "person" && cfg.pedestrians_without_sidewalks);
  // A vehicle standing beside the road (parked) may stand in a parking strip of its width (and 0.5 m) there.
  const bool parked = is_motor_vehicle(cls) && std::abs(spec.speed_mps) < 0.1 && cfg.sizes.has(cls);
  const double beyond = may_use_sidewalk ? cfg.sidewalk_width_m : parked ? cfg.sizes.at(cls).width + 0.5 : 0.0;
  const double max_y = cfg.road.edge(side_sign) + beyond;
  // Where a tracked vehicle stands or drives beyond that (a parking area, a lot the road passes), the ground is
  // there: a person may be beside it, within 1.5 m of its footprint (one hidden behind a parked car).
  auto beside_tracked_vehicle = [&] {
    if (cls != "person") return false;
    for (const ObjectState& o : scene.objects) {
      if (!std::isfinite(o.distance_m) || !is_motor_vehicle(o.label)) continue;
      const Footprint2d f = tracked_footprint(o, scene, cfg.sizes);
      if (std::abs(f.x - spec.initial_distance_m) <= f.length / 2.0 + 1.5 && std::abs(f.y - y) <= f.width / 2.0 + 1.5)
        return true;
    }
    return false;
  };
  if (std::abs(y) > max_y && !beside_tracked_vehicle())
    refuse(refusal::kPlacement, "/lateral_offset_m = " + num_text(y) + " puts the " + cls + " off the " +
                   (may_use_sidewalk ? "road and sidewalk" : parked ? "road and its parking strip" : "road") +
                   " (|y| <= " + num_text(max_y) + " m on the " + (side_sign > 0 ? "left" : "right") + ")");

  // Not on top of a detected object (unless the spec takes that object over).
  const std::optional<int64_t> taken = spec.track_id;
  if (cfg.sizes.has(cls)) {
    const ClassSize& me = cfg.sizes.at(cls);
    for (const ObjectState& o : scene.objects) {
      if (!std::isfinite(o.distance_m)) continue;
      if (taken && *taken == o.track_id) continue;
      // Centre to centre, as the templates place objects, not face to centre.
      const Footprint2d f = tracked_footprint(o, scene, cfg.sizes);
      if (std::abs(f.x - spec.initial_distance_m) < (f.length + me.length) / 2.0 &&
          std::abs(f.y - y) < (f.width + me.width) / 2.0)
        refuse(refusal::kTraffic, "start point (x " + num_text(spec.initial_distance_m) + " m, y " + num_text(y) +
                       " m) overlaps the detected " + o.label + " (track " + std::to_string(o.track_id) +
                       ") centred at x " + num_text(f.x) + " m, y " + num_text(f.y) + " m");
    }
  }

  // When it appears.
  if (spec.start_time_s < cfg.trigger_time_s - 1e-6)
    refuse(refusal::kSpec, "/start_time_s = " + num_text(spec.start_time_s) +
                   " is before the frame the hazard is for (" + num_text(cfg.trigger_time_s) + " s)");
  if (spec.start_time_s > cfg.trigger_time_s + cfg.horizon_s)
    refuse(refusal::kSpec, "/start_time_s = " + num_text(spec.start_time_s) + " is more than " +
                   num_text(cfg.horizon_s) + " s after the frame the hazard is for (" +
                   num_text(cfg.trigger_time_s) + " s)");

  // The target must make the scene critical.
  if (spec.target_ttc_s && *spec.target_ttc_s >= cfg.threshold_s)
    refuse(refusal::kSpec, "/target_ttc_s = " + num_text(*spec.target_ttc_s) + " is not below the risk threshold " +
                   num_text(cfg.threshold_s) + " s, so the scene would stay Safe");

  // What the renderer can draw, and what it cannot remove.
  for (Refusal& e : check_spec_rules(spec, scene, cfg.rules)) errs.push_back(std::move(e));

  if (!cfg.kinematics) return errs;

  // Class limits.
  if (!cfg.limits || !cfg.limits->has(cls)) {
    refuse(refusal::kObjectClass, "/object_class = \"" + cls + "\" has no kinematic limits in " +
                   (cfg.limits ? cfg.limits->file() : std::string("the limits table")));
  } else {
    const KinematicLimits& lim = cfg.limits->at(cls);
    if (spec.speed_mps > lim.max_speed_mps)
      refuse(refusal::kClassLimit, "/speed_mps = " + num_text(spec.speed_mps) + " is more than a " + cls +
                     " can do (at most " + num_text(lim.max_speed_mps) + " m/s)");
    if (spec.deceleration_mps2 && *spec.deceleration_mps2 > lim.max_decel_mps2)
      refuse(refusal::kClassLimit, "/deceleration_mps2 = " + num_text(*spec.deceleration_mps2) + " is more than a " + cls +
                     " can brake (at most " + num_text(lim.max_decel_mps2) + " m/s^2)");
  }

  // Visible to the camera when it appears.
  if (scene.camera.valid()) {
    auto px = scene.camera.project_ego(cv::Vec3d(spec.initial_distance_m, y, 0.0));
    if (!px) {
      refuse(refusal::kNotInView, "/initial_distance_m = " + num_text(spec.initial_distance_m) +
                                      " puts the start point behind the camera");
    } else if (px->x < 0 || px->y < 0 || px->x >= scene.camera.width || px->y >= scene.camera.height) {
      refuse(refusal::kNotInView, "start point (x " + num_text(spec.initial_distance_m) + " m, y " + num_text(y) +
                     " m) is outside the camera view: it projects to pixel (" + num_text(px->x) + ", " +
                     num_text(px->y) + ") in a " + std::to_string(scene.camera.width) + "x" +
                     std::to_string(scene.camera.height) + " image");
    }
  } else if (skipped) {
    skipped->push_back("camera visibility not checked: the frame has no camera model");
  }

  // The motion reaches the target TTC.
  if (cfg.sizes.has(cls)) {
    TtcSimulation sim =
        simulate_ttc(spec, cfg.sizes.at(cls), cfg.ego_speed_mps, cfg.ego_yaw_rate, cfg.ttc, cfg.horizon_s);
    const double target = spec.target_ttc_s.value_or(cfg.threshold_s);
    if (sim.starts_in_collision) {
      refuse(refusal::kPlacement, "the " + cls + " would appear touching the ego vehicle (x " +
                     num_text(spec.initial_distance_m) + " m is within the ego front " +
                     num_text(cfg.ttc.ego_front) + " m plus half its length)");
    } else if (sim.ttc_at_start < target - cfg.ttc_tolerance_s) {
      refuse(refusal::kTtcUnreachable,
          "the " + cls + " would appear with TTC " + num_text(sim.ttc_at_start) +
          " s, already below /target_ttc_s = " + num_text(target) +
          ": a hazard must develop, not appear on a collision course (increase /initial_distance_m)");
    } else if (!sim.enters_path) {
      refuse(refusal::kTtcUnreachable, "/target_ttc_s = " + num_text(target) + " is never reached: with the ego at " +
                     num_text(cfg.ego_speed_mps) + " m/s the " + cls + " never enters the ego path within " +
                     num_text(cfg.horizon_s) + " s (it stays " + num_text(sim.closest_lateral_m) +
                     " m outside)");
    } else if (sim.min_ttc > target + cfg.ttc_tolerance_s) {
      refuse(refusal::kTtcUnreachable, "/target_ttc_s = " + num_text(target) + " is never reached: with the ego at " +
                     num_text(cfg.ego_speed_mps) + " m/s the lowest TTC within " + num_text(cfg.horizon_s) +
                     " s is " + num_text(sim.min_ttc) + " s");
    }
  }
  return errs;
}

}  // namespace hf::llm_hazard
