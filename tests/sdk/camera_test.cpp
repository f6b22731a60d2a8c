// Camera model geometry on synthetic cameras with known answers.
#include <gtest/gtest.h>

#include <cmath>

#include "hazardforge/geometry.hpp"
#include "hazardforge/types.hpp"

namespace hf {
namespace {

TEST(Camera, LevelCameraProjectsGroundPointBelowHorizon) {
  CameraModel c = CameraModel::pinhole(1280, 720, 1000, 1000, 640, 360, 1.5, 0.0, 1.5);
  // A ground point 20 m ahead of the camera: y_img = cy + f * h / Z.
  auto px = c.project_ego({21.5, 0.0, 0.0});
  ASSERT_TRUE(px);
  EXPECT_NEAR(px->x, 640, 1e-9);
  EXPECT_NEAR(px->y, 360 + 1000 * 1.5 / 20.0, 1e-9);
  // A point 2 m to the left appears left of centre.
  auto left = c.project_ego({21.5, 2.0, 1.5});
  ASSERT_TRUE(left);
  EXPECT_NEAR(left->x, 640 - 1000 * 2.0 / 20.0, 1e-9);
  EXPECT_NEAR(left->y, 360, 1e-9);
  EXPECT_FALSE(c.project_ego({0.0, 0.0, 1.0}));  // behind the camera
}

TEST(Camera, PixelToGroundInvertsProjectionWithPitch) {
  CameraModel c = CameraModel::pinhole(1600, 900, 1266, 1266, 816, 491, 1.6, 0.05, 1.7);
  EXPECT_NEAR(c.pitch(), 0.05, 1e-12);
  for (double x : {5.0, 12.0, 40.0})
    for (double y : {-3.0, 0.0, 2.5}) {
      auto px = c.project_ego({x, y, 0.0});
      ASSERT_TRUE(px);
      auto g = c.pixel_to_ground(*px);
      ASSERT_TRUE(g);
      EXPECT_NEAR((*g)[0], x, 1e-6);
      EXPECT_NEAR((*g)[1], y, 1e-6);
      EXPECT_NEAR((*g)[2], 0.0, 1e-9);
    }
  EXPECT_FALSE(c.pixel_to_ground({816, 100}));  // above the horizon
}

TEST(Camera, ScaledToKeepsNormalisedGeometry) {
  CameraModel c = CameraModel::pinhole(1600, 900, 1266, 1266, 816, 491);
  CameraModel s = c.scaled_to(800, 450);
  EXPECT_DOUBLE_EQ(s.fx, 633);
  EXPECT_DOUBLE_EQ(s.cy, 245.5);
}

TEST(Trajectory, InterpolatesAndRefusesOutside) {
  HazardTrajectory t;
  t.points = {{0, 0, 0, 0, 1, 0}, {1, 1, 2, 0, 1, 0}};
  auto p = t.at(0.5);
  ASSERT_TRUE(p);
  EXPECT_DOUBLE_EQ(p->x, 0.5);
  EXPECT_DOUBLE_EQ(p->y, 1.0);
  EXPECT_FALSE(t.at(1.5));
}

// Samples of an object moving along a circle of radius r (centre (0, r)) at speed v from heading 0.
HazardTrajectory on_circle(double r, double v, double seconds, double accel = 0) {
  HazardTrajectory t;
  for (int k = 0; k <= static_cast<int>(seconds * 20); ++k) {
    const double tt = k / 20.0, h = v * tt / r;
    t.points.push_back({tt, r * std::sin(h), r * (1 - std::cos(h)), h, v, accel});
  }
  return t;
}

TEST(Trajectory, CarriesOnAsItEndedPastItsLastPoint) {
  // Within the plan: the interpolation; before it: nothing.
  const HazardTrajectory arc = on_circle(40, 8, 2);
  EXPECT_FALSE(arc.continued_at(-0.1));
  EXPECT_DOUBLE_EQ(arc.continued_at(1.0)->x, arc.at(1.0)->x);
  // Past it: on along the same circle at the same speed (the chords of 0.4 m shorten the arc by 1e-5).
  for (double tt : {2.5, 4.0}) {
    const auto p = arc.continued_at(tt);
    ASSERT_TRUE(p);
    const double h = 8 * tt / 40;
    EXPECT_NEAR(p->x, 40 * std::sin(h), 0.02) << tt;
    EXPECT_NEAR(p->y, 40 * (1 - std::cos(h)), 0.02) << tt;
    EXPECT_NEAR(p->heading, h, 1e-3) << tt;
    EXPECT_DOUBLE_EQ(p->speed, 8);
  }
  // A straight walker walks on in a straight line.
  const HazardTrajectory walk = on_circle(1e9, 1.4, 3);
  const auto w = walk.continued_at(5.0);
  EXPECT_NEAR(w->x, 7.0, 1e-6);
  EXPECT_NEAR(w->y, 0.0, 1e-6);
  // Braking goes on to a standstill and stays there: 6 m/s at 3 m/s^2 stops after 2 s and 6 m more.
  HazardTrajectory brake;
  brake.points = {{0, 0, 0, 0, 12, -3}, {2, 18, 0, 0, 6, -3}};
  EXPECT_NEAR(brake.continued_at(3.0)->x, 18 + 6 - 1.5, 1e-9);
  EXPECT_NEAR(brake.continued_at(3.0)->speed, 3, 1e-9);
  for (double tt : {4.0, 9.0}) {
    EXPECT_NEAR(brake.continued_at(tt)->x, 24, 1e-9) << tt;
    EXPECT_DOUBLE_EQ(brake.continued_at(tt)->speed, 0) << tt;
    EXPECT_DOUBLE_EQ(brake.continued_at(tt)->accel, 0) << tt;
  }
  // A plan that ends speeding up does not speed up any further; one that ended standing stays put.
  HazardTrajectory faster;
  faster.points = {{0, 0, 0, 0, 2, 2}, {1, 3, 0, 0, 4, 2}};
  EXPECT_NEAR(faster.continued_at(2.0)->x, 7, 1e-9);
  HazardTrajectory standing;
  standing.points = {{0, 5, 1, 0.3, 0, 0}, {1, 5, 1, 0.3, 0, 0}};
  EXPECT_NEAR(standing.continued_at(7.0)->x, 5, 1e-12);
  EXPECT_NEAR(standing.continued_at(7.0)->heading, 0.3, 1e-12);
}

}  // namespace
}  // namespace hf
