// Plugin discovery and loading: the ABI handshake is checked before any plugin code beyond the entry runs.
#pragma once

#include <filesystem>
#include <string>
#include <vector>

#include "hazardforge/registry.hpp"

namespace hf::core {

struct LoadedPlugin {
  std::filesystem::path path;
  std::string name, version, license, description;
  std::vector<std::string> components;  // "kind/name"
};

class PluginLoader {
 public:
  explicit PluginLoader(ComponentRegistry& registry) : registry_(registry) {}

  // Loads one library. Throws hf::Error with the complete message (path + reason) on any refusal;
  // in that case nothing from the library is registered. Libraries are never unloaded.
  void load(const std::filesystem::path& library);
  // Loads every *.so in `dir` (sorted); collects refusals instead of stopping at the first.
  void load_dir(const std::filesystem::path& dir, std::vector<std::string>& errors);

  const std::vector<LoadedPlugin>& plugins() const { return plugins_; }

 private:
  ComponentRegistry& registry_;
  std::vector<LoadedPlugin> plugins_;
};

// Plugin folders in priority order: --plugin-path values, $HAZARDFORGE_PLUGIN_PATH (':'-separated), the
// config's plugin_paths (already resolved against the config file), then <exe>/../lib/hazardforge/plugins.
std::vector<std::filesystem::path> plugin_search_path(const std::vector<std::string>& cli_paths,
                                                      const std::vector<std::filesystem::path>& config_paths);

// The running executable's folder.
std::filesystem::path executable_dir();

}  // namespace hf::core
