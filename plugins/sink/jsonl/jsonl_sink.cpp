// JsonlSink: per-frame JSON lines, objects.csv and scenes.csv, each line flushed as soon as it is complete.
#include "jsonl_sink.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <set>

#include "hazardforge/json_text.hpp"
#include "hazardforge/output_path.hpp"

namespace hf::sink {

namespace fs = std::filesystem;

std::string csv_escape(const std::string& v) {
  if (v.find_first_of(",\"\r\n") == std::string::npos) return v;
  std::string o = "\"";
  for (char c : v) {
    if (c == '"') o += '"';
    o += c;
  }
  return o + "\"";
}

std::string csv_number(double v) {
  if (!std::isfinite(v)) return "";
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.9g", v);
  return buf;
}

namespace {
std::string opt_number(const std::optional<double>& v) {
  return v ? csv_number(*v) : "";
}

}  // namespace

// ---- CsvTable
// ----------------------------------------------------------------------------------------------------

void JsonlSink::CsvTable::open(const fs::path& file, std::vector<std::string> fixed_columns,
                               std::vector<std::string> metric_suffixes) {
  file_ = file;
  fixed_cols_ = std::move(fixed_columns);
  suffixes_ = std::move(metric_suffixes);
  out_.open(file_, RecordFile::Mode::kTruncate);
  out_.write(header());
}

std::string JsonlSink::CsvTable::header() const {
  std::string line;
  for (const auto& c : fixed_cols_) line += (line.empty() ? "" : ",") + csv_escape(c);
  for (const auto& m : metrics_)
    for (const auto& s : suffixes_) line += "," + csv_escape(m + s);
  return line + '\n';
}

std::string JsonlSink::CsvTable::row(size_t i) const {
  const auto& [fixed, metric_values] = rows_[i];
  std::string line;
  for (size_t k = 0; k < fixed.size(); ++k) line += (k ? "," : "") + csv_escape(fixed[k]);
  for (const auto& m : metrics_) {
    auto it = std::find_if(metric_values.begin(), metric_values.end(),
                           [&](const auto& mv) { return mv.first == m; });
    for (size_t s = 0; s < suffixes_.size(); ++s)
      line += "," + (it == metric_values.end() ? std::string() : csv_escape(it->second[s]));
  }
  return line + '\n';
}

void JsonlSink::CsvTable::rewrite() {
  // Replaced atomically: readers see the old table or the new one, never a half-written one.
  out_.close();
  std::string text = header();
  for (size_t i = 0; i < rows_.size(); ++i) text += row(i);
  write_file_atomic(file_, text);
  out_.open(file_, RecordFile::Mode::kAppend);
}

void JsonlSink::CsvTable::add(std::vector<std::string> fixed, MetricValues values) {
  bool widened = false;
  for (const auto& [m, v] : values)
    if (std::find(metrics_.begin(), metrics_.end(), m) == metrics_.end()) {
      metrics_.push_back(m);
      widened = true;
    }
  rows_.emplace_back(std::move(fixed), std::move(values));
  if (widened) {
    rewrite();
  } else {
    out_.write(row(rows_.size() - 1));
  }
}

void JsonlSink::CsvTable::close() {
  out_.close();
}

// ---- JsonlSink
// ---------------------------------------------------------------------------------------------------

ComponentInfo JsonlSink::describe() {
  ComponentInfo i;
  i.name = "jsonl";
  i.kind = kind::kSink;
  i.summary = "one JSON line per frame (keyed by producer) plus objects.csv and scenes.csv";
  i.doc =
      "Writes {\"frame\", \"timestamp\", <producer>: <packet JSON>...} per frame, flushed line by line. With "
      "csv, "
      "objects.csv has one row per object of every ObjectStates stream and a column per RiskAssessment "
      "stream "
      "(the object's value); scenes.csv has one row per frame with <metric> (scene value), <metric>_label "
      "and "
      "<metric>_critical_track. Non-finite numbers are JSON null / empty cells.";
  i.inputs = {multi(any_port("records", "any streams to record; keys are the producing node ids"))};
  i.params = {
      ParamSpec::string("file", "frames.jsonl").describe("JSON lines file, relative to the run folder"),
      ParamSpec::boolean("csv", true).describe("also write the per-object and per-scene CSV tables"),
      ParamSpec::string("objects_file", "objects.csv").describe("per-object CSV, relative to the run folder"),
      ParamSpec::string("scenes_file", "scenes.csv")
          .describe("per-frame metric CSV, relative to the run folder"),
  };
  return i;
}

void JsonlSink::open(StageContext& ctx) {
  const Params& p = ctx.params();
  file_ = output_param_path(ctx, "file");
  out_.open(file_, RecordFile::Mode::kTruncate);
  csv_ = p.get_bool("csv");
  if (csv_) {
    objects_.open(
        output_param_path(ctx, "objects_file"),
        {"frame", "timestamp", "states", "track_id", "label", "score", "box_x", "box_y", "box_w", "box_h",
         "distance_m", "lateral_m", "vx_mps", "vy_mps", "speed_mps", "heading_rad", "in_path"},
        {""});
    scenes_.open(output_param_path(ctx, "scenes_file"), {"frame", "timestamp"},
                 {"", "_label", "_critical_track"});
  }
}

void JsonlSink::process(StageContext& ctx, const Inputs& in, Outputs& /*out*/) {
  const auto packets = in.packets("records");
  const auto producers = in.producers("records");
  Json line = {{"frame", ctx.frame_index()}, {"timestamp", finite_or_null(ctx.timestamp())}};
  std::vector<std::pair<std::string, const ObjectStates*>> states;
  std::vector<std::pair<std::string, const RiskAssessment*>> risks;
  for (size_t i = 0; i < packets.size(); ++i) {
    const Packet* p = packets[i];
    if (!p || p->empty()) continue;
    std::string key = i < producers.size() ? producers[i] : "stream" + std::to_string(i);
    // Two streams of one producer (different ports) must not overwrite each other.
    for (int n = 2; line.contains(key); ++n)
      key = (i < producers.size() ? producers[i] : "stream") + "#" + std::to_string(n);
    line[key] = p->serializable()
                    ? p->as_json()
                    : Json{{"type", p->type_name()}, {"version", p->type_version()}, {"serializable", false}};
    if (p->is<ObjectStates>()) states.emplace_back(key, &p->get<ObjectStates>());
    if (p->is<RiskAssessment>()) {
      // CSV columns use the metric's node id ("ttc") when it has one; the stream key otherwise.
      const RiskAssessment& r = p->get<RiskAssessment>();
      const bool taken =
          std::any_of(risks.begin(), risks.end(), [&](const auto& x) { return x.first == r.metric; });
      risks.emplace_back(r.metric.empty() || taken ? key : r.metric, &r);
    }
  }
  // Invalid UTF-8 in free text (dataset descriptions) must not cost the line.
  try {
    out_.write(json_text(line) + '\n');
  } catch (const Error& e) {
    throw Error(std::string(e.what()) + " (frame " + std::to_string(ctx.frame_index()) + ")");
  }
  ++lines_;
  if (!csv_) return;

  const std::string frame = std::to_string(ctx.frame_index()), ts = csv_number(ctx.timestamp());
  for (const auto& [name, st] : states) {
    for (const ObjectState& o : st->objects) {
      CsvTable::MetricValues values;
      for (const auto& [metric, r] : risks) {
        std::string v;
        for (const ObjectRisk& orisk : r->objects)
          if (orisk.track_id == o.track_id) v = csv_number(orisk.value);
        values.emplace_back(metric, std::vector<std::string>{v});
      }
      objects_.add(
          {frame, ts, name, std::to_string(o.track_id), o.label, csv_number(o.score), csv_number(o.box.x),
           csv_number(o.box.y), csv_number(o.box.width), csv_number(o.box.height), csv_number(o.distance_m),
           csv_number(o.lateral_m), o.velocity_rel ? csv_number((*o.velocity_rel)[0]) : "",
           o.velocity_rel ? csv_number((*o.velocity_rel)[1]) : "", opt_number(o.speed_mps),
           opt_number(o.heading_rad), o.in_path ? "1" : "0"},
          std::move(values));
    }
  }
  // One row per frame, also when no metric reported (its cells stay empty).
  CsvTable::MetricValues values;
  for (const auto& [metric, r] : risks)
    values.emplace_back(
        metric, std::vector<std::string>{csv_number(r->scene_value), to_string(r->label),
                                         r->critical_track >= 0 ? std::to_string(r->critical_track) : ""});
  scenes_.add({frame, ts}, std::move(values));
}

void JsonlSink::finish(StageContext& ctx, Outputs& /*out*/) {
  out_.close();
  objects_.close();
  scenes_.close();
  ctx.log(LogLevel::kInfo, "wrote " + std::to_string(lines_) + " lines to " + file_.string());
}

}  // namespace hf::sink
