// Flow-based ego motion on synthetic road images with a known ego motion, and anchoring with it.
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

// The ego's motion between two frames from the points' apparent motion (p_cur = R p_prev + t).
cv::Vec3d ego_step(const PlanarMotion& m) {
  const double c = std::cos(m.dyaw), s = std::sin(m.dyaw);
  return {-(c * m.dx + s * m.dy), -(-s * m.dx + c * m.dy), -m.dyaw};
}

// Tolerances. A road point at X m ahead moves dX/dv = X^2 / (f h) metres per pixel of image row: 5 mm at 10 m,
// 12 mm at 15 m, 47 mm at 30 m (f = 1266 px, h = 1.5 m). LK at half resolution localises a textured feature to
// about 0.1 full-resolution px, and the rigid fit averages a few hundred inliers, so noise contributes well under
// 1 cm; what remains is systematic (resampling of the synthetic texture, pixel-centre conventions), bounded here
// at 2 % of a 1 m step (2 cm) and 0.05 degrees of yaw: at 10 Hz that is a speed error of 0.2 m/s.
constexpr double kTransTol = 0.02;
constexpr double kYawTolDeg = 0.05;

TEST(FlowEgoMotion, RecoversAKnownForwardTranslation) {
  const CameraModel cam = test_camera();
  const cv::Mat a = road().at(cam, 0.0, 0.0, 0.0), b = road().at(cam, 1.0, 0.0, 0.0);
  FlowEgoMotion flow;
  const PlanarMotion m = flow.estimate(a, b, cam, {});
  ASSERT_TRUE(m.ok) << m.why;
  EXPECT_GT(m.inliers, 100);
  const cv::Vec3d step = ego_step(m);
  std::cout << "forward 1 m: estimated (" << step[0] << ", " << step[1] << ") m, yaw " << step[2] * 180 / CV_PI
            << " deg, " << m.inliers << " inliers of " << m.tracked << " tracks\n";
  EXPECT_NEAR(step[0], 1.0, kTransTol);
  EXPECT_NEAR(step[1], 0.0, kTransTol);
  EXPECT_NEAR(step[2] * 180 / CV_PI, 0.0, kYawTolDeg);
}

TEST(FlowEgoMotion, RecoversTranslationWithYawOnAPitchedCamera) {
  const CameraModel cam = test_camera(0.03);
  const double yaw = 1.5 * CV_PI / 180;
  const cv::Mat a = road().at(cam, 2.0, 0.5, 0.0), b = road().at(cam, 2.8, 0.55, yaw);
  FlowEgoMotion flow;
  const PlanarMotion m = flow.estimate(a, b, cam, {});
  ASSERT_TRUE(m.ok) << m.why;
  const cv::Vec3d step = ego_step(m);
  std::cout << "0.8 m + 0.05 m left + 1.5 deg: estimated (" << step[0] << ", " << step[1] << ") m, yaw "
            << step[2] * 180 / CV_PI << " deg, " << m.inliers << " inliers of " << m.tracked << " tracks\n";
  // Expected: the displacement (0.8, 0.05) expressed in the previous ego frame (yaw 0 there), and the turn.
  EXPECT_NEAR(step[0], 0.8, kTransTol);
  EXPECT_NEAR(step[1], 0.05, kTransTol);
  EXPECT_NEAR(step[2] * 180 / CV_PI, 1.5, kYawTolDeg);
}

// Features and the last homography carried from frame to frame, as the renderer runs it: LK starts from the
// last motion on the two finest pyramid levels. A sharp right turn at 6 degrees per frame, then straight on
// (the guess is then off by some 130 px everywhere, beyond those levels' reach: without the retry from zero
// motion step 2 fails with 8 inliers), then a hard stop: every step is recovered.
TEST(FlowEgoMotion, CarriedFeaturesFollowATurnThenStraightOnThenAStop) {
  const CameraModel cam = test_camera();
  struct Step {
    double dx, dy, dyaw_deg;
  };
  const std::vector<Step> steps = {{1.0, 0, -6.0}, {1.0, 0, -6.0}, {1.0, 0, 0},
                                   {1.0, 0, 0},    {0, 0, 0},      {0, 0, 0}};
  FlowEgoMotion flow;
  FlowCarry carry;
  double x = 0, y = 0, yaw = 0;
  FlowFrame prev = flow.prepare(road().at(cam, x, y, yaw), cam);
  for (size_t i = 0; i < steps.size(); ++i) {
    const Step& s = steps[i];
    // The step in the previous ego frame, turned into the world.
    x += s.dx * std::cos(yaw) - s.dy * std::sin(yaw);
    y += s.dx * std::sin(yaw) + s.dy * std::cos(yaw);
    yaw += s.dyaw_deg * CV_PI / 180;
    FlowFrame cur = flow.prepare(road().at(cam, x, y, yaw), cam);
    const bool guessed = carry.homography.has_value();
    const PlanarMotion m = flow.estimate(prev, cur, cam, {}, &carry);
    ASSERT_TRUE(m.ok) << "step " << i << ": " << m.why;
    const cv::Vec3d e = ego_step(m);
    EXPECT_NEAR(e[0], s.dx, kTransTol) << "step " << i;
    EXPECT_NEAR(e[1], s.dy, kTransTol) << "step " << i;
    EXPECT_NEAR(e[2] * 180 / CV_PI, s.dyaw_deg, kYawTolDeg) << "step " << i;
    EXPECT_EQ(guessed, i > 0) << "step " << i << ": the homography is carried after the first step";
    EXPECT_TRUE(carry.homography.has_value());
    EXPECT_GE(carry.points.size(), 25u);
    prev = std::move(cur);
  }
}

TEST(FlowEgoMotion, DegenerateWithoutTextureAndFallsBackToSpeed) {
  const CameraModel cam = test_camera();
  const cv::Mat flat(900, 1600, CV_8UC3, cv::Scalar(100, 100, 100));
  FlowEgoMotion flow;
  const PlanarMotion m = flow.estimate(flat, flat, cam, {});
  EXPECT_FALSE(m.ok);
  EXPECT_FALSE(m.why.empty());
  // The trajectory then integrates the frame's speed: 12 m/s for 0.1 s.
  EgoTrajectory::Options o;
  o.mode = EgoMotionMode::kFlow;
  EgoTrajectory ego(o);
  Frame f = hf::test::make_frame(0, 0.0, flat, cam);
  f.ego.speed_mps = 12.0;
  ego.update(f, {});
  f.index = 1;
  f.timestamp = 0.1;
  ego.update(f, {});
  EXPECT_EQ(ego.last_source(), "constant_speed");
  EXPECT_NEAR(ego.current()(0, 3), 1.2, 1e-9);
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
    ego.update(f, {});
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
    strict.update(hf::test::make_frame(3, 0.3, flat, cam), {});
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
  ego.update(a, {});
  Frame b = hf::test::make_frame(1, 2.5, flat, cam);
  b.ego.T_world_ego = pose(100.0 + 15.0 * std::cos(0.3), 50.0 + 15.0 * std::sin(0.3), 0.3, pitch);
  ego.update(b, {});
  EXPECT_EQ(ego.last_source(), "poses");
  // A point on the road 25 m ahead of the anchor ego is 10 m ahead of the current one, on its ground.
  const cv::Matx44d cur_from_anchor = invert_rigid(ego.current()) * *ego.pose_at(0.0);
  const cv::Vec4d p = cur_from_anchor * cv::Vec4d(25.0, 0.0, 0.0, 1.0);
  EXPECT_NEAR(p[0], 10.0, 1e-9);
  EXPECT_NEAR(p[1], 0.0, 1e-9);
  EXPECT_NEAR(p[2], 0.0, 1e-9);
  EXPECT_NEAR(yaw_of(ego.current()), 0.3, 1e-9);
}

TEST(FlowEgoMotion, AnchorsAHazardWithoutPoses) {
  // Ego drives 1 m per frame (10 m/s at 10 Hz) over the textured road; frames carry no poses, so the renderer
  // anchors with flow (ego_motion: auto). A parked car 30 m ahead must come 1 m closer each frame.
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
    // Errors accumulate like a random walk of the per-frame tolerance.
    EXPECT_NEAR(res.hazard.distance_m, 30.0 - k, kTransTol * std::max(1, k)) << "frame " << k;
    EXPECT_NEAR(res.hazard.lateral_m, 2.0, kTransTol * std::max(1, k)) << "frame " << k;
  }
}

}  // namespace
}  // namespace hf::render
