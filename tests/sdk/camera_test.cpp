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

}  // namespace
}  // namespace hf
