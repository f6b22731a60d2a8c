// Evaluation maths (confusion matrices per threshold, TTC error) and the Markdown / HTML renderings.
#include "evaluation_report.hpp"

#include "hazardforge/markup.hpp"
#include "hazardforge/number_text.hpp"

#include <algorithm>
#include <cmath>
#include <fstream>
#include <functional>
#include <iomanip>
#include <set>
#include <sstream>

namespace hf::eval {

namespace {

const char* kAllScenes = "(all scenes)";

Json number_or_inf(double v) {
  if (std::isnan(v)) return Json();
  if (std::isinf(v)) return v > 0 ? "inf" : "-inf";
  return v;
}

double number_from(const Json& j, const std::string& where, const std::string& field) {
  if (j.is_number()) return j.get<double>();
  if (j.is_string() && j.get<std::string>() == "inf") return kInf;
  if (j.is_string() && j.get<std::string>() == "-inf") return -kInf;
  if (j.is_null()) return std::nan("");
  throw Error(where + ": field '" + field + "' must be a number, \"inf\", \"-inf\" or null, got " + j.dump());
}

Json verdict_json(const Verdict& v) {
  Json j = {{"stage", v.stage},
            {"unit", v.unit},
            {"lower_is_riskier", v.lower_is_riskier},
            {"threshold", v.threshold},
            {"scene_value", number_or_inf(v.scene_value)},
            {"critical", v.critical}};
  if (v.lead_value) j["lead_value"] = number_or_inf(*v.lead_value);
  if (v.decision_value) {
    j["label_rule"] = v.label_rule;
    j["decision_value"] = number_or_inf(*v.decision_value);
  }
  return j;
}

Verdict verdict_from(const Json& j, const std::string& where, const std::string& field) {
  if (!j.is_object()) throw Error(where + ": field '" + field + "' must be an object");
  Verdict v;
  try {
    v.stage = j.at("stage").get<std::string>();
    v.unit = j.at("unit").get<std::string>();
    v.lower_is_riskier = j.at("lower_is_riskier").get<bool>();
    v.threshold = j.at("threshold").get<double>();
    v.critical = j.at("critical").get<int64_t>();
  } catch (const Json::exception& e) {
    throw Error(where + ": field '" + field + "': " + e.what());
  }
  if (!j.contains("scene_value")) throw Error(where + ": field '" + field + "' has no 'scene_value'");
  v.scene_value = number_from(j["scene_value"], where, field + ".scene_value");
  if (j.contains("lead_value")) v.lead_value = number_from(j["lead_value"], where, field + ".lead_value");
  if (j.contains("decision_value")) {
    if (!j.contains("label_rule") || !j["label_rule"].is_string())
      throw Error(where + ": field '" + field + "' has a 'decision_value' but no 'label_rule' string");
    v.label_rule = j["label_rule"].get<std::string>();
    v.decision_value = number_from(j["decision_value"], where, field + ".decision_value");
  }
  return v;
}

bool unsafe(double value, double threshold, bool lower_is_riskier) {
  return lower_is_riskier ? value < threshold : value > threshold;
}

Json ratio(long num, long den) {
  return den > 0 ? Json(static_cast<double>(num) / static_cast<double>(den)) : Json();
}

struct Confusion {
  long tp = 0, fp = 0, fn = 0, tn = 0;
  void add(bool est_unsafe, bool truth_unsafe) {
    if (est_unsafe && truth_unsafe)
      ++tp;
    else if (est_unsafe)
      ++fp;
    else if (truth_unsafe)
      ++fn;
    else
      ++tn;
  }
  Json json(const Json& threshold) const {
    const long n = tp + fp + fn + tn, correct = tp + tn;
    Json j = {{"threshold", threshold},
              {"frames", n},
              {"correct", correct},
              {"incorrect", n - correct},
              {"accuracy", ratio(correct, n)},
              {"tp", tp},
              {"fp", fp},
              {"fn", fn},
              {"tn", tn},
              {"truth_unsafe", tp + fn},
              {"precision", ratio(tp, tp + fp)},
              {"recall", ratio(tp, tp + fn)},
              {"always_safe_accuracy", ratio(tn + fp, n)}};
    // Balanced accuracy needs both classes in the ground truth.
    j["balanced_accuracy"] = (tp + fn > 0 && tn + fp > 0)
                                 ? Json((static_cast<double>(tp) / static_cast<double>(tp + fn) +
                                         static_cast<double>(tn) / static_cast<double>(tn + fp)) /
                                        2.0)
                                 : Json();
    return j;
  }
};

std::string pct(const Json& v) {
  return v.is_number() ? fixed_text(100.0 * v.get<double>(), 1) + " %" : "n/a";
}
std::string secs(const Json& v) {
  return v.is_number() ? fixed_text(v.get<double>(), 2) + " s" : "n/a";
}
std::string num(const Json& v) {
  if (v.is_number_integer()) return std::to_string(v.get<long long>());
  if (v.is_number()) {
    std::ostringstream s;
    s << v.get<double>();
    return s.str();
  }
  return v.is_string() ? v.get<std::string>() : "n/a";
}

// A rendered table: header and rows of cell text, shared by the Markdown and HTML forms.
struct Table {
  std::vector<std::string> header;
  std::vector<std::vector<std::string>> rows;
};

Table threshold_table(const Json& group) {
  Table t;
  t.header = {"metric",
              "threshold",
              "frames",
              "correct",
              "incorrect",
              "accuracy",
              "TP",
              "FP",
              "FN",
              "TN",
              "Unsafe precision",
              "Unsafe recall",
              "balanced accuracy",
              "always-Safe accuracy"};
  for (const Json& m : group.at("metrics")) {
    for (const Json& e : m.at("evaluations")) {
      const std::string th = e.at("threshold").is_string() ? "own (" + num(m.at("threshold")) + " " +
                                                                 m.at("unit").get<std::string>() + ")"
                                                           : num(e.at("threshold")) + " s";
      t.rows.push_back({m.at("name").get<std::string>(), th, num(e.at("frames")), num(e.at("correct")),
                        num(e.at("incorrect")), pct(e.at("accuracy")), num(e.at("tp")), num(e.at("fp")),
                        num(e.at("fn")), num(e.at("tn")), pct(e.at("precision")), pct(e.at("recall")),
                        pct(e.at("balanced_accuracy")), pct(e.at("always_safe_accuracy"))});
    }
  }
  return t;
}

// Every metric on one row: accuracy, balanced accuracy and Unsafe recall at each threshold, and the TTC
// error.
Table summary_table(const Json& group, const std::vector<double>& thresholds) {
  Table t;
  t.header = {"metric", "frames"};
  for (double th : thresholds) t.header.push_back("at " + num(th) + " s: accuracy / balanced / recall");
  t.header.push_back("own threshold: accuracy / balanced / recall");
  t.header.push_back("TTC error: median abs / rel");
  auto cell = [](const Json& e) {
    return pct(e.at("accuracy")) + " / " + pct(e.at("balanced_accuracy")) + " / " + pct(e.at("recall"));
  };
  for (const Json& m : group.at("metrics")) {
    const Json& ev = m.at("evaluations");
    std::vector<std::string> row = {m.at("name").get<std::string>(),
                                    ev.empty() ? "0" : num(ev[0].at("frames"))};
    const bool own = !ev.empty() && ev[0].at("threshold").is_string();
    for (size_t k = 0; k < thresholds.size(); ++k) row.push_back(own || k >= ev.size() ? "—" : cell(ev[k]));
    row.push_back(own ? cell(ev[0]) : "—");
    const Json& err = m.at("ttc_error");
    row.push_back(err.is_null() ? "—" : secs(err.at("median_abs_s")) + " / " + pct(err.at("median_rel")));
    t.rows.push_back(std::move(row));
  }
  return t;
}

Table error_table(const Json& group, double max_ttc) {
  Table t;
  t.header = {"metric", "frames with true TTC finite and < " + num(max_ttc) + " s", "estimate finite",
              "median absolute error", "median relative error"};
  for (const Json& m : group.at("metrics")) {
    const Json& e = m.at("ttc_error");
    if (e.is_null()) continue;
    t.rows.push_back({m.at("name").get<std::string>(), num(e.at("frames")), num(e.at("estimate_finite")),
                      secs(e.at("median_abs_s")), pct(e.at("median_rel"))});
  }
  return t;
}

std::string markdown_table(const Table& t) {
  std::ostringstream s;
  s << "|";
  for (const auto& h : t.header) s << " " << h << " |";
  s << "\n|";
  for (size_t i = 0; i < t.header.size(); ++i) s << (i < 2 ? " --- |" : " ---: |");
  s << "\n";
  for (const auto& r : t.rows) {
    s << "|";
    for (const auto& c : r) s << " " << c << " |";
    s << "\n";
  }
  return s.str();
}

std::string html_table(const Table& t) {
  std::ostringstream s;
  s << "<table><thead><tr>";
  for (const auto& h : t.header) s << "<th>" << xml_escape(h) << "</th>";
  s << "</tr></thead><tbody>\n";
  for (const auto& r : t.rows) {
    s << "<tr>";
    for (size_t i = 0; i < r.size(); ++i)
      s << (i < 2 ? "<td class=l>" : "<td>") << xml_escape(r[i]) << "</td>";
    s << "</tr>\n";
  }
  s << "</tbody></table>\n";
  return s.str();
}

// Frames whose ground truth is unknown (NaN scene value) are left out of every table of the group.
std::string truth_unknown_line(const Json& group) {
  const long n = group.value("truth_unknown", 0L);
  if (n == 0) return "";
  return std::to_string(n) + " of " + std::to_string(group.value("frames", 0L)) +
         " frames have no ground-truth value (unknown) and are not scored.\n\n";
}

// A metric's value in a record: the stream's scene value, or its value for the truth's critical object.
const Verdict* stream_of(const FrameRecord& r, const Json& metric) {
  return r.estimate(metric.value("stream", metric.at("name").get<std::string>()));
}
double value_of(const Verdict& v, const Json& metric) {
  return metric.value("compare", "scene") == "lead" ? v.lead_value.value_or(std::nan("")) : v.scene_value;
}

std::vector<std::string> notes_of(const Json& report) {
  std::vector<std::string> notes;
  for (const Json& m : report.at("metrics")) {
    if (!m.at("lower_is_riskier").get<bool>())
      notes.push_back(
          "`" + m.at("name").get<std::string>() + "` is higher-is-riskier (" +
          m.at("unit").get<std::string>() +
          "): the TTC thresholds do not apply to it; it is evaluated once, its own label (scene value "
          "above its threshold " +
          num(m.at("threshold")) + ") against the ground truth's label at the ground truth's threshold (" +
          num(report.at("protocol").at("truth_threshold")) + " s), and it has no TTC error.");
    else if (m.at("stage") == "thw")
      notes.push_back(
          "`" + m.at("name").get<std::string>() +
          "` is a time headway, not a time-to-collision: its labels and errors compare a following-"
          "distance measure with the true TTC.");
    const std::string rule = m.value("label_rule", "value");
    if (rule != "value")
      notes.push_back("`" + m.at("name").get<std::string>() + "` labels by its interval's " +
                      (rule == "safer_bound"
                           ? "safer end (Unsafe only when even the high end of an in-path "
                             "object's TTC interval is below the threshold)"
                           : "riskier end (Unsafe when the low end of an in-path object's TTC "
                             "interval is below the threshold)") +
                      " at every threshold; its TTC error is on its value.");
  }
  for (const Json& m : report.at("metrics"))
    if (m.value("compare", "scene") == "lead") {
      notes.push_back(
          "`@lead` metrics compare the stream's value for the ground truth's critical object (the same "
          "track id) with the ground truth, whether or not the stream counts that object in path; a "
          "frame where the stream has no value for it counts as Safe with no TTC.");
      break;
    }
  notes.push_back(
      "n/a: a ratio with an empty denominator — precision without any estimated Unsafe frame, recall "
      "without any true Unsafe frame, balanced accuracy unless both classes occur in the ground truth.");
  return notes;
}

}  // namespace

double median(std::vector<double> v) {
  if (v.empty()) return std::nan("");
  std::sort(v.begin(), v.end());
  const size_t n = v.size();
  return n % 2 ? v[n / 2] : (v[n / 2 - 1] + v[n / 2]) / 2.0;
}

Verdict verdict_of(const RiskAssessment& r) {
  Verdict v;
  v.stage = r.stage;
  v.unit = r.unit;
  v.lower_is_riskier = r.lower_is_riskier;
  v.threshold = r.threshold;
  v.scene_value = r.scene_value;
  v.critical = r.critical_track;
  if (r.label_rule != "value") {
    v.label_rule = r.label_rule;
    v.decision_value = deciding_value(r);
  }
  return v;
}

const Verdict* FrameRecord::estimate(const std::string& label) const {
  for (const auto& [k, v] : estimates)
    if (k == label) return &v;
  return nullptr;
}

Json to_json(const FrameRecord& r) {
  Json est = Json::array();
  for (const auto& [k, v] : r.estimates) {
    Json e = verdict_json(v);
    e["name"] = k;
    est.push_back(std::move(e));
  }
  return {{"frame", r.frame},
          {"timestamp", r.timestamp},
          {"scene", r.scene},
          {"truth", verdict_json(r.truth)},
          {"estimates", est}};
}

FrameRecord record_from_json(const Json& j, const std::string& where) {
  if (!j.is_object()) throw Error(where + ": a record must be a JSON object");
  FrameRecord r;
  try {
    r.frame = j.at("frame").get<int64_t>();
    r.timestamp = j.at("timestamp").get<double>();
    r.scene = j.at("scene").get<std::string>();
  } catch (const Json::exception& e) {
    throw Error(where + ": " + e.what());
  }
  if (!j.contains("truth")) throw Error(where + ": no field 'truth'");
  r.truth = verdict_from(j["truth"], where, "truth");
  if (!j.contains("estimates") || !j["estimates"].is_array())
    throw Error(where + ": field 'estimates' must be an array");
  for (size_t k = 0; k < j["estimates"].size(); ++k) {
    const Json& e = j["estimates"][k];
    const std::string field = "estimates[" + std::to_string(k) + "]";
    if (!e.is_object() || !e.contains("name") || !e["name"].is_string())
      throw Error(where + ": field '" + field + "' needs a string 'name'");
    const std::string name = e["name"].get<std::string>();
    if (r.estimate(name)) throw Error(where + ": estimate '" + name + "' appears twice");
    r.estimates.emplace_back(name, verdict_from(e, where, field));
  }
  return r;
}

std::vector<FrameRecord> read_records(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw Error("cannot read evaluation records '" + path + "'");
  std::vector<FrameRecord> out;
  std::string line;
  for (int n = 1; std::getline(in, line); ++n) {
    if (line.empty()) continue;
    const std::string where = path + ":" + std::to_string(n);
    Json j;
    try {
      j = Json::parse(line);
    } catch (const Json::exception& e) {
      throw Error(where + ": not JSON: " + e.what());
    }
    out.push_back(record_from_json(j, where));
  }
  return out;
}

Json options_to_json(const Options& o) {
  return {{"thresholds", o.thresholds},
          {"max_ttc_s", o.max_ttc_s},
          {"plot_max_s", o.plot_max_s},
          {"title", o.title},
          {"compare", o.compare}};
}

Options options_from_json(const Json& j) {
  Options o;
  o.thresholds = j.at("thresholds").get<std::vector<double>>();
  o.max_ttc_s = j.at("max_ttc_s").get<double>();
  o.plot_max_s = j.at("plot_max_s").get<double>();
  o.title = j.at("title").get<std::string>();
  // Reports written before the comparison modes existed compared scene values only.
  if (j.contains("compare")) o.compare = j.at("compare").get<std::vector<std::string>>();
  return o;
}

std::string metric_name(const std::string& stream, const std::string& mode) {
  return mode == "lead" ? stream + "@lead" : stream;
}

Json evaluate(const std::vector<FrameRecord>& records, const Options& o) {
  for (const std::string& mode : o.compare)
    if (mode != "scene" && mode != "lead")
      throw Error("evaluation: comparison mode '" + mode + "' is not one of scene, lead");
  // Streams and scenes in order of first appearance; one metric per (comparison mode, stream).
  std::vector<std::string> streams, scenes;
  std::map<std::string, Verdict> first;
  for (const FrameRecord& r : records) {
    if (std::find(scenes.begin(), scenes.end(), r.scene) == scenes.end()) scenes.push_back(r.scene);
    for (const auto& [name, v] : r.estimates)
      if (first.emplace(name, v).second) streams.push_back(name);
  }
  struct Series {
    std::string name, stream, mode;
  };
  std::vector<Series> series;
  for (const std::string& mode : o.compare)
    for (const std::string& st : streams) series.push_back({metric_name(st, mode), st, mode});

  Json report;
  Json protocol = options_to_json(o);
  protocol["truth_stage"] = records.empty() ? "" : records.front().truth.stage;
  protocol["truth_threshold"] = records.empty() ? 1.5 : records.front().truth.threshold;
  report["protocol"] = protocol;
  report["frames"] = records.size();
  report["scenes"] = scenes;
  Json metrics = Json::array();
  for (const Series& se : series) {
    const Verdict& v = first[se.stream];
    metrics.push_back({{"name", se.name},
                       {"stream", se.stream},
                       {"compare", se.mode},
                       {"stage", v.stage},
                       {"unit", v.unit},
                       {"lower_is_riskier", v.lower_is_riskier},
                       {"threshold", v.threshold},
                       {"label_rule", se.mode == "lead" ? std::string("value") : v.label_rule}});
  }
  report["metrics"] = metrics;

  std::vector<std::string> groups = scenes;
  if (scenes.size() > 1) groups.push_back(kAllScenes);
  Json results = Json::array();
  Json summary = Json::array();
  for (const std::string& g : groups) {
    long truth_unknown = 0, in_group = 0;
    for (const FrameRecord& r : records) {
      if (g != kAllScenes && r.scene != g) continue;
      ++in_group;
      if (std::isnan(r.truth.scene_value)) ++truth_unknown;
    }
    Json group = {
        {"scene", g}, {"frames", in_group}, {"truth_unknown", truth_unknown}, {"metrics", Json::array()}};
    for (const Series& se : series) {
      const Verdict& meta = first[se.stream];
      // (truth value, estimate value); frames with an unknown truth are not scored. `decide`: what the
      // estimate's label compares with a threshold (its label rule's bound in the scene comparison).
      std::vector<std::pair<double, double>> pairs;
      std::vector<double> decide;
      for (const FrameRecord& r : records) {
        if (g != kAllScenes && r.scene != g) continue;
        if (std::isnan(r.truth.scene_value)) continue;
        const Verdict* e = r.estimate(se.stream);
        if (!e) continue;
        const double v = se.mode == "lead" ? e->lead_value.value_or(std::nan("")) : e->scene_value;
        pairs.push_back({r.truth.scene_value, v});
        decide.push_back(se.mode == "lead" ? v : e->deciding());
      }
      const double truth_threshold = records.empty() ? 1.5 : records.front().truth.threshold;
      Json m = {{"name", se.name},
                {"stage", meta.stage},
                {"unit", meta.unit},
                {"lower_is_riskier", meta.lower_is_riskier},
                {"threshold", meta.threshold},
                {"label_rule", se.mode == "lead" ? std::string("value") : meta.label_rule}};
      Json evals = Json::array();
      if (meta.lower_is_riskier) {
        for (double th : o.thresholds) {
          Confusion c;
          for (size_t k = 0; k < pairs.size(); ++k)
            c.add(unsafe(decide[k], th, true), unsafe(pairs[k].first, th, true));
          evals.push_back(c.json(th));
        }
      } else {
        Confusion c;
        for (size_t k = 0; k < pairs.size(); ++k)
          c.add(unsafe(decide[k], meta.threshold, false), unsafe(pairs[k].first, truth_threshold, true));
        evals.push_back(c.json("own"));
      }
      m["evaluations"] = evals;
      if (meta.lower_is_riskier && meta.unit == "s") {
        std::vector<double> abs_err, rel_err;
        long eligible = 0;
        for (const auto& [t, e] : pairs) {
          if (!std::isfinite(t) || t >= o.max_ttc_s) continue;
          ++eligible;
          if (!std::isfinite(e)) continue;
          const double err = std::abs(e - t);
          abs_err.push_back(err);
          // A true TTC of 0 (overlapping boxes) has no relative error.
          if (t > 0) rel_err.push_back(err / t);
        }
        m["ttc_error"] = {{"frames", eligible},
                          {"estimate_finite", static_cast<long>(abs_err.size())},
                          {"median_abs_s", abs_err.empty() ? Json() : Json(median(abs_err))},
                          {"median_rel", rel_err.empty() ? Json() : Json(median(rel_err))}};
      } else {
        m["ttc_error"] = Json();
      }
      // Flat rows, one per threshold, for comparisons across runs (`hazardforge experiment`).
      const Json& err = m["ttc_error"];
      for (const Json& e : evals) {
        Json row = {{"metric", se.name},
                    {"threshold", e.at("threshold")},
                    {"frames", e.at("frames")},
                    {"accuracy", e.at("accuracy")},
                    {"balanced_accuracy", e.at("balanced_accuracy")},
                    {"unsafe_precision", e.at("precision")},
                    {"unsafe_recall", e.at("recall")},
                    {"always_safe_accuracy", e.at("always_safe_accuracy")},
                    {"ttc_median_abs_err_s", err.is_null() ? Json() : err.at("median_abs_s")},
                    {"ttc_median_rel_err", err.is_null() ? Json() : err.at("median_rel")},
                    {"ttc_frames", err.is_null() ? Json() : err.at("estimate_finite")},
                    {"ttc_eligible_frames", err.is_null() ? Json() : err.at("frames")}};
        // The unnamed scene of a stream without scene names is left out.
        if (g != "all") row["scene"] = g;
        summary.push_back(std::move(row));
      }
      group["metrics"].push_back(m);
    }
    results.push_back(group);
  }
  report["results"] = results;
  report["summary"] = summary;
  return report;
}

std::string render_markdown(const Json& report) {
  const Json& p = report.at("protocol");
  std::ostringstream s;
  s << "# " << p.at("title").get<std::string>() << "\n\n";
  s << "Ground truth: stage `" << p.at("truth_stage").get<std::string>() << "`, Unsafe below "
    << num(p.at("truth_threshold")) << " s. Frames: " << num(report.at("frames"))
    << ". Labels of the truth and of "
    << "every TTC-like estimate are recomputed from their scene values (or the interval bound their label "
       "rule names) at each threshold (Unsafe when below). TTC "
       "error on frames whose true TTC is finite and below "
    << num(p.at("max_ttc_s")) << " s; an infinite estimate there has no error and is counted apart.\n\n";
  for (const Json& g : report.at("results")) {
    s << "## " << g.at("scene").get<std::string>() << "\n\n"
      << truth_unknown_line(g) << "### All metrics\n\n"
      << markdown_table(summary_table(g, p.at("thresholds").get<std::vector<double>>()))
      << "\n### Safe / Unsafe\n\n"
      << markdown_table(threshold_table(g));
    s << "\n### TTC error\n\n" << markdown_table(error_table(g, p.at("max_ttc_s").get<double>())) << "\n";
  }
  s << "## Notes\n\n";
  for (const std::string& n : notes_of(report)) s << "- " << n << "\n";
  return s.str();
}

namespace {

std::string svg_plot(const std::string& scene, const std::vector<const FrameRecord*>& recs,
                     const Json& report) {
  const double W = 860, H = 320, L = 50, R = 190, T = 15, B = 40;
  const double ymax = report.at("protocol").at("plot_max_s").get<double>();
  const double t0 = recs.front()->timestamp, t1 = std::max(recs.back()->timestamp, t0 + 1e-6);
  auto X = [&](double t) { return L + (t - t0) / (t1 - t0) * (W - L - R); };
  auto Y = [&](double v) { return T + (1.0 - std::clamp(v, 0.0, ymax) / ymax) * (H - T - B); };
  static const char* kColors[] = {"#1f77b4", "#d62728", "#2ca02c", "#9467bd", "#ff7f0e",
                                  "#8c564b", "#e377c2", "#17becf", "#bcbd22", "#7f7f7f"};
  std::ostringstream s;
  s << std::fixed << std::setprecision(1);
  s << "<svg xmlns='http://www.w3.org/2000/svg' width='" << W << "' height='" << H << "' viewBox='0 0 " << W
    << " " << H << "' role='img' aria-label='TTC over time, " << xml_escape(scene) << "'>\n";
  s << "<rect x='" << L << "' y='" << T << "' width='" << W - L - R << "' height='" << H - T - B
    << "' fill='#fff' stroke='#999'/>\n";
  for (double v = 0; v <= ymax + 1e-9; v += 2.0)
    s << "<text x='" << L - 6 << "' y='" << Y(v) + 4 << "' font-size='11' text-anchor='end'>"
      << (std::abs(v - ymax) < 1e-9 ? "\u2265" : "") << fixed_text(v, 0) << "</text>\n";
  for (double th : report.at("protocol").at("thresholds").get<std::vector<double>>())
    s << "<line x1='" << L << "' x2='" << W - R << "' y1='" << Y(th) << "' y2='" << Y(th)
      << "' stroke='#bbb' stroke-dasharray='4 3'/><text x='" << W - R + 3 << "' y='" << Y(th) + 4
      << "' font-size='10' fill='#888'>" << num(th) << " s</text>\n";
  const int ticks = 5;
  for (int k = 0; k <= ticks; ++k) {
    const double t = t0 + (t1 - t0) * k / ticks;
    s << "<text x='" << X(t) << "' y='" << H - B + 15 << "' font-size='11' text-anchor='middle'>"
      << fixed_text(t - t0, 1) << "</text>\n";
  }
  s << "<text x='" << (L + W - R) / 2 << "' y='" << H - 5
    << "' font-size='11' text-anchor='middle'>time since scene start (s)</text>\n";
  s << "<text x='12' y='" << (T + H - B) / 2 << "' font-size='11' transform='rotate(-90 12 "
    << (T + H - B) / 2 << ")' text-anchor='middle'>scene TTC (s, clipped; top = \u221e)</text>\n";

  struct Series {
    std::string name, color;
    double width;
    std::function<double(const FrameRecord&)> get;  // NaN = no point
  };
  std::vector<Series> series;
  series.push_back({"ground truth", "#000", 2.5, [](const FrameRecord& r) { return r.truth.scene_value; }});
  int ci = 0;
  for (const Json& m : report.at("metrics")) {
    if (!m.at("lower_is_riskier").get<bool>() || m.at("unit") != "s") continue;
    series.push_back({m.at("name").get<std::string>(), kColors[ci++ % 10], 1.5, [m](const FrameRecord& r) {
                        const Verdict* v = stream_of(r, m);
                        return v ? value_of(*v, m) : std::nan("");
                      }});
  }
  for (size_t k = 0; k < series.size(); ++k) {
    const Series& se = series[k];
    std::ostringstream pts;
    pts << std::fixed << std::setprecision(1);
    for (const FrameRecord* r : recs)
      if (const double v = se.get(*r); !std::isnan(v)) pts << X(r->timestamp) << "," << Y(v) << " ";
    s << "<polyline fill='none' stroke='" << se.color << "' stroke-width='" << se.width << "' points='"
      << pts.str() << "'/>\n";
    s << "<line x1='" << W - R + 40 << "' x2='" << W - R + 60 << "' y1='" << T + 12 + 16 * k << "' y2='"
      << T + 12 + 16 * k << "' stroke='" << se.color << "' stroke-width='" << se.width << "'/><text x='"
      << W - R + 64 << "' y='" << T + 16 + 16 * k << "' font-size='11'>" << xml_escape(se.name)
      << "</text>\n";
  }
  s << "</svg>\n";
  return s.str();
}

}  // namespace

std::string render_html(const Json& report, const std::vector<FrameRecord>& records) {
  const Json& p = report.at("protocol");
  const std::string title = p.at("title").get<std::string>();
  std::ostringstream s;
  s << "<!DOCTYPE html>\n<html lang='en'><head><meta charset='utf-8'><title>" << xml_escape(title)
    << "</"
       "title>\n<style>body{font-family:sans-serif;margin:2em;max-width:1200px}table{border-collapse:"
       "collapse;"
       "margin:0.5em 0 1.5em}th,td{border:1px solid #ccc;padding:3px 7px;text-align:right;font-size:13px}"
       "td.l{text-align:left}th{background:#f3f3f3}</style></head><body>\n";
  s << "<h1>" << xml_escape(title) << "</h1>\n<p>Ground truth: stage <code>"
    << xml_escape(p.at("truth_stage").get<std::string>()) << "</code>, Unsafe below "
    << num(p.at("truth_threshold")) << " s. Frames: " << num(report.at("frames"))
    << ". Labels are recomputed from scene values at each threshold (Unsafe when below). TTC error on frames "
       "whose "
       "true TTC is finite and below "
    << num(p.at("max_ttc_s")) << " s.</p>\n";
  for (const Json& g : report.at("results")) {
    const std::string scene = g.at("scene").get<std::string>();
    s << "<h2>" << xml_escape(scene) << "</h2>\n";
    if (const std::string u = truth_unknown_line(g); !u.empty()) s << "<p>" << xml_escape(u) << "</p>\n";
    s << "<h3>All metrics</h3>\n"
      << html_table(summary_table(g, p.at("thresholds").get<std::vector<double>>()))
      << "<h3>Safe / Unsafe</h3>\n"
      << html_table(threshold_table(g));
    s << "<h3>TTC error</h3>\n" << html_table(error_table(g, p.at("max_ttc_s").get<double>()));
    std::vector<const FrameRecord*> recs;
    for (const FrameRecord& r : records)
      if (r.scene == scene) recs.push_back(&r);
    if (!recs.empty()) s << "<h3>Scene TTC over time</h3>\n" << svg_plot(scene, recs, report);
  }
  s << "<h2>Notes</h2>\n<ul>\n";
  for (const std::string& n : notes_of(report)) s << "<li>" << xml_escape(n) << "</li>\n";
  s << "</ul>\n</body></html>\n";
  return s.str();
}

}  // namespace hf::eval
