// The ground_odometry stage on synthetic road images with a known ego motion: the speed and yaw rate it
// writes into the frames, its fallbacks, and a hazard anchored by the renderer on its frames.
#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <iostream>

#include "ar_renderer.hpp"
#include "ground_odometry_stage.hpp"
#include "hazardforge/testing/stage_runner.hpp"
#include "render_fixtures.hpp"

namespace hf::render {
namespace {

using filter::GroundOdometryStage;
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
// yaw rate at 10 fps). With smoothing 0 the stage writes each measurement as it is.
constexpr double kSpeedRel = 0.05;
constexpr double kYawRateTol = 0.02;

// A drive over the textured road at `speed` m/s turning at `yaw_rate` rad/s, frames `dt` apart, without
// poses; `paint` may change each frame's picture.
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

// The stage's lines in the run folder, one JSON object per frame.
std::vector<Json> lines(const hf::testing::StageRunner& r, const std::string& file = "ego_odometry.jsonl") {
  std::ifstream in(r.output_dir() / file);
  std::vector<Json> v;
  for (std::string l; std::getline(in, l);) v.push_back(Json::parse(l));
  return v;
}

void expect_measures(const Drive& d, int frames, const std::string& what) {
  const CameraModel cam = test_camera();
  auto r = hf::testing::StageRunner::create<GroundOdometryStage>("smoothing: 0");
  std::vector<Frame> in;
  for (int k = 0; k < frames; ++k) {
    in.push_back(d.frame(cam, k));
    r.push("frames", in.back(), d.dt * k);
  }
  r.run();
  const auto out = r.collect<Frame>("frames");
  const auto log = lines(r);
  ASSERT_EQ(out.size(), static_cast<size_t>(frames)) << what;
  ASSERT_EQ(log.size(), static_cast<size_t>(frames)) << what;
  EXPECT_FALSE(out[0].ego.speed_mps) << what << ": the first frame has nothing to compare with";
  int measured = 0;
  for (int k = 1; k < frames; ++k) {
    const Frame& f = out[static_cast<size_t>(k)];
    EXPECT_EQ(f.index, k);
    EXPECT_EQ(f.image.data, in[static_cast<size_t>(k)].image.data) << "the picture is passed on, not copied";
    ASSERT_TRUE(f.ego.speed_mps && f.ego.yaw_rate) << what << ", frame " << k;
    EXPECT_EQ(f.ego.source, "video");
    EXPECT_NEAR(*f.ego.speed_mps, d.speed, kSpeedRel * d.speed) << what << ", frame " << k;
    EXPECT_NEAR(*f.ego.yaw_rate, d.yaw_rate, kYawRateTol) << what << ", frame " << k;
    EXPECT_NEAR(log[static_cast<size_t>(k)]["speed_mps"].get<double>(), *f.ego.speed_mps, 1e-9);
    measured += log[static_cast<size_t>(k)]["measured"].get<bool>() ? 1 : 0;
  }
  EXPECT_GE(measured, frames - 2) << what;
}

TEST(GroundOdometryStage, MeasuresTheSpeedAndTurnOfARenderedDrive) {
  expect_measures(Drive{10.0, 0.0, 0.1}, 8, "straight at 10 m/s, 10 fps");
  expect_measures(Drive{10.0, 0.15, 0.1}, 8, "turning left at 0.15 rad/s");
  expect_measures(Drive{20.0, 0.0, 0.04}, 8, "highway, 25 fps");
}

// A dash camera that sees its own bonnet: static, textured rows at the bottom of every frame. The renderer's
// former optical flow took its features there and read 0 m/s on the Udacity clip; the odometry detects the
// bonnet and measures the road.
TEST(GroundOdometryStage, ABonnetInThePictureDoesNotStopTheEgo) {
  Drive d{20.0, 0.0, 0.04};
  d.paint = [](cv::Mat img) {
    static const cv::Mat bonnet = hf::test::textured_image({1600, 110}, 5);
    bonnet.copyTo(img.rowRange(img.rows - bonnet.rows, img.rows));
    return img;
  };
  expect_measures(d, 10, "bonnet over the bottom 110 rows");
}

TEST(GroundOdometryStage, FramesItCannotMeasureKeepWhatTheyCarry) {
  const CameraModel cam = test_camera();
  const cv::Mat flat(900, 1600, CV_8UC3, cv::Scalar(100, 100, 100));
  // Nothing to measure and nothing carried: the frames pass without a speed, with one warning naming the
  // first frame that could have been measured.
  auto r = hf::testing::StageRunner::create<GroundOdometryStage>();
  for (int k = 0; k < 3; ++k) r.push("frames", hf::test::make_frame(k, 0.1 * k, flat, cam), 0.1 * k);
  r.run();
  for (const Frame& f : r.collect<Frame>("frames")) EXPECT_FALSE(f.ego.speed_mps) << "frame " << f.index;
  int warnings = 0;
  for (const auto& l : r.log())
    if (l.rfind("warning: ", 0) == 0) {
      ++warnings;
      EXPECT_NE(l.find("frame 1 "), std::string::npos) << l;
      EXPECT_NE(l.find("no motion measurement"), std::string::npos) << l;
    }
  EXPECT_EQ(warnings, 1);
  for (const Json& l : lines(r)) EXPECT_TRUE(l["speed_mps"].is_null());
  // Frames with their own speed pass unchanged (the odometry is not run on them) ...
  auto keep = hf::testing::StageRunner::create<GroundOdometryStage>();
  // ... and with replace, their own speed stays where the road view measures nothing.
  auto replace = hf::testing::StageRunner::create<GroundOdometryStage>("replace: true");
  for (int k = 0; k < 3; ++k) {
    Frame f = hf::test::make_frame(k, 0.1 * k, flat, cam);
    f.ego.speed_mps = 12.0;
    f.ego.yaw_rate = 0.01;
    f.ego.source = "dataset";
    keep.push("frames", f, 0.1 * k);
    replace.push("frames", f, 0.1 * k);
  }
  keep.run();
  replace.run();
  for (auto* run : {&keep, &replace}) {
    for (const Frame& f : run->collect<Frame>("frames")) {
      ASSERT_TRUE(f.ego.speed_mps);
      EXPECT_EQ(*f.ego.speed_mps, 12.0);
      EXPECT_EQ(*f.ego.yaw_rate, 0.01);
      EXPECT_EQ(f.ego.source, "dataset");
    }
  }
  for (const Json& l : lines(keep)) EXPECT_FALSE(l.contains("measured")) << l.dump();
  for (const Json& l : lines(replace)) EXPECT_FALSE(l["measured"].get<bool>()) << l.dump();
}

TEST(GroundOdometryStage, AFrameWithoutAPictureIsAnErrorNamingIt) {
  auto r = hf::testing::StageRunner::create<GroundOdometryStage>("file: ''");
  r.push("frames", hf::test::make_frame(0, 0.0, cv::Mat(), test_camera()), 0.0);
  try {
    r.run();
    ADD_FAILURE() << "no error";
  } catch (const std::exception& e) {
    EXPECT_NE(std::string(e.what()).find("frame 0 (t=0"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("image and camera model"), std::string::npos) << e.what();
  }
  EXPECT_FALSE(std::filesystem::exists(r.output_dir() / "ego_odometry.jsonl"));
}

TEST(GroundOdometryStage, TheRendererAnchorsAHazardOnItsFrames) {
  // Ego drives 1 m per frame (10 m/s at 10 Hz) over the textured road; frames carry no poses, so the renderer
  // (ego_motion: auto) dead-reckons on the speed and yaw rate the stage measured. A parked car 30 m ahead
  // must come 1 m closer each frame.
  const CameraModel cam = test_camera();
  constexpr int kFrames = 6;
  auto odo = hf::testing::StageRunner::create<GroundOdometryStage>("smoothing: 0");
  for (int k = 0; k < kFrames; ++k)
    odo.push("frames", hf::test::make_frame(k, k * 0.1, road().at(cam, k * 1.0, 0.0, 0.0), cam), k * 0.1);
  odo.run();
  const auto frames = odo.collect<Frame>("frames");
  ASSERT_EQ(frames.size(), static_cast<size_t>(kFrames));
  RendererOptions o;
  o.ego.mode = EgoMotionMode::kAuto;
  auto assets =
      std::make_shared<const AssetLibrary>(AssetLibrary::load(std::filesystem::path(share_dir()) / "assets"));
  HazardRenderer r(o, assets);
  auto traj = std::make_shared<const HazardTrajectory>(
      hf::test::static_object("car", 30.0, 2.0, 0.0, 0.0, 1.0, 0.0, cv::Vec3d(4.5, 1.85, 1.52)));
  for (int k = 0; k < kFrames; ++k) {
    auto res = r.render(frames[static_cast<size_t>(k)], traj, {});
    if (k > 0) {
      EXPECT_EQ(r.ego().last_source(), "frame speed (video)") << "frame " << k;
    }
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
