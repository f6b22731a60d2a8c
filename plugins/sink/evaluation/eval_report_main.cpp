// hf_eval_report: recomputes an evaluation report from one or more per_frame.jsonl files -- to pool the runs
// of an experiment (e.g. one KITTI sequence per run) into one report with per-scene and all-scene tables, or
// to re-score a run at other thresholds.
#include <CLI/CLI.hpp>

#include <filesystem>
#include <fstream>
#include <iostream>
#include <sstream>

#include "evaluation_report.hpp"
#include "hazardforge/atomic_file.hpp"
#include "hazardforge/json_text.hpp"

namespace fs = std::filesystem;

int main(int argc, char** argv) {
  CLI::App app{
      "Recompute an evaluation report (report.json/.md/.html) from per_frame.jsonl files of the evaluation "
      "sink. "
      "Records keep their scene names, so files of different scenes give per-scene tables plus one over all "
      "scenes. The protocol (thresholds, max TTC, comparison modes, title) comes from the report.json next "
      "to "
      "the first file unless given here."};
  std::vector<std::string> inputs;
  std::string out_dir, title, compare;
  std::vector<double> thresholds;
  double max_ttc = -1, plot_max = -1;
  app.add_option("records", inputs, "per_frame.jsonl files")->required()->check(CLI::ExistingFile);
  app.add_option("-o,--output", out_dir, "folder for report.json, report.md, report.html, per_frame.jsonl")
      ->required();
  app.add_option("--thresholds", thresholds, "TTC thresholds (s)")->delimiter(',');
  app.add_option("--max-ttc", max_ttc, "TTC error only where the true TTC is finite and below this (s)");
  app.add_option("--plot-max", plot_max, "upper end of the plots' y axis (s)");
  app.add_option("--compare", compare, "comparison modes, comma-separated: scene, lead");
  app.add_option("--title", title, "report title");
  CLI11_PARSE(app, argc, argv);
  try {
    hf::eval::Options o;
    const fs::path first_report = fs::path(inputs.front()).parent_path() / "report.json";
    if (fs::exists(first_report)) {
      std::ifstream in(first_report);
      const hf::Json j = hf::Json::parse(in);
      if (!j.contains("protocol")) throw hf::Error("'" + first_report.string() + "' has no 'protocol'");
      o = hf::eval::options_from_json(j.at("protocol"));
    }
    if (!thresholds.empty()) o.thresholds = thresholds;
    if (max_ttc >= 0) o.max_ttc_s = max_ttc;
    if (plot_max > 0) o.plot_max_s = plot_max;
    if (!title.empty()) o.title = title;
    if (!compare.empty()) {
      o.compare.clear();
      std::stringstream ss(compare);
      for (std::string m; std::getline(ss, m, ',');) o.compare.push_back(m);
    }
    std::vector<hf::eval::FrameRecord> records;
    std::string jsonl;
    for (const std::string& f : inputs) {
      auto r = hf::eval::read_records(f);
      for (auto& rec : r) {
        jsonl += hf::json_text(hf::eval::to_json(rec)) + "\n";
        records.push_back(std::move(rec));
      }
    }
    const hf::Json report = hf::eval::evaluate(records, o);
    fs::create_directories(out_dir);
    hf::write_file_atomic(fs::path(out_dir) / "per_frame.jsonl", jsonl);
    hf::write_file_atomic(fs::path(out_dir) / "report.json", hf::json_text(report, 2) + "\n");
    hf::write_file_atomic(fs::path(out_dir) / "report.md", hf::eval::render_markdown(report));
    hf::write_file_atomic(fs::path(out_dir) / "report.html", hf::eval::render_html(report, records));
    std::cerr << records.size() << " records from " << inputs.size() << " files -> " << out_dir << "\n";
  } catch (const std::exception& e) {
    std::cerr << "hf_eval_report: error: " << e.what() << "\n";
    return 1;
  }
  return 0;
}
