// Test helpers for the scenario tests: a known camera and scene, templates from a registry, and peak
// kinematics computed here independently of the library under test.
#pragma once

#include <algorithm>
#include <cmath>
#include <fstream>
#include <memory>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "hazardforge/angles.hpp"
#include "hazardforge/registry.hpp"
#include "hazardforge/stage.hpp"
#include "hazardforge/types.hpp"
#include "refusal_support.hpp"

#include "cut_in_template.hpp"
#include "pedestrian_along_road_template.hpp"
#include "pedestrian_crossing_template.hpp"
#include "pedestrian_dart_out_template.hpp"
#include "pull_out_template.hpp"
#include "stopped_vehicle_template.hpp"
#include "sudden_stop_template.hpp"

namespace hf::test {

// nuScenes-like front camera: 1600x900, f = 1266 px, level, 1.5 m high and 1.5 m ahead of the rear axle.
inline CameraModel test_camera() {
  return CameraModel::pinhole(1600, 900, 1266, 1266, 800, 450, 1.5, 0.0, 1.5);
}

inline SceneContext test_scene(double ego_speed, double t = 2.0) {
  SceneContext s;
  s.timestamp = t;
  s.ego_speed_mps = ego_speed;
  s.camera = test_camera();
  return s;
}

inline ComponentRegistry& template_registry() {
  static ComponentRegistry reg;
  static const bool registered = [] {
    reg.add<PedestrianCrossingTemplate>();
    reg.add<CutInTemplate>();
    reg.add<SuddenStopTemplate>();
    reg.add<StoppedVehicleTemplate>();
    reg.add<PullOutTemplate>();
    reg.add<PedestrianAlongRoadTemplate>();
    reg.add<PedestrianDartOutTemplate>();
    return true;
  }();
  (void)registered;
  return reg;
}

inline std::unique_ptr<hazard::TemplateBase> make_template(const std::string& kind,
                                                           const Json& params = Json::object()) {
  auto t = template_registry().create<hazard::TemplateBase>(kind::kHazardTemplate, kind, params);
  return t;
}

// Peak |a|, |jerk| and turn rate from positions/headings only, by plain finite differences.
struct Peaks {
  double accel = 0, jerk = 0, yaw_rate_dps = 0, lateral_speed = 0, speed = 0;
};
inline Peaks peaks(const std::vector<TrajectoryPoint>& p) {
  Peaks k;
  const double dt = p[1].t - p[0].t;
  for (size_t i = 1; i + 1 < p.size(); ++i) {
    const double ax = (p[i + 1].x - 2 * p[i].x + p[i - 1].x) / (dt * dt);
    const double ay = (p[i + 1].y - 2 * p[i].y + p[i - 1].y) / (dt * dt);
    k.accel = std::max(k.accel, std::hypot(ax, ay));
  }
  for (size_t i = 1; i + 2 < p.size(); ++i) {
    const double jx = (p[i + 2].x - 3 * p[i + 1].x + 3 * p[i].x - p[i - 1].x) / (dt * dt * dt);
    const double jy = (p[i + 2].y - 3 * p[i + 1].y + 3 * p[i].y - p[i - 1].y) / (dt * dt * dt);
    k.jerk = std::max(k.jerk, std::hypot(jx, jy));
  }
  for (size_t i = 0; i + 1 < p.size(); ++i) {
    const double dh = angle_diff(p[i + 1].heading, p[i].heading);
    k.yaw_rate_dps = std::max(k.yaw_rate_dps, std::abs(dh) / dt * 180 / M_PI);
    k.lateral_speed = std::max(k.lateral_speed, std::abs(p[i + 1].y - p[i].y) / dt);
    k.speed = std::max(k.speed, std::hypot(p[i + 1].x - p[i].x, p[i + 1].y - p[i].y) / dt);
  }
  return k;
}

// Plans stay within the class's limits (peaks by finite differences, 2 % for their sampling error).
inline void expect_within_limits(const HazardTrajectory& tr, const KinematicLimits& lim) {
  const Peaks k = peaks(tr.points);
  const double tol = 1.02;
  EXPECT_LE(k.accel, std::max(lim.max_accel_mps2, lim.max_decel_mps2) * tol);
  EXPECT_LE(k.jerk, lim.max_jerk_mps3 * tol);
  EXPECT_LE(k.yaw_rate_dps, lim.max_yaw_rate_dps * tol);
  EXPECT_LE(k.speed, lim.max_speed_mps * tol);
}

// Random bits for proposals from a seed (splitmix64), the same on every platform.
struct Bits : RandomDraw {
  uint64_t state;
  explicit Bits(uint64_t seed) : state(seed) {}
  uint64_t next() override {
    uint64_t z = (state += 0x9e3779b97f4a7c15ULL);
    z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ULL;
    z = (z ^ (z >> 27)) * 0x94d049bb133111ebULL;
    return z ^ (z >> 31);
  }
};

inline std::string read_text(const std::string& path) {
  std::ifstream in(path);
  return std::string(std::istreambuf_iterator<char>(in), {});
}

}  // namespace hf::test
