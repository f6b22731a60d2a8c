// The run manifest: everything needed to reproduce a run (resolved config, plugins, model hashes, times).
#pragma once

#include <filesystem>
#include <string>
#include <vector>

#include "hazardforge/atomic_file.hpp"
#include "hazardforge/core/graph.hpp"
#include "hazardforge/core/plugin_loader.hpp"
#include "hazardforge/core/scheduler.hpp"

namespace hf::core {

std::string sha256_file(const std::filesystem::path& file);  // hex; throws hf::Error if unreadable
std::string sha256_text(const std::string& text);
std::string iso8601_now();

struct ManifestInput {
  std::vector<std::string> argv;
  const Graph* graph = nullptr;
  const GraphConfig* config = nullptr;
  const std::vector<LoadedPlugin>* plugins = nullptr;
  std::string started_at;
  // The run folder's entries (relative, folders ending in '/'): those it held that the run did not write,
  // and, once the run has ended, those the run wrote. --overwrite removes the outputs and keeps the rest.
  const std::vector<std::string>* kept = nullptr;
  const std::vector<std::string>* outputs = nullptr;
};

// status: "running", "completed", "incomplete" (a stage used its input only in part, as allowed),
// "interrupted", "failed".
Json make_manifest(const ManifestInput& in, const std::string& status, const RunResult* result,
                   const std::string& ended_at);

// Per-stage latency table (median/mean/p90 per frame, frames/s) as Markdown.
std::string timing_table(const RunResult& r);
Json timing_json(const RunResult& r);

}  // namespace hf::core
