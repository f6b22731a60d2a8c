// Evaluation of risk-metric streams against a ground-truth stream: per-frame records, the metrics computed
// from them, and the Markdown / HTML renderings. Pure functions, so a report can be recomputed from its
// records.
#pragma once

#include <map>
#include <optional>
#include <string>
#include <vector>

#include "hazardforge/error.hpp"
#include "hazardforge/types.hpp"

namespace hf::eval {

// One stream's verdict on one frame (scene value and what it needs to be re-thresholded).
struct Verdict {
  std::string stage;
  std::string unit;
  bool lower_is_riskier = true;
  double threshold = 1.5;
  double scene_value = kInf;
  int64_t critical = -1;
  // Estimates only, with the "lead" comparison: this stream's value for the truth's critical object (same
  // track id), NaN when it has no such object or the truth has none.
  std::optional<double> lead_value;
  // A metric whose label rule is an interval bound (RiskAssessment::label_rule riskier_bound / safer_bound):
  // the rule and the number it compares with a threshold (hf::deciding_value). The scene comparison labels
  // the frame by it at every threshold; the TTC error stays on scene_value.
  std::string label_rule = "value";
  std::optional<double> decision_value;
  double deciding() const { return decision_value.value_or(scene_value); }
};

struct FrameRecord {
  int64_t frame = 0;
  double timestamp = 0.0;
  std::string scene;
  Verdict truth;
  std::vector<std::pair<std::string, Verdict>> estimates;  // (stream label, verdict) in input order

  const Verdict* estimate(const std::string& label) const;
};

struct Options {
  std::vector<double> thresholds{1.5, 2.0, 3.0};
  double max_ttc_s = 10.0;   // TTC error only on frames whose true TTC is finite and below this
  double plot_max_s = 12.0;  // y range of the plots
  std::string title = "HazardForge evaluation";
  // What of each estimate is compared with the truth: "scene" = its scene value; "lead" = its value for the
  // truth's critical object (metric named "<stream>@lead"). Each listed mode adds one metric per stream.
  std::vector<std::string> compare{"scene"};
};

// Name of the metric a stream gets under a comparison mode.
std::string metric_name(const std::string& stream, const std::string& mode);

Verdict verdict_of(const RiskAssessment& r);

// JSON line form. Non-finite scene values are written as the strings "inf" / "-inf" (JSON has no infinity and
// the difference matters when re-thresholding).
Json to_json(const FrameRecord& r);
// Throws hf::Error naming `where` (e.g. "per_frame.jsonl:12") and the field on a malformed record.
FrameRecord record_from_json(const Json& j, const std::string& where);
std::vector<FrameRecord> read_records(const std::string& jsonl_path);

Json options_to_json(const Options& o);
Options options_from_json(const Json& j);

// The report: protocol, metric list, scenes, per (scene, metric) the confusion tables at each threshold and
// the TTC error, and `summary`, one flat row per (scene, metric, threshold) for side-by-side comparisons.
// Frames whose true scene value is unknown (NaN) are not scored; each group counts them. Depends only on the
// records and the options.
Json evaluate(const std::vector<FrameRecord>& records, const Options& options);

std::string render_markdown(const Json& report);
// Self-contained HTML (inline CSS and SVG): the report's tables and a TTC-over-time plot per scene.
std::string render_html(const Json& report, const std::vector<FrameRecord>& records);

double median(std::vector<double> v);

}  // namespace hf::eval
