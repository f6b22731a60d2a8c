// Host facade: plugins + config + graph + run + manifest, shared by run/eval/bench/experiment.
#include "hazardforge/core/host.hpp"

#include "hazardforge/json_text.hpp"
#include "hazardforge/output_path.hpp"

#include <fcntl.h>
#include <sys/file.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <ctime>
#include <fstream>
#include <iomanip>
#include <iostream>
#include <mutex>
#include <set>
#include <sstream>

namespace hf::core {

Host::Host(std::vector<std::string> cli_plugin_paths) : cli_paths_(std::move(cli_plugin_paths)), loader_(registry_) {}

std::vector<std::string> Host::load_plugins(const std::vector<std::filesystem::path>& config_paths) {
  std::vector<std::string> errors;
  searched_ = plugin_search_path(cli_paths_, config_paths);
  for (const auto& dir : searched_) loader_.load_dir(dir, errors);
  return errors;
}

Graph load_graph(Host& host, const std::filesystem::path& config, const std::vector<std::string>& overrides,
                 GraphConfig* config_out, bool load_config_plugins, const std::vector<Json>& extra_nodes,
                 const std::filesystem::path& overrides_dir) {
  GraphConfig cfg = load_graph_config(config, overrides, overrides_dir);
  if (!extra_nodes.empty() && cfg.doc.value.contains("nodes") && cfg.doc.value["nodes"].is_array())
    for (const Json& n : extra_nodes) cfg.doc.value["nodes"].push_back(n);
  std::vector<std::filesystem::path> config_paths;
  if (load_config_plugins)
    config_paths = cfg.plugin_paths;
  else if (!cfg.plugin_paths.empty())
    std::cerr << config.string()
              << ": warning: plugin_paths not loaded (loading runs the libraries' code); pass "
                 "--load-config-plugins to load them\n";
  std::vector<std::string> errors = host.load_plugins(config_paths);
  if (!errors.empty()) {
    std::vector<Diagnostic> d;
    for (auto& e : errors) d.push_back({Diagnostic::Severity::kError, {}, e});
    throw DiagnosticError(std::move(d));
  }
  Graph g = build_graph(cfg, host.registry());
  if (config_out) *config_out = std::move(cfg);
  return g;
}

std::vector<std::string> upstream_of(const Graph& graph, const std::string& node) {
  std::set<std::string> needed;
  std::vector<std::string> todo = {node};
  while (!todo.empty()) {
    const NodeSpec* n = graph.node(todo.back());
    todo.pop_back();
    if (!n) continue;
    for (const auto& [port, streams] : n->inputs)
      for (const std::string& s : streams)
        if (auto it = graph.producers.find(s); it != graph.producers.end() && needed.insert(it->second.first).second)
          todo.push_back(it->second.first);
  }
  std::vector<std::string> out;
  for (const NodeSpec& n : graph.nodes)
    if (needed.count(n.id) && n.id != node) out.push_back(n.id);
  return out;
}

namespace {

std::string utc_stamp() {
  std::time_t t = std::time(nullptr);
  std::tm tm{};
  gmtime_r(&t, &tm);
  char buf[32];
  std::strftime(buf, sizeof buf, "%Y%m%d-%H%M%S", &tm);
  return buf;
}

std::string fmt_duration(double s) {
  if (!std::isfinite(s) || s < 0) return "--:--";
  const long t = std::lround(s);
  std::ostringstream os;
  os << t / 60 << ":" << std::setw(2) << std::setfill('0') << t % 60;
  return os.str();
}

// Progress bar with rate and ETA on a terminal (after the first second), a line every 5 s otherwise.
class Progress {
 public:
  explicit Progress(bool enabled) : enabled_(enabled), tty_(isatty(STDERR_FILENO) == 1) {}
  void update(int64_t done, std::optional<int64_t> total) {
    if (!enabled_) return;
    const double el = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0_).count();
    const double rate = el > 0 ? static_cast<double>(done) / el : 0.0;
    const double eta = (total && rate > 0) ? static_cast<double>(*total - done) / rate : NAN;
    std::ostringstream os;
    os << std::fixed << std::setprecision(1);
    if (tty_) {
      if (el < 1.0) return;
      os << "\r";
      if (total && *total > 0) {
        const int w = 30, fill = static_cast<int>(w * static_cast<double>(done) / static_cast<double>(*total));
        os << "[" << std::string(std::min(fill, w), '#') << std::string(std::max(0, w - fill), '.') << "] ";
        os << done << "/" << *total;
      } else {
        os << done << " frames";
      }
      os << "  " << rate << " frames/s  ETA " << fmt_duration(eta) << "   ";
      std::cerr << os.str() << std::flush;
      drawn_ = true;
    } else {
      if (el - last_line_ < 5.0) return;
      last_line_ = el;
      os << "progress: " << done;
      if (total) os << "/" << *total;
      os << " frames, " << rate << " frames/s";
      if (total) os << ", ETA " << fmt_duration(eta);
      std::cerr << os.str() << "\n";
    }
  }
  void done() {
    if (drawn_) std::cerr << "\n";
  }

 private:
  bool enabled_, tty_;
  bool drawn_ = false;
  double last_line_ = 0.0;
  std::chrono::steady_clock::time_point t0_ = std::chrono::steady_clock::now();
};

}  // namespace

namespace {

bool folder_empty(const std::filesystem::path& dir) {
  std::error_code ec;
  return std::filesystem::directory_iterator(dir, ec) == std::filesystem::directory_iterator();
}

// Every entry below `dir`, relative, folders with a trailing '/'; symlinks are entries, never followed.
std::set<std::string> entries_below(const std::filesystem::path& dir) {
  std::set<std::string> out;
  std::error_code ec;
  for (auto it = std::filesystem::recursive_directory_iterator(dir, ec);
       !ec && it != std::filesystem::recursive_directory_iterator(); it.increment(ec)) {
    const std::string rel = it->path().lexically_relative(dir).generic_string();
    out.insert(it->is_directory(ec) && !it->is_symlink(ec) ? rel + "/" : rel);
  }
  return out;
}

std::vector<std::string> string_list(const Json& j) {
  std::vector<std::string> out;
  if (j.is_array())
    for (const Json& e : j)
      if (e.is_string()) out.push_back(e.get<std::string>());
  return out;
}

// An entry as the manifest lists it: a path component with "user:pass@" or "?query" (a URL given as a file
// name) has them replaced by "***" as URLs elsewhere in the manifest have. --overwrite matches entries in
// this form.
std::string listed(const std::string& rel) {
  std::string out, part;
  for (size_t i = 0; i <= rel.size(); ++i) {
    if (i < rel.size() && rel[i] != '/') {
      part += rel[i];
      continue;
    }
    if (const size_t at = part.rfind('@'); at != std::string::npos) part = "***" + part.substr(at);
    if (const size_t q = part.find('?'); q != std::string::npos) part = part.substr(0, q + 1) + "***";
    out += part + (i < rel.size() ? "/" : "");
    part.clear();
  }
  return out;
}

std::vector<std::string> listed(const std::vector<std::string>& entries) {
  std::vector<std::string> out;
  for (const std::string& e : entries) out.push_back(listed(e));
  return out;
}

// What only HazardForge's own manifest holds: a web app's or another tool's manifest.json is not a run.
bool is_run_manifest(const Json& m) {
  return m.is_object() && m.contains("hazardforge_version") && m["hazardforge_version"].is_string() &&
         m.contains("abi_tag") && m["abi_tag"].is_string() && m.contains("status") &&
         m["status"].is_string() && m.contains("started_at") && m["started_at"].is_string();
}

// Removes `rel` below `dir` when it names an entry there without leaving it (no "..", no absolute path, no
// symlinked folder on the way); a folder only when it is empty.
void remove_run_entry(const std::filesystem::path& dir, const std::string& rel) {
  namespace fs = std::filesystem;
  const bool folder = !rel.empty() && rel.back() == '/';
  const fs::path p = fs::path(folder ? rel.substr(0, rel.size() - 1) : rel).lexically_normal();
  if (p.empty() || p.is_absolute()) return;
  fs::path at = dir;
  for (auto it = p.begin(); it != p.end(); ++it) {
    if (*it == ".." || *it == ".") return;
    at /= *it;
    std::error_code ec;
    if (std::next(it) != p.end() && !fs::is_directory(fs::symlink_status(at, ec))) return;
  }
  std::error_code ec;
  if (folder) {
    if (fs::is_directory(fs::symlink_status(at, ec)) && folder_empty(at)) fs::remove(at, ec);
  } else {
    fs::remove(at, ec);
  }
}

// Makes `dir` ready for a run as `use` allows and returns the entries in it that the run does not own (the
// user's files, kept by --overwrite); throws hf::Error with what to do otherwise.
namespace {

// A run holds its folder for as long as it runs: an exclusive flock on the folder itself (no file of its own
// in it), on a descriptor closed on exec, so a program a stage starts does not keep it. A second run into the
// same folder (--resume or --overwrite while the first still writes) is refused instead of writing beside it.
class FolderLock {
 public:
  FolderLock() = default;
  FolderLock(const FolderLock&) = delete;
  FolderLock& operator=(const FolderLock&) = delete;
  ~FolderLock() {
    if (fd_ >= 0) ::close(fd_);
  }
  bool held() const { return fd_ >= 0; }
  void take(const std::filesystem::path& dir) {
    fd_ = ::open(dir.c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC);
    if (fd_ < 0) return;  // not a folder we can open: claim_run_folder says what is wrong with it
    if (flock(fd_, LOCK_EX | LOCK_NB) != 0) {
      ::close(fd_);
      fd_ = -1;
      throw Error(dir.string() +
                  ": another run is still writing into this folder; wait for it to end or choose another "
                  "folder");
    }
  }

 private:
  int fd_ = -1;
};

}  // namespace

std::vector<std::string> claim_run_folder(const std::filesystem::path& dir, FolderUse use,
                                          const Json& config) {
  std::error_code ec;
  if (!std::filesystem::exists(dir, ec) || folder_empty(dir)) return {};
  const std::string d = dir.string();
  const auto manifest_file = dir / "manifest.json";
  if (!std::filesystem::is_regular_file(manifest_file, ec))
    throw Error(d +
                ": the output folder is not empty and holds no run (no manifest.json); a run folder belongs "
                "to one run: choose a new or empty folder");
  Json old;
  try {
    std::ifstream in(manifest_file);
    old = Json::parse(in);
  } catch (const std::exception& e) {
    throw Error(manifest_file.string() + ": unreadable manifest of an earlier run: " + e.what());
  }
  if (!is_run_manifest(old))
    throw Error(
        manifest_file.string() +
        ": not a HazardForge run manifest (it lacks 'hazardforge_version', 'abi_tag', 'status' or "
        "'started_at'), so the folder holds something else; a run folder belongs to one run: choose a "
        "new or empty folder");
  const std::string status = old["status"].get<std::string>();
  // The earlier run's own entries: listed by a run that ended; a run that never ended (killed) owns all but
  // what it found there.
  const std::set<std::string> present = entries_below(dir);
  const bool ended = old.contains("outputs");
  const std::vector<std::string> listing = string_list(old.value(ended ? "outputs" : "kept", Json::array()));
  const std::set<std::string> in_listing(listing.begin(), listing.end());
  std::set<std::string> owned;
  for (const std::string& e : present)
    if (e == "manifest.json" || in_listing.count(listed(e)) == (ended ? 1u : 0u)) owned.insert(e);
  std::vector<std::string> kept;
  for (const std::string& e : present)
    if (!owned.count(e)) kept.push_back(e);
  switch (use) {
    case FolderUse::kNew:
      throw Error(d + ": the output folder already holds a run (status '" + status +
                  "'); use --resume to run the same config into it again or --overwrite to clear it first");
    case FolderUse::kResume: {
      const Json before = old.value("config_after_overrides", Json());
      if (before != config) {
        const Json patch = Json::diff(before, config);
        const std::string where = patch.empty() ? std::string("/") : patch[0].value("path", std::string("/"));
        throw Error(d + ": --resume needs the same config, but the earlier run's config differs at '" +
                    (where.empty() ? std::string("/") : where) + "'; use --overwrite or a new folder");
      }
      return kept;
    }
    case FolderUse::kOverwrite: {
      // Files first, then the run's folders deepest first, each only if nothing of the user's is left in it.
      std::vector<std::string> files, folders;
      for (const std::string& e : owned) (e.back() == '/' ? folders : files).push_back(e);
      std::sort(folders.begin(), folders.end(),
                [](const std::string& a, const std::string& b) { return a.size() > b.size(); });
      for (const std::string& e : files) remove_run_entry(dir, e);
      for (const std::string& e : folders) remove_run_entry(dir, e);
      std::vector<std::string> left;
      for (const std::string& e : entries_below(dir)) left.push_back(e);
      return left;
    }
  }
  return {};
}

}  // namespace

RunOutcome run_config(Host& host, const RunRequest& req) {
  RunOutcome o;
  GraphConfig cfg;
  Graph graph;
  try {
    graph = load_graph(host, req.config, req.overrides, &cfg, true, req.extra_nodes, req.overrides_dir);
  } catch (const Error& e) {
    o.exit_code = 1;
    o.message = e.what();
    return o;
  }
  if (!req.only_nodes.empty()) graph = graph.subgraph(req.only_nodes);
  if (!req.quiet)
    for (const Diagnostic& w : graph.warnings) std::cerr << w.str() << "\n";
  // The config's name comes from the user: made a single safe path component so it cannot climb out of runs/.
  o.output_dir = req.output_dir.empty()
                     ? std::filesystem::path("runs") / (safe_path_component(graph.name) + "-" + utc_stamp())
                     : req.output_dir;
  std::vector<std::string> kept;  // what the folder held that this run did not write
  FolderLock folder_lock;         // held until this function returns: the run's folder is its own
  try {
    std::error_code ec;
    if (std::filesystem::is_directory(o.output_dir, ec)) folder_lock.take(o.output_dir);
    kept = claim_run_folder(o.output_dir, req.folder_use, cfg.doc.value);
    std::filesystem::create_directories(o.output_dir, ec);
    if (ec) throw Error(o.output_dir.string() + ": cannot create output folder: " + ec.message());
    if (!folder_lock.held()) folder_lock.take(o.output_dir);
  } catch (const std::exception& e) {
    o.exit_code = 1;
    o.message = std::string("error: ") + e.what();
    return o;
  }
  ManifestInput mi{req.argv, &graph, &cfg, &host.loader().plugins(), iso8601_now()};
  const std::vector<std::string> kept_listed = listed(kept);
  mi.kept = &kept_listed;
  const auto manifest_path = o.output_dir / "manifest.json";
  try {
    write_file_atomic(manifest_path, json_text(make_manifest(mi, "running", nullptr, ""), 2));
  } catch (const std::exception& e) {
    o.exit_code = 1;
    o.message = std::string("error: ") + e.what();
    return o;
  }

  RunOptions opt;
  opt.output_dir = o.output_dir;
  opt.max_frames = req.max_frames;
  opt.first_frame = req.first_frame;
  opt.last_frame = req.last_frame;
  opt.interrupt = req.interrupt;
  opt.quiet = req.quiet;
  opt.quiet_keeps_warnings = true;
  Progress progress(req.progress && !req.quiet);
  std::mutex pmu;
  opt.on_progress = [&](int64_t done, std::optional<int64_t> total) {
    std::lock_guard lk(pmu);
    progress.update(done, total);
  };
  RunResult r;
  // The manifest already says "running": whatever escapes the scheduler must still end up in it.
  try {
    r = run_graph(graph, host.registry(), opt);
  } catch (const std::exception& e) {
    r.errors.push_back(e.what());
  } catch (...) {
    r.errors.push_back("unknown exception while running the graph");
  }
  progress.done();
  const std::string status = !r.ok()                 ? "failed"
                             : r.interrupted         ? "interrupted"
                             : !r.incomplete.empty() ? "incomplete"
                                                     : "completed";
  try {
    write_file_atomic(o.output_dir / "timing.md", timing_table(r));
  } catch (const std::exception& e) {
    r.errors.push_back(e.what());
  }
  // The run's own entries, so that --overwrite removes these and nothing else.
  std::vector<std::string> outputs = {"manifest.json"};
  const std::set<std::string> not_ours(kept.begin(), kept.end());
  for (const std::string& e : entries_below(o.output_dir))
    if (e != "manifest.json" && !not_ours.count(e)) outputs.push_back(listed(e));
  mi.outputs = &outputs;
  try {
    write_file_atomic(manifest_path,
                      json_text(make_manifest(mi, r.ok() ? status : "failed", &r, iso8601_now()), 2));
  } catch (const std::exception& e) {
    r.errors.push_back(e.what());
  }
  if (!r.ok()) {
    o.exit_code = 1;
    std::string msg;
    for (const auto& e : r.errors) msg += (msg.empty() ? "" : "\n") + std::string("error: ") + e;
    o.message = msg + "\noutputs written so far are kept in " + o.output_dir.string();
  } else if (r.interrupted) {
    o.exit_code = 130;
    o.message = "interrupted after " + std::to_string(r.frames) + " frames; outputs kept in " + o.output_dir.string();
  } else if (!r.incomplete.empty()) {
    std::string msg;
    for (const auto& e : r.incomplete)
      msg += (msg.empty() ? "" : "\n") + std::string("warning: incomplete: ") + e;
    o.message = msg;
  }
  o.result = std::move(r);
  return o;
}

}  // namespace hf::core
