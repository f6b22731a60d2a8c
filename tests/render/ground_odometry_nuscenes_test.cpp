// Ego motion without poses on real data (nuScenes scene-0916 keyframes, 2 Hz, 2-3 m and up to 15 degrees
// between frames): the ground_odometry stage (the footage kit's ground-plane odometry) measures the pairs it
// can and, with replace, keeps the frames' own speed and yaw rate on the others; the renderer's dead
// reckoning on its frames is measured against the dataset's poses.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <map>

#include "ego_motion.hpp"
#include "ground_odometry_stage.hpp"
#include "hazardforge/testing/stage_runner.hpp"
#include "nuscenes_source.hpp"
#include "temp_dir.hpp"
#include "test_support.hpp"
#include "video_source.hpp"

namespace hf::render {
namespace {

// scene-0916's 41 keyframes as NuScenesSource gives them (poses, speeds, the calibrated camera).
std::vector<Frame> scene_keyframes(const std::filesystem::path& root) {
  auto src = hf::testing::StageRunner::create<source::NuScenesSource>("dataroot: " + root.string() +
                                                                      "\nscenes: [scene-0916]");
  src.run();
  return src.collect<Frame>("frames");
}

TEST(EgoMotionNuScenes, GroundOdometryOnKeyframesAgainstThePoses) {
  const auto root = hf::test::shared_data("nuscenes");
  HF_REQUIRE_SHARED(root / "v1.0-mini" / "ego_pose.json");
  const auto frames = scene_keyframes(root);
  ASSERT_EQ(frames.size(), 41u);
  auto odo = hf::testing::StageRunner::create<filter::GroundOdometryStage>("replace: true");
  for (const Frame& f : frames) {
    Frame g = f;
    g.ego.T_world_ego.reset();  // as a source without poses; speed and yaw rate stay
    g.ego.velocity_world.reset();
    g.ego_track.reset();
    odo.push("frames", g, g.timestamp);
  }
  odo.run();
  const auto out = odo.collect<Frame>("frames");
  ASSERT_EQ(out.size(), frames.size());
  std::ifstream in(odo.output_dir() / "ego_odometry.jsonl");
  std::vector<Json> lines;
  for (std::string l; std::getline(in, l);) lines.push_back(Json::parse(l));
  ASSERT_EQ(lines.size(), frames.size());
  EgoTrajectory ego(EgoTrajectory::Options{});
  std::map<std::string, int> sources;
  std::vector<cv::Matx44d> poses;
  std::vector<double> rel;        // relative speed error of the pairs the odometry measured
  std::vector<double> rel_lever;  // ... of those whose speed came from (or with) the camera's lever arm
  int measured = 0;
  for (size_t i = 0; i < out.size(); ++i) {
    ego.update(out[i]);
    if (i > 0) ++sources[out[i].ego.source];
    poses.push_back(ego.current());
    if (i > 0 && lines[i]["measured"].get<bool>()) {
      ++measured;
      const cv::Matx44d gt = invert_rigid(*frames[i - 1].ego.T_world_ego) * *frames[i].ego.T_world_ego;
      const double v = std::hypot(gt(0, 3), gt(1, 3)) / (frames[i].timestamp - frames[i - 1].timestamp);
      rel.push_back(std::abs(lines[i]["raw_speed_mps"].get<double>() - v) / v);
      if (lines[i]["raw_speed_from"].get<std::string>() != "road") rel_lever.push_back(rel.back());
    }
  }
  std::sort(rel.begin(), rel.end());
  const double median_rel = rel.empty() ? 1.0 : rel[rel.size() / 2];
  std::sort(rel_lever.begin(), rel_lever.end());
  const double median_lever = rel_lever.empty() ? 1.0 : rel_lever[rel_lever.size() / 2];
  std::cout << "odometry measured " << measured << " of 40 keyframe pairs (median relative speed error "
            << median_rel << "; " << rel_lever.size() << " in the bends with the lever arm, median "
            << median_lever << "); frames leaving with its estimate " << sources["video"]
            << ", with their own (dataset) speed " << sources["dataset"] << "\n";
  // The kit's figures on this scene (docs/footage-geometry.md): the road view alone measured fewer than half
  // the pairs (18), the bends' pairs are the lever arm's (the straight travel from the straight pairs seen so
  // far, else none: the calibrated mounting's).
  EXPECT_GE(measured, 25);
  EXPECT_GE(rel_lever.size(), 10u);
  EXPECT_LT(median_lever, 0.15);
  EXPECT_GE(sources["video"], measured);
  EXPECT_EQ(sources["video"] + sources["dataset"], 40);
  EXPECT_LT(median_rel, 0.15);
  // Over any 2 s window (4 steps, ~9 m driven) the dead-reckoned path stays within 3 m of the poses (printed
  // below for the docs; with the frames' speed alone it was 0.26 m: where a source carries a speed, the stage
  // without replace leaves it alone; with replace, the more pairs measured, the fewer frames keep the poses'
  // own speed).
  double worst = 0;
  for (size_t i = 0; i + 4 < frames.size(); ++i) {
    const cv::Matx44d gt = invert_rigid(*frames[i].ego.T_world_ego) * *frames[i + 4].ego.T_world_ego;
    const cv::Matx44d est = invert_rigid(poses[i]) * poses[i + 4];
    worst = std::max(worst, std::hypot(gt(0, 3) - est(0, 3), gt(1, 3) - est(1, 3)));
  }
  EXPECT_LT(worst, 3.0);
  RecordProperty("worst_2s_error_m", std::to_string(worst));
  std::cout << "worst 2 s dead-reckoning error: " << worst << " m\n";
}

// The issue's own measure of the video's ego speed: the scene's 41 CAM_FRONT keyframes as a plain image folder
// (000.jpg ... 040.jpg, no tables, no calibration, no times in the names) at a stated 2 fps, nothing else
// stated; every frame's smoothed speed against the poses' central difference at that keyframe (the mean of the
// two intervals' speeds around it, weighted by their lengths). docs/footage-geometry.md: 8.3 %, no frame beyond
// 20 %; the goal is 10 %.
TEST(EgoMotionNuScenes, TheVideoSourceOnThePlainKeyframeFolderAgainstThePoses) {
  const auto root = hf::test::shared_data("nuscenes");
  HF_REQUIRE_SHARED(root / "v1.0-mini" / "ego_pose.json");
  const auto frames = scene_keyframes(root);
  ASSERT_EQ(frames.size(), 41u);
  std::vector<std::filesystem::path> files;
  for (const auto& e : std::filesystem::directory_iterator(root / "samples" / "CAM_FRONT")) files.push_back(e.path());
  std::sort(files.begin(), files.end());  // the dataset's names carry the times: this is the scene's order
  ASSERT_EQ(files.size(), 41u);
  hf::test::TempDir dir;
  for (size_t k = 0; k < files.size(); ++k) {
    const std::string n = std::to_string(k);
    std::filesystem::create_symlink(std::filesystem::absolute(files[k]),
                                    dir / (std::string(3 - n.size(), '0') + n + ".jpg"));
  }
  auto video = hf::testing::StageRunner::create<source::VideoSource>("{path: '" + dir.path().string() +
                                                                     "', fps: 2}");
  video.run();
  ASSERT_EQ(video.collect<Frame>("frames").size(), 41u);
  std::ifstream in(video.output_dir() / "ego_motion.jsonl");
  std::vector<double> speed;
  for (std::string l; std::getline(in, l);) speed.push_back(Json::parse(l)["speed_mps"].get<double>());
  ASSERT_EQ(speed.size(), 41u);
  // The poses' speed over each interval, and at each keyframe.
  std::vector<double> v(41, 0.0), dt(41, 0.0);
  for (size_t i = 1; i < 41; ++i) {
    const cv::Matx44d gt = invert_rigid(*frames[i - 1].ego.T_world_ego) * *frames[i].ego.T_world_ego;
    dt[i] = frames[i].timestamp - frames[i - 1].timestamp;
    v[i] = std::hypot(gt(0, 3), gt(1, 3)) / dt[i];
  }
  std::vector<double> rel;
  int beyond = 0;
  for (size_t k = 0; k < 41; ++k) {
    const double truth = k == 0 ? v[1] : k == 40 ? v[40] : (v[k] * dt[k] + v[k + 1] * dt[k + 1]) / (dt[k] + dt[k + 1]);
    rel.push_back(std::abs(speed[k] - truth) / truth);
    beyond += rel.back() > 0.2 ? 1 : 0;
  }
  std::sort(rel.begin(), rel.end());
  std::cout << "video source on the plain keyframe folder: median relative speed error " << rel[20] << ", "
            << beyond << " frames beyond 20 %, largest " << rel.back() << "\n";
  EXPECT_LT(rel[20], 0.10);
  EXPECT_LE(beyond, 3);
}

}  // namespace
}  // namespace hf::render
