// `hazardforge bench`: the whole graph's frames/s (whole run and steady state) against the detector's bare
// forward() on the same frames, per-stage median latency and the non-inference share, medians over repeated
// interleaved runs in one process on the same machine.
#include <sys/resource.h>

#include <algorithm>
#include <chrono>
#include <fstream>
#include <iomanip>
#include <iostream>
#include <mutex>
#include <sstream>
#include <thread>

#include "hazardforge/apps/commands.hpp"
#include "hazardforge/core/manifest.hpp"
#include "hazardforge/json_text.hpp"

namespace hf::apps {

using namespace hf::core;  // the host's public interface

namespace {

using Clock = std::chrono::steady_clock;

// Frames every node must have finished before the steady-state clock starts: the first frame carries one-off
// costs (first inference allocates, caches warm up, the sink may buffer frames to find the rate) and the
// pipeline is still filling.
constexpr int64_t kWarmupFrames = 2;

struct Sample {
  int64_t frames = 0;
  double wall_s = 0;          // the scheduler's run time (after open(), through every finish())
  double graph_fps = 0;       // frames / wall_s
  double steady_fps = 0;      // (frames - warm-up) / (last frame done - warm-up frames done)
  double finish_s = 0;        // last frame done -> run returned: end-of-stream finish() (encoder flush, files)
  double cpu_ms_per_frame = 0;  // this process + waited child processes (encoders), first frame -> end
  std::map<std::string, double> stage_ms;                         // node -> median ms per frame
  std::map<std::string, double> stage_cpu_ms;                     // node -> median CPU ms of its own thread
  std::map<std::string, std::map<std::string, double>> inner_ms;  // node -> label -> median ms
};

double cpu_seconds() {
  double s = 0;
  for (int who : {RUSAGE_SELF, RUSAGE_CHILDREN}) {
    rusage u{};
    getrusage(who, &u);
    s += static_cast<double>(u.ru_utime.tv_sec + u.ru_stime.tv_sec) +
         static_cast<double>(u.ru_utime.tv_usec + u.ru_stime.tv_usec) * 1e-6;
  }
  return s;
}

std::string load_average() {
  std::ifstream in("/proc/loadavg");
  std::string a, b, c;
  if (!(in >> a >> b >> c)) return "unknown";
  return a + " " + b + " " + c;
}

std::string cpu_model() {
  std::ifstream in("/proc/cpuinfo");
  for (std::string line; std::getline(in, line);)
    if (line.rfind("model name", 0) == 0) {
      const size_t colon = line.find(':');
      if (colon != std::string::npos) return line.substr(line.find_first_not_of(' ', colon + 1));
    }
  return "unknown CPU";
}

// Runs `g` once; progress callbacks (about every 100 ms) give the time at which every node had finished k
// frames, from which the steady-state rate is taken.
Sample run_once(const Graph& g, Host& host, const std::filesystem::path& out, const BenchOptions& b,
                const CommonOptions& o, std::string* error) {
  RunOptions opt;
  opt.output_dir = out;
  opt.max_frames = b.max_frames;
  opt.interrupt = o.interrupt;
  opt.quiet = true;
  std::mutex mu;
  std::vector<std::pair<int64_t, Clock::time_point>> seen;  // (frames done by every node, first seen at)
  double cpu0 = -1;
  opt.on_progress = [&](int64_t done, std::optional<int64_t>) {
    const auto now = Clock::now();
    std::lock_guard lk(mu);
    if (cpu0 < 0) cpu0 = cpu_seconds();
    if (seen.empty() || done > seen.back().first) seen.emplace_back(done, now);
  };
  const RunResult r = run_graph(g, host.registry(), opt);
  const auto end = Clock::now();
  Sample s;
  if (!r.ok() || r.interrupted) {
    for (const auto& e : r.errors) *error += (error->empty() ? "" : "\n") + std::string("error: ") + e;
    if (error->empty()) *error = "interrupted";
    return s;
  }
  s.frames = r.frames;
  s.wall_s = r.wall_s;
  s.graph_fps = r.wall_s > 0 ? static_cast<double>(r.frames) / r.wall_s : 0;
  if (cpu0 >= 0 && r.frames > 0) s.cpu_ms_per_frame = (cpu_seconds() - cpu0) * 1e3 / static_cast<double>(r.frames);
  auto first_at = [&](int64_t k) -> std::optional<Clock::time_point> {
    for (const auto& [done, t] : seen)
      if (done >= k) return t;
    return std::nullopt;
  };
  const int64_t warm = std::min<int64_t>(kWarmupFrames, std::max<int64_t>(r.frames - 1, 0));
  const auto t_warm = first_at(warm), t_last = first_at(r.frames);
  if (warm > 0 && t_warm && t_last && *t_last > *t_warm)
    s.steady_fps = static_cast<double>(r.frames - warm) / std::chrono::duration<double>(*t_last - *t_warm).count();
  if (t_last) s.finish_s = std::chrono::duration<double>(end - *t_last).count();
  for (const NodeTiming& t : r.timings) {
    s.stage_ms[t.id] = median(t.process_s) * 1e3;
    s.stage_cpu_ms[t.id] = median(t.process_cpu_s) * 1e3;
    for (const auto& [label, v] : t.inner_s) s.inner_ms[t.id][label] = median(v) * 1e3;
  }
  return s;
}

}  // namespace

int cmd_bench(Host& host, const CommonOptions& o, const BenchOptions& b) {
  GraphConfig cfg;
  Graph g;
  try {
    g = load_graph(host, o.config, o.overrides, &cfg, true, {}, o.set_base);
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
  for (const Diagnostic& w : g.warnings) std::cerr << w.str() << "\n";
  const Graph bare_graph = g.subgraph({source, detector});
  const std::filesystem::path out_dir =
      o.output_dir.empty() ? std::filesystem::path("runs") / ("bench-" + g.name) : std::filesystem::path(o.output_dir);
  const std::string load_start = load_average();
  std::vector<Sample> full, bare;
  for (int rep = 0; rep < b.repeat; ++rep) {
    for (int which = 0; which < 2; ++which) {
      const std::filesystem::path dir = out_dir / ((which == 0 ? "graph-" : "bare-") + std::to_string(rep));
      std::string error;
      Sample s = run_once(which == 0 ? g : bare_graph, host, dir, b, o, &error);
      if (!error.empty()) {
        std::cerr << error << "\noutputs written so far are kept in " << dir.string() << "\n";
        return o.interrupt && o.interrupt->load() ? 130 : 1;
      }
      (which == 0 ? full : bare).push_back(std::move(s));
      std::cerr << "bench: repetition " << rep + 1 << "/" << b.repeat << (which == 0 ? " whole graph" : " bare detector")
                << " done\n";
    }
  }
  const std::string load_end = load_average();
  auto med = [](const std::vector<Sample>& v, auto get) {
    std::vector<double> x;
    for (const Sample& s : v) x.push_back(get(s));
    return median(x);
  };
  auto forward_of = [&](const Sample& s) {
    auto it = s.inner_ms.find(detector);
    if (it != s.inner_ms.end() && it->second.count("forward")) return it->second.at("forward");
    return s.stage_ms.count(detector) ? s.stage_ms.at(detector) : 0.0;
  };
  const double graph_fps = med(full, [](const Sample& s) { return s.graph_fps; });
  const double steady_fps = med(full, [](const Sample& s) { return s.steady_fps; });
  const double finish_s = med(full, [](const Sample& s) { return s.finish_s; });
  const double forward_ms = med(bare, forward_of);
  const double bare_fps = forward_ms > 0 ? 1e3 / forward_ms : 0;
  const double bare_steady_fps = med(bare, [](const Sample& s) { return s.steady_fps; });
  const double forward_in_graph_ms = med(full, forward_of);
  const double cpu_graph = med(full, [](const Sample& s) { return s.cpu_ms_per_frame; });
  const double cpu_bare = med(bare, [](const Sample& s) { return s.cpu_ms_per_frame; });
  const int64_t frames = full.empty() ? 0 : full.front().frames;
  auto ratio = [&](double x) { return bare_fps > 0 ? x / bare_fps : 0.0; };

  std::ostringstream md;
  md << std::fixed << std::setprecision(2);
  md << "# Benchmark: " << g.name << "\n\n";
  md << "Config `" << o.config << "`";
  for (const auto& s : o.overrides) md << " --set " << s;
  md << ", " << b.repeat << " repetitions (medians; whole-graph and bare-detector runs alternate), " << frames
     << " frames per run.\n";
  md << "Machine: " << std::thread::hardware_concurrency() << " cores, " << cpu_model()
     << "; load average (1/5/15 min) " << load_start << " at the start, " << load_end << " at the end.\n\n";
  md << "| measure | value |\n|---|---:|\n";
  md << "| whole graph frames/s, whole run (frames / wall time, incl. end-of-stream finish()) | " << graph_fps << " |\n";
  md << "| whole graph frames/s, steady state (from frame " << kWarmupFrames
     << " done by every node to the last frame done; excludes warm-up and finish()) | " << steady_fps << " |\n";
  md << "| end-of-stream finish() after the last frame (sink flush), s | " << finish_s << " |\n";
  md << "| bare detector forward() frames/s (1000 / median forward() ms, node `" << detector
     << "` in a source + detector run) | " << bare_fps << " |\n";
  md << "| ratio whole run / bare forward | " << ratio(graph_fps) << " |\n";
  md << "| ratio steady state / bare forward | " << ratio(steady_fps) << " |\n";
  md << "| source + detector run frames/s, steady state | " << bare_steady_fps << " |\n";
  md << "| detector forward() median in the whole-graph run, ms | " << forward_in_graph_ms << " |\n";
  md << "| CPU time per frame, whole graph (process + encoder child processes), ms | " << cpu_graph << " |\n";
  md << "| CPU time per frame, source + detector run, ms | " << cpu_bare << " |\n";
  double other_ms = 0;
  Json stages = Json::object();
  md << "\n| node | stage | median ms/frame | median CPU ms/frame (node thread) | inner steps (median ms) |\n"
        "|---|---|---:|---:|---|\n";
  for (const NodeSpec& n : g.nodes) {
    const double ms = med(full, [&](const Sample& s) { return s.stage_ms.count(n.id) ? s.stage_ms.at(n.id) : 0.0; });
    const double cpu_ms = med(
        full, [&](const Sample& s) { return s.stage_cpu_ms.count(n.id) ? s.stage_cpu_ms.at(n.id) : 0.0; });
    stages[n.id] = {{"stage", n.component->info.name}, {"median_ms", ms}, {"median_thread_cpu_ms", cpu_ms}};
    std::string inner;
    if (!full.empty() && full.front().inner_ms.count(n.id)) {
      for (const auto& entry : full.front().inner_ms.at(n.id)) {
        // A named copy, not a structured binding: clang before 16 cannot capture bindings in lambdas.
        const std::string& label = entry.first;
        const double v = med(full, [&](const Sample& x) {
          auto it = x.inner_ms.find(n.id);
          return (it != x.inner_ms.end() && it->second.count(label)) ? it->second.at(label) : 0.0;
        });
        stages[n.id]["inner_ms"][label] = v;
        std::ostringstream s;
        s << std::fixed << std::setprecision(2) << label << " " << v;
        inner += (inner.empty() ? "" : ", ") + s.str();
      }
    }
    md << "| " << n.id << " | " << n.component->info.name << " | " << ms << " | " << cpu_ms << " | " << inner
       << " |\n";
    if (n.id != detector) other_ms += ms;
  }
  const double det_total_ms =
      med(full, [&](const Sample& s) { return s.stage_ms.count(detector) ? s.stage_ms.at(detector) : 0.0; });
  const double det_pre_post_ms = std::max(0.0, det_total_ms - forward_in_graph_ms);
  other_ms += det_pre_post_ms;
  md << "\nEverything except inference (every other node's median + the detector's own pre/post-processing "
     << det_pre_post_ms << " ms): " << other_ms << " ms/frame = "
     << (forward_in_graph_ms > 0 ? 100.0 * other_ms / forward_in_graph_ms : 0)
     << "% of the detector's forward() in the graph run (" << forward_in_graph_ms << " ms), "
     << (forward_ms > 0 ? 100.0 * other_ms / forward_ms : 0) << "% of the bare forward() (" << forward_ms
     << " ms).\n";

  Json j = {{"config", o.config},
            {"overrides", o.overrides},
            {"repeat", b.repeat},
            {"frames", frames},
            {"cores", std::thread::hardware_concurrency()},
            {"cpu_model", cpu_model()},
            {"load_average_start", load_start},
            {"load_average_end", load_end},
            {"warmup_frames", kWarmupFrames},
            {"graph_fps", graph_fps},
            {"graph_steady_fps", steady_fps},
            {"finish_s", finish_s},
            {"bare_forward_fps", bare_fps},
            {"bare_forward_ms", forward_ms},
            {"bare_run_steady_fps", bare_steady_fps},
            {"ratio", ratio(graph_fps)},
            {"steady_ratio", ratio(steady_fps)},
            {"forward_ms_in_graph", forward_in_graph_ms},
            {"non_inference_ms", other_ms},
            {"cpu_ms_per_frame_graph", cpu_graph},
            {"cpu_ms_per_frame_bare", cpu_bare},
            {"stages", stages}};
  try {
    std::filesystem::create_directories(out_dir);
    write_file_atomic(out_dir / "bench.md", md.str());
    write_file_atomic(out_dir / "bench.json", hf::json_text(j, 2));
  } catch (const Error& e) {
    std::cerr << "error: " << e.what() << "\n";
    return 1;
  }
  std::cout << md.str();
  return 0;
}

}  // namespace hf::apps
