// Ego motion for anchoring: the recording's ego track, dataset poses, the frames' own speed (dead reckoning).
#include <gtest/gtest.h>

#include <cmath>

#include "ego_motion.hpp"
#include "hazardforge/error.hpp"
#include "render_fixtures.hpp"

namespace hf::render {
namespace {

using hf::test::test_camera;

TEST(EgoTrajectoryTrack, FollowsTheRecordingsEgoTrackInAutoMode) {
  // No poses, but the source estimated the ego's motion (a left arc at 10 m/s, 0.2 rad/s): auto picks the
  // track and the poses are the track's, interpolated between its samples.
  const CameraModel cam = test_camera();
  const cv::Mat flat(900, 1600, CV_8UC3, cv::Scalar(100, 100, 100));
  auto track = std::make_shared<EgoTrack>();
  track->source = "video";
  for (int k = 0; k <= 10; ++k) {
    const double t = 0.1 * k, yaw = 0.2 * t;
    track->samples.push_back({t, 50.0 * std::sin(yaw), 50.0 * (1 - std::cos(yaw)), yaw, 10.0, 0.2});
  }
  EgoTrajectory ego(EgoTrajectory::Options{});
  for (int k = 0; k <= 4; ++k) {
    Frame f = hf::test::make_frame(k, 0.25 * k, flat, cam);
    f.ego_track = track;
    ego.update(f);
    EXPECT_EQ(ego.last_source(), "track (video)");
    const EgoTrackSample want = track->at(0.25 * k);
    EXPECT_NEAR(ego.current()(0, 3), want.x, 1e-9);
    EXPECT_NEAR(ego.current()(1, 3), want.y, 1e-9);
  }
  EXPECT_NEAR(*ego.yaw_rate(), 0.2, 0.01);
  // Asked for explicitly on a frame without a track: one message naming the frame.
  EgoTrajectory::Options o;
  o.mode = EgoMotionMode::kTrack;
  EgoTrajectory strict(o);
  try {
    strict.update(hf::test::make_frame(3, 0.3, flat, cam));
    ADD_FAILURE() << "no error";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("ego_motion 'track' needs the recording's ego track"),
              std::string::npos)
        << e.what();
  }
}

// Dataset poses whose attitude comes from an IMU while their height stays fixed (nuScenes: z = 0, pitch up to
// a few degrees): a hazard on the road where it was planned must stay on the road the current ego stands on.
// Chaining the pitch lifted a car 25 m ahead of its anchor frame by 0.35 m (1.4 degrees); the ego's pose on
// the map (x, y, heading) carries it instead.
TEST(EgoTrajectoryPoses, APitchedPoseWithAFixedHeightKeepsTheHazardOnTheRoad) {
  const CameraModel cam = test_camera();
  const cv::Mat flat(900, 1600, CV_8UC3, cv::Scalar(100, 100, 100));
  auto pose = [](double x, double y, double yaw, double pitch) {
    const cv::Matx33d Rz(std::cos(yaw), -std::sin(yaw), 0, std::sin(yaw), std::cos(yaw), 0, 0, 0, 1);
    const cv::Matx33d Ry(std::cos(pitch), 0, std::sin(pitch), 0, 1, 0, -std::sin(pitch), 0, std::cos(pitch));
    const cv::Matx33d R = Rz * Ry;
    return cv::Matx44d(R(0, 0), R(0, 1), R(0, 2), x, R(1, 0), R(1, 1), R(1, 2), y, R(2, 0), R(2, 1), R(2, 2),
                       0.0, 0, 0, 0, 1);
  };
  EgoTrajectory ego(EgoTrajectory::Options{});
  const double pitch = -1.4 * CV_PI / 180.0;
  Frame a = hf::test::make_frame(0, 0.0, flat, cam);
  a.ego.T_world_ego = pose(100.0, 50.0, 0.3, pitch);
  ego.update(a);
  Frame b = hf::test::make_frame(1, 2.5, flat, cam);
  b.ego.T_world_ego = pose(100.0 + 15.0 * std::cos(0.3), 50.0 + 15.0 * std::sin(0.3), 0.3, pitch);
  ego.update(b);
  EXPECT_EQ(ego.last_source(), "poses");
  // A point on the road 25 m ahead of the anchor ego is 10 m ahead of the current one, on its ground.
  const cv::Matx44d cur_from_anchor = invert_rigid(ego.current()) * *ego.pose_at(0.0);
  const cv::Vec4d p = cur_from_anchor * cv::Vec4d(25.0, 0.0, 0.0, 1.0);
  EXPECT_NEAR(p[0], 10.0, 1e-9);
  EXPECT_NEAR(p[1], 0.0, 1e-9);
  EXPECT_NEAR(p[2], 0.0, 1e-9);
  EXPECT_NEAR(yaw_of(ego.current()), 0.3, 1e-9);
}

// A source that carries only the ego's speed and yaw rate (or the ground_odometry stage before the renderer):
// auto dead-reckons on them, each interval at the mean of its two ends, along the arc.
TEST(EgoTrajectoryFrameSpeed, DeadReckonsOnTheFramesSpeedAndYawRate) {
  const CameraModel cam = test_camera();
  const cv::Mat flat(900, 1600, CV_8UC3, cv::Scalar(100, 100, 100));
  EgoTrajectory ego(EgoTrajectory::Options{});
  for (int k = 0; k <= 10; ++k) {
    Frame f = hf::test::make_frame(k, 0.1 * k, flat, cam);
    f.ego.speed_mps = 10.0;
    f.ego.yaw_rate = 0.2;
    f.ego.source = "video";
    ego.update(f);
    EXPECT_EQ(ego.last_source(), "frame speed (video)");
  }
  // 1 s at 10 m/s on a 50 m radius: the arc, to what laying each step's arc length (1 m) along its chord adds
  // (1.7e-5 m a step, 1.7e-4 m over the ten).
  EXPECT_NEAR(ego.current()(0, 3), 50.0 * std::sin(0.2), 3e-4);
  EXPECT_NEAR(ego.current()(1, 3), 50.0 * (1 - std::cos(0.2)), 3e-4);
  EXPECT_NEAR(yaw_of(ego.current()), 0.2, 1e-9);
  EXPECT_TRUE(ego.take_warnings().empty());
  // Nothing known anywhere: the ego is held, with one warning naming the frame and the stage that measures
  // it.
  EgoTrajectory still(EgoTrajectory::Options{});
  for (int k = 0; k < 3; ++k) still.update(hf::test::make_frame(k, 0.1 * k, flat, cam));
  EXPECT_NEAR(still.current()(0, 3), 0.0, 1e-12);
  const auto w = still.take_warnings();
  ASSERT_EQ(w.size(), 1u);
  EXPECT_NE(w[0].find("frame 1"), std::string::npos) << w[0];
  EXPECT_NE(w[0].find("ground_odometry"), std::string::npos) << w[0];
  // The renderer's former 'flow' mode says where ego motion from the frames went.
  try {
    parse_ego_motion_mode("flow");
    ADD_FAILURE() << "no error";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("ground_odometry stage"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace hf::render
