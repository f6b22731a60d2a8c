// Scoring a system's answers against a scenario's labels: detection, warning lead time against the true TTC,
// the pass rule, and false warnings on the control.
#include <gtest/gtest.h>

#include "hazardforge/apps/system_test.hpp"

namespace hf {
namespace {

// 21 frames at 10 Hz; the hazard shows from 0.5 s on, its true TTC falls 0.2 s per frame from 3.0 s at 0.5 s
// (below 1.5 s from 1.3 s on).
scenario::Package package() {
  scenario::Package p;
  p.header.kind = "cut_in";
  p.header.object_class = "car";
  for (int i = 0; i <= 20; ++i) {
    scenario::PackageFrame f;
    f.frame = 100 + i;
    f.timestamp = 0.1 * i;
    if (i >= 5) {
      scenario::LabelledObject o;
      o.label = "car";
      o.inserted = true;
      o.visible = true;
      o.box = cv::Rect2f(100, 100, 50, 40);
      o.distance_m = 30.0 - i;
      o.ttc_s = 3.0 - 0.2 * (i - 5);
      f.hazard = o;
    }
    p.frames.push_back(f);
  }
  return p;
}

std::vector<SystemResponse> answers(int warn_from, bool detect, int from = 0) {
  std::vector<SystemResponse> v;
  for (int i = from; i <= 20; ++i) {
    SystemResponse r;
    r.frame_index = 100 + i;
    r.warning = warn_from >= 0 && i >= warn_from;
    if (detect && i >= 7) {
      r.detections.push_back(Detection{cv::Rect2f(102, 101, 50, 40), 2, "car", 0.9f});
      r.ttc_s = 3.2 - 0.2 * (i - 5);
    }
    v.push_back(r);
  }
  return v;
}

TEST(SystemScore, LeadTimeDetectionAndThePassRule) {
  const auto pkg = package();
  apps::PassRule rule;  // critical below 1.5 s, lead >= 0, IoU 0.5
  // Warns at 1.0 s: 0.3 s before the true TTC falls below 1.5 s (1.3 s).
  const Json s = apps::score_scenario(pkg, answers(10, true), answers(-1, false), rule);
  EXPECT_EQ(s["verdict"], "passed") << s.dump(2);
  EXPECT_NEAR(s["warning"]["critical_at_s"].get<double>(), 1.3, 1e-9);
  EXPECT_NEAR(s["warning"]["lead_s"].get<double>(), 0.3, 1e-9);
  EXPECT_NEAR(s["warning"]["true_ttc_at_warning_s"].get<double>(), 2.0, 1e-9);
  EXPECT_TRUE(s["detection"]["detected"].get<bool>());
  EXPECT_NEAR(s["detection"]["first_detected_s"].get<double>(), 0.7, 1e-9);
  EXPECT_NEAR(s["detection"]["range_at_first_detection_m"].get<double>(), 23.0, 1e-9);
  EXPECT_EQ(s["detection"]["visible_frames"], 16);
  EXPECT_EQ(s["detection"]["matched_frames"], 14);
  EXPECT_NEAR(s["detection"]["recall"].get<double>(), 14.0 / 16.0, 1e-12);
  EXPECT_NEAR(s["detection"]["precision"].get<double>(), 1.0, 1e-12);
  EXPECT_NEAR(s["detection"]["median_ttc_error_s"].get<double>(), 0.2, 1e-9);
  EXPECT_EQ(s["control"]["verdict"], "passed");

  // The same answers under a rule asking 1 s of lead fail, saying why.
  rule.min_lead_s = 1.0;
  const Json late = apps::score_scenario(pkg, answers(10, true), answers(-1, false), rule);
  EXPECT_EQ(late["verdict"], "failed");
  EXPECT_NE(late["why"].get<std::string>().find("warned 0.3 s before"), std::string::npos) << late["why"];

  // No warning at all; a warning before the hazard shows is not one for it.
  rule.min_lead_s = 0.0;
  EXPECT_EQ(apps::score_scenario(pkg, answers(-1, true), answers(-1, false), rule)["verdict"], "failed");
  const Json early = apps::score_scenario(pkg, answers(0, false), answers(-1, false), rule);
  EXPECT_NEAR(early["warning"]["warned_at_s"].get<double>(), 0.5, 1e-9);  // counted from when it shows
  EXPECT_FALSE(early["detection"]["detected"].get<bool>());
  EXPECT_EQ(early["detection"]["recall"], 0.0);

  // Warnings on the original frames are false warnings.
  const Json ctl = apps::score_scenario(pkg, answers(10, true), answers(18, false), rule);
  EXPECT_EQ(ctl["control"]["verdict"], "failed");
  EXPECT_EQ(ctl["control"]["false_warning_frames"].size(), 3u);
  EXPECT_EQ(ctl["control"]["frames"], 21);
}

TEST(SystemScore, AHazardNeverCriticalIsNotScoredAsAPassOrAFailure) {
  auto pkg = package();
  for (auto& f : pkg.frames)
    if (f.hazard) f.hazard->ttc_s = 4.0;
  const Json s = apps::score_scenario(pkg, answers(10, true), answers(-1, false), apps::PassRule{});
  EXPECT_EQ(s["verdict"], "not_critical");
}

}  // namespace
}  // namespace hf
