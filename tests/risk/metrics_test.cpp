// Risk metrics on hand-made object states with known answers: approaching, receding, equal speed, crossing,
// out of path, unknown velocity and unknown ego speed.
#include <gtest/gtest.h>

#include <cmath>

#include "drac_metric.hpp"
#include "hazardforge/testing/stage_runner.hpp"
#include "time_headway_metric.hpp"
#include "ttc_paper_metric.hpp"
#include "ttc_scale_metric.hpp"

namespace hf {
namespace {

// An object d m ahead at lateral y with absolute speed and heading relative to the ego; velocity_rel to
// match.
ObjectState object(int64_t id, double d, double y, std::optional<double> speed, double heading_deg = 0.0,
                   double ego = 10.0) {
  ObjectState s;
  s.track_id = id;
  s.label = "car";
  s.distance_m = d;
  s.lateral_m = y;
  s.width_m = 1.8;
  s.length_m = 4.5;
  if (speed) {
    const double h = heading_deg * M_PI / 180.0;
    s.speed_mps = *speed;
    s.heading_rad = h;
    s.velocity_rel = cv::Vec2d(*speed * std::cos(h) - ego, *speed * std::sin(h));
  }
  return s;
}

ObjectStates states(std::vector<ObjectState> objs, std::optional<double> ego = 10.0) {
  ObjectStates s;
  s.frame_index = 5;
  s.ego_speed_mps = ego;
  s.objects = std::move(objs);
  return s;
}

template <class M>
RiskAssessment assess(const ObjectStates& st, const std::string& params = "") {
  testing::StageRunner r = testing::StageRunner::create<M>(params);
  r.push("states", st, 0.5);
  r.run();
  auto out = r.collect<RiskAssessment>("risk");
  EXPECT_EQ(out.size(), 1u);
  return out.at(0);
}

TEST(TtcPaper, ApproachingRecedingEqualCrossingAndOutOfPath) {
  const RiskAssessment r = assess<TtcPaperMetric>(states({
      object(1, 12.0, 0.0, 4.0),       // closing 10 - 4 = 6 -> 2 s
      object(2, 20.0, 0.5, 12.0),      // receding -> inf
      object(3, 15.0, -0.3, 10.0),     // equal speed -> inf
      object(4, 9.0, 1.0, 5.0, 90.0),  // crossing: v_obj cos psi = 0 -> closing 10 -> 0.9 s
      object(5, 5.0, 6.0, 0.0),        // out of path: 0.5 s, not counted
  }));
  ASSERT_EQ(r.objects.size(), 5u);
  EXPECT_DOUBLE_EQ(r.objects[0].value, 2.0);
  EXPECT_EQ(r.objects[1].value, kInf);
  EXPECT_EQ(r.objects[2].value, kInf);
  EXPECT_NEAR(r.objects[3].value, 0.9, 1e-12);
  EXPECT_DOUBLE_EQ(r.objects[4].value, 0.5);
  EXPECT_TRUE(r.objects[3].in_path);
  EXPECT_FALSE(r.objects[4].in_path);
  EXPECT_NEAR(r.scene_value, 0.9, 1e-12);
  EXPECT_EQ(r.critical_track, 4);
  EXPECT_EQ(r.label, SafetyLabel::kUnsafe);
  EXPECT_EQ(r.unit, "s");
  EXPECT_EQ(r.stage, "ttc_paper");
  EXPECT_EQ(r.metric, "ttc_paper");
  EXPECT_EQ(r.frame_index, 5);
  EXPECT_TRUE(r.lower_is_riskier);
}

// The label rule picks which number of an uncertain object decides Unsafe. One object 12 m ahead closing at
// 8.57 m/s (TTC 1.4 s) with a 1 m/s closing-speed sigma: its interval straddles the 1.5 s threshold, so the
// value and the riskier end say Unsafe and the safer end says Safe; a certain object gives its value under
// every rule. deciding_value is what the label compared with the threshold.
TEST(TtcPaper, LabelRuleDecidesByValueOrIntervalEnd) {
  ObjectState o = object(1, 12.0, 0.0, 10.0 - 12.0 / 1.4);
  o.covariance = cv::Matx44d::zeros();
  (*o.covariance)(0, 0) = 0.01;
  (*o.covariance)(2, 2) = 1.0;
  for (const char* rule : {"value", "riskier_bound", "safer_bound"}) {
    const RiskAssessment r = assess<TtcPaperMetric>(states({o}), std::string("{unsafe_when: ") + rule + "}");
    ASSERT_EQ(r.objects.size(), 1u);
    const ObjectRisk& a = r.objects[0];
    EXPECT_NEAR(a.value, 1.4, 1e-9);
    ASSERT_TRUE(a.low < 1.5 && a.high > 1.5) << a.low << " .. " << a.high;
    EXPECT_NEAR(r.scene_value, 1.4, 1e-9) << rule;  // the scene value is the value under every rule
    EXPECT_EQ(r.label_rule, rule);
    const double expect = std::string(rule) == "value"           ? a.value
                          : std::string(rule) == "riskier_bound" ? a.low
                                                                 : a.high;
    EXPECT_DOUBLE_EQ(deciding_value(r), expect) << rule;
    EXPECT_EQ(r.label, std::string(rule) == "safer_bound" ? SafetyLabel::kSafe : SafetyLabel::kUnsafe)
        << rule;
  }
  // Without a covariance there is no interval: the value decides under every rule.
  const RiskAssessment plain =
      assess<TtcPaperMetric>(states({object(1, 12.0, 0.0, 10.0 - 12.0 / 1.4)}), "{unsafe_when: safer_bound}");
  EXPECT_TRUE(std::isnan(plain.objects[0].high));
  EXPECT_NEAR(deciding_value(plain), 1.4, 1e-9);
  EXPECT_EQ(plain.label, SafetyLabel::kUnsafe);
  // Out-of-path objects decide nothing.
  ObjectState aside = o;
  aside.lateral_m = 6.0;
  const RiskAssessment none = assess<TtcPaperMetric>(states({aside}), "{unsafe_when: riskier_bound}");
  EXPECT_EQ(deciding_value(none), kInf);
  EXPECT_EQ(none.label, SafetyLabel::kSafe);
}

TEST(TtcPaper, ThresholdAndEpsilonAreParams) {
  const ObjectStates st = states({object(1, 12.0, 0.0, 4.0), object(2, 30.0, 0.0, 9.95)});
  EXPECT_EQ(assess<TtcPaperMetric>(st).label, SafetyLabel::kSafe);  // 2 s >= 1.5 s
  EXPECT_EQ(assess<TtcPaperMetric>(st, "threshold: 2.5").label, SafetyLabel::kUnsafe);
  // Closing 0.05 m/s: infinite under the default epsilon (0.1), 600 s with epsilon 0.01.
  EXPECT_EQ(assess<TtcPaperMetric>(st).objects[1].value, kInf);
  EXPECT_NEAR(assess<TtcPaperMetric>(st, "min_closing_mps: 0.01").objects[1].value, 600.0, 1e-6);
}

TEST(TtcPaper, UnknownEgoSpeedAndUnknownVelocity) {
  ObjectState s = object(1, 12.0, 0.0, 4.0);
  s.speed_mps.reset();
  s.heading_rad.reset();  // as the estimator reports without an ego speed: relative velocity only
  const ObjectStates st = states({s, object(2, 3.0, 0.0, std::nullopt)}, std::nullopt);
  const RiskAssessment fallback = assess<TtcPaperMetric>(st);
  EXPECT_DOUBLE_EQ(fallback.objects[0].value, 2.0);    // -v_rel.x = 6
  EXPECT_TRUE(std::isnan(fallback.objects[1].value));  // no velocity yet: unknown, not counted
  EXPECT_DOUBLE_EQ(fallback.scene_value, 2.0);
  const RiskAssessment strict = assess<TtcPaperMetric>(st, "relative_fallback: false");
  EXPECT_TRUE(std::isnan(strict.objects[0].value));
  EXPECT_EQ(strict.scene_value, kInf);
  EXPECT_EQ(strict.label, SafetyLabel::kSafe);
  EXPECT_EQ(strict.critical_track, -1);
}

TEST(TtcScale, InverseScaleRate) {
  ObjectState a = object(1, 12.0, 0.0, 4.0), b = a, c = a, d = a, e = a;
  a.scale_rate = 0.5;    // growing: 2 s
  b.scale_rate = 0.0;    // constant size: inf
  c.scale_rate = -0.2;   // shrinking: inf
  d.scale_rate.reset();  // unknown
  e.scale_rate = 1.0;    // 1 s but out of path
  e.lateral_m = -5.0;
  for (auto* s : {&b, &c, &d, &e}) s->track_id = s == &b ? 2 : s == &c ? 3 : s == &d ? 4 : 5;
  const RiskAssessment r = assess<TtcScaleMetric>(states({a, b, c, d, e}, std::nullopt));
  EXPECT_DOUBLE_EQ(r.objects[0].value, 2.0);
  EXPECT_EQ(r.objects[1].value, kInf);
  EXPECT_EQ(r.objects[2].value, kInf);
  EXPECT_TRUE(std::isnan(r.objects[3].value));
  EXPECT_DOUBLE_EQ(r.objects[4].value, 1.0);
  EXPECT_DOUBLE_EQ(r.scene_value, 2.0);
  EXPECT_EQ(r.critical_track, 1);
  EXPECT_EQ(r.label, SafetyLabel::kSafe);
  a.scale_rate = 0.005;  // below min_scale_rate 0.01
  EXPECT_EQ(assess<TtcScaleMetric>(states({a})).objects[0].value, kInf);
  EXPECT_DOUBLE_EQ(assess<TtcScaleMetric>(states({a}), "min_scale_rate: 0.001").objects[0].value, 200.0);
}

TEST(TimeHeadway, DistanceOverEgoSpeed) {
  const ObjectStates st = states({object(1, 12.0, 0.0, 15.0), object(2, 8.0, 4.0, 0.0)}, 10.0);
  const RiskAssessment r = assess<TimeHeadwayMetric>(st);
  EXPECT_DOUBLE_EQ(r.objects[0].value, 1.2);  // independent of the object's own (receding) speed
  EXPECT_DOUBLE_EQ(r.objects[1].value, 0.8);  // out of path
  EXPECT_DOUBLE_EQ(r.scene_value, 1.2);
  EXPECT_EQ(r.label, SafetyLabel::kUnsafe);
  // Standing ego: infinite; unknown ego speed: unknown, so the scene is Safe.
  EXPECT_EQ(assess<TimeHeadwayMetric>(states({object(1, 12.0, 0.0, 0.0)}, 0.0)).objects[0].value, kInf);
  const RiskAssessment unknown = assess<TimeHeadwayMetric>(states({object(1, 12.0, 0.0, 0.0)}, std::nullopt));
  EXPECT_TRUE(std::isnan(unknown.objects[0].value));
  EXPECT_EQ(unknown.scene_value, kInf);
  EXPECT_EQ(unknown.label, SafetyLabel::kSafe);
}

TEST(Drac, HigherIsRiskierWithItsOwnThreshold) {
  const RiskAssessment r = assess<DracMetric>(states({
      object(1, 12.0, 0.0, 4.0),   // closing 6: 36 / 24 = 1.5 m/s2
      object(2, 10.0, 0.0, 0.0),   // closing 10: 100 / 20 = 5 m/s2
      object(3, 10.0, 0.0, 14.0),  // receding: 0
      object(4, 2.0, -5.0, 0.0),   // out of path: 25 m/s2, not counted
  }));
  EXPECT_FALSE(r.lower_is_riskier);
  EXPECT_EQ(r.unit, "m/s2");
  EXPECT_DOUBLE_EQ(r.threshold, 3.35);
  EXPECT_DOUBLE_EQ(r.objects[0].value, 1.5);
  EXPECT_DOUBLE_EQ(r.objects[1].value, 5.0);
  EXPECT_DOUBLE_EQ(r.objects[2].value, 0.0);
  EXPECT_DOUBLE_EQ(r.objects[3].value, 25.0);
  EXPECT_DOUBLE_EQ(r.scene_value, 5.0);
  EXPECT_EQ(r.critical_track, 2);
  EXPECT_EQ(r.label, SafetyLabel::kUnsafe);
  EXPECT_EQ(assess<DracMetric>(states({object(1, 12.0, 0.0, 4.0)})).label, SafetyLabel::kSafe);
  EXPECT_EQ(assess<DracMetric>(states({object(1, 12.0, 0.0, 4.0)}), "threshold: 1.0").label,
            SafetyLabel::kUnsafe);
  // Equal speed and no velocity.
  const RiskAssessment e = assess<DracMetric>(states({object(1, 12.0, 0.0, 10.0), object(2, 5.0, 0.0, {})}));
  EXPECT_DOUBLE_EQ(e.objects[0].value, 0.0);
  EXPECT_TRUE(std::isnan(e.objects[1].value));
  EXPECT_EQ(e.label, SafetyLabel::kSafe);
}

}  // namespace
}  // namespace hf
