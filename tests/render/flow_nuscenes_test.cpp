// Ego motion without poses on real data (nuScenes scene-0916 keyframes, 2 Hz, 2-3 m and up to 15 degrees
// between frames): ego_motion 'flow' (the footage kit's ground-plane odometry) measures the pairs it can and
// falls back to the frames' speed and yaw rate on the others; measured against the dataset's poses.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <iostream>
#include <map>

#include "ego_motion.hpp"
#include "hazardforge/testing/stage_runner.hpp"
#include "nuscenes_source.hpp"
#include "test_support.hpp"

namespace hf::render {
namespace {

TEST(EgoMotionNuScenes, FlowOnKeyframesAgainstThePoses) {
  const auto root = hf::test::shared_data("nuscenes");
  HF_REQUIRE_SHARED(root / "v1.0-mini" / "ego_pose.json");
  auto src = hf::testing::StageRunner::create<source::NuScenesSource>("dataroot: " + root.string() +
                                                                      "\nscenes: [scene-0916]");
  src.run();
  const auto frames = src.collect<Frame>("frames");
  ASSERT_EQ(frames.size(), 41u);
  EgoTrajectory::Options o;
  o.mode = EgoMotionMode::kFlow;
  EgoTrajectory ego(o);
  std::map<std::string, int> sources;
  std::vector<cv::Matx44d> odo;
  std::vector<double> rel;  // relative speed error of the pairs the odometry measured
  for (size_t i = 0; i < frames.size(); ++i) {
    Frame f = frames[i];
    f.ego.T_world_ego.reset();  // as a source without poses; speed and yaw rate stay
    ego.update(f);
    if (i > 0) ++sources[ego.last_source()];
    odo.push_back(ego.current());
    if (i > 0 && ego.last_odometry().measured) {
      const cv::Matx44d gt = invert_rigid(*frames[i - 1].ego.T_world_ego) * *frames[i].ego.T_world_ego;
      const double v = std::hypot(gt(0, 3), gt(1, 3)) / (frames[i].timestamp - frames[i - 1].timestamp);
      rel.push_back(std::abs(ego.last_odometry().speed_mps - v) / v);
    }
  }
  std::sort(rel.begin(), rel.end());
  const double median_rel = rel.empty() ? 1.0 : rel[rel.size() / 2];
  std::cout << "odometry measured " << sources["flow"]
            << " of 40 keyframe pairs (median relative speed error " << median_rel << "), frame speed on "
            << sources["constant_speed"] << "\n";
  // The kit's figures on this scene (docs/footage-geometry.md): fewer than half the pairs measured, 10-20 %
  // off.
  EXPECT_GE(sources["flow"], 10);
  EXPECT_EQ(sources["flow"] + sources["constant_speed"], 40);
  EXPECT_LT(median_rel, 0.25);
  // Over any 2 s window (4 steps, ~9 m driven) the integrated path stays within 3 m of the poses (measured
  // worst case 2.2 m, printed below for the docs; with the frames' speed alone it was 0.26 m: where a source
  // carries a speed, ego_motion auto or constant_speed is the better choice).
  double worst = 0;
  for (size_t i = 0; i + 4 < frames.size(); ++i) {
    const cv::Matx44d gt = invert_rigid(*frames[i].ego.T_world_ego) * *frames[i + 4].ego.T_world_ego;
    const cv::Matx44d est = invert_rigid(odo[i]) * odo[i + 4];
    worst = std::max(worst, std::hypot(gt(0, 3) - est(0, 3), gt(1, 3) - est(1, 3)));
  }
  EXPECT_LT(worst, 3.0);
  RecordProperty("worst_2s_error_m", std::to_string(worst));
  std::cout << "worst 2 s dead-reckoning error: " << worst << " m\n";
}

}  // namespace
}  // namespace hf::render
