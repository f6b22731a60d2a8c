// Sink that scores risk-metric streams against the ground-truth metric and writes the evaluation report.
#pragma once

#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include "evaluation_report.hpp"
#include "hazardforge/atomic_file.hpp"
#include "hazardforge/stage.hpp"

namespace hf {

// Sink "evaluation".
// Ports: truth (RiskAssessment, from risk_metric/ground_truth), estimates (RiskAssessment, multi: one stream
// per metric/detector combination, each labelled by its producer node id), frames (Frame, optional: scene
// name from Frame::origin, or the `scene` param). A frame is recorded when the truth and at least one
// estimate arrive for it; its time is the frame's timestamp; frames whose true scene value is unknown (NaN)
// are recorded but not scored. With compare [lead], each estimate also records its value for the truth's
// critical object (same track id). Writes below <output_dir>/<dir>: per_frame.jsonl (one record per frame,
// appended as frames arrive), and at finish report.json (with a flat `summary` of rows per scene, metric and
// threshold), report.md and report.html (self-contained, inline SVG), each written atomically.
// Params: dir, thresholds, max_ttc_s, plot_max_s, scene, compare, title.
class EvaluationSink : public Stage {
 public:
  static ComponentInfo describe();
  void open(StageContext& ctx) override;
  void process(StageContext& ctx, const Inputs& in, Outputs& out) override;
  void finish(StageContext& ctx, Outputs& out) override;

 private:
  std::filesystem::path dir_;
  eval::Options options_;
  std::string scene_;  // fixed scene name, empty = from the frames
  bool lead_ = false;  // "lead" comparison: record each stream's value for the truth's critical object
  std::vector<eval::FrameRecord> records_;
  RecordFile jsonl_;
};

}  // namespace hf
