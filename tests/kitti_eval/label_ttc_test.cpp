// label_ttc on a hand-made KITTI tracking label file read by the kitti source: camera-relative closing speed
// from the labels' 3D positions, gap from the camera, corridor, categories and unknown velocities.
#include <gtest/gtest.h>

#include <cmath>
#include <fstream>

#include <unistd.h>

#include "hazardforge/testing/stage_runner.hpp"
#include "kitti_source.hpp"
#include "label_ttc_metric.hpp"

namespace hf {
namespace {

namespace fs = std::filesystem;

// Sequence 0000 of a tiny KITTI tracking tree: three frames, camera 1.65 m above the road, P2 without offset
// (camera 2 = rectified camera 0).
struct LabelTree {
  fs::path root;
  explicit LabelTree(const std::string& labels) {
    root = fs::temp_directory_path() / ("hf_label_ttc_" + std::to_string(::getpid()));
    fs::create_directories(root / "training" / "calib");
    fs::create_directories(root / "training" / "label_02");
    std::ofstream(root / "training" / "calib" / "0000.txt") << "P2: 700 0 600 0 0 700 180 0 0 0 1 0\n";
    std::ofstream(root / "training" / "label_02" / "0000.txt") << labels;
  }
  ~LabelTree() { fs::remove_all(root); }

  std::vector<RiskAssessment> run(const std::string& params = "") const {
    auto src = testing::StageRunner::create<source::KittiSource>(
        "{layout: tracking, root: '" + root.string() + "', sequence: '0000', images_required: false}");
    src.run();
    auto metric = testing::StageRunner::create<LabelTtcMetric>(params);
    for (const Frame& f : src.collect<Frame>("frames")) metric.push("frames", f, f.timestamp);
    metric.run();
    return metric.collect<RiskAssessment>("risk");
  }
};

// frame track type truncated occluded alpha x1 y1 x2 y2 h w l x y z rotation_y (camera coordinates: x right,
// y down, z forward; location = bottom centre).
const char* kLabels =
    // Track 1: a car 0.2 m right of the camera, closing at 10 m/s: z = 20, 19, 18.
    "0 1 Car 0 0 -1.57 560 150 640 250 1.5 1.8 4.0 0.2 1.65 20 -1.57\n"
    "1 1 Car 0 0 -1.57 560 150 640 250 1.5 1.8 4.0 0.2 1.65 19 -1.57\n"
    "2 1 Car 0 0 -1.57 560 150 640 250 1.5 1.8 4.0 0.2 1.65 18 -1.57\n"
    // Track 2: a pedestrian 4 m left, closing at 5 m/s: out of the corridor (|y| >= 1.5 + 0.3).
    "0 2 Pedestrian 0 0 0 100 150 140 250 1.7 0.6 0.8 -4 1.65 10 0\n"
    "1 2 Pedestrian 0 0 0 100 150 140 250 1.7 0.6 0.8 -4 1.65 9.5 0\n"
    "2 2 Pedestrian 0 0 0 100 150 140 250 1.7 0.6 0.8 -4 1.65 9 0\n"
    // Track 3: a car ahead, receding at 10 m/s.
    "0 3 Car 0 0 -1.57 590 160 610 190 1.5 1.8 4.0 0 1.65 30 -1.57\n"
    "1 3 Car 0 0 -1.57 590 160 610 190 1.5 1.8 4.0 0 1.65 31 -1.57\n"
    "2 3 Car 0 0 -1.57 590 160 610 190 1.5 1.8 4.0 0 1.65 32 -1.57\n"
    // Track 4: a van labelled in frame 1 only (no velocity), 8 m ahead in the path.
    "1 4 Van 0 0 -1.57 550 140 650 260 2.0 1.9 4.5 -0.5 1.65 8 -1.57\n"
    // Track 5: Misc, closing fast in the path: not a counted category.
    "0 5 Misc 0 0 0 580 170 620 200 1.0 1.0 1.0 0 1.65 6 0\n"
    "1 5 Misc 0 0 0 580 170 620 200 1.0 1.0 1.0 0 1.65 5 0\n"
    "2 5 Misc 0 0 0 580 170 620 200 1.0 1.0 1.0 0 1.65 4 0\n"
    "1 -1 DontCare -1 -1 -10 0 0 50 50 -1 -1 -1 -1000 -1000 -1000 -10\n";

const ObjectRisk* object(const RiskAssessment& r, int64_t id) {
  for (const ObjectRisk& o : r.objects)
    if (o.track_id == id) return &o;
  return nullptr;
}

TEST(LabelTtc, CameraRelativeTtcOfEveryLabelledTrack) {
  LabelTree tree(kLabels);
  const auto risks = tree.run();
  ASSERT_EQ(risks.size(), 3u);
  // Car 1: gap = z - l/2 from the camera; closing 10 m/s (one-sided differences at the ends).
  const double expected[] = {(20 - 2.0) / 10, (19 - 2.0) / 10, (18 - 2.0) / 10};
  for (size_t k = 0; k < 3; ++k) {
    const RiskAssessment& r = risks[k];
    EXPECT_EQ(r.stage, "label_ttc");
    EXPECT_NEAR(r.scene_value, expected[k], 1e-9) << k;
    EXPECT_EQ(r.critical_track, 1) << k;  // the KITTI track id
    EXPECT_EQ(r.label, SafetyLabel::kSafe);
    const ObjectRisk* car = object(r, 1);
    ASSERT_NE(car, nullptr);
    EXPECT_TRUE(car->in_path);
    // Pedestrian 2: (z - 0.4) / 5, outside the corridor.
    const ObjectRisk* ped = object(r, 2);
    ASSERT_NE(ped, nullptr);
    EXPECT_FALSE(ped->in_path);
    EXPECT_NEAR(ped->value, (10 - 0.5 * static_cast<double>(k) - 0.4) / 5.0, 1e-9);
    // Car 3 recedes: infinite.
    ASSERT_NE(object(r, 3), nullptr);
    EXPECT_TRUE(std::isinf(object(r, 3)->value));
    EXPECT_EQ(object(r, 5), nullptr);  // Misc is not counted
  }
  // Van 4 has one label: unknown, and it does not take the scene value although it is closer.
  const ObjectRisk* van = object(risks[1], 4);
  ASSERT_NE(van, nullptr);
  EXPECT_TRUE(van->in_path);
  EXPECT_TRUE(std::isnan(van->value));
  EXPECT_EQ(risks[1].objects.size(), 4u);  // DontCare dropped
}

TEST(LabelTtc, ThresholdGapReferenceAndCategoriesAreParams) {
  LabelTree tree(kLabels);
  // Gap from a bumper 1 m ahead of the camera: (19 - 1 - 2) / 10 at frame 1; Unsafe below 1.65 s.
  const auto r = tree.run("{front_overhang: 1.0, threshold: 1.65}");
  EXPECT_NEAR(r[1].scene_value, 1.6, 1e-9);
  EXPECT_EQ(r[0].label, SafetyLabel::kSafe);  // 1.7 s
  EXPECT_EQ(r[1].label, SafetyLabel::kUnsafe);
  // Misc counted: (5 - 0.5) / 10 = 0.45 s at frame 1 (central difference of 6 -> 4 m).
  const auto m = tree.run("{categories: [Car, Misc]}");
  EXPECT_NEAR(m[1].scene_value, 0.45, 1e-9);
  EXPECT_EQ(m[1].critical_track, 5);
  // Parked when unknown: the van 8 m ahead then has an infinite TTC, still not the minimum.
  const auto s = tree.run("{missing_object_velocity: static}");
  EXPECT_TRUE(std::isinf(object(s[1], 4)->value));
}

TEST(LabelTtc, FramesWithoutLabelsAreAnError) {
  auto metric = testing::StageRunner::create<LabelTtcMetric>();
  Frame f;
  f.index = 3;
  metric.push("frames", f, 0.3);
  try {
    metric.run();
    FAIL() << "no error";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("label_ttc: frame 3: no annotations"), std::string::npos)
        << e.what();
  }
}

}  // namespace
}  // namespace hf
