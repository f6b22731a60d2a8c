// The ground_odometry stage, causal, on the real Udacity highway clip (25 fps, about 28-31 m/s): its first
// frames. The road view's first pairs there read about 0 m/s with few inliers (a static bonnet before its rows
// are known); a distance search narrowed around such a reading held the next pairs near it until frame 8.
#include <gtest/gtest.h>

#include <algorithm>
#include <fstream>
#include <iostream>

#include "ground_odometry_stage.hpp"
#include "hazardforge/testing/stage_runner.hpp"
#include "test_support.hpp"
#include "video_source.hpp"

namespace hf::filter {
namespace {

TEST(GroundOdometryUdacity, TheFirstFramesReadTheSpeedNotTheFirstReading) {
  const auto clip = hf::test::shared_data("udacity-highway/test_video.mp4");
  HF_REQUIRE_SHARED(clip);
  const auto calib = hf::test::source_dir() / "share/calibration/udacity_highway.yaml";
  // The camera of configs/examples/odometry_udacity.yaml: the chessboard calibration, 1.2 m, the pitch a
  // self-calibrating run measured; nothing estimated before the first frame.
  auto src = hf::testing::StageRunner::create<source::VideoSource>(
      "{path: '" + clip.string() + "', calibration: '" + calib.string() +
      "', camera_height: 1.2, camera_pitch_deg: -1.55, self_calibrate: false}");
  src.run();
  const auto frames = src.collect<Frame>("frames");
  ASSERT_GE(frames.size(), 30u);
  auto odo = hf::testing::StageRunner::create<GroundOdometryStage>("smoothing: 0.5");
  for (const Frame& f : frames) odo.push("frames", f, f.timestamp);
  odo.run();
  std::ifstream in(odo.output_dir() / "ego_odometry.jsonl");
  std::vector<Json> lines;
  for (std::string l; std::getline(in, l);) lines.push_back(Json::parse(l));
  ASSERT_EQ(lines.size(), frames.size());
  std::vector<double> later;  // raw readings from frame 10 on: the clip's speed
  for (size_t i = 10; i < lines.size(); ++i)
    if (lines[i].value("measured", false)) later.push_back(lines[i]["raw_speed_mps"].get<double>());
  ASSERT_GE(later.size(), 20u);
  std::sort(later.begin(), later.end());
  const double speed = later[later.size() / 2];
  EXPECT_GT(speed, 25.0);
  EXPECT_LT(speed, 35.0);
  int early = 0;
  for (size_t i = 2; i < 8; ++i) {
    if (!lines[i].value("measured", false)) continue;
    ++early;
    EXPECT_NEAR(lines[i]["raw_speed_mps"].get<double>(), speed, 0.15 * speed) << "frame " << i;
  }
  EXPECT_GE(early, 4);
  // Smoothed, the speed is within 15 % of the clip's from frame 5 on.
  for (size_t i = 5; i < 10; ++i) EXPECT_NEAR(lines[i]["speed_mps"].get<double>(), speed, 0.15 * speed) << "frame " << i;
  std::cout << "clip speed " << speed << " m/s; raw readings of frames 1-7:";
  for (size_t i = 1; i < 8; ++i) std::cout << " " << lines[i].value("raw_speed_mps", -1.0);
  std::cout << "\n";
}

}  // namespace
}  // namespace hf::filter
