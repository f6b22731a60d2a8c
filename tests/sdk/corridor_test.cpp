// The in-path corridor (corridor.hpp) on synthetic geometry with known answers: straight and curved ego
// paths.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>

#include "hazardforge/corridor.hpp"

namespace hf {
namespace {

constexpr double kLane = 3.5;  // m, lane width of the curve scenarios

// Ego-frame point at arc length s along `path`, offset `d` to the left of it.
cv::Vec2d on_path(const EgoPath& path, double s, double d) {
  const cv::Vec3d p = path.at(s);
  return {p[0] - d * std::sin(p[2]), p[1] + d * std::cos(p[2])};
}

TEST(Corridor, HalfWidthMarginAndObjectWidth) {
  Corridor k;                              // 1.0 + 0.5
  EXPECT_TRUE(k.contains(10, 2.3, 1.8));   // 2.3 < 1.5 + 0.9
  EXPECT_FALSE(k.contains(10, 2.5, 1.8));  // 2.5 > 2.4
  EXPECT_FALSE(k.contains(-1, 0, 1.8));    // behind
}

TEST(Corridor, StraightPathIsTheProtocolRule) {
  // The ground-truth protocol: x > 0 and |y| < half_width + margin + w/2. A straight path, and a corridor
  // that ignores the path (follow_path = false) whatever the path is, give exactly that.
  const EgoPath left = EgoPath::from_motion(10.0, 0.2);
  for (const Corridor k : {Corridor{}, Corridor{0.9, 0.3, true}, Corridor{1.0, 0.5, false}})
    for (double x = -5.0; x <= 60.0; x += 0.5)
      for (double y = -4.0; y <= 4.0; y += 0.05)
        for (double w : {0.0, 0.6, 1.8}) {
          const bool rule = x > 0 && std::abs(y) < k.ego_half_width + k.margin + w / 2.0;
          ASSERT_EQ(k.contains(x, y, w), rule) << x << ", " << y << ", " << w;
          if (!k.follow_path) {
            ASSERT_EQ(k.contains(x, y, w, left), rule) << x << ", " << y << ", " << w;
          }
        }
  const EgoPath straight;
  const EgoPath::Coordinates c = straight.project(12.5, -1.25);
  EXPECT_DOUBLE_EQ(c.s, 12.5);
  EXPECT_DOUBLE_EQ(c.d, -1.25);
}

TEST(EgoPath, PointsOnLeftAndRightArcsProjectOntoThemselves) {
  for (double radius : {40.0, -40.0, 150.0, -150.0}) {  // positive = left turn
    const EgoPath path{1.0 / radius};
    for (double s : {0.5, 5.0, 20.0, 45.0, 90.0, 120.0}) {
      // The arc by its closed form: centre (0, R), swept angle s / R.
      const double phi = s / radius;
      const double x = radius * std::sin(phi), y = radius * (1.0 - std::cos(phi));
      const cv::Vec3d at = path.at(s);
      EXPECT_NEAR(at[0], x, 1e-9) << radius << " " << s;
      EXPECT_NEAR(at[1], y, 1e-9) << radius << " " << s;
      EXPECT_NEAR(at[2], phi, 1e-12) << radius << " " << s;
      const EgoPath::Coordinates c = path.project(x, y);
      EXPECT_NEAR(c.s, s, 1e-9) << radius << " " << s;
      EXPECT_NEAR(c.d, 0.0, 1e-9) << radius << " " << s;
      // Offsets along the path's normal come back as d (left positive), with the same s.
      for (double d : {-3.5, -1.0, 1.0, 3.5}) {
        const cv::Vec2d p = on_path(path, s, d);
        const EgoPath::Coordinates o = path.project(p[0], p[1]);
        EXPECT_NEAR(o.s, s, 1e-9) << radius << " " << s << " " << d;
        EXPECT_NEAR(o.d, d, 1e-9) << radius << " " << s << " " << d;
      }
    }
  }
  // A right turn bends towards -y, a left one towards +y.
  EXPECT_LT(EgoPath{-0.02}.at(30)[1], 0.0);
  EXPECT_GT(EgoPath{0.02}.at(30)[1], 0.0);
}

TEST(Corridor, CarsInTheLanesOfACurveThirtyMetresAhead) {
  // 10 m/s with 0.1 rad/s of yaw: a 100 m radius. Cars 30 m along the curve: in the ego lane, on the
  // adjacent lane inside the curve and on the adjacent lane outside it.
  const Corridor k;
  const double car_width = 1.8;
  for (double yaw_rate : {0.1, -0.1}) {
    const EgoPath path = EgoPath::from_motion(10.0, yaw_rate);
    ASSERT_NEAR(path.curvature, yaw_rate / 10.0, 1e-15);
    const double inner = yaw_rate > 0 ? kLane : -kLane;  // the inside of the curve is the turning side
    const cv::Vec2d ego_lane = on_path(path, 30, 0.0), in_lane = on_path(path, 30, inner),
                    out_lane = on_path(path, 30, -inner);
    EXPECT_TRUE(k.contains(ego_lane[0], ego_lane[1], car_width, path)) << yaw_rate;
    EXPECT_FALSE(k.contains(in_lane[0], in_lane[1], car_width, path)) << yaw_rate;
    EXPECT_FALSE(k.contains(out_lane[0], out_lane[1], car_width, path)) << yaw_rate;
    // Within the corridor's edge at that distance: half-width 1.0 + margin 0.5 + 0.9 = 2.4 m from the path.
    const cv::Vec2d edge_in = on_path(path, 30, 2.35), edge_out = on_path(path, 30, 2.45);
    EXPECT_TRUE(k.contains(edge_in[0], edge_in[1], car_width, path));
    EXPECT_FALSE(k.contains(edge_out[0], edge_out[1], car_width, path));
  }
}

TEST(Corridor, StraightCorridorMisjudgesACurveThatTheArcGetsRight) {
  const EgoPath path = EgoPath::from_motion(10.0, 0.1);  // left, 100 m radius
  const Corridor along_path{1.0, 0.5, true}, straight{1.0, 0.5, false};
  // The car ahead in the ego's own lane, 40 m along the curve, is 7.9 m to the left of the ego's x axis: the
  // straight corridor loses it.
  const cv::Vec2d lead = on_path(path, 40, 0.0);
  EXPECT_NEAR(lead[1], 100.0 * (1.0 - std::cos(0.4)), 1e-9);
  EXPECT_TRUE(along_path.contains(lead[0], lead[1], 1.8, path));
  EXPECT_FALSE(straight.contains(lead[0], lead[1], 1.8, path));
  // A car in the lane outside the curve, 25 m ahead, sits on the ego's x axis: the straight corridor calls
  // it in path although the ego turns away from it.
  const cv::Vec2d outer = on_path(path, 25, -kLane);
  EXPECT_LT(std::abs(outer[1]), 0.5);
  EXPECT_FALSE(along_path.contains(outer[0], outer[1], 1.8, path));
  EXPECT_TRUE(straight.contains(outer[0], outer[1], 1.8, path));
}

TEST(Corridor, BehindTheEgoIsNeverInPath) {
  const Corridor k;
  for (double curvature : {0.0, 0.01, -0.01, 0.2, -0.2}) {
    const EgoPath path{curvature};
    for (double x : {-0.01, -1.0, -10.0, -60.0})
      for (double y : {-20.0, -2.0, 0.0, 2.0, 20.0}) {
        EXPECT_LT(path.project(x, y).s, 0.0) << curvature << " " << x << " " << y;
        EXPECT_FALSE(k.contains(x, y, 1.8, path)) << curvature << " " << x << " " << y;
      }
    // The tightest turn: the point where the path comes back past the ego's rear axle is behind it too.
    if (curvature != 0.0) {
      EXPECT_FALSE(k.contains(-0.5, 2.0 / curvature, 1.8, path)) << curvature;
    }
  }
}

TEST(EgoPath, FromMotionIsStraightWithoutASpeedOrAYawRate) {
  const double nan = std::numeric_limits<double>::quiet_NaN();
  EXPECT_EQ(EgoPath::from_motion(std::nullopt, 0.3).curvature, 0.0);
  EXPECT_EQ(EgoPath::from_motion(10.0, std::nullopt).curvature, 0.0);
  EXPECT_EQ(EgoPath::from_motion(nan, 0.3).curvature, 0.0);
  EXPECT_EQ(EgoPath::from_motion(10.0, nan).curvature, 0.0);
  EXPECT_EQ(EgoPath::from_motion(0.0, 0.3).curvature, 0.0);
  EXPECT_EQ(EgoPath::from_motion(-5.0, 0.3).curvature, 0.0);
  EXPECT_EQ(EgoPath::from_motion(0.9, 0.1).curvature, 0.0);  // below the 1 m/s default
  EXPECT_NEAR(EgoPath::from_motion(0.9, 0.1, 0.5).curvature, 0.1 / 0.9, 1e-15);
  EXPECT_NEAR(EgoPath::from_motion(8.0, -0.2).curvature, -0.025, 1e-15);
}

TEST(EgoPath, FromMotionCapsTheCurvature) {
  EXPECT_DOUBLE_EQ(EgoPath::from_motion(2.0, 1.0).curvature, 0.2);  // 0.5 1/m asked, 5 m radius at most
  EXPECT_DOUBLE_EQ(EgoPath::from_motion(2.0, -1.0).curvature, -0.2);
  EXPECT_DOUBLE_EQ(EgoPath::from_motion(2.0, 1.0, 1.0, 0.05).curvature, 0.05);
}

TEST(Corridor, EstimatedObjectsUseTheirDistanceOriginAndTheStatesEgoMotion) {
  ObjectStates states;
  states.distance_origin_x = 1.7;  // distances measured from a camera 1.7 m ahead of the rear axle
  ObjectState s;
  s.width_m = 1.8;
  const EgoPath path = EgoPath::from_motion(10.0, 0.1);
  const cv::Vec2d lead = on_path(path, 40, 0.0);
  s.distance_m = lead[0] - 1.7;
  s.lateral_m = lead[1];
  const Corridor k;
  EXPECT_FALSE(k.contains(states, s));  // no ego motion known: straight, and 7.9 m to the left is out
  states.ego_speed_mps = 10.0;
  states.ego_yaw_rate = 0.1;
  EXPECT_TRUE(k.contains(states, s));
  EXPECT_FALSE((Corridor{1.0, 0.5, false}.contains(states, s)));
  // Between the rear axle and the camera: ahead of the ego origin, so in path.
  ObjectState beside = s;
  beside.distance_m = -1.0;
  beside.lateral_m = 0.0;
  EXPECT_TRUE(k.contains(states, beside));
}

TEST(Corridor, ParamsHaveOneSpelling) {
  std::vector<std::string> names;
  for (const ParamSpec& p : Corridor::params()) names.push_back(p.name);
  EXPECT_EQ(names, (std::vector<std::string>{"corridor_half_width", "corridor_margin", "corridor_path"}));
  EXPECT_EQ(Corridor::params()[2].default_value, "ego_path");
  EXPECT_EQ(Corridor::params(false)[2].default_value, "straight");
  const Corridor c = Corridor::from(
      Params(Json{{"corridor_half_width", 0.9}, {"corridor_margin", 0.2}, {"corridor_path", "straight"}}));
  EXPECT_DOUBLE_EQ(c.ego_half_width, 0.9);
  EXPECT_DOUBLE_EQ(c.margin, 0.2);
  EXPECT_FALSE(c.follow_path);
  EXPECT_TRUE(Corridor::from(Params(Json{{"corridor_path", "ego_path"}})).follow_path);
}

}  // namespace
}  // namespace hf
