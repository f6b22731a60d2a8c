// Feasibility checks for hazard specs and the constant-speed ego replay that decides whether the TTC is reached.
#include "feasibility.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>

#include <hazardforge/error.hpp>
#include <hazardforge/yaml_json.hpp>

namespace hf::llm_hazard {

namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr double kMinClosing = 0.1;  // m/s, as the project's TTC metrics

double number_field(const YamlDocument& doc, const std::string& ptr) {
  Json::json_pointer p(ptr);
  if (!doc.value.contains(p) || !doc.value.at(p).is_number())
    throw Error(doc.at(ptr), "'" + ptr.substr(1) + "' must be a number");
  return doc.value.at(p).get<double>();
}

std::vector<std::string> string_list(const YamlDocument& doc, const std::string& ptr) {
  Json::json_pointer p(ptr);
  std::vector<std::string> out;
  if (!doc.value.contains(p)) return out;
  const Json& v = doc.value.at(p);
  if (!v.is_array()) throw Error(doc.at(ptr), "'" + ptr.substr(1) + "' must be a list of names");
  for (const Json& s : v) {
    if (!s.is_string()) throw Error(doc.at(ptr), "'" + ptr.substr(1) + "' must be a list of names");
    out.push_back(s.get<std::string>());
  }
  return out;
}

bool flag(const YamlDocument& doc, const std::string& ptr) {
  Json::json_pointer p(ptr);
  if (!doc.value.contains(p)) return false;
  if (!doc.value.at(p).is_boolean()) throw Error(doc.at(ptr), "'" + ptr.substr(1) + "' must be true or false");
  return doc.value.at(p).get<bool>();
}

std::string join(const std::vector<std::string>& v) {
  std::string out;
  for (const std::string& s : v) out += (out.empty() ? "" : ", ") + s;
  return out;
}

bool contains(const std::vector<std::string>& v, const std::string& s) {
  return std::find(v.begin(), v.end(), s) != v.end();
}

bool is_vehicle(const std::string& cls) { return cls == "car" || cls == "truck" || cls == "bus" || cls == "motorcycle"; }

struct Extent {
  double lateral_half, longitudinal_half;
};
Extent extent(const ClassSize& size, double heading_rad) {
  double c = std::abs(std::cos(heading_rad)), s = std::abs(std::sin(heading_rad));
  return {(size.length * s + size.width * c) / 2.0, (size.length * c + size.width * s) / 2.0};
}

}  // namespace

std::string num(double v) {
  if (!std::isfinite(v)) return v > 0 ? "inf" : (v < 0 ? "-inf" : "nan");
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.2f", v);
  std::string s = buf;
  while (!s.empty() && s.back() == '0') s.pop_back();
  if (!s.empty() && s.back() == '.') s.pop_back();
  if (s == "-0") s = "0";
  return s;
}

HazardLimits HazardLimits::load(const std::string& path) {
  YamlDocument doc = load_yaml_file(path);
  HazardLimits l;
  l.file = path;
  if (!doc.value.is_object() || !doc.value.contains("classes") || !doc.value["classes"].is_object())
    throw Error(doc.at(""), "hazard limits need a 'classes' mapping");
  for (auto it = doc.value["classes"].begin(); it != doc.value["classes"].end(); ++it) {
    std::string base = "/classes/" + it.key();
    l.classes[it.key()] = {number_field(doc, base + "/max_speed_mps"), number_field(doc, base + "/max_decel_mps2")};
  }
  if (doc.value.contains("kinds")) {
    if (!doc.value["kinds"].is_object()) throw Error(doc.at("/kinds"), "'kinds' must be a mapping");
    for (auto it = doc.value["kinds"].begin(); it != doc.value["kinds"].end(); ++it) {
      std::string base = "/kinds/" + it.key();
      KindRules r;
      r.classes = string_list(doc, base + "/classes");
      for (const std::string& c : r.classes)
        if (!l.classes.count(c)) throw Error(doc.at(base + "/classes"), "class '" + c + "' has no entry in 'classes'");
      if (it.value().contains("abs_heading_deg")) {
        const Json& h = it.value()["abs_heading_deg"];
        if (!h.is_array() || h.size() != 2 || !h[0].is_number() || !h[1].is_number())
          throw Error(doc.at(base + "/abs_heading_deg"), "'abs_heading_deg' must be [min, max] in degrees");
        r.abs_heading_deg = std::make_pair(h[0].get<double>(), h[1].get<double>());
      }
      r.sides = string_list(doc, base + "/sides");
      r.needs_deceleration = flag(doc, base + "/needs_deceleration");
      r.needs_crossing_from = flag(doc, base + "/needs_crossing_from");
      r.needs_multi_lane = flag(doc, base + "/needs_multi_lane");
      l.kinds[it.key()] = std::move(r);
    }
  }
  return l;
}

Json HazardLimits::to_json() const {
  Json j = {{"classes", Json::object()}, {"kinds", Json::object()}};
  for (const auto& [name, c] : classes)
    j["classes"][name] = {{"max_speed_mps", c.max_speed_mps}, {"max_decel_mps2", c.max_decel_mps2}};
  for (const auto& [name, r] : kinds) {
    Json k = {{"classes", r.classes},
              {"sides", r.sides},
              {"needs_deceleration", r.needs_deceleration},
              {"needs_crossing_from", r.needs_crossing_from},
              {"needs_multi_lane", r.needs_multi_lane}};
    if (r.abs_heading_deg) k["abs_heading_deg"] = {r.abs_heading_deg->first, r.abs_heading_deg->second};
    j["kinds"][name] = std::move(k);
  }
  return j;
}

TtcSimulation simulate_ttc(const HazardSpec& spec, const ClassSize& size, double ego_speed_mps,
                           const Corridor& corridor, double ego_front_m, double horizon_s, double dt) {
  TtcSimulation sim;
  const double h = spec.heading_deg * kPi / 180.0;
  const Extent ext = extent(size, h);
  const double decel = spec.deceleration_mps2.value_or(0.0);
  const double corridor_half = corridor.ego_half_width + corridor.margin + ext.lateral_half;
  double x = spec.initial_distance_m, y = spec.lateral_offset_m, v = spec.speed_mps;
  const int steps = static_cast<int>(std::ceil(horizon_s / dt));
  for (int i = 0; i <= steps; ++i) {
    const double t = i * dt;
    const double xr = x - ego_speed_mps * t;
    const bool in_path = corridor.contains(xr, y, 2.0 * ext.lateral_half);
    sim.closest_lateral_m = std::min(sim.closest_lateral_m, std::max(0.0, std::abs(y) - corridor_half));
    if (in_path) {
      sim.enters_path = true;
      const double gap = xr - ego_front_m - ext.longitudinal_half;
      const double closing = ego_speed_mps - v * std::cos(h);
      double ttc = kInf;
      if (gap <= 0.0) ttc = 0.0;
      else if (closing > kMinClosing) ttc = gap / closing;
      if (i == 0) {
        sim.starts_in_collision = gap <= 0.0;
        sim.ttc_at_start = ttc;
      }
      if (ttc < sim.min_ttc) {
        sim.min_ttc = ttc;
        sim.t_min_ttc = t;
      }
      if (gap <= 0.0) break;  // collision: nothing after it matters
    }
    x += v * std::cos(h) * dt;
    y += v * std::sin(h) * dt;
    v = std::max(0.0, v - decel * dt);
  }
  return sim;
}

std::vector<std::string> check_feasibility(const HazardSpec& spec, const SceneContext& scene,
                                           const FeasibilityConfig& cfg, std::vector<std::string>* skipped) {
  std::vector<std::string> errs;
  const std::string& cls = spec.object_class;
  const std::string limits_file = cfg.limits.file.empty() ? "hazard limits" : cfg.limits.file;

  // Class limits.
  auto cl = cfg.limits.classes.find(cls);
  if (cl == cfg.limits.classes.end()) {
    errs.push_back("/object_class = \"" + cls + "\" has no physical limits in " + limits_file);
  } else {
    if (spec.speed_mps > cl->second.max_speed_mps)
      errs.push_back("/speed_mps = " + num(spec.speed_mps) + " is more than a " + cls + " can do (at most " +
                     num(cl->second.max_speed_mps) + " m/s)");
    if (spec.deceleration_mps2 && *spec.deceleration_mps2 > cl->second.max_decel_mps2)
      errs.push_back("/deceleration_mps2 = " + num(*spec.deceleration_mps2) + " is more than a " + cls +
                     " can brake (at most " + num(cl->second.max_decel_mps2) + " m/s^2)");
  }

  // Kind rules.
  if (auto kr = cfg.limits.kinds.find(spec.kind); kr != cfg.limits.kinds.end()) {
    const KindRules& r = kr->second;
    if (!r.classes.empty() && !contains(r.classes, cls))
      errs.push_back("/object_class = \"" + cls + "\" cannot make a " + spec.kind + " (allowed: " + join(r.classes) + ")");
    if (r.abs_heading_deg) {
      double a = std::abs(spec.heading_deg);
      if (a < r.abs_heading_deg->first || a > r.abs_heading_deg->second)
        errs.push_back("/heading_deg = " + num(spec.heading_deg) + " does not fit a " + spec.kind + " (|heading| in [" +
                       num(r.abs_heading_deg->first) + ", " + num(r.abs_heading_deg->second) + "] deg)");
    }
    if (!r.sides.empty() && !contains(r.sides, spec.side))
      errs.push_back("/side = \"" + spec.side + "\" does not fit a " + spec.kind + " (allowed: " + join(r.sides) + ")");
    if (r.needs_deceleration && !spec.deceleration_mps2)
      errs.push_back("/deceleration_mps2 is null but a " + spec.kind + " needs a braking deceleration");
    if (r.needs_deceleration && spec.deceleration_mps2 && *spec.deceleration_mps2 <= 0.0)
      errs.push_back("/deceleration_mps2 = " + num(*spec.deceleration_mps2) + " does not brake (must be > 0)");
    if (r.needs_crossing_from) {
      const Json* from = spec.extra.contains("crossing_from") ? &spec.extra["crossing_from"] : nullptr;
      if (!from || !from->is_string()) {
        errs.push_back("/extra/crossing_from is null but a " + spec.kind + " needs the side it starts from");
      } else {
        std::string f = from->get<std::string>();
        if (f != spec.side)
          errs.push_back("/extra/crossing_from = \"" + f + "\" contradicts /side = \"" + spec.side + "\"");
        if ((f == "left" && spec.heading_deg > 0) || (f == "right" && spec.heading_deg < 0))
          errs.push_back("/heading_deg = " + num(spec.heading_deg) + " moves away from the road: crossing from the " + f +
                         " needs a heading " + (f == "left" ? "< 0" : "> 0"));
      }
    }
    if (r.needs_multi_lane && !cfg.road.multi_lane)
      errs.push_back("/kind = \"" + spec.kind + "\" needs a lane beside the ego lane; this road has one lane (multi_lane = no)");
  }

  // Scene rules (the prompt's rules 3 and 4).
  if (cls == "person" && !cfg.road.sidewalks)
    errs.push_back("/object_class = \"person\" is not allowed: the scene has no sidewalks (sidewalks = no)");
  if (is_vehicle(cls) && std::abs(spec.heading_deg) > 45.0 && !cfg.road.intersection)
    errs.push_back("/heading_deg = " + num(spec.heading_deg) +
                   " makes a vehicle cross the ego path, which needs an intersection (intersection = no)");

  // Side agrees with the lateral position.
  const double y = spec.lateral_offset_m;
  const double lane_half = cfg.corridor.ego_half_width + cfg.corridor.margin;
  if (spec.side == "left" && y <= 0.0)
    errs.push_back("/side = \"left\" contradicts /lateral_offset_m = " + num(y) + " (left of the ego means y > 0)");
  if (spec.side == "right" && y >= 0.0)
    errs.push_back("/side = \"right\" contradicts /lateral_offset_m = " + num(y) + " (right of the ego means y < 0)");
  if (spec.side == "center" && std::abs(y) > lane_half)
    errs.push_back("/side = \"center\" contradicts /lateral_offset_m = " + num(y) + " (center means |y| <= " +
                   num(lane_half) + " m)");

  // On the road (or a sidewalk for people and bicycles).
  const bool may_use_sidewalk = (cls == "person" || cls == "bicycle") && cfg.road.sidewalks;
  const double max_y = cfg.road.road_half_width_m + (may_use_sidewalk ? cfg.road.sidewalk_width_m : 0.0);
  if (std::abs(y) > max_y)
    errs.push_back("/lateral_offset_m = " + num(y) + " puts the " + cls + " off the " +
                   (may_use_sidewalk ? "road and sidewalk" : "road") + " (|y| <= " + num(max_y) + " m)");

  // Visible to the camera at the start.
  if (scene.camera.valid()) {
    auto px = scene.camera.project_ego(cv::Vec3d(spec.initial_distance_m, y, 0.0));
    if (!px) {
      errs.push_back("/initial_distance_m = " + num(spec.initial_distance_m) + " puts the start point behind the camera");
    } else if (px->x < 0 || px->y < 0 || px->x >= scene.camera.width || px->y >= scene.camera.height) {
      errs.push_back("start point (x " + num(spec.initial_distance_m) + " m, y " + num(y) + " m) is outside the camera view: it projects to pixel (" +
                     num(px->x) + ", " + num(px->y) + ") in a " + std::to_string(scene.camera.width) + "x" +
                     std::to_string(scene.camera.height) + " image");
    }
  } else if (skipped) {
    skipped->push_back("camera visibility not checked: the frame has no camera model");
  }

  // Not on top of a detected object.
  if (cfg.sizes.has(cls)) {
    const ClassSize& me = cfg.sizes.at(cls);
    for (const ObjectState& o : scene.objects) {
      if (!std::isfinite(o.distance_m)) continue;
      ClassSize other = cfg.sizes.has(o.label) ? cfg.sizes.at(o.label) : ClassSize{};
      double ow = o.width_m > 0 ? o.width_m : other.width, ol = o.length_m > 0 ? o.length_m : other.length;
      if (std::abs(o.distance_m - spec.initial_distance_m) < (ol + me.length) / 2.0 &&
          std::abs(o.lateral_m - y) < (ow + me.width) / 2.0)
        errs.push_back("start point (x " + num(spec.initial_distance_m) + " m, y " + num(y) + " m) overlaps the detected " +
                       o.label + " (track " + std::to_string(o.track_id) + ") at x " + num(o.distance_m) + " m, y " +
                       num(o.lateral_m) + " m");
    }
  }

  // When it appears.
  if (spec.start_time_s < cfg.trigger_time_s - 1e-6)
    errs.push_back("/start_time_s = " + num(spec.start_time_s) + " is before the frame the hazard is for (" +
                   num(cfg.trigger_time_s) + " s)");
  if (spec.start_time_s > cfg.trigger_time_s + cfg.horizon_s)
    errs.push_back("/start_time_s = " + num(spec.start_time_s) + " is more than " + num(cfg.horizon_s) +
                   " s after the frame the hazard is for (" + num(cfg.trigger_time_s) + " s)");

  // The target TTC must make the scene critical, and the motion must reach it.
  if (spec.target_ttc_s && *spec.target_ttc_s >= cfg.threshold_s)
    errs.push_back("/target_ttc_s = " + num(*spec.target_ttc_s) + " is not below the risk threshold " +
                   num(cfg.threshold_s) + " s, so the scene would stay Safe");
  if (cfg.sizes.has(cls)) {
    TtcSimulation sim = simulate_ttc(spec, cfg.sizes.at(cls), cfg.ego_speed_mps, cfg.corridor, cfg.ego_front_m,
                                     cfg.horizon_s);
    const double target = spec.target_ttc_s.value_or(cfg.threshold_s);
    if (sim.starts_in_collision) {
      errs.push_back("the " + cls + " would appear already touching the ego vehicle (x " + num(spec.initial_distance_m) +
                     " m is within the ego front " + num(cfg.ego_front_m) + " m plus half its length)");
    } else if (sim.ttc_at_start < target - cfg.ttc_tolerance_s) {
      errs.push_back("the " + cls + " would appear with TTC " + num(sim.ttc_at_start) + " s, already below /target_ttc_s = " +
                     num(target) + ": a hazard must develop, not appear inside the collision course (increase /initial_distance_m)");
    } else if (!sim.enters_path) {
      errs.push_back("/target_ttc_s = " + num(target) + " is never reached: with the ego at " + num(cfg.ego_speed_mps) +
                     " m/s the " + cls + " never enters the ego path within " + num(cfg.horizon_s) + " s (it stays " +
                     num(sim.closest_lateral_m) + " m outside)");
    } else if (sim.min_ttc > target + cfg.ttc_tolerance_s) {
      errs.push_back("/target_ttc_s = " + num(target) + " is never reached: with the ego at " + num(cfg.ego_speed_mps) +
                     " m/s the lowest TTC within " + num(cfg.horizon_s) + " s is " + num(sim.min_ttc) + " s");
    }
  }
  return errs;
}

}  // namespace hf::llm_hazard
