// The ground-truth protocol on the real nuScenes scene (scene-0916, 41 CAM_FRONT keyframes), read by the
// nuscenes source. Expected values come from an independent evaluation of the protocol on the raw JSON
// tables.
#include <gtest/gtest.h>

#include <cmath>

#include "ground_truth_metric.hpp"
#include "hazardforge/testing/stage_runner.hpp"
#include "nuscenes_source.hpp"
#include "test_support.hpp"

namespace hf {
namespace {

std::vector<RiskAssessment> ground_truth_of_scene(const std::string& metric_params = "") {
  auto src = testing::StageRunner::create<source::NuScenesSource>("dataroot: " +
                                                                  test::shared_data("nuscenes").string());
  src.run();
  auto gt = testing::StageRunner::create<GroundTruthRiskMetric>(metric_params);
  for (const Packet& p : src.outputs("frames")) gt.push("frames", p);
  gt.run();
  return gt.collect<RiskAssessment>("risk");
}

TEST(NuScenesGroundTruth, SceneTtcMatchesTheProtocolOnTheRawTables) {
  HF_REQUIRE_SHARED(test::shared_data("nuscenes/v1.0-mini/sample_annotation.json"));
  const std::vector<RiskAssessment> r = ground_truth_of_scene();
  ASSERT_EQ(r.size(), 41u);
  // frame -> scene TTC (s): the closest calls of the scene (parked cars while the ego passes at ~4 m/s), a
  // pedestrian, a distant car, and frames with nothing closing in path.
  const std::vector<std::pair<int, double>> expected = {{1, 4.00138},   {8, 2.88610},  {14, 2.12828},
                                                        {15, 1.65922},  {16, 1.90571}, {17, 1.60605},
                                                        {20, 13.13881}, {37, 1.87850}};
  for (const auto& [i, ttc] : expected) EXPECT_NEAR(r[i].scene_value, ttc, 1e-3) << "frame " << i;
  for (int i : {0, 9, 13, 38, 39, 40}) EXPECT_EQ(r[i].scene_value, kInf) << "frame " << i;
  int unsafe = 0, under2 = 0, under3 = 0;
  for (const RiskAssessment& a : r) {
    unsafe += a.label == SafetyLabel::kUnsafe;
    under2 += a.scene_value < 2.0;
    under3 += a.scene_value < 3.0;
  }
  EXPECT_EQ(unsafe, 0);  // no frame of this scene is below 1.5 s
  EXPECT_EQ(under2, 4);
  EXPECT_EQ(under3, 8);
  EXPECT_EQ(ground_truth_of_scene("threshold: 2")[15].label, SafetyLabel::kUnsafe);
}

}  // namespace
}  // namespace hf
