// Ground-truth TTC protocol on hand-made annotations with known answers.
#include <gtest/gtest.h>

#include <cmath>

#include "ground_truth_metric.hpp"
#include "hazardforge/testing/stage_runner.hpp"

namespace hf {
namespace {

AnnotatedObject annotated(const std::string& category, double x, double y, double l, double w,
                          std::optional<cv::Vec3d> v) {
  AnnotatedObject o;
  o.instance_id = category + std::to_string(x);
  o.category = category;
  o.center_ego = {x, y, 0.8};
  o.size_lwh = {l, w, 1.5};
  o.velocity_ego = v;
  return o;
}

Frame annotated_frame(std::vector<AnnotatedObject> objs, std::optional<cv::Vec3d> ego = cv::Vec3d(10, 0, 0)) {
  auto a = std::make_shared<Annotations>();
  a->objects = std::move(objs);
  a->ego_velocity_ego = ego;
  Frame f;
  f.index = 2;
  f.timestamp = 1.0;
  f.source_id = "sample_2";
  f.annotations = a;
  return f;
}

RiskAssessment run(const Frame& f, const std::string& params = "") {
  auto r = testing::StageRunner::create<GroundTruthRiskMetric>(params);
  r.push("frames", f, f.timestamp);
  r.run();
  auto out = r.collect<RiskAssessment>("risk");
  EXPECT_EQ(out.size(), 1u);
  return out.at(0);
}

TEST(GroundTruthRisk, ApproachingRecedingStationaryCrossingOutOfPath) {
  const Frame f = annotated_frame({
      annotated("vehicle.car", 20.0, 0.0, 4.0, 1.8, cv::Vec3d(5, 0, 0)),     // 0: gap 14.6, closing 5 -> 2.92
      annotated("vehicle.car", 15.0, 0.5, 4.0, 1.8, cv::Vec3d(15, 0, 0)),    // 1: receding -> inf
      annotated("vehicle.truck", 30.0, -1.0, 8.0, 2.5, cv::Vec3d(0, 0, 0)),  // 2: parked, closing 10 -> 2.26
      annotated("human.pedestrian.adult", 8.0, 0.5, 0.5, 0.6, cv::Vec3d(0, 1.4, 0)),  // 3: crossing -> 0.435
      annotated("vehicle.car", 10.0, 4.0, 4.0, 1.8, cv::Vec3d(0, 0, 0)),    // 4: |4| >= 2.4, out of path
      annotated("vehicle.car", -10.0, 0.0, 4.0, 1.8, cv::Vec3d(20, 0, 0)),  // 5: behind
      annotated("movable_object.barrier", 6.0, 0.0, 0.5, 2.0, cv::Vec3d(0, 0, 0)),  // not a road user
  });
  const RiskAssessment r = run(f);
  ASSERT_EQ(r.objects.size(), 6u);
  EXPECT_NEAR(r.objects[0].value, 14.6 / 5.0, 1e-12);
  EXPECT_EQ(r.objects[1].value, kInf);
  EXPECT_NEAR(r.objects[2].value, (30.0 - 3.4 - 4.0) / 10.0, 1e-12);
  EXPECT_NEAR(r.objects[3].value, (8.0 - 3.4 - 0.25) / 10.0, 1e-12);
  EXPECT_NEAR(r.objects[4].value, (10.0 - 3.4 - 2.0) / 10.0, 1e-12);
  EXPECT_FALSE(r.objects[4].in_path);
  EXPECT_FALSE(r.objects[5].in_path);
  for (int i : {0, 1, 2, 3}) EXPECT_TRUE(r.objects[i].in_path) << i;
  for (int i = 0; i < 6; ++i) EXPECT_EQ(r.objects[i].track_id, i);  // annotation index
  EXPECT_NEAR(r.scene_value, 0.435, 1e-12);
  EXPECT_EQ(r.critical_track, 3);
  EXPECT_EQ(r.label, SafetyLabel::kUnsafe);
  EXPECT_EQ(r.frame_index, 2);
  EXPECT_EQ(r.metric, "ground_truth");
  EXPECT_EQ(r.stage, "ground_truth");
  EXPECT_DOUBLE_EQ(r.threshold, 1.5);
}

TEST(GroundTruthRisk, EqualSpeedAndSlowClosingAreInfinite) {
  const Frame f = annotated_frame({annotated("vehicle.car", 12.0, 0.0, 4.0, 1.8, cv::Vec3d(10, 0, 0)),
                                   annotated("vehicle.car", 25.0, 0.0, 4.0, 1.8, cv::Vec3d(9.95, 0, 0))});
  const RiskAssessment r = run(f);
  EXPECT_EQ(r.objects[0].value, kInf);
  EXPECT_EQ(r.objects[1].value, kInf);  // closing 0.05 <= 0.1
  EXPECT_EQ(r.scene_value, kInf);
  EXPECT_EQ(r.label, SafetyLabel::kSafe);
  EXPECT_EQ(r.critical_track, -1);
  EXPECT_NEAR(run(f, "min_closing_mps: 0.01").objects[1].value, (25.0 - 3.4 - 2.0) / 0.05, 1e-6);
}

TEST(GroundTruthRisk, OverlappingBoxGivesZeroAndConstantsAreParams) {
  const Frame f = annotated_frame({annotated("vehicle.car", 5.0, 2.6, 4.0, 1.8, cv::Vec3d(2, 0, 0))});
  // |2.6| >= 1.0 + 0.5 + 0.9: out of path by default; a wider corridor takes it in.
  EXPECT_FALSE(run(f).objects[0].in_path);
  const RiskAssessment wide = run(f, "{corridor_margin: 1.0}");
  EXPECT_TRUE(wide.objects[0].in_path);
  EXPECT_DOUBLE_EQ(wide.objects[0].value, 0.0);  // gap 5 - 3.4 - 2 < 0 -> 0
  EXPECT_EQ(wide.label, SafetyLabel::kUnsafe);
  const RiskAssessment short_nose = run(f, "{corridor_half_width: 1.5, front_overhang: 1.0}");
  EXPECT_DOUBLE_EQ(short_nose.objects[0].value, 2.0 / 8.0);
  // Categories: only humans.
  EXPECT_TRUE(run(f, "categories: [human.]").objects.empty());
  // Threshold.
  const Frame g = annotated_frame({annotated("vehicle.car", 20.0, 0.0, 4.0, 1.8, cv::Vec3d(5, 0, 0))});
  EXPECT_EQ(run(g).label, SafetyLabel::kSafe);
  EXPECT_EQ(run(g, "threshold: 3").label, SafetyLabel::kUnsafe);
}

TEST(GroundTruthRisk, CorridorPathStraightByDefaultOrAlongTheRecordedYawRate) {
  // The ego turns left at 10 m/s and 0.1 rad/s (100 m radius). A parked car in its lane 40 m along the
  // curve is 7.9 m left of the ego's x axis; a parked car in the lane outside the curve, 25 m along, sits
  // on that axis.
  const double R = 100.0;
  const double a = 40.0 / R, b = 25.0 / R;
  Frame f = annotated_frame({
      annotated("vehicle.car", R * std::sin(a), R * (1 - std::cos(a)), 4.0, 1.8, cv::Vec3d(0, 0, 0)),
      annotated("vehicle.car", (R + 3.5) * std::sin(b), R - (R + 3.5) * std::cos(b), 4.0, 1.8,
                cv::Vec3d(0, 0, 0)),
  });
  f.ego.speed_mps = 10.0;
  f.ego.yaw_rate = 0.1;
  const RiskAssessment straight = run(f);  // the protocol: straight ahead whatever the ego does
  EXPECT_FALSE(straight.objects[0].in_path);
  EXPECT_TRUE(straight.objects[1].in_path);
  EXPECT_EQ(straight.critical_track, 1);
  const RiskAssessment along = run(f, "corridor_path: ego_path");
  EXPECT_TRUE(along.objects[0].in_path);
  EXPECT_FALSE(along.objects[1].in_path);
  EXPECT_EQ(along.critical_track, 0);
  // The TTC itself keeps the protocol's gap along x.
  EXPECT_DOUBLE_EQ(along.scene_value, (R * std::sin(a) - 3.4 - 2.0) / 10.0);
  // Without a yaw rate the ego path is straight.
  f.ego.yaw_rate.reset();
  EXPECT_FALSE(run(f, "corridor_path: ego_path").objects[0].in_path);
}

TEST(GroundTruthRisk, ObjectWithoutVelocity) {
  const Frame f = annotated_frame({annotated("vehicle.car", 13.4, 0.0, 4.0, 1.8, std::nullopt)});
  const RiskAssessment ignored = run(f);
  EXPECT_TRUE(std::isnan(ignored.objects[0].value));
  EXPECT_EQ(ignored.scene_value, kInf);
  EXPECT_EQ(ignored.label, SafetyLabel::kSafe);
  const RiskAssessment parked = run(f, "missing_object_velocity: static");
  EXPECT_DOUBLE_EQ(parked.objects[0].value, 0.8);  // gap 8 / closing 10
  EXPECT_EQ(parked.label, SafetyLabel::kUnsafe);
}

TEST(GroundTruthRisk, MissingInputsGetOneClearMessage) {
  try {
    run(annotated_frame({}, std::nullopt));
    FAIL();
  } catch (const Error& e) {
    EXPECT_EQ(
        std::string(e.what()),
        "frame 2 (sample_2): the annotations carry no ego velocity (Annotations::ego_velocity_ego); the "
        "ground_truth metric needs it (the source derives it from neighbouring keyframe poses)");
  }
  Frame bare = annotated_frame({});
  bare.annotations.reset();
  try {
    run(bare);
    FAIL();
  } catch (const Error& e) {
    EXPECT_EQ(std::string(e.what()),
              "frame 2 (sample_2): no annotations; the ground_truth metric needs a source that carries them "
              "(e.g. nuscenes)");
  }
}

}  // namespace
}  // namespace hf
