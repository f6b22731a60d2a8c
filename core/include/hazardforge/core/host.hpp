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

// What a run may do with an output folder that already holds something. A run folder belongs to one run:
// mixing two runs' files in one folder makes both unreadable.
enum class FolderUse {
  kNew,        // the folder must be absent or empty
  kResume,     // the folder holds a run of the same config (manifest.json); run again into it
  kOverwrite,  // the folder holds a run (manifest.json); its contents are removed first
};

struct RunRequest {
  std::filesystem::path config;
  std::vector<std::string> overrides;
  std::filesystem::path
      overrides_dir;                 // relative paths in overrides resolve against it; empty = current folder
  std::filesystem::path output_dir;  // empty = runs/<config name, made path-safe>-<UTC time>
  int64_t max_frames = -1;
  int64_t first_frame = 0;  // the recording's frame window (RunOptions::first_frame / last_frame)
  int64_t last_frame = -1;
  bool progress = true;  // progress bar on a terminal, periodic lines otherwise
  bool quiet = false;
  std::vector<std::string> argv;
  const std::atomic<bool>* interrupt = nullptr;
  // Nodes added to the config before it is validated ({id, stage, inputs, params} objects), e.g. a campaign's
  // record of what its scouting run saw.
  std::vector<Json> extra_nodes;
  // Keep only these nodes (and nothing downstream of a dropped node); empty = all. For benchmarks and scouting.
  std::vector<std::string> only_nodes;
  FolderUse folder_use = FolderUse::kNew;
};

struct RunOutcome {
  int exit_code = 0;  // 0 ok, 1 invalid input or stage failure, 130 interrupted
  std::filesystem::path output_dir;
  std::optional<RunResult> result;
  std::string message;  // what went wrong, already formatted
};

// Loads the config and plugins, validates the whole graph, runs it, and writes manifest.json (at start with
// status "running", at the end with the outcome) and timing.md into the output folder. Once the manifest says
// "running" it always ends "completed", "interrupted" or "failed" (with the message), whatever was thrown.
RunOutcome run_config(Host& host, const RunRequest& request);

// Validated graph for `config` (loads plugins as needed). Throws hf::Error / hf::DiagnosticError. Without
// `load_config_plugins` the config's plugin_paths are not loaded (a warning says so): loading a library runs
// its code, and validating or drawing a config someone sent must not.
Graph load_graph(Host& host, const std::filesystem::path& config, const std::vector<std::string>& overrides,
                 GraphConfig* config_out = nullptr, bool load_config_plugins = true,
                 const std::vector<Json>& extra_nodes = {}, const std::filesystem::path& overrides_dir = {});

// Node ids whose outputs `node` depends on, directly or not (not `node` itself), in the graph's order.
std::vector<std::string> upstream_of(const Graph& graph, const std::string& node);

}  // namespace hf::core
