// The closed-loop verifier on synthetic hazard instances, re-detections and re-assessed risk.
#include <gtest/gtest.h>

#include "closed_loop_verifier.hpp"
#include "hazardforge/testing/stage_runner.hpp"
#include "scenario_support.hpp"

namespace hf {
namespace {

const cv::Rect2f kBox(100, 100, 50, 100);

HazardInstance instance(int64_t frame, bool visible, double intended_ttc) {
  HazardInstance h;
  h.frame_index = frame;
  h.visible = visible;
  h.kind = "pedestrian_crossing";
  h.object_class = "person";
  h.box = kBox;
  h.distance_m = 20.0;
  h.intended_ttc_s = intended_ttc;
  return h;
}

Detections detections(int64_t frame, std::vector<Detection> items) {
  Detections d;
  d.frame_index = frame;
  d.items = std::move(items);
  return d;
}

// IoU with kBox: shifted by 5 px horizontally -> 45 * 100 / (2 * 5000 - 4500) = 0.818.
Detection near_box(const std::string& label = "person", float score = 0.8f) {
  return Detection{cv::Rect2f(105, 100, 50, 100), 0, label, score};
}

RiskAssessment risk(int64_t frame, double ttc, const std::string& metric = "ttc") {
  RiskAssessment r;
  r.frame_index = frame;
  r.metric = metric;
  r.unit = "s";
  r.scene_value = ttc;
  r.critical_track = 4;
  r.label = ttc < 1.5 ? SafetyLabel::kUnsafe : SafetyLabel::kSafe;
  return r;
}

// A deceleration-based metric (higher is riskier) that calls every frame Unsafe.
RiskAssessment drac(int64_t frame) {
  RiskAssessment r;
  r.frame_index = frame;
  r.metric = "drac";
  r.unit = "m/s2";
  r.lower_is_riskier = false;
  r.threshold = 3.0;
  r.scene_value = 5.0;
  r.label = SafetyLabel::kUnsafe;
  return r;
}

ObjectStates states(int64_t frame, double distance) {
  ObjectStates s;
  s.frame_index = frame;
  ObjectState o;
  o.track_id = 4;
  o.label = "person";
  o.box = cv::Rect2f(104, 100, 50, 100);
  o.distance_m = distance;
  s.objects.push_back(o);
  return s;
}

HazardTrajectory trajectory(double min_ttc) {
  HazardTrajectory t;
  t.kind = "pedestrian_crossing";
  t.object_class = "person";
  t.intended_min_ttc_s = min_ttc;
  return t;
}

TEST(Verifier, PassesWhenReDetectedMeasuredAndUnsafe) {
  auto r = testing::StageRunner::create<ClosedLoopVerifier>("{intended_distance_at: centre}");
  const double intended[] = {3.0, 2.5, 2.0, 1.5, 1.2};
  const double achieved[] = {3.2, 2.6, 2.1, 1.4, 1.3};
  r.push("trajectory", trajectory(0.9), 0.0);
  for (int i = 0; i < 5; ++i) {
    const double t = 0.1 * i;
    r.push("hazard", instance(i, true, intended[i]), t);
    r.push("detections", i < 4 ? detections(i, {near_box()}) : detections(i, {}), t);
    r.push("risk", risk(i, achieved[i]), t, "ttc");
    r.push("states", states(i, i < 2 ? 22.0 : 19.0), t);
  }
  r.run();
  const auto recs = r.collect<Record>("records");
  ASSERT_EQ(recs.size(), 6u);  // 5 frames + the summary
  EXPECT_EQ(recs[0].kind, "verification");
  EXPECT_NEAR(recs[0].data["best_iou"].get<double>(), 4500.0 / 5500.0, 1e-6);
  EXPECT_EQ(recs[0].data["redetected"], true);
  EXPECT_EQ(recs[4].data["redetected"], false);
  EXPECT_EQ(recs[3].data["unsafe"], true);
  EXPECT_EQ(recs[3].data["hazard_is_critical"], true);
  EXPECT_DOUBLE_EQ(recs[0].data["distance_abs_error_m"].get<double>(), 2.0);

  const Json s = Json::parse(test::read_text((r.output_dir() / "verification.json").string()));
  EXPECT_EQ(s, recs[5].data);
  EXPECT_EQ(recs[5].kind, "verification_summary");
  EXPECT_EQ(s["passed"], true);
  EXPECT_EQ(s["reasons"], Json::array());
  EXPECT_EQ(s["visible_frames"], 5);
  EXPECT_DOUBLE_EQ(s["redetection"]["rate"].get<double>(), 0.8);
  EXPECT_NEAR(s["redetection"]["mean_confidence"].get<double>(), 0.8, 1e-6);
  EXPECT_DOUBLE_EQ(s["ttc"]["achieved_min_ttc_s"].get<double>(), 1.3);
  EXPECT_EQ(s["ttc"]["achieved_at_frame"], 4);
  EXPECT_DOUBLE_EQ(s["ttc"]["intended_min_ttc_visible_s"].get<double>(), 1.2);
  EXPECT_DOUBLE_EQ(s["ttc"]["intended_min_ttc_s"].get<double>(), 0.9);
  EXPECT_NEAR(s["ttc"]["abs_error_s"].get<double>(), 0.1, 1e-12);
  EXPECT_EQ(s["ttc"]["metric"], "ttc");
  EXPECT_EQ(s["unsafe"]["reached"], true);
  EXPECT_EQ(s["unsafe"]["first_frame"], 3);
  EXPECT_EQ(s["unsafe"]["frames"], 2);
  EXPECT_EQ(s["distance"]["matched_frames"], 5);
  EXPECT_DOUBLE_EQ(s["distance"]["median_abs_error_m"].get<double>(), 1.0);
  EXPECT_DOUBLE_EQ(s["distance"]["median_rel_error"].get<double>(), 0.05);
  EXPECT_DOUBLE_EQ(s["distance"]["max_abs_error_m"].get<double>(), 2.0);
  EXPECT_EQ(s["hazard_critical_frames"], 5);
}

TEST(Verifier, DistancesAreComparedFromTheRearAxleAtTheNearFace) {
  // The states say where their distances start: here the camera, 1.5 m ahead of the rear axle. The intended
  // distance is the object's centre (20 m) minus half its 4.5 m length: 17.75 m from the rear axle, so a
  // camera reading of 16 m (17.5 m from the rear axle) is 0.25 m short. Measured from a bumper 3.4 m ahead of
  // the axle, the same object reads 14.35 m and is exact.
  for (const auto& [origin, reading, error] : {std::tuple{1.5, 16.0, 0.25}, std::tuple{3.4, 14.35, 0.0}}) {
    auto r = testing::StageRunner::create<ClosedLoopVerifier>();
    HazardTrajectory tr = trajectory(1.0);
    tr.size_lwh = cv::Vec3d(4.5, 1.8, 1.5);
    r.push("trajectory", tr, 0.0);
    r.push("hazard", instance(0, true, 1.0), 0.0);
    r.push("detections", detections(0, {near_box()}), 0.0);
    ObjectStates st = states(0, reading);
    st.distance_origin_x = origin;
    r.push("states", st, 0.0);
    r.run();
    const auto recs = r.collect<Record>("records");
    const Json compared = recs[0].data["distance_compared_m"];
    EXPECT_NEAR(compared[0].get<double>(), reading + origin, 1e-9);
    EXPECT_DOUBLE_EQ(compared[1].get<double>(), 17.75);
    EXPECT_NEAR(recs[0].data["distance_abs_error_m"].get<double>(), error, 1e-9) << "origin " << origin;
    EXPECT_DOUBLE_EQ(recs.back().data["distance"]["state_origin_x_m"].get<double>(), origin);
  }
}

TEST(Verifier, FailsWithExactReasonsWhenMissedAndNeverUnsafe) {
  auto r = testing::StageRunner::create<ClosedLoopVerifier>("max_ttc_error_s: 0.5");
  for (int i = 0; i < 5; ++i) {
    const double t = 0.1 * i;
    r.push("hazard", instance(i, true, 1.0), t);
    // Only frame 0 re-detects it; frame 1 finds a car on it, which does not count for a person.
    r.push("detections",
           detections(i, i == 0   ? std::vector<Detection>{near_box()}
                         : i == 1 ? std::vector<Detection>{near_box("car", 0.9f)}
                                  : std::vector<Detection>{}),
           t);
    r.push("risk", risk(i, 2.0 + 0.1 * i), t, "ttc");
    r.push("risk", drac(i), t, "drac");  // not a TTC; unsafe_metrics limits what counts below
  }
  r.run();
  const Json s = r.collect<Record>("records").back().data;
  EXPECT_EQ(s["passed"], false);
  // The DRAC stream says Unsafe on every frame: with all metrics counting, the scene is Unsafe.
  EXPECT_EQ(s["reasons"],
            Json::array({"re-detection rate 0.2 is below min_redetection_rate 0.5 (1 of 5 visible "
                         "frames with IoU >= 0.5)",
                         "achieved minimum TTC 2 s is 1 s away from the intended 1 s (max_ttc_error_s "
                         "0.5)"}));
  EXPECT_EQ(s["unsafe"]["metrics"], Json::array({"drac"}));

  auto only_ttc = testing::StageRunner::create<ClosedLoopVerifier>("unsafe_metrics: [ttc]");
  for (int i = 0; i < 5; ++i) {
    const double t = 0.1 * i;
    only_ttc.push("hazard", instance(i, true, 1.0), t);
    only_ttc.push("detections",
                  detections(i, i == 0 ? std::vector<Detection>{near_box()} : std::vector<Detection>{}), t);
    only_ttc.push("risk", risk(i, 2.0 + 0.1 * i), t, "ttc");
    only_ttc.push("risk", drac(i), t, "drac");
  }
  only_ttc.run();
  const Json s2 = only_ttc.collect<Record>("records").back().data;
  EXPECT_EQ(s2["reasons"],
            Json::array({"re-detection rate 0.2 is below min_redetection_rate 0.5 (1 of 5 visible "
                         "frames with IoU >= 0.5)",
                         "the scene never becomes Unsafe while the hazard is visible (minimum scene "
                         "TTC 2 s)"}));
}

TEST(Verifier, NeverVisibleHazardFails) {
  auto r = testing::StageRunner::create<ClosedLoopVerifier>();
  for (int i = 0; i < 3; ++i) {
    r.push("hazard", instance(i, false, kInf), 0.1 * i);
    r.push("detections", detections(i, {near_box()}), 0.1 * i);
  }
  r.run();
  const Json s = r.collect<Record>("records").back().data;
  EXPECT_EQ(s["reasons"], Json::array({"the inserted object is never visible (0 of 3 frames)"}));
  EXPECT_EQ(s["redetection"]["rate"], Json());
}

// Three Unsafe frames (scene TTC 1.0 s): frame 0 another object is critical; frame 1 the hazard is critical but
// its plan says TTC 14 s there (a tracking artefact closing in); frame 2 the hazard is critical and planned at
// 1.3 s (`credited` decides whether that frame exists).
Json attribution_run(bool credited) {
  auto r = testing::StageRunner::create<ClosedLoopVerifier>("{require_hazard_critical: true}");
  r.push("trajectory", trajectory(1.3), 0.0);
  const double planned[] = {14.0, 14.0, 1.3};
  for (int i = 0; i < (credited ? 3 : 2); ++i) {
    const double t = 0.1 * i;
    r.push("hazard", instance(i, true, planned[i]), t);
    r.push("detections", detections(i, {near_box()}), t);
    RiskAssessment k = risk(i, 1.0);
    k.critical_track = i == 0 ? 9 : 4;  // the hazard's state is track 4
    r.push("risk", k, t, "ttc");
    r.push("states", states(i, 20.0), t);
  }
  r.run();
  const auto recs = r.collect<Record>("records");
  EXPECT_EQ(recs[0].data["attribution"], "spurious: the inserted object is not the critical track");
  EXPECT_EQ(recs[1].data["attribution"],
            "spurious: the hazard's planned TTC 14 s is not below the threshold 1.5 s + 0.5 s");
  if (credited) {
    EXPECT_EQ(recs[2].data["attribution"], "hazard");
  }
  return recs.back().data;
}

TEST(Verifier, OnlyUnsafeFramesTheHazardCausesAsPlannedMakeAPass) {
  const Json artefacts = attribution_run(false);
  EXPECT_EQ(artefacts["passed"], false);
  EXPECT_EQ(artefacts["reasons"],
            Json::array({"none of the 2 Unsafe visible frames is the hazard's: 1 with another object critical, 1 "
                         "where the plan does not make the hazard critical (spurious Unsafe frames never pass)"}));
  EXPECT_EQ(artefacts["unsafe"]["attributed_frames"], 0);
  EXPECT_EQ(artefacts["unsafe"]["spurious_frames"].size(), 2u);
  const Json real = attribution_run(true);
  EXPECT_EQ(real["passed"], true) << real["reasons"];
  EXPECT_EQ(real["unsafe"]["attributed_frames"], 1);
  EXPECT_EQ(real["unsafe"]["first_hazard_critical_frame"], 2);
  EXPECT_EQ(real["unsafe"]["spurious_frames"].size(), 2u);  // still reported
}

TEST(Verifier, NoPlannedHazardSaysSoInsteadOfNeverVisible) {
  // The renderer had no trajectory (the generator or planner failed): its instances carry no kind.
  auto r = testing::StageRunner::create<ClosedLoopVerifier>();
  for (int i = 0; i < 3; ++i) {
    HazardInstance h;
    h.frame_index = i;
    r.push("hazard", h, 0.1 * i);
    r.push("detections", detections(i, {}), 0.1 * i);
  }
  r.run();
  const Json s = r.collect<Record>("records").back().data;
  EXPECT_EQ(s["reasons"],
            Json::array({"no hazard was inserted: no planned trajectory arrived (the generator or "
                         "the planner produced none; the run's log says why)"}));
  EXPECT_EQ(s["passed"], false);
}

TEST(Verifier, UnsafeOnlyCountsWhileTheHazardIsVisible) {
  auto r = testing::StageRunner::create<ClosedLoopVerifier>("min_redetection_rate: 0");
  r.push("hazard", instance(0, false, 1.0), 0.0);
  r.push("detections", detections(0, {}), 0.0);
  r.push("risk", risk(0, 1.0), 0.0, "ttc");
  r.push("hazard", instance(1, true, 1.0), 0.1);
  r.push("detections", detections(1, {}), 0.1);
  r.push("risk", risk(1, 3.0), 0.1, "ttc");
  r.run();
  const Json s = r.collect<Record>("records").back().data;
  EXPECT_EQ(s["reasons"],
            Json::array({"the scene never becomes Unsafe while the hazard is visible (minimum scene "
                         "TTC 3 s)"}));
}

TEST(Verifier, NamedTtcMetricMustExist) {
  auto r = testing::StageRunner::create<ClosedLoopVerifier>("ttc_metric: ttc_scale");
  r.push("hazard", instance(0, true, 1.0), 0.0);
  r.push("detections", detections(0, {}), 0.0);
  r.push("risk", risk(0, 1.0), 0.0, "ttc");
  try {
    r.run();
    FAIL();
  } catch (const Error& e) {
    EXPECT_EQ(std::string(e.what()),
              "node 'verifier': ttc_metric 'ttc_scale' is none of the risk streams at frame 0 (ttc)");
  }
}

}  // namespace
}  // namespace hf

namespace hf {
namespace {

AppearanceStats looks(const std::string& label, double halo, double sharpness) {
  AppearanceStats a;
  a.label = label;
  a.halo = halo;
  a.sharpness = sharpness;
  return a;
}

TEST(Verifier, ReportsRealismAndAnIndependentDetectorWithoutChangingTheVerdict) {
  auto report = [](bool with_extras) {
    auto r = testing::StageRunner::create<ClosedLoopVerifier>("{intended_distance_at: centre}");
    r.push("trajectory", trajectory(0.9), 0.0);
    for (int i = 0; i < 4; ++i) {
      const double t = 0.1 * i;
      HazardInstance h = instance(i, true, 1.2);
      if (with_extras) {
        h.appearance = looks("person", 20.0 + i, 1.0);  // a strong fringe, natural sharpness
        for (int k = 0; k < 3; ++k) h.references.push_back(looks("person", k + 3 * i, 0.8 + 0.1 * k));
        h.references.push_back(looks("car", 100.0, 100.0));  // another class: not a reference for a person
        // The independent detector finds the person in frames 0-2 (one of them as a bicycle), nothing in 3.
        r.push("independent_detections",
               detections(i, i == 3 ? std::vector<Detection>{}
                                    : std::vector<Detection>{near_box(i == 1 ? "bicycle" : "person")}),
               t);
      }
      r.push("hazard", h, t);
      r.push("detections", detections(i, {near_box()}), t);
      r.push("risk", risk(i, 1.2), t, "ttc");
      r.push("states", states(i, 20.0), t);
    }
    r.run();
    return Json::parse(test::read_text((r.output_dir() / "verification.json").string()));
  };
  const Json plain = report(false), s = report(true);
  EXPECT_EQ(s["passed"], plain["passed"]);
  EXPECT_EQ(s["reasons"], plain["reasons"]);
  EXPECT_FALSE(plain.contains("realism"));
  EXPECT_FALSE(plain.contains("independent_redetection"));

  const Json& rz = s["realism"];
  EXPECT_EQ(rz["inserted_frames"], 4);
  EXPECT_EQ(rz["reference_samples"], 12);  // the person references only
  EXPECT_EQ(rz["metrics"]["halo"]["inserted"]["median"], 21.5);
  EXPECT_EQ(rz["metrics"]["halo"]["within"], false);  // real halos 0..11
  EXPECT_EQ(rz["metrics"]["sharpness"]["within"], true);
  EXPECT_EQ(rz["metrics"]["outside"], Json::array({"halo"}));

  const Json& ind = s["independent_redetection"];
  EXPECT_EQ(ind["counted_frames"], 4);
  EXPECT_EQ(ind["redetected_frames"], 2);  // a bicycle is not a person
  EXPECT_EQ(ind["right_class_frames"], 2);
  EXPECT_DOUBLE_EQ(ind["rate"].get<double>(), 0.5);
  EXPECT_EQ(ind["labels"]["person"], 2);
  EXPECT_EQ(ind["labels"]["bicycle"], 1);
  EXPECT_EQ(ind["labels"]["(none)"], 1);
}

// Re-detection is judged where a detector can be expected to see the object: frames with less than
// min_visible_share of its silhouette in view (cut by the picture's border or hidden by a nearer object) are
// reported but not counted, and the detection is compared with the box of what is drawn, not the projected
// 3D box around it.
TEST(Verifier, ReDetectionIsCountedWhereEnoughOfTheObjectIsInView) {
  auto r = testing::StageRunner::create<ClosedLoopVerifier>("{intended_distance_at: centre}");
  r.push("trajectory", trajectory(0.9), 0.0);
  for (int i = 0; i < 6; ++i) {
    const double t = 0.1 * i;
    HazardInstance h = instance(i, true, 1.2);
    if (i < 3) h.occluded_fraction = 0.9;  // 0.1 of it seen: behind a parked car, never found
    if (i == 3) h.in_picture_fraction = 0.55, h.occluded_fraction = 0.1;  // 0.495 seen: not counted
    // The projected box is 40 px wider than the silhouette drawn in it: IoU 50 x 100 / 90 x 100 = 0.56 with
    // a detection on the silhouette, 1.0 with the silhouette's own box.
    h.box = cv::Rect2f(80, 100, 90, 100);
    h.drawn_box = cv::Rect2f(105, 100, 50, 100);
    r.push("hazard", h, t);
    r.push("detections", detections(i, i < 4 ? std::vector<Detection>{} : std::vector<Detection>{near_box()}),
           t);
    r.push("risk", risk(i, 1.2), t, "ttc");
    r.push("states", states(i, 20.0), t);
  }
  r.run();
  const auto recs = r.collect<Record>("records");
  EXPECT_EQ(recs[0].data["counted"], false);
  EXPECT_NEAR(recs[0].data["visible_share"].get<double>(), 0.1, 1e-9);
  EXPECT_EQ(recs[3].data["counted"], false);
  EXPECT_EQ(recs[4].data["counted"], true);
  EXPECT_DOUBLE_EQ(recs[4].data["best_iou"].get<double>(), 1.0);  // against the drawn silhouette's box
  const Json s = recs.back().data;
  EXPECT_EQ(s["passed"], true) << s["reasons"];
  EXPECT_EQ(s["visible_frames"], 6);
  EXPECT_EQ(s["redetection"]["counted_frames"], 2);
  EXPECT_EQ(s["redetection"]["partly_visible_frames"], 4);
  EXPECT_DOUBLE_EQ(s["redetection"]["rate"].get<double>(), 1.0);
  EXPECT_EQ(s["unsafe"]["frames"], 6);  // Unsafe counts in every visible frame, partly visible or not
}

TEST(Verifier, AnObjectNeverHalfInViewFailsAndSaysSo) {
  auto run = [](double min_share) {
    auto r = testing::StageRunner::create<ClosedLoopVerifier>(
        "{min_visible_share: " + std::to_string(min_share) + "}");
    r.push("trajectory", trajectory(0.9), 0.0);
    for (int i = 0; i < 3; ++i) {
      HazardInstance h = instance(i, true, 1.2);
      h.in_picture_fraction = 0.4;  // its lower part below the picture in every frame
      r.push("hazard", h, 0.1 * i);
      r.push("detections", detections(i, {near_box()}), 0.1 * i);
      r.push("risk", risk(i, 1.2), 0.1 * i, "ttc");
    }
    r.run();
    return r.collect<Record>("records").back().data;
  };
  const Json s = run(0.5);
  EXPECT_EQ(s["passed"], false);
  EXPECT_EQ(
      s["reasons"],
      Json::array({"the inserted object is never at least 0.5 in view (min_visible_share): at most 0.4 of "
                   "it is seen in its 3 visible frames, too little to expect a detection"}));
  EXPECT_EQ(s["redetection"]["rate"], Json());
  // Asked to count every visible frame, the same run is judged on its detections.
  const Json all = run(0.0);
  EXPECT_EQ(all["passed"], true) << all["reasons"];
  EXPECT_EQ(all["redetection"]["counted_frames"], 3);
}

}  // namespace
}  // namespace hf
