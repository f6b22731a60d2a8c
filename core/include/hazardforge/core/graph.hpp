// The YAML graph: loading with overrides and ${VAR} expansion, whole-graph validation, topological order.
#pragma once

#include <filesystem>
#include <map>
#include <set>
#include <string>
#include <vector>

#include "hazardforge/registry.hpp"
#include "hazardforge/yaml_json.hpp"

namespace hf::core {

struct GraphConfig {
  std::filesystem::path file;
  std::filesystem::path dir;  // params of type path resolve against this
  YamlDocument doc;           // after overrides and ${VAR} expansion
  std::vector<std::filesystem::path> plugin_paths;
  std::vector<std::string> overrides;
  std::filesystem::path overrides_dir;     // relative paths given by overrides resolve against this
  std::set<std::string> stage_overridden;  // node ids whose stage a --set NODE.stage=... replaced
  std::set<std::string> params_overridden;  // "node/param" a --set replaced (wins over the scene block)
};

// Reads the file, applies `--set node.key[.sub]=value` overrides (`--set node.stage=NAME` swaps the stage;
// the node's params the new stage does not declare are then dropped with a warning) and expands
// ${VAR}/${VAR:-default} in every string. A relative path in the file is relative to the file's folder; one
// given by an override is relative to `overrides_dir` (empty = the current folder: what a user typed on the
// command line). Throws hf::DiagnosticError (all problems found) or hf::Error (unreadable file, YAML syntax).
GraphConfig load_graph_config(const std::filesystem::path& file,
                              const std::vector<std::string>& overrides = {},
                              const std::filesystem::path& overrides_dir = {});

struct NodeSpec {
  std::string id;
  std::string stage;  // as written
  const RegisteredComponent* component = nullptr;
  Json params;  // validated, defaults filled
  std::set<std::string> stated;  // params given on the node, by the scene block or on the command line
  SourceLocation where;
  std::map<std::string, std::vector<std::string>> inputs;  // port -> stream names
  std::map<std::string, std::string> outputs;              // port -> stream name
};

struct Graph {
  std::string name;
  std::string description;
  Json scene = Json::object();  // the config's `scene:` block (validated)
  std::filesystem::path file;
  std::filesystem::path dir;
  std::vector<NodeSpec> nodes;  // topological order; the source first
  std::map<std::string, std::pair<std::string, std::string>> producers;  // stream -> (node id, port)
  std::vector<Diagnostic> warnings;  // e.g. params dropped because --set swapped a node's stage

  const NodeSpec* node(const std::string& id) const;
  // Graphviz text: nodes labelled "id\nstage", edges labelled with stream and type.
  std::string to_dot() const;
  // The fully resolved config (params with defaults) for the run manifest.
  Json resolved() const;
  // A copy keeping only `keep` node ids (and their connections), e.g. source + detector for benchmarks.
  Graph subgraph(const std::vector<std::string>& keep) const;
};

// Validates everything at once — unknown keys and stages (with suggestions), params, ports, stream producers,
// types, cycles, the single source — and throws hf::DiagnosticError listing every problem.
Graph build_graph(const GraphConfig& config, const ComponentRegistry& registry);

}  // namespace hf::core
