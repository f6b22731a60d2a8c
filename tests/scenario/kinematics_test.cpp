// The shared hazard kinematics: S-curve profiles, min-jerk shifts, the protocol's TTC, the limits table.
#include <gtest/gtest.h>

#include <cstdio>
#include <filesystem>
#include <fstream>

#include "hazardforge/hazard/kinematics.hpp"
#include "temp_dir.hpp"

namespace hf::hazard {
namespace {

TEST(SpeedProfile, SCurveStopHasClosedFormDurationAndDistance) {
  // 15 m/s -> 0 at 6 m/s^2 with jerk 12: ramps of 0.5 s, 2 s at full braking; symmetric, so s = v0 * T / 2.
  SpeedProfile p = SpeedProfile(15.0).change_speed(0.0, 6.0, 12.0);
  EXPECT_NEAR(p.duration(), 3.0, 1e-12);
  EXPECT_NEAR(p.end_distance(), 22.5, 1e-9);
  EXPECT_NEAR(p.at(0.25).a, -3.0, 1e-12);
  EXPECT_NEAR(p.at(1.0).a, -6.0, 1e-12);
  EXPECT_NEAR(p.at(0.5).v, 15.0 - 12.0 * 0.25 / 2, 1e-12);
  EXPECT_DOUBLE_EQ(p.at(10.0).v, 0.0);
  EXPECT_FALSE(p.time_at_distance(30.0).has_value());
  EXPECT_NEAR(*p.time_at_distance(p.at(1.7).s), 1.7, 1e-9);
}

TEST(SpeedProfile, ShortChangeIsTriangular) {
  // dv = 0.5 < A^2/J = 0.9: peak acceleration sqrt(dv J) = sqrt(5), never the limit.
  SpeedProfile p = SpeedProfile(0.0).hold(1.0).change_speed(0.5, 3.0, 10.0);
  EXPECT_NEAR(p.duration(), 1.0 + 2 * std::sqrt(0.05), 1e-12);
  EXPECT_NEAR(p.at(1.0 + std::sqrt(0.05)).a, std::sqrt(5.0), 1e-9);
  EXPECT_DOUBLE_EQ(p.at(0.5).s, 0.0);
}

TEST(MinJerkShift, DurationMeetsTheBindingLimit) {
  // 3.5 m with 2 m/s, 4 m/s^2, 12 m/s^3: the rate binds (1.875 * 3.5 / 2 = 3.28 s).
  const double T = min_jerk_duration(3.5, 2.0, 4.0, 12.0);
  EXPECT_NEAR(T, 3.28125, 1e-12);
  EXPECT_NEAR(min_jerk_shift(3.5, T, T / 2).v, 2.0, 1e-12);
  EXPECT_NEAR(min_jerk_shift(3.5, T, T).p, 3.5, 1e-12);
  EXPECT_NEAR(min_jerk_shift(3.5, T, T / 2).p, 1.75, 1e-12);
  EXPECT_LE(min_jerk_shift(3.5, T, 0.2113 * T).a, 4.0);
}

TEST(Ttc, FollowsTheGroundTruthProtocol) {
  TtcConventions conv;
  TrajectoryPoint ego{0.0, 0.0, 0.0, 0.0, 10.0, 0.0};
  TrajectoryPoint lead{0.0, 20.0, 0.5, 0.0, 5.0, 0.0};
  const cv::Vec3d car(4.5, 1.8, 1.5);
  TtcSample s = ttc_at(ego, lead, car, conv);
  EXPECT_TRUE(s.in_path);
  EXPECT_NEAR(s.gap, 20.0 - 3.4 - 2.25, 1e-12);
  EXPECT_NEAR(s.closing, 5.0, 1e-12);
  EXPECT_NEAR(s.ttc, 14.35 / 5.0, 1e-12);
  // |y| = 2.5 >= 1.0 + 0.5 + 0.9: not in path.
  lead.y = 2.5;
  EXPECT_TRUE(std::isinf(ttc_at(ego, lead, car, conv).ttc));
  // Opening gap: no TTC.
  lead.y = 0.0;
  lead.speed = 12.0;
  EXPECT_TRUE(std::isinf(ttc_at(ego, lead, car, conv).ttc));
  // Seen from an ego turned by 90 degrees, an object 20 m to its left along world y is straight ahead.
  TrajectoryPoint ego_n{0.0, 0.0, 0.0, M_PI / 2, 10.0, 0.0};
  TrajectoryPoint obj_n{0.0, 0.0, 20.0, M_PI / 2, 5.0, 0.0};
  EXPECT_NEAR(ttc_at(ego_n, obj_n, car, conv).ttc, 14.35 / 5.0, 1e-9);
}

TEST(Measure, PeaksOfAKnownParabola) {
  // x = t^2 (a = 2) sampled at 10 Hz: second differences are exactly 2, third differences 0.
  std::vector<TrajectoryPoint> pts;
  for (int k = 0; k <= 20; ++k) {
    const double t = k / 10.0;
    pts.push_back({t, t * t, 0.0, 0.0, 2 * t, 2.0});
  }
  const MotionStats s = measure(pts);
  EXPECT_NEAR(s.max_accel, 2.0, 1e-9);
  EXPECT_NEAR(s.max_long_accel, 2.0, 1e-9);
  EXPECT_NEAR(s.max_jerk, 0.0, 1e-6);
  EXPECT_NEAR(s.max_speed, 4.0, 0.11);
  KinematicLimits lim{"car", 60, 1.5, 10, 20, 4, 2, 45};
  const auto r = exceeded_limits(s, lim);
  ASSERT_EQ(r.size(), 1u);
  EXPECT_EQ(r[0], "peak acceleration 2 m/s^2 exceeds the car limit of 1.5 m/s^2");
}

TEST(LimitsTable, ShippedTableHasEveryClassTheTemplatesUse) {
  const LimitsTable t = LimitsTable::load(LimitsTable::default_path());
  for (const char* c : {"person", "bicycle", "motorcycle", "car", "truck", "bus"}) EXPECT_TRUE(t.has(c)) << c;
  EXPECT_DOUBLE_EQ(t.at("person").max_speed_mps, 7.0);
  EXPECT_DOUBLE_EQ(t.at("car").max_decel_mps2, 10.0);
  try {
    t.at("tram");
    FAIL();
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("object_class 'tram' has no kinematic limits in "),
              std::string::npos);
    EXPECT_NE(std::string(e.what()).find("(known: bicycle, bus, car, motorcycle, person, truck)"),
              std::string::npos);
  }
}

TEST(LimitsTable, BadFieldIsReportedWithFileAndLine) {
  const hf::test::TempDir tmp;
  const auto path = tmp / "bad_limits.yaml";
  std::ofstream(path) << "car:\n  max_speed_mps: 60\n  max_accel_mps2: fast\n";
  try {
    LimitsTable::load(path.string());
    FAIL();
  } catch (const Error& e) {
    EXPECT_EQ(std::string(e.what()),
              path.string() + ":3:19: error: class 'car': 'max_accel_mps2' must be a positive number");
  }
}

}  // namespace
}  // namespace hf::hazard
