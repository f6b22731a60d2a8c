// Sink writing one JSON line per frame, plus per-object and per-scene CSV tables.
#pragma once

#include <map>
#include <string>
#include <vector>

#include "hazardforge/atomic_file.hpp"
#include "hazardforge/stage.hpp"

namespace hf::sink {

// Ports: in `records` (multi, any type). No outputs.
// Each frame becomes one line {"frame": i, "timestamp": t, "<producer>": <packet JSON>, ...} keyed by the
// producer the host reports for each packet (the stream, e.g. "ttc.risk"), flushed at once, so an interrupted
// run keeps every line written. With `csv`, objects.csv gets one row per ObjectStates object and one column
// per RiskAssessment stream (named by the assessment's metric, i.e. its node id; that object's value);
// scenes.csv one row per frame with each metric's scene value, label and critical track. Non-finite numbers:
// JSON null / empty CSV cell. Timestamps: the frame's stream time as the host reports it. Params: file, csv,
// objects_file, scenes_file.
class JsonlSink : public Stage {
 public:
  static ComponentInfo describe();
  void open(StageContext& ctx) override;
  void process(StageContext& ctx, const Inputs& in, Outputs& out) override;
  void finish(StageContext& ctx, Outputs& out) override;

 private:
  // A CSV table whose risk columns grow as new metric streams appear; rows are kept so the file can be
  // rewritten (atomically) with the wider header when that happens.
  class CsvTable {
   public:
    // metric -> one value per suffix, in the order the metrics arrived.
    using MetricValues = std::vector<std::pair<std::string, std::vector<std::string>>>;
    // Each metric gets one column per suffix ("" -> "<metric>", "_label" -> "<metric>_label").
    void open(const std::filesystem::path& file, std::vector<std::string> fixed_columns,
              std::vector<std::string> metric_suffixes);
    // Appends a row (fixed values + metric -> one value per suffix); new metrics widen the table.
    void add(std::vector<std::string> fixed, MetricValues metric_values);
    void close();

   private:
    std::string header() const;
    std::string row(size_t i) const;
    void rewrite();
    std::filesystem::path file_;
    RecordFile out_;
    std::vector<std::string> fixed_cols_, suffixes_, metrics_;
    std::vector<std::pair<std::vector<std::string>, MetricValues>> rows_;
  };

  std::filesystem::path file_;
  RecordFile out_;
  bool csv_ = true;
  CsvTable objects_, scenes_;
  int64_t lines_ = 0;
};

// RFC 4180 quoting when the value holds a comma, quote or line break.
std::string csv_escape(const std::string& v);
// Shortest round-trip-ish text of a number; "" when not finite.
std::string csv_number(double v);

}  // namespace hf::sink
