// The verifier's attribution of an Unsafe verdict: counted only when the inserted object is the TTC metric's
// critical track, and required with require_hazard_critical.
#include <gtest/gtest.h>

#include <optional>

#include "closed_loop_verifier.hpp"
#include "hazardforge/testing/stage_runner.hpp"

namespace hf {
namespace {

// Three visible frames: the inserted person is re-detected and tracked as track 4 at the box; frame 2 is
// Unsafe (TTC 1.1 s) with `critical` as the metric's critical track.
Json run_verifier(const std::string& params, int64_t critical, std::vector<double> uncovered = {},
                  std::optional<cv::Rect2f> last_state_box = std::nullopt, int64_t last_track = 4,
                  int64_t new_track_on_box = -1, bool plan_takes_over_7 = false,
                  std::vector<Json>* frame_records = nullptr,
                  std::optional<double> plan_end_t = std::nullopt) {
  auto r = testing::StageRunner::create<ClosedLoopVerifier>(params);
  HazardTrajectory tr;
  tr.kind = "pedestrian_crossing";
  tr.object_class = "person";
  tr.intended_min_ttc_s = 0.1;
  if (plan_takes_over_7 || !uncovered.empty()) tr.spec.track_id = 7;
  if (plan_end_t) tr.points = {{0.0, 10, 0, 0, 1, 0}, {*plan_end_t, 10, 0, 0, 1, 0}};
  r.push("trajectory", tr, 0.0);
  const cv::Rect2f box(100, 100, 50, 100);
  for (int i = 0; i < 3; ++i) {
    const double t = 0.5 * i;
    HazardInstance h;
    h.frame_index = i;
    h.visible = true;
    h.kind = "pedestrian_crossing";
    h.object_class = "person";
    h.box = box;
    h.distance_m = 10.0 - 2 * i;
    h.intended_ttc_s = 2.0 - 0.5 * i;
    if (!uncovered.empty()) h.taken_over = TakenOver{7, box, i != 1, uncovered.at(i)};
    r.push("hazard", h, t);
    Detections d;
    d.frame_index = i;
    d.items.push_back(Detection{box, 0, "person", 0.8f});
    r.push("detections", d, t);
    ObjectStates s;
    s.frame_index = i;
    ObjectState o;
    o.track_id = i == 2 ? last_track : 4;
    o.label = "person";
    o.box = i == 2 && last_state_box ? *last_state_box : box;
    o.distance_m = h.distance_m;
    s.objects.push_back(o);
    if (i == 2 && new_track_on_box >= 0) {  // a second track starts right on the inserted object
      ObjectState twin = o;
      twin.track_id = new_track_on_box;
      twin.box = box;
      twin.distance_m = 14.7;
      s.objects.push_back(twin);
    }
    r.push("states", s, t);
    RiskAssessment risk;
    risk.frame_index = i;
    risk.metric = "ttc";
    risk.unit = "s";
    risk.scene_value = i == 2 ? 1.1 : 3.0;
    risk.critical_track = i == 2 ? critical : 4;
    risk.label = i == 2 ? SafetyLabel::kUnsafe : SafetyLabel::kSafe;
    r.push("risk", risk, t, "ttc");
  }
  r.run();
  const auto records = r.collect<Record>("records");
  if (frame_records)
    for (const Record& rec : records) frame_records->push_back(rec.data);
  return records.back().data;
}

TEST(VerifierAttribution, UnsafeCausedByTheInsertedObjectIsCounted) {
  const Json s = run_verifier("{require_hazard_critical: true}", 4);
  EXPECT_TRUE(s["passed"].get<bool>()) << s.dump(2);
  EXPECT_EQ(s["unsafe"]["frames"], 1);
  EXPECT_EQ(s["unsafe"]["hazard_critical_frames"], 1);
  EXPECT_EQ(s["unsafe"]["first_hazard_critical_frame"], 2);
  EXPECT_EQ(s["criteria"]["require_hazard_critical"], true);
}

// A plan that ends before the last frame (at 0.5 s): the renderer draws the hazard carrying on; the verifier
// marks that frame, counts it, and takes the plan's intended minimum over the frames within the plan.
TEST(VerifierAttribution, FramesPastThePlanAreMarkedAndLeftOutOfThePlansMinimum) {
  std::vector<Json> frames;
  const Json s =
      run_verifier("{require_hazard_critical: true}", 4, {}, std::nullopt, 4, -1, false, &frames, 0.5);
  ASSERT_EQ(frames.size(), 4u);  // three frames and the summary
  EXPECT_FALSE(frames[1].contains("after_plan"));
  EXPECT_EQ(frames[2]["after_plan"], true);
  EXPECT_EQ(s["visible_frames_after_plan"], 1);
  EXPECT_DOUBLE_EQ(s["ttc"]["intended_min_ttc_visible_s"].get<double>(),
                   1.5);  // frame 1's, not frame 2's 1.0
  const Json whole =
      run_verifier("{require_hazard_critical: true}", 4, {}, std::nullopt, 4, -1, false, nullptr, 1.0);
  EXPECT_EQ(whole["visible_frames_after_plan"], 0);
  EXPECT_DOUBLE_EQ(whole["ttc"]["intended_min_ttc_visible_s"].get<double>(), 1.0);
}

TEST(VerifierAttribution, UnsafeCausedBySomeoneElseFailsWhenRequired) {
  // Another road user (track 9) is critical in the only Unsafe frame.
  const Json lenient = run_verifier("{}", 9);
  EXPECT_TRUE(lenient["passed"].get<bool>());                 // the default does not ask who caused it ...
  EXPECT_EQ(lenient["unsafe"]["hazard_critical_frames"], 0);  // ... but reports it
  const Json strict = run_verifier("{require_hazard_critical: true}", 9);
  EXPECT_FALSE(strict["passed"].get<bool>());
  EXPECT_EQ(
      strict["reasons"],
      Json::array(
          {"none of the 1 Unsafe visible frames is the hazard's: 1 with another object critical, 0 where "
           "the plan does not make the hazard critical (spurious Unsafe frames never pass)"}));
}

// Close up, the tracked box and the inserted object's projected box part ways (the border cuts one): the
// track that was on the inserted object stays its track while it still overlaps it (min_iou_tracked), so an
// Unsafe frame it causes is the hazard's; a different track there is not.
TEST(VerifierAttribution, TheHazardsTrackKeepsItWhenTheBoxesPartWays) {
  const std::string params = "{require_hazard_critical: true}";
  const cv::Rect2f apart(130, 100, 50, 100);  // IoU 0.25 with the inserted box
  const Json same = run_verifier(params, 4, {}, apart, 4);
  EXPECT_TRUE(same["passed"].get<bool>()) << same.dump(2);
  EXPECT_EQ(same["unsafe"]["attributed_frames"], 1);
  const Json other = run_verifier(params, 9, {}, apart, 9);
  EXPECT_FALSE(other["passed"].get<bool>());
  EXPECT_EQ(other["unsafe"]["attributed_frames"], 0);
  const Json strict = run_verifier(
      "{require_hazard_critical: true, "
      "min_iou_tracked: 0.5}",
      4, {}, apart, 4);
  EXPECT_FALSE(strict["passed"].get<bool>());
  // A second track (11) starting right on the object does not take the first one's place: both are its
  // tracks.
  const Json twin = run_verifier(params, 4, {}, apart, 4, 11);
  EXPECT_TRUE(twin["passed"].get<bool>()) << twin.dump(2);
  EXPECT_TRUE(run_verifier(params, 11, {}, apart, 4, 11)["passed"].get<bool>());
  EXPECT_FALSE(run_verifier(params, 9, {}, apart, 4, 11)["passed"].get<bool>());
}

// A hazard that took over a real object (track 7) passes only while the drawn one hides it: in no frame may
// more than max_takeover_uncovered of the real one's box show the inpainted fill.
TEST(VerifierAttribution, ATakenOverObjectMustBeHiddenByTheHazard) {
  const std::string params = "{require_hazard_critical: true}";
  const Json hidden = run_verifier(params, 4, {0.2, 0.1, 0.35});
  EXPECT_TRUE(hidden["passed"].get<bool>()) << hidden.dump(2);
  EXPECT_EQ(hidden["taken_over"]["track_id"], 7);
  EXPECT_EQ(hidden["taken_over"]["frames"], 3);
  EXPECT_EQ(hidden["taken_over"]["frames_from_held_box"], 1);
  EXPECT_DOUBLE_EQ(hidden["taken_over"]["max_uncovered_fraction"].get<double>(), 0.35);
  const Json shows = run_verifier(params, 4, {0.2, 0.62, 0.35});
  EXPECT_FALSE(shows["passed"].get<bool>());
  EXPECT_EQ(shows["reasons"],
            Json::array({"the taken-over real object (track 7) is not hidden by the hazard drawn in "
                         "its place: 0.62 of its box shows the inpainted fill at frame 1 "
                         "(max_takeover_uncovered 0.5)"}));
  // Without a takeover there is nothing to report.
  EXPECT_FALSE(run_verifier(params, 4).contains("taken_over"));
  // A plan that takes over track 7 where the renderer never removed it (no taken_over in any frame) fails.
  const Json kept = run_verifier(params, 4, {}, std::nullopt, 4, -1, true);
  EXPECT_FALSE(kept["passed"].get<bool>());
  EXPECT_EQ(kept["reasons"],
            Json::array({"the hazard takes over track 7, but the renderer never removed the real "
                         "one: it stays in the video beside the hazard"}));
}

}  // namespace
}  // namespace hf
