// `hazardforge bench`: the whole graph's frames/s against the detector's bare forward() on the same frames,
// per-stage median latency, medians over repeated runs in one process on the same machine.
#include <algorithm>
#include <iomanip>
#include <iostream>
#include <sstream>

#include "hazardforge/core/commands.hpp"

namespace hf::core {

namespace {

struct Sample {
  double graph_fps = 0;
  std::map<std::string, double> stage_ms;                 // node -> median ms per frame
  std::map<std::string, std::map<std::string, double>> inner_ms;  // node -> label -> median ms
};

Sample summarize(const RunResult& r) {
  Sample s;
  s.graph_fps = r.wall_s > 0 ? static_cast<double>(r.frames) / r.wall_s : 0;
  for (const NodeTiming& t : r.timings) {
    s.stage_ms[t.id] = median(t.process_s) * 1e3;
    for (const auto& [label, v] : t.inner_s) s.inner_ms[t.id][label] = median(v) * 1e3;
  }
  return s;
}

}  // namespace

int cmd_bench(Host& host, const CommonOptions& o, const BenchOptions& b) {
  GraphConfig cfg;
  Graph g;
  try {
    g = load_graph(host, o.config, o.overrides, &cfg);
  } catch (const Error& e) {
    std::cerr << e.what() << "\n";
    return 1;
  }
  std::string source, detector = b.detector_node;
  for (const NodeSpec& n : g.nodes) {
    if (n.component->info.is_source) source = n.id;
    if (detector.empty() && n.component->info.kind == kind::kDetector) detector = n.id;
  }
  const NodeSpec* det = g.node(detector);
  if (!det) {
    std::cerr << "error: " << o.config << ": no detector node" << (detector.empty() ? "" : " '" + detector + "'")
              << " to benchmark against (use --detector NODE)\n";
    return 1;
  }
  const std::filesystem::path out_dir =
      o.output_dir.empty() ? std::filesystem::path("runs") / ("bench-" + g.name) : std::filesystem::path(o.output_dir);
  std::vector<Sample> full, bare;
  for (int rep = 0; rep < b.repeat; ++rep) {
    for (int which = 0; which < 2; ++which) {
      RunRequest req{o.config, o.overrides, out_dir / ((which == 0 ? "graph-" : "bare-") + std::to_string(rep)),
                     b.max_frames, false, true, o.argv, o.interrupt, {}};
      if (which == 1) req.only_nodes = {source, detector};
      RunOutcome out = run_config(host, req);
      if (out.exit_code != 0) {
        std::cerr << out.message << "\n";
        return out.exit_code;
      }
      (which == 0 ? full : bare).push_back(summarize(*out.result));
      std::cerr << "bench: repetition " << rep + 1 << "/" << b.repeat << (which == 0 ? " whole graph" : " bare detector")
                << " done\n";
    }
  }
  auto med = [](const std::vector<Sample>& v, auto get) {
    std::vector<double> x;
    for (const Sample& s : v) x.push_back(get(s));
    return median(x);
  };
  const double graph_fps = med(full, [](const Sample& s) { return s.graph_fps; });
  const double forward_ms = med(bare, [&](const Sample& s) {
    auto it = s.inner_ms.find(detector);
    if (it != s.inner_ms.end() && it->second.count("forward")) return it->second.at("forward");
    return s.stage_ms.at(detector);
  });
  const double bare_fps = forward_ms > 0 ? 1e3 / forward_ms : 0;
  const double forward_in_graph_ms = med(full, [&](const Sample& s) {
    auto it = s.inner_ms.find(detector);
    return (it != s.inner_ms.end() && it->second.count("forward")) ? it->second.at("forward") : s.stage_ms.at(detector);
  });

  std::ostringstream md;
  md << std::fixed << std::setprecision(2);
  md << "# Benchmark: " << g.name << "\n\n";
  md << "Config `" << o.config << "`";
  for (const auto& s : o.overrides) md << " --set " << s;
  md << ", " << b.repeat << " repetitions (medians), "
     << (b.max_frames >= 0 ? std::to_string(b.max_frames) + " frames each" : std::string("all frames")) << ".\n\n";
  md << "| measure | value |\n|---|---:|\n";
  md << "| whole graph frames/s | " << graph_fps << " |\n";
  md << "| bare detector forward() frames/s (node `" << detector << "`) | " << bare_fps << " |\n";
  md << "| ratio graph / bare forward | " << (bare_fps > 0 ? graph_fps / bare_fps : 0) << " |\n";
  double other_ms = 0;
  md << "\n| node | stage | median ms/frame | inner steps (median ms) |\n|---|---|---:|---|\n";
  for (const NodeSpec& n : g.nodes) {
    const double ms = med(full, [&](const Sample& s) { return s.stage_ms.count(n.id) ? s.stage_ms.at(n.id) : 0.0; });
    std::string inner;
    if (!full.empty() && full.front().inner_ms.count(n.id)) {
      for (const auto& [label, v0] : full.front().inner_ms.at(n.id)) {
        (void)v0;
        std::ostringstream s;
        s << std::fixed << std::setprecision(2) << label << " "
          << med(full, [&](const Sample& x) {
               auto it = x.inner_ms.find(n.id);
               return (it != x.inner_ms.end() && it->second.count(label)) ? it->second.at(label) : 0.0;
             });
        inner += (inner.empty() ? "" : ", ") + s.str();
      }
    }
    md << "| " << n.id << " | " << n.component->info.name << " | " << ms << " | " << inner << " |\n";
    if (n.id != detector) other_ms += ms;
  }
  const double det_total_ms =
      med(full, [&](const Sample& s) { return s.stage_ms.count(detector) ? s.stage_ms.at(detector) : 0.0; });
  other_ms += std::max(0.0, det_total_ms - forward_in_graph_ms);  // the detector's own pre/post-processing
  md << "\nEverything except inference (other stages + detector pre/post-processing): " << other_ms
     << " ms/frame = " << (forward_in_graph_ms > 0 ? 100.0 * other_ms / forward_in_graph_ms : 0)
     << "% of the detector's forward() (" << forward_in_graph_ms << " ms in the graph run).\n";

  Json j = {{"config", o.config},
            {"overrides", o.overrides},
            {"repeat", b.repeat},
            {"graph_fps", graph_fps},
            {"bare_forward_fps", bare_fps},
            {"ratio", bare_fps > 0 ? graph_fps / bare_fps : 0},
            {"forward_ms_in_graph", forward_in_graph_ms},
            {"non_inference_ms", other_ms}};
  try {
    std::filesystem::create_directories(out_dir);
    write_file_atomic(out_dir / "bench.md", md.str());
    write_file_atomic(out_dir / "bench.json", j.dump(2));
  } catch (const Error& e) {
    std::cerr << "error: " << e.what() << "\n";
    return 1;
  }
  std::cout << md.str();
  return 0;
}

}  // namespace hf::core
