// Evaluation sink: collects (truth, estimates) per frame, appends them to per_frame.jsonl, writes the
// reports.
#include "evaluation_sink.hpp"

#include <algorithm>
#include <cmath>

#include "hazardforge/atomic_file.hpp"
#include "hazardforge/json_text.hpp"
#include "hazardforge/output_path.hpp"

namespace hf {

ComponentInfo EvaluationSink::describe() {
  ComponentInfo i;
  i.name = "evaluation";
  i.kind = kind::kSink;
  i.summary = "scores risk-metric streams against the ground-truth metric (accuracy, confusion, TTC error)";
  i.doc =
      "Per metric stream and per scene, at each TTC threshold: frames, correct, incorrect, accuracy, the "
      "confusion matrix (TP = both Unsafe), Unsafe precision and recall, balanced accuracy and the "
      "always-Safe "
      "baseline; labels of truth and estimate are recomputed from their scene values. Higher-is-riskier "
      "metrics (DRAC) are scored once with their own label. TTC error: median absolute and relative error of "
      "the scene TTC on frames whose true TTC is finite and below max_ttc_s. Frames with an unknown (NaN) "
      "true "
      "scene value are not scored. compare: lead scores each stream's value for the truth's critical object "
      "(lidar_ttc's lead vehicle). report.json carries a flat `summary` for `hazardforge experiment`. See "
      "docs/evaluation.md.";
  i.inputs = {
      port<RiskAssessment>("truth", "reference assessment (ground_truth, label_ttc, lidar_ttc)"),
      multi(port<RiskAssessment>("estimates", "assessments to score, labelled by their producer node")),
      optional(port<Frame>("frames", "for the scene name (Frame.origin.scene) of each frame"))};
  i.params = {
      ParamSpec::string("dir", "evaluation").describe("folder below the run's output folder"),
      ParamSpec::number_list("thresholds", {1.5, 2.0, 3.0}).describe("TTC thresholds (s): Unsafe when below"),
      ParamSpec::number("max_ttc_s", 10.0)
          .range(0, 1e6)
          .describe("TTC error only on frames whose true scene TTC is finite and below this (s)"),
      ParamSpec::number("plot_max_s", 12.0)
          .range(0.1, 1e6)
          .describe("upper end of the TTC plots' y axis (s)"),
      ParamSpec::string("scene", "")
          .describe("scene name of every frame (e.g. a KITTI sequence per run); empty = from the frames"),
      ParamSpec::string_list("compare", {"scene"})
          .describe("scene = score each stream's scene value; lead = its value for the truth's critical "
                    "object (same track id; metric '<stream>@lead'); both = one metric per mode"),
      ParamSpec::string("title", "HazardForge evaluation").describe("report title"),
  };
  return i;
}

void EvaluationSink::open(StageContext& ctx) {
  const Params& p = ctx.params();
  options_.thresholds = p.get_doubles("thresholds");
  if (options_.thresholds.empty())
    throw Error("stage 'evaluation': 'thresholds' must list at least one value");
  options_.max_ttc_s = p.get_double("max_ttc_s");
  options_.plot_max_s = p.get_double("plot_max_s");
  options_.title = p.get_string("title");
  scene_ = p.get_string("scene");
  options_.compare = p.get_strings("compare");
  if (options_.compare.empty()) throw Error("stage 'evaluation': 'compare' must list scene and/or lead");
  for (const std::string& m : options_.compare)
    if (m != "scene" && m != "lead")
      throw Error("stage 'evaluation': parameter 'compare': '" + m + "' is not one of scene, lead");
  lead_ = std::find(options_.compare.begin(), options_.compare.end(), "lead") != options_.compare.end();
  dir_ = output_param_path(ctx, "dir", /*is_dir=*/true);
  std::error_code ec;
  std::filesystem::create_directories(dir_, ec);
  if (ec) throw Error("cannot create '" + dir_.string() + "': " + ec.message());
  records_.clear();
  jsonl_.open(dir_ / "per_frame.jsonl", RecordFile::Mode::kTruncate);
}

void EvaluationSink::process(StageContext& ctx, const Inputs& in, Outputs&) {
  const RiskAssessment& truth = in.require<RiskAssessment>("truth");
  eval::FrameRecord r;
  r.frame = truth.frame_index;
  r.timestamp = ctx.timestamp();
  r.truth = eval::verdict_of(truth);
  r.scene = "all";
  if (const Frame* f = in.get<Frame>("frames")) {
    r.timestamp = f->timestamp;
    if (!f->origin.scene.empty()) r.scene = f->origin.scene;
  }
  if (!scene_.empty()) r.scene = scene_;
  const std::vector<const Packet*> packets = in.packets("estimates");
  const std::vector<std::string> producers = in.producers("estimates");
  for (size_t k = 0; k < packets.size(); ++k) {
    if (!packets[k] || packets[k]->empty()) continue;
    const RiskAssessment& e = packets[k]->get<RiskAssessment>();
    const std::string label = k < producers.size() && !producers[k].empty() ? producers[k] : e.metric;
    if (r.estimate(label))
      throw Error("frame " + std::to_string(r.frame) + ": two estimate packets from '" + label + "'");
    eval::Verdict v = eval::verdict_of(e);
    if (lead_) {
      // The stream's own value for the object the truth calls critical; unknown when it has none.
      v.lead_value = std::nan("");
      if (truth.critical_track >= 0)
        for (const ObjectRisk& o : e.objects)
          if (o.track_id == truth.critical_track) v.lead_value = o.value;
    }
    r.estimates.emplace_back(label, std::move(v));
  }
  if (r.estimates.empty()) return;
  jsonl_.write(json_text(eval::to_json(r)) + "\n");
  records_.push_back(std::move(r));
}

void EvaluationSink::finish(StageContext& ctx, Outputs&) {
  jsonl_.close();
  const Json report = eval::evaluate(records_, options_);
  write_file_atomic(dir_ / "report.json", json_text(report, 2) + "\n");
  write_file_atomic(dir_ / "report.md", eval::render_markdown(report));
  write_file_atomic(dir_ / "report.html", eval::render_html(report, records_));
  ctx.log(LogLevel::kInfo,
          "evaluation of " + std::to_string(records_.size()) + " frames written to " + dir_.string());
}

}  // namespace hf
