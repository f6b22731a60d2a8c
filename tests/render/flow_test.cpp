// Ego motion for anchoring on synthetic road images with a known ego motion: the odometry (ego_motion flow),
// the recording's ego track, dataset poses.
#include <gtest/gtest.h>

#include <cmath>
#include <iostream>

#include "ar_renderer.hpp"
#include "ego_motion.hpp"
#include "render_fixtures.hpp"

namespace hf::render {
namespace {

using hf::test::noise_texture;
using hf::test::road_image;
using hf::test::test_camera;

// A 120 m x 40 m road texture at 4 cm per texel with blobs of 10 cm to 1 m, starting 5 m behind the ego.
struct Road {
  cv::Mat tex = noise_texture({3000, 1000}, 11, 70.0);
  double res = 0.04, x0 = -5.0;
  cv::Mat at(const CameraModel& cam, double x, double y, double yaw) const {
    return road_image(cam, tex, res, x0, x, y, yaw);
  }
};

const Road& road() {
  static const Road r;
  return r;
}

// The odometry's accuracy on a rendered road (the footage kit's own tests: 5 % of the speed, 0.02 rad/s of
// yaw rate at 10 fps). Through the trajectory the same bounds hold per frame; positions integrate them.
constexpr double kSpeedRel = 0.05;
constexpr double kYawRateTol = 0.02;

// A drive over the textured road at `speed` m/s turning at `yaw_rate` rad/s, frames `dt` apart, through an
// EgoTrajectory in `mode` (no poses, no track on the frames); `paint` may change each frame's picture.
struct Drive {
  double speed = 10.0, yaw_rate = 0.0, dt = 0.1;
  cv::Mat (*paint)(cv::Mat) = nullptr;
  Frame frame(const CameraModel& cam, int k) const {
    const double t = dt * k, yaw = yaw_rate * t;
    const double x = std::abs(yaw_rate) > 1e-9 ? speed / yaw_rate * std::sin(yaw) : speed * t;
    const double y = std::abs(yaw_rate) > 1e-9 ? speed / yaw_rate * (1 - std::cos(yaw)) : 0.0;
    cv::Mat img = road().at(cam, x, y, yaw);
    if (paint) img = paint(img);
    return hf::test::make_frame(k, t, img, cam);
  }
};

void expect_flow_measures(const Drive& d, int frames, const std::string& what) {
  const CameraModel cam = test_camera();
  EgoTrajectory::Options o;
  o.mode = EgoMotionMode::kFlow;
  o.smoothing = 0.0;
  EgoTrajectory ego(o);
  int measured = 0;
  for (int k = 0; k < frames; ++k) {
    ego.update(d.frame(cam, k));
    EXPECT_TRUE(ego.take_warnings().empty()) << what << ", frame " << k;
    if (k == 0 || !ego.last_odometry().measured) continue;
    ++measured;
    EXPECT_EQ(ego.last_source(), "flow");
    EXPECT_NEAR(ego.velocity_ego()[0], d.speed, kSpeedRel * d.speed) << what << ", frame " << k;
    EXPECT_NEAR(*ego.yaw_rate(), d.yaw_rate, kYawRateTol) << what << ", frame " << k;
  }
  EXPECT_GE(measured, frames - 2) << what;
}

TEST(EgoTrajectoryFlow, MeasuresTheSpeedAndTurnOfARenderedDrive) {
  expect_flow_measures(Drive{10.0, 0.0, 0.1}, 8, "straight at 10 m/s, 10 fps");
  expect_flow_measures(Drive{10.0, 0.15, 0.1}, 8, "turning left at 0.15 rad/s");
  expect_flow_measures(Drive{20.0, 0.0, 0.04}, 8, "highway, 25 fps");
}

// A dash camera that sees its own bonnet: static, textured rows at the bottom of every frame. The renderer's
// former optical flow took its features there and read 0 m/s on the Udacity clip; the odometry detects the
// bonnet and measures the road.
TEST(EgoTrajectoryFlow, ABonnetInThePictureDoesNotStopTheEgo) {
  Drive d{20.0, 0.0, 0.04};
  d.paint = [](cv::Mat img) {
    static const cv::Mat bonnet = hf::test::textured_image({1600, 110}, 5);
    bonnet.copyTo(img.rowRange(img.rows - bonnet.rows, img.rows));
    return img;
  };
  expect_flow_measures(d, 10, "bonnet over the bottom 110 rows");
}

TEST(EgoTrajectoryFlow, FramesWithoutTextureFallBackToTheFramesSpeed) {
  const CameraModel cam = test_camera();
  const cv::Mat flat(900, 1600, CV_8UC3, cv::Scalar(100, 100, 100));
  EgoTrajectory::Options o;
  o.mode = EgoMotionMode::kFlow;
  EgoTrajectory ego(o);
  Frame f = hf::test::make_frame(0, 0.0, flat, cam);
  f.ego.speed_mps = 12.0;
  ego.update(f);
  f.index = 1;
  f.timestamp = 0.1;
  ego.update(f);
  EXPECT_FALSE(ego.last_odometry().measured);
  EXPECT_EQ(ego.last_source(), "constant_speed");
  EXPECT_NEAR(ego.current()(0, 3), 1.2, 1e-9);
  // Without a speed anywhere the ego is held still, with one warning that says why.
  EgoTrajectory still(o);
  still.update(hf::test::make_frame(0, 0.0, flat, cam));
  still.update(hf::test::make_frame(1, 0.1, flat, cam));
  const auto w = still.take_warnings();
  ASSERT_EQ(w.size(), 1u);
  EXPECT_NE(w[0].find("the road view gave no motion measurement"), std::string::npos) << w[0];
  EXPECT_NE(w[0].find("frame 1"), std::string::npos) << w[0];
}

TEST(EgoTrajectoryTrack, FollowsTheRecordingsEgoTrackInAutoMode) {
  // No poses, but the source estimated the ego's motion (a left arc at 10 m/s, 0.2 rad/s): auto picks the track
  // and the poses are the track's, interpolated between its samples.
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
    EXPECT_NE(std::string(e.what()).find("ego_motion 'track' needs the recording's ego track"), std::string::npos)
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

TEST(EgoTrajectoryFlow, AnchorsAHazardWithoutPoses) {
  // Ego drives 1 m per frame (10 m/s at 10 Hz) over the textured road; frames carry no poses, so the renderer
  // anchors with the ground-plane odometry (ego_motion: auto). A parked car 30 m ahead must come 1 m closer
  // each frame.
  const CameraModel cam = test_camera();
  RendererOptions o;
  o.ego.mode = EgoMotionMode::kAuto;
  o.ego.smoothing = 0.0;
  auto assets = std::make_shared<const AssetLibrary>(AssetLibrary::load(std::filesystem::path(share_dir()) / "assets"));
  HazardRenderer r(o, assets);
  auto traj = std::make_shared<const HazardTrajectory>(
      hf::test::static_object("car", 30.0, 2.0, 0.0, 0.0, 1.0, 0.0, cv::Vec3d(4.5, 1.85, 1.52)));
  constexpr int kFrames = 6;
  for (int k = 0; k < kFrames; ++k) {
    auto res = r.render(hf::test::make_frame(k, k * 0.1, road().at(cam, k * 1.0, 0.0, 0.0), cam), traj, {});
    EXPECT_EQ(r.ego().last_source(), "flow") << "frame " << k;
    ASSERT_TRUE(res.hazard.visible);
    std::cout << "frame " << k << ": distance " << res.hazard.distance_m << " m (true " << 30.0 - k
              << "), lateral " << res.hazard.lateral_m << " m (true 2)\n";
    // The per-frame bound (5 % of the 1 m step) accumulates over the frames driven since the first.
    EXPECT_NEAR(res.hazard.distance_m, 30.0 - k, 0.02 + kSpeedRel * k) << "frame " << k;
    EXPECT_NEAR(res.hazard.lateral_m, 2.0, 0.02 + kSpeedRel * k) << "frame " << k;
  }
}

}  // namespace
}  // namespace hf::render
