// The host facade used by every CLI command: plugin loading, config → graph, a run with its manifest.
#pragma once

#include <atomic>
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include "hazardforge/core/graph.hpp"
#include "hazardforge/core/manifest.hpp"
#include "hazardforge/core/plugin_loader.hpp"
#include "hazardforge/core/scheduler.hpp"

namespace hf::core {

class Host {
 public:
  explicit Host(std::vector<std::string> cli_plugin_paths = {});

  // Loads every plugin on the search path (plus the config's plugin_paths). Returns the refusals; each is a
  // complete message naming the library.
  std::vector<std::string> load_plugins(const std::vector<std::filesystem::path>& config_paths = {});

  ComponentRegistry& registry() { return registry_; }
  const PluginLoader& loader() const { return loader_; }
  const std::vector<std::filesystem::path>& searched() const { return searched_; }

 private:
  std::vector<std::string> cli_paths_;
  ComponentRegistry registry_;
  PluginLoader loader_;
  std::vector<std::filesystem::path> searched_;
};

struct RunRequest {
  std::filesystem::path config;
  std::vector<std::string> overrides;
  std::filesystem::path output_dir;  // empty = runs/<config name>-<UTC time>
  int64_t max_frames = -1;
  bool progress = true;  // progress bar on a terminal, periodic lines otherwise
  bool quiet = false;
  std::vector<std::string> argv;
  const std::atomic<bool>* interrupt = nullptr;
  // Keep only these nodes (and nothing downstream of a dropped node); empty = all. For benchmarks.
  std::vector<std::string> only_nodes;
};

struct RunOutcome {
  int exit_code = 0;  // 0 ok, 1 invalid input or stage failure, 130 interrupted
  std::filesystem::path output_dir;
  std::optional<RunResult> result;
  std::string message;  // what went wrong, already formatted
};

// Loads the config and plugins, validates the whole graph, runs it, and writes manifest.json (at start with
// status "running", at the end with the outcome) and timing.md into the output folder.
RunOutcome run_config(Host& host, const RunRequest& request);

// Validated graph for `config` (loads plugins as needed). Throws hf::Error / hf::DiagnosticError.
Graph load_graph(Host& host, const std::filesystem::path& config, const std::vector<std::string>& overrides,
                 GraphConfig* config_out = nullptr);

}  // namespace hf::core
