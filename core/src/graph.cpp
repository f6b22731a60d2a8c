// Graph config loading, overrides, expansion and whole-graph validation with compiler-style diagnostics.
#include "hazardforge/core/graph.hpp"

#include "hazardforge/scene.hpp"

#include <algorithm>
#include <functional>
#include <set>
#include <sstream>
#include <unordered_map>

namespace hf::core {

namespace {

using Severity = Diagnostic::Severity;

const std::vector<std::string> kTopKeys = {"name", "description", "scene", "nodes", "plugin_paths", "meta"};
const std::vector<std::string> kNodeKeys = {"id", "stage", "params", "inputs", "outputs"};

std::string ptr_token(const std::string& s) {
  std::string out;
  for (char c : s) out += c == '~' ? std::string("~0") : c == '/' ? std::string("~1") : std::string(1, c);
  return out;
}

// The variables a config names as holding a secret (api_key_env: NAME, at any depth).
void secret_variables(const Json& j, std::set<std::string>& names) {
  if (j.is_array()) {
    for (const Json& e : j) secret_variables(e, names);
  } else if (j.is_object()) {
    for (auto it = j.begin(); it != j.end(); ++it) {
      if (it.key() == "api_key_env" && it.value().is_string()) names.insert(it.value().get<std::string>());
      secret_variables(it.value(), names);
    }
  }
}

void expand_strings(Json& j, const std::string& ptr, const YamlDocument& doc,
                    const std::map<std::string, std::string>& vars, const std::set<std::string>& secrets,
                    std::vector<Diagnostic>& diags) {
  if (j.is_string()) {
    const std::string& text = j.get_ref<const std::string&>();
    for (const std::string& name : secrets)
      if (text.find("${" + name + "}") != std::string::npos ||
          text.find("${" + name + ":-") != std::string::npos) {
        diags.push_back({Severity::kError, doc.at(ptr),
                         "${" + name +
                             "} is not expanded: the config names it as api_key_env, a secret that "
                             "only the provider reads"});
        return;
      }
    try {
      j = expand_vars(text, vars);
    } catch (const Error& e) {
      diags.push_back({Severity::kError, doc.at(ptr), e.what()});
    }
  } else if (j.is_array()) {
    for (size_t i = 0; i < j.size(); ++i)
      expand_strings(j[i], ptr + "/" + std::to_string(i), doc, vars, secrets, diags);
  } else if (j.is_object()) {
    for (auto it = j.begin(); it != j.end(); ++it)
      expand_strings(it.value(), ptr + "/" + ptr_token(it.key()), doc, vars, secrets, diags);
  }
}

void apply_override(GraphConfig& cfg, const std::string& text, std::vector<Diagnostic>& diags) {
  const SourceLocation where{"--set " + text, 0, 0};
  const auto eq = text.find('=');
  const auto dot = text.find('.');
  if (eq == std::string::npos || dot == std::string::npos || dot > eq) {
    diags.push_back({Severity::kError, where, "expected --set node.param=value"});
    return;
  }
  const std::string node_id = text.substr(0, dot);
  const std::string key_path = text.substr(dot + 1, eq - dot - 1);
  Json value;
  const std::string raw = text.substr(eq + 1);
  try {
    value = parse_yaml(raw, "--set").value;
  } catch (const Error& e) {
    diags.push_back({Severity::kError, where, std::string("cannot parse the value: ") + e.what()});
    return;
  }
  // A command line has no comments: "Main St #5, downtown" is the street, not "Main St" and a comment. Where
  // YAML read a '#' as a comment (or folded a line break), the text itself is the value.
  const bool comment = raw.rfind('#', 0) == 0 || raw.find(" #") != std::string::npos ||
                       raw.find("\t#") != std::string::npos || raw.find('\n') != std::string::npos;
  const size_t b = raw.find_first_not_of(" \t"), e = raw.find_last_not_of(" \t\n");
  const std::string whole = b == std::string::npos ? std::string() : raw.substr(b, e - b + 1);
  const bool quoted = !whole.empty() && (whole.front() == '"' || whole.front() == '\'');  // YAML's own string
  if (comment && !quoted && (value.is_null() || value.is_string())) value = whole;
  if (node_id == "scene") {  // --set scene.road.lanes_left=2
    Json* target = &cfg.doc.value["scene"];
    std::string ptr = "/scene";
    std::stringstream ss(key_path);
    std::vector<std::string> parts;
    for (std::string p; std::getline(ss, p, '.');) parts.push_back(p);
    for (const std::string& part : parts) {
      if (!target->is_object()) *target = Json::object();
      target = &(*target)[part];
      ptr += "/" + ptr_token(part);
    }
    *target = value;
    cfg.doc.locations[ptr] = where;
    cfg.doc.locations[ptr + "#key"] = where;
    return;
  }
  Json& nodes = cfg.doc.value["nodes"];
  if (!nodes.is_array()) {
    diags.push_back({Severity::kError, where, "the config has no nodes to override"});
    return;
  }
  std::vector<std::string> ids;
  for (size_t i = 0; i < nodes.size(); ++i) {
    Json& n = nodes[i];
    if (!n.is_object() || !n.contains("id") || !n["id"].is_string()) continue;
    ids.push_back(n["id"].get<std::string>());
    if (ids.back() != node_id) continue;
    std::string base = "/nodes/" + std::to_string(i);
    std::vector<std::string> parts;
    std::stringstream ss(key_path);
    for (std::string p; std::getline(ss, p, '.');) parts.push_back(p);
    Json* target;
    if (parts.size() == 1 && (parts[0] == "stage")) {
      target = &n["stage"];
      base += "/stage";
      cfg.stage_overridden.insert(node_id);
    } else {
      if (!n.contains("params") || !n["params"].is_object()) n["params"] = Json::object();
      target = &n["params"];
      base += "/params";
      for (size_t k = 0; k + 1 < parts.size(); ++k) {
        if (!target->contains(parts[k]) || !(*target)[parts[k]].is_object()) (*target)[parts[k]] = Json::object();
        target = &(*target)[parts[k]];
        base += "/" + ptr_token(parts[k]);
      }
      target = &(*target)[parts.back()];
      base += "/" + ptr_token(parts.back());
      cfg.params_overridden.insert(node_id + "/" + parts.front());
    }
    *target = value;
    cfg.doc.locations[base] = where;
    cfg.doc.locations[base + "#key"] = where;
    return;
  }
  std::string near = nearest_name(node_id, ids);
  diags.push_back({Severity::kError, where,
                   "no node '" + node_id + "'" + (near.empty() ? "" : "; did you mean '" + near + "'?")});
}

// ---- include: subgraphs ------------------------------------------------------------------------------------------

const std::vector<std::string> kIncludeKeys = {"include", "prefix", "inputs", "params"};
const std::vector<std::string> kSubgraphKeys = {"description", "inputs", "nodes"};

// Moves the locations of `from` below pointer `from_ptr` to `to_ptr` in `to`.
void copy_locations(const LocationMap& from, const std::string& from_ptr, LocationMap& to, const std::string& to_ptr) {
  for (auto it = from.lower_bound(from_ptr); it != from.end() && it->first.rfind(from_ptr, 0) == 0; ++it) {
    const std::string rest = it->first.substr(from_ptr.size());
    if (!rest.empty() && rest[0] != '/' && rest[0] != '#') continue;  // "/nodes/1" must not take "/nodes/10"
    to[to_ptr + rest] = it->second;
  }
}

// Includes expanded in one config, at most: a subgraph included from two places is expanded twice, so files
// that each include the next twice would otherwise multiply without end.
constexpr int kMaxIncludes = 1000;

// Replaces every `- include: FILE` entry of doc's nodes by the subgraph's nodes, renamed with the entry's prefix
// and with its inputs bound; keeps every location (nodes from a subgraph point into the subgraph file).
// `includes` counts the includes expanded so far, over the whole config.
void expand_includes(YamlDocument& doc, const std::filesystem::path& dir,
                     std::vector<std::filesystem::path>& stack, std::vector<Diagnostic>& diags,
                     int& includes) {
  Json& nodes = doc.value["nodes"];
  if (!nodes.is_array()) return;
  bool any = false;
  for (const Json& n : nodes) any = any || (n.is_object() && n.contains("include"));
  if (!any) return;
  auto error = [&](const SourceLocation& w, std::string m) { diags.push_back({Severity::kError, w, std::move(m)}); };
  Json out = Json::array();
  LocationMap locs;
  for (auto it = doc.locations.begin(); it != doc.locations.end(); ++it)
    if (it->first.rfind("/nodes/", 0) != 0) locs.insert(*it);
  for (size_t i = 0; i < nodes.size(); ++i) {
    const std::string base = "/nodes/" + std::to_string(i);
    const Json& entry = nodes[i];
    if (!entry.is_object() || !entry.contains("include")) {
      copy_locations(doc.locations, base, locs, "/nodes/" + std::to_string(out.size()));
      out.push_back(entry);
      continue;
    }
    for (auto it = entry.begin(); it != entry.end(); ++it)
      if (std::find(kIncludeKeys.begin(), kIncludeKeys.end(), it.key()) == kIncludeKeys.end()) {
        const std::string near = nearest_name(it.key(), kIncludeKeys);
        error(doc.at(base + "/" + ptr_token(it.key()) + "#key"),
              "unknown include key '" + it.key() + "'" + (near.empty() ? "" : "; did you mean '" + near + "'?"));
      }
    if (!entry["include"].is_string()) {
      error(doc.at(base + "/include"), "'include' names a subgraph file");
      continue;
    }
    std::filesystem::path file = entry["include"].get<std::string>();
    if (file.is_relative()) file = dir / file;
    file = file.lexically_normal();
    if (includes > kMaxIncludes) continue;  // reported once, where the limit was passed
    if (++includes > kMaxIncludes) {
      error(doc.at(base + "/include"), "more than " + std::to_string(kMaxIncludes) +
                                           " subgraph includes in all (each place that includes a subgraph "
                                           "expands it again, and so do the subgraphs it includes)");
      continue;
    }
    if (std::find(stack.begin(), stack.end(), file) != stack.end()) {
      error(doc.at(base + "/include"), "subgraph '" + file.string() + "' includes itself");
      continue;
    }
    if (!std::filesystem::exists(file)) {
      error(doc.at(base + "/include"), "subgraph file '" + file.string() + "' not found");
      continue;
    }
    const std::string prefix = entry.contains("prefix") && entry["prefix"].is_string() ? entry["prefix"].get<std::string>() : "";
    if (entry.contains("prefix") && !entry["prefix"].is_string())
      error(doc.at(base + "/prefix"), "'prefix' is a string put before every node id of the subgraph");
    YamlDocument sub;
    try {
      sub = load_yaml_file(file.string());
    } catch (const Error& e) {
      diags.push_back({Severity::kError, doc.at(base + "/include"), e.what()});
      continue;
    }
    if (!sub.value.is_object() || !sub.value.contains("nodes") || !sub.value["nodes"].is_array()) {
      error(sub.at(""), "a subgraph is a mapping with 'nodes' (and 'inputs' it takes)");
      continue;
    }
    for (auto it = sub.value.begin(); it != sub.value.end(); ++it)
      if (std::find(kSubgraphKeys.begin(), kSubgraphKeys.end(), it.key()) == kSubgraphKeys.end()) {
        const std::string near = nearest_name(it.key(), kSubgraphKeys);
        error(sub.at("/" + ptr_token(it.key()) + "#key"), "unknown subgraph key '" + it.key() + "'" +
                                                              (near.empty() ? "" : "; did you mean '" + near + "'?"));
      }
    stack.push_back(file);
    expand_includes(sub, file.parent_path(), stack, diags, includes);
    stack.pop_back();
    // Declared inputs and their bindings.
    std::set<std::string> declared;
    if (sub.value.contains("inputs")) {
      if (!sub.value["inputs"].is_object())
        error(sub.at("/inputs"), "a subgraph's 'inputs' maps each input name to what it carries");
      else
        for (auto it = sub.value["inputs"].begin(); it != sub.value["inputs"].end(); ++it) declared.insert(it.key());
    }
    std::map<std::string, Json> bound;
    if (entry.contains("inputs")) {
      if (!entry["inputs"].is_object()) {
        error(doc.at(base + "/inputs"), "an include's 'inputs' binds the subgraph's inputs to streams");
      } else {
        for (auto it = entry["inputs"].begin(); it != entry["inputs"].end(); ++it) {
          if (!declared.count(it.key())) {
            const std::string near = nearest_name(it.key(), {declared.begin(), declared.end()});
            error(doc.at(base + "/inputs/" + ptr_token(it.key()) + "#key"),
                  "subgraph '" + file.filename().string() + "' has no input '" + it.key() + "'" +
                      (near.empty() ? "" : "; did you mean '" + near + "'?"));
            continue;
          }
          bound[it.key()] = it.value();
        }
      }
    }
    for (const std::string& d : declared)
      if (!bound.count(d))
        error(doc.at(base + "/include"),
              "include of '" + file.filename().string() + "': input '" + d + "' is not bound (inputs: {" + d + ": NODE.PORT})");
    std::set<std::string> ids;
    for (const Json& n : sub.value["nodes"])
      if (n.is_object() && n.contains("id") && n["id"].is_string()) ids.insert(n["id"].get<std::string>());
    // Param additions per subgraph node id.
    Json extra = entry.contains("params") ? entry["params"] : Json::object();
    if (!extra.is_object()) {
      error(doc.at(base + "/params"), "an include's 'params' maps subgraph node ids to params");
      extra = Json::object();
    }
    for (auto it = extra.begin(); it != extra.end(); ++it)
      if (!ids.count(it.key())) {
        const std::string near = nearest_name(it.key(), {ids.begin(), ids.end()});
        error(doc.at(base + "/params/" + ptr_token(it.key()) + "#key"),
              "subgraph '" + file.filename().string() + "' has no node '" + it.key() + "'" +
                  (near.empty() ? "" : "; did you mean '" + near + "'?"));
      }
    // Renames a stream reference of a subgraph node.
    auto rename = [&](const Json& ref, const SourceLocation& where) -> Json {
      if (!ref.is_string()) return ref;
      const std::string r = ref.get<std::string>();
      if (!r.empty() && r[0] == '$') {
        auto b = bound.find(r.substr(1));
        if (b != bound.end()) return b->second;
        if (!declared.count(r.substr(1)))
          error(where, "'" + r + "' is not an input the subgraph declares");
        return ref;
      }
      const auto dot = r.find('.');
      if (dot != std::string::npos && ids.count(r.substr(0, dot))) return prefix + r;
      error(where, "stream '" + r + "' is not produced inside subgraph '" + file.filename().string() +
                       "'; declare it under 'inputs' and refer to it as $NAME");
      return ref;
    };
    for (size_t k = 0; k < sub.value["nodes"].size(); ++k) {
      Json n = sub.value["nodes"][k];
      const std::string sub_base = "/nodes/" + std::to_string(k);
      const std::string to = "/nodes/" + std::to_string(out.size());
      copy_locations(sub.locations, sub_base, locs, to);
      if (n.is_object() && n.contains("id") && n["id"].is_string()) {
        const std::string id = n["id"].get<std::string>();
        n["id"] = prefix + id;
        if (n.contains("inputs") && n["inputs"].is_object()) {
          for (auto it = n["inputs"].begin(); it != n["inputs"].end(); ++it) {
            const std::string ip = sub_base + "/inputs/" + ptr_token(it.key());
            if (it->is_array()) {
              Json list = Json::array();
              for (size_t e = 0; e < it->size(); ++e) list.push_back(rename((*it)[e], sub.at(ip + "/" + std::to_string(e))));
              *it = list;
            } else {
              *it = rename(*it, sub.at(ip));
            }
          }
        }
        if (n.contains("outputs") && n["outputs"].is_object())
          for (auto it = n["outputs"].begin(); it != n["outputs"].end(); ++it)
            if (it->is_string()) *it = prefix + it->get<std::string>();
        if (extra.contains(id) && extra[id].is_object()) {
          if (!n.contains("params") || !n["params"].is_object()) n["params"] = Json::object();
          for (auto it = extra[id].begin(); it != extra[id].end(); ++it) {
            n["params"][it.key()] = it.value();
            locs[to + "/params/" + ptr_token(it.key())] = doc.at(base + "/params/" + ptr_token(id) + "/" + ptr_token(it.key()));
            locs[to + "/params/" + ptr_token(it.key()) + "#key"] =
                doc.at(base + "/params/" + ptr_token(id) + "/" + ptr_token(it.key()) + "#key");
          }
        }
      }
      out.push_back(std::move(n));
    }
  }
  nodes = std::move(out);
  locs["/nodes"] = doc.at("/nodes");
  doc.locations = std::move(locs);
}

}  // namespace

GraphConfig load_graph_config(const std::filesystem::path& file, const std::vector<std::string>& overrides,
                              const std::filesystem::path& overrides_dir) {
  GraphConfig cfg;
  cfg.file = file;
  cfg.dir = std::filesystem::absolute(file).parent_path();
  cfg.overrides = overrides;
  cfg.overrides_dir =
      std::filesystem::absolute(overrides_dir.empty() ? std::filesystem::current_path() : overrides_dir);
  if (!std::filesystem::exists(file)) throw Error(file.string() + ": error: config file not found");
  cfg.doc = load_yaml_file(file.string());
  std::vector<Diagnostic> diags;
  if (!cfg.doc.value.is_object()) {
    throw DiagnosticError({{Severity::kError, cfg.doc.at(""), "a graph config is a mapping with 'nodes'"}});
  }
  std::vector<std::filesystem::path> stack = {std::filesystem::absolute(file).lexically_normal()};
  int includes = 0;
  expand_includes(cfg.doc, cfg.dir, stack, diags, includes);
  for (const std::string& o : overrides) apply_override(cfg, o, diags);
  const std::map<std::string, std::string> vars = {{"CONFIG_DIR", cfg.dir.string()}};
  std::set<std::string> secrets;
  secret_variables(cfg.doc.value, secrets);
  expand_strings(cfg.doc.value, "", cfg.doc, vars, secrets, diags);
  if (cfg.doc.value.contains("plugin_paths")) {
    const Json& pp = cfg.doc.value["plugin_paths"];
    if (!pp.is_array()) {
      diags.push_back({Severity::kError, cfg.doc.at("/plugin_paths"), "'plugin_paths' must be a list of folders"});
    } else {
      for (size_t i = 0; i < pp.size(); ++i) {
        if (!pp[i].is_string()) {
          diags.push_back({Severity::kError, cfg.doc.at("/plugin_paths/" + std::to_string(i)), "expected a folder"});
          continue;
        }
        std::filesystem::path p = pp[i].get<std::string>();
        cfg.plugin_paths.push_back((p.is_relative() ? cfg.dir / p : p).lexically_normal());
      }
    }
  }
  if (!diags.empty()) throw DiagnosticError(std::move(diags));
  return cfg;
}

const NodeSpec* Graph::node(const std::string& id) const {
  for (const auto& n : nodes)
    if (n.id == id) return &n;
  return nullptr;
}

Graph build_graph(const GraphConfig& cfg, const ComponentRegistry& registry) {
  const YamlDocument& doc = cfg.doc;
  const Json& root = doc.value;
  std::vector<Diagnostic> diags;
  auto error = [&](const SourceLocation& w, std::string msg) { diags.push_back({Severity::kError, w, std::move(msg)}); };

  Graph g;
  g.file = cfg.file;
  g.dir = cfg.dir;
  g.name = cfg.file.stem().string();
  if (root.contains("name")) {
    if (root["name"].is_string())
      g.name = root["name"].get<std::string>();
    else
      error(doc.at("/name"), "'name' must be a string");
  }
  g.description = root.contains("description") && root["description"].is_string() ? root["description"].get<std::string>() : "";

  for (auto it = root.begin(); it != root.end(); ++it) {
    if (std::find(kTopKeys.begin(), kTopKeys.end(), it.key()) == kTopKeys.end()) {
      std::string near = nearest_name(it.key(), kTopKeys);
      error(doc.at("/" + ptr_token(it.key()) + "#key"),
            "unknown top-level key '" + it.key() + "'" + (near.empty() ? "" : "; did you mean '" + near + "'?"));
    }
  }
  if (!root.contains("nodes") || !root["nodes"].is_array() || root["nodes"].empty()) {
    error(doc.at("/nodes"), "the graph needs a non-empty 'nodes' list");
    throw DiagnosticError(std::move(diags));
  }

  // ---- the scene: facts stated once, filled into every parameter bound to them ---------------------------------
  if (root.contains("scene")) {
    validate_scene(root["scene"], [&](const std::string& p) { return doc.at("/scene" + p); }, diags);
    if (root["scene"].is_object()) g.scene = root["scene"];
  }

  // ---- nodes, stages, params -----------------------------------------------------------------------------------
  std::vector<NodeSpec> nodes;
  std::set<std::string> ids;
  const Json& jnodes = root["nodes"];
  for (size_t i = 0; i < jnodes.size(); ++i) {
    const std::string base = "/nodes/" + std::to_string(i);
    const Json& jn = jnodes[i];
    NodeSpec n;
    n.where = doc.at(base);
    if (!jn.is_object()) {
      error(n.where, "a node is a mapping with 'id' and 'stage'");
      continue;
    }
    for (auto it = jn.begin(); it != jn.end(); ++it) {
      if (std::find(kNodeKeys.begin(), kNodeKeys.end(), it.key()) == kNodeKeys.end()) {
        std::string near = nearest_name(it.key(), kNodeKeys);
        error(doc.at(base + "/" + ptr_token(it.key()) + "#key"),
              "unknown node key '" + it.key() + "'" + (near.empty() ? "" : "; did you mean '" + near + "'?"));
      }
    }
    if (!jn.contains("id") || !jn["id"].is_string() || jn["id"].get<std::string>().empty()) {
      error(n.where, "node has no 'id'");
      continue;
    }
    n.id = jn["id"].get<std::string>();
    // A duplicate is reported once; its stage and params are still checked, but it joins no stream.
    const bool duplicate = !ids.insert(n.id).second;
    if (duplicate) error(doc.at(base + "/id"), "duplicate node id '" + n.id + "'");
    const std::string who = "node '" + n.id + "'";
    if (!jn.contains("stage") || !jn["stage"].is_string()) {
      error(n.where, who + " has no 'stage'");
      continue;
    }
    n.stage = jn["stage"].get<std::string>();
    std::string why;
    n.component = registry.find(n.stage, true, &why);
    if (!n.component) {
      error(doc.at(base + "/stage"), who + ": " + why);
      continue;
    }
    const ComponentInfo& info = n.component->info;
    const std::string owner = who + ": stage '" + info.name + "'";
    // params
    Json given = jn.contains("params") ? jn["params"] : Json::object();
    if (cfg.stage_overridden.count(n.id) && given.is_object()) {
      for (auto it = given.begin(); it != given.end();) {
        if (info.param(it.key())) {
          ++it;
          continue;
        }
        g.warnings.push_back({Severity::kWarning, doc.at(base + "/params/" + ptr_token(it.key()) + "#key"),
                              who + ": parameter '" + it.key() + "' dropped: stage '" + info.name +
                                  "' (set on the command line) does not declare it"});
        it = given.erase(it);
      }
    }
    // Parameters bound to a scene fact the scene states take its value; the node restating it is an error.
    auto scene_ptr = [](const std::string& key) {
      const auto dot = key.find('.');
      return "/scene/" + (dot == std::string::npos ? ptr_token(key)
                                                   : ptr_token(key.substr(0, dot)) + "/" + ptr_token(key.substr(dot + 1)));
    };
    std::vector<std::string> from_scene;
    if (given.is_object() && !g.scene.empty()) {
      const Json stated = given;
      for (const std::string& name : fill_from_scene(info.params, g.scene, given)) {
        const ParamSpec* ps = info.param(name);
        if (cfg.params_overridden.count(n.id + "/" + name)) {  // the command line wins over the scene
          g.warnings.push_back({Severity::kWarning, doc.at(base + "/params/" + ptr_token(name)),
                                who + ": --set " + n.id + "." + name + " overrides scene." + ps->scene_key});
          continue;
        }
        error(doc.at(base + "/params/" + ptr_token(name) + "#key"),
              who + ": parameter '" + name + "' restates scene." + ps->scene_key + " (" +
                  doc.at(scene_ptr(ps->scene_key)).str() + "); state it once, in the scene block");
      }
      for (auto it = given.begin(); it != given.end(); ++it)
        if (!stated.contains(it.key())) from_scene.push_back(it.key());
    }
    ParamLocations locs;
    if (given.is_object())
      for (auto it = given.begin(); it != given.end(); ++it) {
        const std::string p = base + "/params/" + ptr_token(it.key());
        locs[it.key()] = doc.locations.count(p + "#key") && !doc.locations.count(p) ? doc.at(p + "#key") : doc.at(p);
        // Unknown names are best pointed at by their key.
        if (!info.param(it.key())) locs[it.key()] = doc.at(p + "#key");
      }
    for (const std::string& name : from_scene) locs[name] = doc.at(scene_ptr(info.param(name)->scene_key));
    if (given.is_object())
      for (auto it = given.begin(); it != given.end(); ++it)
        if (!it->is_null()) n.stated.insert(it.key());
    n.params = validate_params(info.params, given.is_null() ? Json::object() : given, owner, doc.at(base + "/stage"),
                               locs, diags);
    // A relative path in the config file is relative to the config's folder; one typed on the command line
    // (--set node.param=..., --set scene....) to the folder the command was typed in (cfg.overrides_dir).
    for (const ParamSpec& ps : info.params) {
      if (ps.type != ParamType::kPath || !n.params.contains(ps.name) || !n.params[ps.name].is_string())
        continue;
      const auto loc = locs.find(ps.name);
      const std::string text = n.params[ps.name].get<std::string>();
      if (loc == locs.end() || loc->second.file.rfind("--set ", 0) != 0 || text.empty() ||
          !std::filesystem::path(text).is_relative())
        continue;
      n.params[ps.name] = (cfg.overrides_dir / text).lexically_normal().string();
    }
    // inputs
    if (jn.contains("inputs")) {
      const Json& ins = jn["inputs"];
      if (!ins.is_object()) {
        error(doc.at(base + "/inputs"), who + ": 'inputs' maps input ports to streams");
      } else {
        for (auto it = ins.begin(); it != ins.end(); ++it) {
          const std::string p = base + "/inputs/" + ptr_token(it.key());
          const PortSpec* port = info.input(it.key());
          if (!port) {
            std::vector<std::string> names;
            for (const auto& ip : info.inputs) names.push_back(ip.name);
            std::string near = nearest_name(it.key(), names);
            error(doc.at(p + "#key"), who + ": stage '" + info.name + "' has no input '" + it.key() + "'" +
                                          (near.empty() ? "" : "; did you mean '" + near + "'?"));
            continue;
          }
          std::vector<std::string> streams;
          if (it->is_string()) {
            streams.push_back(it->get<std::string>());
          } else if (it->is_array() && port->multi) {
            for (const Json& s : *it)
              if (s.is_string()) streams.push_back(s.get<std::string>());
              else error(doc.at(p), who + ": input '" + it.key() + "' lists a non-string stream");
          } else if (it->is_array()) {
            error(doc.at(p), who + ": input '" + it.key() + "' takes one stream, not a list");
            continue;
          } else {
            error(doc.at(p), who + ": input '" + it.key() + "' must name a stream like 'node.port'");
            continue;
          }
          n.inputs[it.key()] = streams;
        }
      }
    }
    for (const PortSpec& ip : info.inputs)
      if (!ip.optional && !n.inputs.count(ip.name))
        error(doc.at(base + "/stage"), who + ": required input '" + ip.name + "' (" + ip.type_str() + ") is not connected");
    // outputs: defaults to "<id>.<port>", renames allowed
    for (const PortSpec& op : info.outputs) n.outputs[op.name] = n.id + "." + op.name;
    if (jn.contains("outputs")) {
      const Json& outs = jn["outputs"];
      if (!outs.is_object()) {
        error(doc.at(base + "/outputs"), who + ": 'outputs' maps output ports to stream names");
      } else {
        for (auto it = outs.begin(); it != outs.end(); ++it) {
          if (!info.output(it.key())) {
            std::vector<std::string> names;
            for (const auto& op : info.outputs) names.push_back(op.name);
            std::string near = nearest_name(it.key(), names);
            error(doc.at(base + "/outputs/" + ptr_token(it.key()) + "#key"),
                  who + ": stage '" + info.name + "' has no output '" + it.key() + "'" +
                      (near.empty() ? "" : "; did you mean '" + near + "'?"));
          } else if (!it->is_string()) {
            error(doc.at(base + "/outputs/" + ptr_token(it.key())), who + ": output stream names are strings");
          } else {
            n.outputs[it.key()] = it->get<std::string>();
          }
        }
      }
    }
    if (!duplicate) nodes.push_back(std::move(n));
  }

  // ---- streams: exactly one producer each, types match ------------------------------------------------------
  std::map<std::string, std::pair<const NodeSpec*, const PortSpec*>> producers;
  for (const NodeSpec& n : nodes) {
    for (const auto& [port, stream] : n.outputs) {
      const PortSpec* ps = n.component->info.output(port);
      auto [it, inserted] = producers.emplace(stream, std::make_pair(&n, ps));
      if (!inserted) {
        error(n.where, "stream '" + stream + "' has two producers: node '" + it->second.first->id + "' (output '" +
                           it->second.second->name + "') and node '" + n.id + "' (output '" + port + "')");
      }
    }
  }
  std::vector<std::string> stream_names;
  for (const auto& [s, p] : producers) stream_names.push_back(s);
  // Indexes built once keep validation near-linear in nodes and edges (graphs with tens of thousands of
  // nodes).
  std::unordered_map<std::string, size_t> json_index;  // node id -> its (last) position in the file
  for (size_t j = 0; j < jnodes.size(); ++j)
    if (jnodes[j].is_object() && jnodes[j].contains("id") && jnodes[j]["id"].is_string())
      json_index[jnodes[j]["id"].get<std::string>()] = j;
  for (size_t i = 0; i < nodes.size(); ++i) {
    const NodeSpec& n = nodes[i];
    for (const auto& [port, streams] : n.inputs) {
      const PortSpec* ip = n.component->info.input(port);
      for (size_t k = 0; k < streams.size(); ++k) {
        std::string p;
        if (auto j = json_index.find(n.id); j != json_index.end()) p = "/nodes/" + std::to_string(j->second);
        p += "/inputs/" + ptr_token(port);
        if (ip->multi && jnodes.is_array()) p += "/" + std::to_string(k);
        const std::string& s = streams[k];
        auto it = producers.find(s);
        if (it == producers.end()) {
          std::string near = nearest_name(s, stream_names);
          error(doc.at(p), "node '" + n.id + "': input '" + port + "' reads stream '" + s +
                               "', which no node produces" + (near.empty() ? "" : "; did you mean '" + near + "'?"));
          continue;
        }
        const PortSpec* op = it->second.second;
        const bool any = ip->type_name == kAnyType || op->type_name == kAnyType;
        if (!any && (ip->type_name != op->type_name || ip->type_version != op->type_version)) {
          error(doc.at(p), "node '" + n.id + "': input '" + port + "' takes " + ip->type_str() + " but stream '" + s +
                               "' carries " + op->type_str() + " (from node '" + it->second.first->id + "')");
        }
      }
    }
  }

  // ---- one source ---------------------------------------------------------------------------------------------
  std::vector<std::string> sources;
  for (const NodeSpec& n : nodes)
    if (n.component->info.is_source) sources.push_back(n.id);
  if (sources.empty() && diags.empty()) error(doc.at("/nodes"), "the graph has no source node");
  if (sources.size() > 1) {
    std::string list;
    for (const auto& s : sources) list += (list.empty() ? "'" : ", '") + s + "'";
    error(doc.at("/nodes"), "the graph has " + std::to_string(sources.size()) + " source nodes (" + list +
                                "); a graph is driven by exactly one source");
  }

  // ---- topological order and cycles
  // ----------------------------------------------------------------------------- Depth-first search with an
  // explicit stack: a chain of 80,000 nodes must not recurse 80,000 calls deep.
  std::unordered_map<std::string, size_t> index_of;  // node id -> position in `nodes`
  for (size_t i = 0; i < nodes.size(); ++i) index_of.emplace(nodes[i].id, i);
  std::vector<std::vector<size_t>> deps(nodes.size());  // node -> upstream nodes
  for (size_t i = 0; i < nodes.size(); ++i)
    for (const auto& [port, streams] : nodes[i].inputs)
      for (const auto& s : streams)
        if (auto it = producers.find(s); it != producers.end())
          deps[i].push_back(index_of.at(it->second.first->id));
  std::vector<int> state(nodes.size(), 0);     // 0 new, 1 on the path, 2 done
  std::vector<size_t> path_pos(nodes.size());  // where a node on the path sits in `path`
  std::vector<size_t> order;
  std::set<std::string> reported;
  struct Visit {
    size_t node, next_dep;
  };
  for (size_t root_node = 0; root_node < nodes.size(); ++root_node) {
    if (state[root_node] != 0) continue;
    std::vector<Visit> path{{root_node, 0}};
    state[root_node] = 1;
    path_pos[root_node] = 0;
    while (!path.empty()) {
      Visit& v = path.back();
      if (v.next_dep == deps[v.node].size()) {
        state[v.node] = 2;
        order.push_back(v.node);
        path.pop_back();
        continue;
      }
      const size_t d = deps[v.node][v.next_dep++];
      if (state[d] == 1) {
        std::vector<std::string> cyc;
        for (size_t k = path_pos[d]; k < path.size(); ++k) cyc.push_back(nodes[path[k].node].id);
        std::vector<std::string> key = cyc;
        std::sort(key.begin(), key.end());
        std::string k;
        for (auto& x : key) k += x + ",";
        if (reported.insert(k).second) {
          std::string text;
          for (auto& x : cyc) text += "'" + x + "' -> ";
          text += "'" + nodes[d].id + "'";
          error(nodes[d].where, "the graph has a cycle: " + text);
        }
      } else if (state[d] == 0) {
        state[d] = 1;
        path_pos[d] = path.size();
        path.push_back({d, 0});
      }
    }
  }

  if (!diags.empty()) throw DiagnosticError(std::move(diags));

  for (const auto& [s, p] : producers) g.producers[s] = {p.first->id, p.second->name};
  for (const size_t i : order) g.nodes.push_back(std::move(nodes[i]));
  return g;
}

std::string Graph::to_dot() const {
  std::ostringstream os;
  auto q = [](const std::string& s) {
    std::string o = "\"";
    for (char c : s) o += (c == '"' ? std::string("\\\"") : std::string(1, c));
    return o + "\"";
  };
  os << "digraph " << q(name) << " {\n  rankdir=LR;\n  node [shape=box, style=rounded, fontname=\"Helvetica\"];\n";
  for (const NodeSpec& n : nodes)
    os << "  " << q(n.id) << " [label=" << q(n.id + "\\n" + n.component->info.kind + "/" + n.component->info.name)
       << "];\n";
  std::unordered_map<std::string, const NodeSpec*> by_id;
  for (const NodeSpec& n : nodes) by_id.emplace(n.id, &n);
  for (const NodeSpec& n : nodes)
    for (const auto& [port, streams] : n.inputs)
      for (const auto& s : streams) {
        auto it = producers.find(s);
        if (it == producers.end()) continue;
        const auto found = by_id.find(it->second.first);
        const NodeSpec* src = found == by_id.end() ? nullptr : found->second;
        const PortSpec* op = src ? src->component->info.output(it->second.second) : nullptr;
        os << "  " << q(it->second.first) << " -> " << q(n.id) << " [label="
           << q(it->second.second + " → " + port + (op ? "\\n" + op->type_str() : "")) << "];\n";
      }
  os << "}\n";
  return os.str();
}

Json Graph::resolved() const {
  Json j = {{"name", name}, {"file", file.string()}, {"scene", scene}, {"nodes", Json::array()}};
  for (const NodeSpec& n : nodes) {
    Json jn = {{"id", n.id},
               {"stage", n.component->info.kind + "/" + n.component->info.name},
               {"library", n.component->library},
               {"plugin", n.component->plugin_name},
               {"plugin_version", n.component->plugin_version},
               {"params", n.params},
               {"inputs", n.inputs},
               {"outputs", n.outputs}};
    j["nodes"].push_back(jn);
  }
  return j;
}

Graph Graph::subgraph(const std::vector<std::string>& keep) const {
  Graph g = *this;
  g.nodes.clear();
  for (const NodeSpec& n : nodes)
    if (std::find(keep.begin(), keep.end(), n.id) != keep.end()) g.nodes.push_back(n);
  for (auto it = g.producers.begin(); it != g.producers.end();)
    it = std::find(keep.begin(), keep.end(), it->second.first) == keep.end() ? g.producers.erase(it) : std::next(it);
  return g;
}

}  // namespace hf::core
