// Evaluation sink: confusion tables, TTC error and baselines on hand-made assessments with known answers, and
// recomputing the report from its own per-frame records.
#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <sstream>

#include <unistd.h>

#include "evaluation_report.hpp"
#include "evaluation_sink.hpp"
#include "hazardforge/testing/stage_runner.hpp"

namespace hf {
namespace {

RiskAssessment assessment(int64_t frame, const std::string& stage, double value, bool lower = true,
                          double threshold = 1.5) {
  RiskAssessment r;
  r.frame_index = frame;
  r.metric = stage;
  r.stage = stage;
  r.unit = lower ? "s" : "m/s2";
  r.lower_is_riskier = lower;
  r.threshold = threshold;
  r.scene_value = value;
  r.label = (lower ? value < threshold : value > threshold) ? SafetyLabel::kUnsafe : SafetyLabel::kSafe;
  return r;
}

std::string slurp(const std::filesystem::path& p) {
  std::ifstream in(p);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

// Ten frames in two scenes: ground truth, a TTC estimate and a DRAC estimate (see the expected tables below).
testing::StageRunner run_ten_frames(const std::string& params = "") {
  const double truth[] = {kInf, 5, 2.5, 1.8, 1.2, 0.8, kInf, 1.0, 2.2, 9.0};
  const double ttc[] = {kInf, 4, 3.0, 1.4, 1.0, kInf, 8, 1.3, 2.8, 12.0};
  const double drac[] = {0, 1, 2, 4, 5, 6, 0, 5, 1, 0};
  auto r = testing::StageRunner::create<EvaluationSink>(params);
  for (int i = 0; i < 10; ++i) {
    const double t = 0.5 * i;
    Frame f;
    f.index = i;
    f.timestamp = t;
    f.origin.scene = i < 6 ? "scene-a" : "scene-b";
    r.push("frames", f, t);
    r.push("truth", assessment(i, "ground_truth", truth[i]), t);
    r.push("estimates", assessment(i, "ttc_paper", ttc[i]), t, "ttc_yolo");
    r.push("estimates", assessment(i, "drac", drac[i], false, 3.35), t, "drac_yolo");
  }
  r.run();
  return r;
}

const Json& group(const Json& report, const std::string& scene) {
  for (const Json& g : report.at("results"))
    if (g.at("scene") == scene) return g;
  throw Error("no group " + scene);
}
const Json& metric(const Json& g, const std::string& name) {
  for (const Json& m : g.at("metrics"))
    if (m.at("name") == name) return m;
  throw Error("no metric " + name);
}

TEST(Evaluation, ConfusionAccuracyBaselineAndErrorAtEachThreshold) {
  auto r = run_ten_frames();
  const std::filesystem::path dir = r.output_dir() / "evaluation";
  const Json report = Json::parse(slurp(dir / "report.json"));
  EXPECT_EQ(report.at("frames"), 10);
  EXPECT_EQ(report.at("scenes"), Json::array({"scene-a", "scene-b"}));
  // Metrics in input order, not alphabetical.
  EXPECT_EQ(report.at("metrics")[0].at("name"), "ttc_yolo");
  EXPECT_EQ(report.at("metrics")[1].at("name"), "drac_yolo");
  const Json& ttc = metric(group(report, "(all scenes)"), "ttc_yolo");
  ASSERT_EQ(ttc.at("evaluations").size(), 3u);
  const Json& e15 = ttc.at("evaluations")[0];
  EXPECT_EQ(e15.at("threshold"), 1.5);
  EXPECT_EQ(e15.at("frames"), 10);
  EXPECT_EQ(e15.at("tp"), 2);  // frames 4, 7
  EXPECT_EQ(e15.at("fp"), 1);  // frame 3 (1.4 vs 1.8)
  EXPECT_EQ(e15.at("fn"), 1);  // frame 5 (infinite vs 0.8)
  EXPECT_EQ(e15.at("tn"), 6);
  EXPECT_EQ(e15.at("correct"), 8);
  EXPECT_EQ(e15.at("incorrect"), 2);
  EXPECT_DOUBLE_EQ(e15.at("accuracy").get<double>(), 0.8);
  EXPECT_DOUBLE_EQ(e15.at("precision").get<double>(), 2.0 / 3.0);
  EXPECT_DOUBLE_EQ(e15.at("recall").get<double>(), 2.0 / 3.0);
  EXPECT_DOUBLE_EQ(e15.at("balanced_accuracy").get<double>(), (2.0 / 3.0 + 6.0 / 7.0) / 2.0);
  EXPECT_DOUBLE_EQ(e15.at("always_safe_accuracy").get<double>(), 0.7);
  const Json& e2 = ttc.at("evaluations")[1];
  EXPECT_EQ(std::vector<int>({e2.at("tp"), e2.at("fp"), e2.at("fn"), e2.at("tn")}),
            std::vector<int>({3, 0, 1, 6}));
  const Json& e3 = ttc.at("evaluations")[2];
  EXPECT_EQ(std::vector<int>({e3.at("tp"), e3.at("fp"), e3.at("fn"), e3.at("tn")}),
            std::vector<int>({4, 0, 2, 4}));
  EXPECT_DOUBLE_EQ(e3.at("always_safe_accuracy").get<double>(), 0.4);
  // TTC error on the 8 frames with a finite true TTC below 10 s; frame 5's estimate is infinite.
  const Json& err = ttc.at("ttc_error");
  EXPECT_EQ(err.at("frames"), 8);
  EXPECT_EQ(err.at("estimate_finite"), 7);
  EXPECT_NEAR(err.at("median_abs_s").get<double>(), 0.5, 1e-12);
  EXPECT_NEAR(err.at("median_rel").get<double>(), 0.4 / 1.8, 1e-12);
  // Per scene: scene-a alone at 1.5 s.
  const Json& a15 = metric(group(report, "scene-a"), "ttc_yolo").at("evaluations")[0];
  EXPECT_EQ(std::vector<int>({a15.at("tp"), a15.at("fp"), a15.at("fn"), a15.at("tn")}),
            std::vector<int>({1, 1, 1, 3}));
  // DRAC: scored once with its own label, no TTC error.
  const Json& drac = metric(group(report, "(all scenes)"), "drac_yolo");
  ASSERT_EQ(drac.at("evaluations").size(), 1u);
  const Json& d = drac.at("evaluations")[0];
  EXPECT_EQ(d.at("threshold"), "own");
  EXPECT_EQ(std::vector<int>({d.at("tp"), d.at("fp"), d.at("fn"), d.at("tn")}),
            std::vector<int>({3, 1, 0, 6}));
  EXPECT_DOUBLE_EQ(d.at("precision").get<double>(), 0.75);
  EXPECT_TRUE(drac.at("ttc_error").is_null());
}

TEST(Evaluation, ReportIsRecomputedFromItsOwnRecords) {
  auto r = run_ten_frames("{thresholds: [1.5, 2.5], max_ttc_s: 5}");
  const std::filesystem::path dir = r.output_dir() / "evaluation";
  const Json report = Json::parse(slurp(dir / "report.json"));
  const std::vector<eval::FrameRecord> records = eval::read_records((dir / "per_frame.jsonl").string());
  ASSERT_EQ(records.size(), 10u);
  EXPECT_EQ(records[0].truth.scene_value, kInf);  // infinity survives the JSON round trip
  const Json again = eval::evaluate(records, eval::options_from_json(report.at("protocol")));
  EXPECT_EQ(again, report);
  EXPECT_EQ(eval::render_markdown(again), slurp(dir / "report.md"));
  EXPECT_EQ(eval::render_html(again, records), slurp(dir / "report.html"));
  EXPECT_EQ(report.at("protocol").at("max_ttc_s"), 5.0);
  EXPECT_EQ(metric(group(report, "(all scenes)"), "ttc_yolo").at("ttc_error").at("frames"), 6);
}

TEST(Evaluation, ReportsAreSelfContainedAndSayWhatDoesNotApply) {
  auto r = run_ten_frames();
  const std::filesystem::path dir = r.output_dir() / "evaluation";
  const std::string html = slurp(dir / "report.html");
  EXPECT_EQ(html.find("<script"), std::string::npos);
  EXPECT_EQ(html.find("src="), std::string::npos);
  EXPECT_EQ(html.find("href="), std::string::npos);
  EXPECT_EQ(html.find("<link"), std::string::npos);
  // One plot per scene.
  size_t svgs = 0;
  for (size_t p = html.find("<svg"); p != std::string::npos; p = html.find("<svg", p + 1)) ++svgs;
  EXPECT_EQ(svgs, 2u);
  const std::string md = slurp(dir / "report.md");
  EXPECT_NE(
      md.find(
          "| ttc_yolo | 1.5 s | 10 | 8 | 2 | 80.0 % | 2 | 1 | 1 | 6 | 66.7 % | 66.7 % | 76.2 % | 70.0 % |"),
      std::string::npos)
      << md;
  EXPECT_NE(md.find("`drac_yolo` is higher-is-riskier"), std::string::npos);
  // The side-by-side summary: accuracy / balanced accuracy / recall per threshold, then the TTC error.
  EXPECT_NE(
      md.find(
          "| ttc_yolo | 10 | 80.0 % / 76.2 % / 66.7 % | 90.0 % / 87.5 % / 75.0 % | 80.0 % / 83.3 % / 66.7 % "
          "| — | 0.50 s / 22.2 % |"),
      std::string::npos)
      << md;
  EXPECT_NE(md.find("| drac_yolo | 10 | — | — | — | 90.0 % / 92.9 % / 100.0 % | — |"), std::string::npos);
  EXPECT_NE(md.find("| drac_yolo | own (3.35 m/s2) |"), std::string::npos);
}

TEST(Evaluation, NoUnsafeTruthGivesNotApplicableRecall) {
  auto r = testing::StageRunner::create<EvaluationSink>("dir: out");
  for (int i = 0; i < 3; ++i) {
    r.push("truth", assessment(i, "ground_truth", 4.0), i * 0.1);
    r.push("estimates", assessment(i, "ttc_paper", i == 1 ? 1.0 : 5.0), i * 0.1, "ttc");
  }
  r.run();
  const Json report = Json::parse(slurp(r.output_dir() / "out" / "report.json"));
  const Json& e = report.at("results")[0].at("metrics")[0].at("evaluations")[0];
  EXPECT_EQ(report.at("results")[0].at("scene"), "all");  // no frames input: one scene
  EXPECT_TRUE(e.at("recall").is_null());
  EXPECT_TRUE(e.at("balanced_accuracy").is_null());
  EXPECT_DOUBLE_EQ(e.at("precision").get<double>(), 0.0);
  EXPECT_DOUBLE_EQ(e.at("always_safe_accuracy").get<double>(), 1.0);
  EXPECT_NEAR(e.at("accuracy").get<double>(), 2.0 / 3.0, 1e-12);
}

// A metric labelling by its interval's safer end (unsafe_when: safer_bound) is scored by that end at every
// threshold, its TTC error by its value; the records carry the rule and the deciding number, so the report is
// recomputed from them.
TEST(Evaluation, IntervalLabelRuleDecidesAtEveryThreshold) {
  const double truth[] = {1.2, 2.5, 5.0};
  const double value[] = {1.3, 1.4, 4.0}, high[] = {1.8, 2.2, 6.0};
  auto r = testing::StageRunner::create<EvaluationSink>("dir: out");
  for (int i = 0; i < 3; ++i) {
    RiskAssessment e = assessment(i, "ttc_paper", value[i]);
    e.label_rule = "safer_bound";
    ObjectRisk o;
    o.track_id = 7;
    o.in_path = true;
    o.value = value[i];
    o.low = value[i] - 0.3;
    o.high = high[i];
    e.objects = {o, ObjectRisk{8, 0.2, false}};  // out of path: decides nothing
    r.push("truth", assessment(i, "ground_truth", truth[i]), i * 0.1);
    r.push("estimates", e, i * 0.1, "ttc_confirmed");
  }
  r.run();
  const std::filesystem::path dir = r.output_dir() / "out";
  const Json report = Json::parse(slurp(dir / "report.json"));
  const Json& m = report.at("results")[0].at("metrics")[0];
  EXPECT_EQ(m.at("label_rule"), "safer_bound");
  auto cells = [&](int k) {
    const Json& e = m.at("evaluations")[static_cast<size_t>(k)];
    return std::vector<int>({e.at("tp"), e.at("fp"), e.at("fn"), e.at("tn")});
  };
  EXPECT_EQ(cells(0), std::vector<int>({0, 0, 1, 2}));  // 1.5 s: frame 0's high end 1.8 is not below
  EXPECT_EQ(cells(1), std::vector<int>({1, 0, 0, 2}));  // 2 s: 1.8 < 2; frame 1's 2.2 is Safe like its truth
  EXPECT_EQ(cells(2), std::vector<int>({2, 0, 0, 1}));  // 3 s
  EXPECT_NEAR(m.at("ttc_error").at("median_abs_s").get<double>(), 1.0, 1e-12);  // |4 - 5|: on the values
  const std::vector<eval::FrameRecord> records = eval::read_records((dir / "per_frame.jsonl").string());
  ASSERT_EQ(records.size(), 3u);
  EXPECT_EQ(records[0].estimates[0].second.label_rule, "safer_bound");
  EXPECT_DOUBLE_EQ(records[0].estimates[0].second.decision_value.value(), 1.8);
  EXPECT_EQ(eval::evaluate(records, eval::options_from_json(report.at("protocol"))), report);
  EXPECT_NE(slurp(dir / "report.md").find("`ttc_confirmed` labels by its interval's safer end"),
            std::string::npos);
}

TEST(Evaluation, MalformedRecordsNameFileLineAndField) {
  const std::filesystem::path p =
      std::filesystem::temp_directory_path() / ("hf_eval_bad_" + std::to_string(::getpid()) + ".jsonl");
  {
    std::ofstream out(p);
    out << R"({"frame":0,"timestamp":0,"scene":"s","truth":{"stage":"ground_truth","unit":"s","lower_is_riskier":true,"threshold":1.5,"scene_value":"inf","critical":-1},"estimates":[]})"
        << "\n"
        << R"({"frame":1,"timestamp":0.1,"scene":"s","truth":{"stage":"ground_truth","unit":"s","lower_is_riskier":true,"threshold":1.5,"scene_value":"soon","critical":-1},"estimates":[]})"
        << "\n";
  }
  try {
    eval::read_records(p.string());
    FAIL();
  } catch (const Error& e) {
    EXPECT_EQ(std::string(e.what()),
              p.string() +
                  ":2: field 'truth.scene_value' must be a number, \"inf\", \"-inf\" or "
                  "null, got \"soon\"");
  }
  std::filesystem::remove(p);
}

}  // namespace
}  // namespace hf
