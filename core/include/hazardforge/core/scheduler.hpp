// Runs a validated graph over the source's frames: one thread per node, bounded queues between them, so
// decoding, inference and drawing overlap across cores while every node still sees frames in order.
#pragma once

#include <atomic>
#include <filesystem>
#include <functional>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include "hazardforge/core/graph.hpp"

namespace hf::core {

struct RunOptions {
  std::filesystem::path output_dir;
  size_t queue_capacity = 4;   // frames in flight per edge
  int64_t max_frames = -1;     // stop after this many source frames (-1 = all)
  // Recording frames outside [first_frame, last_frame] (Frame::index) never leave the source: nothing downstream
  // sees them, and the source stops after last_frame (-1 = to the end). Indexes and times stay the recording's.
  int64_t first_frame = 0;
  int64_t last_frame = -1;
  const std::atomic<bool>* interrupt = nullptr;  // set by the Ctrl-C handler
  // Called from the runner's thread about every 100 ms: frames completed by every node, total if known.
  std::function<void(int64_t done, std::optional<int64_t> total)> on_progress;
  LogLevel min_log_level = LogLevel::kInfo;
  bool quiet = false;  // no log lines on stderr (tests, benchmarks) ...
  bool quiet_keeps_warnings = false;  // ... except warnings and errors (`run -q`: a verdict's reasons still show)
};

struct NodeTiming {
  std::string id;
  std::string stage;
  std::string kind;
  std::vector<double> process_s;                        // per frame (next() for the source)
  std::map<std::string, std::vector<double>> inner_s;   // record_timing() labels
  std::vector<double> process_cpu_s;  // per frame: CPU time of the node's own thread during process()/next()
};

// A stage that ended the run because no hazard fits the scene (NoHazardFits), with its typed reasons.
struct NodeRefusal {
  std::string node;
  int64_t frame = -1;  // the frame it was processing (-1 = at open or finish)
  std::vector<Refusal> reasons;
};

struct RunResult {
  int64_t frames = 0;       // frames the source produced
  double wall_s = 0.0;
  bool interrupted = false;
  std::vector<std::string> errors;  // "node 'x' (stage 'y', lib): frame N: message"
  std::vector<NodeTiming> timings;
  std::vector<std::filesystem::path> resources;
  std::vector<std::string> log;  // warnings and errors stages logged
  std::vector<std::string> incomplete;  // "node 'x': reason" for inputs a stage could use only in part
  std::vector<NodeRefusal> refusals;     // also in errors, as text
  // A node failed while being created or opened (its params, files or models): the graph never ran, and
  // would not with any other frames.
  bool failed_to_start = false;
  bool ok() const { return errors.empty(); }
};

// Instantiates and opens every node, runs to the end of the stream (or interruption / first error), then lets
// every node finish() so outputs are flushed. Never throws for stage failures: they are in RunResult::errors.
RunResult run_graph(const Graph& graph, const ComponentRegistry& registry, const RunOptions& options);

double median(std::vector<double> v);

}  // namespace hf::core
