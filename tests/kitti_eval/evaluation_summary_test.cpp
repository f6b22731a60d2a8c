// The evaluation sink's flat summary rows (report.json "summary"), the lead-object comparison, unknown truths
// and fixed scene names; the summary recomputed from per_frame.jsonl; pooling runs with hf_eval_report.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdlib>
#include <fstream>
#include <sstream>

#include "evaluation_report.hpp"
#include "evaluation_sink.hpp"
#include "hazardforge/testing/stage_runner.hpp"
#include "test_support.hpp"

namespace hf {
namespace {

namespace fs = std::filesystem;

RiskAssessment assessment(const std::string& stage, double scene, int64_t critical,
                          std::vector<ObjectRisk> objects = {}) {
  RiskAssessment r;
  r.stage = stage;
  r.unit = "s";
  r.threshold = 1.5;
  r.scene_value = scene;
  r.critical_track = critical;
  r.objects = std::move(objects);
  return r;
}

Json read_json(const fs::path& p) {
  std::ifstream in(p);
  return Json::parse(in);
}

// Six frames. Truth: a lead (track 3) at 5, 4, 2.5, 1.8, unknown, 1.0 s. The camera metric's scene value
// follows a spurious in-path track 9 at 0.8 s in frames 0-1; its value for track 3 is what "@lead" scores.
const double kTruth[] = {5, 4, 2.5, 1.8, NAN, 1.0};
const double kScene[] = {0.8, 0.8, 3.0, 1.6, 2.0, kInf};
const double kLead[] = {4.0, 6.0, 3.0, 1.6, 2.0, NAN};  // NaN: track 3 absent from the estimate

testing::StageRunner run_sink(const std::string& params) {
  auto r = testing::StageRunner::create<EvaluationSink>(params);
  for (int i = 0; i < 6; ++i) {
    const double t = 0.1 * i;
    RiskAssessment truth = assessment("lidar_ttc", kTruth[i], 3, {{3, kTruth[i], true}});
    std::vector<ObjectRisk> objs;
    if (!std::isnan(kLead[i])) objs.push_back({3, kLead[i], i != 2});  // frame 2: not counted in path
    if (i < 2) objs.push_back({9, 0.8, true});
    r.push("truth", truth, t);
    r.push("estimates", assessment("ttc_paper", kScene[i], i < 2 ? 9 : 3, objs), t, "ttc");
  }
  r.run();
  return r;
}

const Json& row(const Json& summary, const std::string& metric, double threshold) {
  for (const Json& r : summary.at("summary"))
    if (r.at("metric") == metric && r.at("threshold") == threshold) return r;
  throw Error("no summary row " + metric);
}

TEST(EvaluationSummary, FlatRowsPerMetricAndThreshold) {
  auto r = run_sink("{compare: [scene, lead], thresholds: [2.0, 3.0], scene: seq7}");
  const Json report = read_json(r.output_dir() / "evaluation" / "report.json");
  ASSERT_EQ(report.at("summary").size(), 4u);  // (scene, lead) x (2 s, 3 s)
  EXPECT_EQ(report.at("results")[0].at("truth_unknown"), 1);
  // Scene values at 2 s on the five scored frames (frame 4's truth is unknown):
  //   truth Unsafe: 1.8, 1.0 (frames 3, 5); estimate Unsafe: 0.8, 0.8, 1.6 (frames 0, 1, 3).
  //   TP 1 (frame 3), FP 2 (0, 1), FN 1 (5), TN 1 (2).
  const Json& s2 = row(report, "ttc", 2.0);
  EXPECT_EQ(s2.at("scene"), "seq7");
  EXPECT_EQ(s2.at("frames"), 5);
  EXPECT_DOUBLE_EQ(s2.at("accuracy").get<double>(), 2.0 / 5.0);
  EXPECT_DOUBLE_EQ(s2.at("unsafe_precision").get<double>(), 1.0 / 3.0);
  EXPECT_DOUBLE_EQ(s2.at("unsafe_recall").get<double>(), 0.5);
  EXPECT_DOUBLE_EQ(s2.at("balanced_accuracy").get<double>(), (0.5 + 1.0 / 3.0) / 2.0);
  EXPECT_DOUBLE_EQ(s2.at("always_safe_accuracy").get<double>(), 3.0 / 5.0);
  // TTC error on the 5 frames with a finite true TTC < 10 s; frame 5's estimate is infinite:
  //   |0.8-5|, |0.8-4|, |3-2.5|, |1.6-1.8| -> median of {4.2, 3.2, 0.5, 0.2} = 1.85 s.
  EXPECT_EQ(s2.at("ttc_eligible_frames"), 5);
  EXPECT_EQ(s2.at("ttc_frames"), 4);
  EXPECT_NEAR(s2.at("ttc_median_abs_err_s").get<double>(), 1.85, 1e-12);
  EXPECT_NEAR(s2.at("ttc_median_rel_err").get<double>(), (3.2 / 4 + 0.5 / 2.5) / 2, 1e-12);
  // "@lead": the estimate's value for track 3, in path or not: 4, 6, 3, 1.6, -, NaN (absent).
  //   At 2 s: truth Unsafe in frames 3, 5; lead estimate Unsafe in frame 3 only -> TP 1, FN 1, TN 3.
  const Json& l2 = row(report, "ttc@lead", 2.0);
  EXPECT_DOUBLE_EQ(l2.at("accuracy").get<double>(), 4.0 / 5.0);
  EXPECT_TRUE(l2.at("unsafe_precision") == 1.0);
  EXPECT_DOUBLE_EQ(l2.at("unsafe_recall").get<double>(), 0.5);
  //   Errors |4-5|, |6-4|, |3-2.5|, |1.6-1.8| -> median 0.75 s; frame 5 has no value.
  EXPECT_EQ(l2.at("ttc_frames"), 4);
  EXPECT_NEAR(l2.at("ttc_median_abs_err_s").get<double>(), 0.75, 1e-12);
  // Every field of the documented row is present (numbers or null).
  for (const char* k :
       {"metric", "scene", "threshold", "frames", "accuracy", "balanced_accuracy", "unsafe_precision",
        "unsafe_recall", "always_safe_accuracy", "ttc_median_abs_err_s", "ttc_median_rel_err", "ttc_frames"})
    EXPECT_TRUE(l2.contains(k)) << k;
}

TEST(EvaluationSummary, RecomputedFromPerFrameRecords) {
  auto r = run_sink("{compare: [scene, lead], thresholds: [1.5, 2.0, 3.0]}");
  const fs::path dir = r.output_dir() / "evaluation";
  const Json report = read_json(dir / "report.json");
  const auto records = eval::read_records((dir / "per_frame.jsonl").string());
  ASSERT_EQ(records.size(), 6u);
  EXPECT_TRUE(std::isnan(records[4].truth.scene_value));  // unknown survives the round trip (null)
  ASSERT_TRUE(records[5].estimates[0].second.lead_value.has_value());
  EXPECT_TRUE(std::isnan(*records[5].estimates[0].second.lead_value));
  const Json again = eval::evaluate(records, eval::options_from_json(report.at("protocol")));
  EXPECT_EQ(again.at("summary"), report.at("summary"));
  EXPECT_EQ(again, report);
  EXPECT_EQ(report.at("summary").size(), 6u);
  EXPECT_FALSE(report.at("summary")[0].contains("scene"));  // frames without scene names
  // Hand check of one row against the records: accuracy at 3 s of the scene comparison.
  long correct = 0, n = 0;
  for (const auto& rec : records) {
    if (std::isnan(rec.truth.scene_value)) continue;
    ++n;
    correct += (rec.truth.scene_value < 3.0) == (rec.estimates[0].second.scene_value < 3.0);
  }
  EXPECT_DOUBLE_EQ(row(report, "ttc", 3.0).at("accuracy").get<double>(), static_cast<double>(correct) / n);
}

TEST(EvaluationSummary, PoolingRunsGivesPerSceneAndAllSceneRows) {
  auto a = run_sink("{scene: '0000'}");
  auto b = run_sink("{scene: '0001'}");
  const fs::path fa = a.output_dir() / "evaluation" / "per_frame.jsonl";
  const fs::path fb = b.output_dir() / "evaluation" / "per_frame.jsonl";
  const fs::path out = fs::temp_directory_path() / ("hf_eval_pool_" + std::to_string(::getpid()));
  const fs::path tool = test::binary_dir() / "bin" / "hf_eval_report";
  ASSERT_TRUE(fs::exists(tool)) << tool;
  const std::string cmd = tool.string() + " " + fa.string() + " " + fb.string() + " -o " + out.string() +
                          " --thresholds 2 2>/dev/null";
  ASSERT_EQ(std::system(cmd.c_str()), 0) << cmd;
  const Json pooled = read_json(out / "report.json");
  EXPECT_EQ(pooled.at("scenes"), Json::array({"0000", "0001"}));
  ASSERT_EQ(pooled.at("summary").size(), 3u);  // 0000, 0001, (all scenes) at 2 s
  const Json& all = pooled.at("summary")[2];
  EXPECT_EQ(all.at("scene"), "(all scenes)");
  EXPECT_EQ(all.at("frames"), 10);
  EXPECT_DOUBLE_EQ(all.at("accuracy").get<double>(), 0.4);  // 2 of 5 per run
  EXPECT_NEAR(all.at("ttc_median_abs_err_s").get<double>(), 1.85, 1e-12);
  // The pooled records are written too, so the pooled report is itself recomputable.
  EXPECT_EQ(eval::read_records((out / "per_frame.jsonl").string()).size(), 12u);
  fs::remove_all(out);
}

}  // namespace
}  // namespace hf
