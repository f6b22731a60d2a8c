// Component registry: registration with duplicate detection, lookup with suggestions, creation.
#include "hazardforge/registry.hpp"

#include "hazardforge/scene.hpp"

namespace hf {

void ComponentRegistry::set_origin(std::string library, std::string plugin_name, std::string plugin_version) {
  library_ = std::move(library);
  plugin_name_ = std::move(plugin_name);
  plugin_version_ = std::move(plugin_version);
}

void ComponentRegistry::add_component(ComponentInfo info, ComponentMaker make) {
  if (info.name.empty()) throw Error("a component was registered without a name");
  if (info.kind.empty()) throw Error("component '" + info.name + "' was registered without a kind");
  if (const RegisteredComponent* prev = find(info.kind, info.name)) {
    throw Error("duplicate " + info.kind + " '" + info.name + "': registered by " +
                (prev->library.empty() ? std::string("<built-in>") : prev->library) + " and by " +
                (library_.empty() ? std::string("<built-in>") : library_));
  }
  entries_.push_back({std::move(info), make, library_, plugin_name_, plugin_version_});
}

const RegisteredComponent* ComponentRegistry::find(const std::string& kind, const std::string& name) const {
  for (const auto& e : entries_)
    if (e.info.kind == kind && e.info.name == name) return &e;
  return nullptr;
}

const RegisteredComponent* ComponentRegistry::find(const std::string& qualified, bool stages_only,
                                                   std::string* error) const {
  std::string kind, name = qualified;
  if (auto slash = qualified.find('/'); slash != std::string::npos) {
    kind = qualified.substr(0, slash);
    name = qualified.substr(slash + 1);
  }
  std::vector<const RegisteredComponent*> hits;
  std::vector<std::string> names;
  for (const auto& e : entries_) {
    if (stages_only && !e.info.is_stage) continue;
    names.push_back(e.info.name);
    if (e.info.name == name && (kind.empty() || e.info.kind == kind)) hits.push_back(&e);
  }
  if (hits.size() == 1) return hits.front();
  if (error) {
    if (hits.empty()) {
      std::string near = nearest_name(name, names);
      *error = "unknown " + std::string(stages_only ? "stage" : "component") + " '" + qualified + "'" +
               (near.empty() ? std::string() : "; did you mean '" + near + "'?");
    } else {
      std::string list;
      for (const auto* h : hits) list += (list.empty() ? "" : ", ") + h->info.kind + "/" + h->info.name;
      *error = "stage name '" + qualified + "' is ambiguous: " + list + "; write it as kind/name";
    }
  }
  return nullptr;
}

Params ComponentRegistry::make_params(const ComponentInfo& info, const Json& given,
                                      const std::filesystem::path& base_dir, const std::string& owner) {
  std::vector<Diagnostic> diags;
  Json values = validate_params(info.params, given, owner, {}, {}, diags);
  if (!diags.empty()) throw DiagnosticError(std::move(diags));
  Params p(std::move(values), base_dir);
  std::set<std::string> stated;
  if (given.is_object())
    for (auto it = given.begin(); it != given.end(); ++it)
      if (!it->is_null()) stated.insert(it.key());
  p.set_stated(std::move(stated));
  return p;
}

std::unique_ptr<Component> ComponentRegistry::create_component(const std::string& kind, const std::string& name,
                                                               const Json& params) const {
  return create_component(kind, name, params, Json::object());
}

std::unique_ptr<Component> ComponentRegistry::create_component(const std::string& kind, const std::string& name,
                                                               const Json& params, const Json& scene) const {
  const RegisteredComponent* e = find(kind, name);
  if (!e) {
    std::string near = nearest_name(name, component_names(kind));
    throw Error("unknown " + kind + " '" + name + "'" + (near.empty() ? "" : "; did you mean '" + near + "'?"));
  }
  std::unique_ptr<Component> c = e->make();
  // Providers and templates take their params through open(); validate here so messages are uniform.
  Json given = params.is_null() ? Json::object() : params;
  fill_from_scene(e->info.params, scene, given);
  Params p = make_params(e->info, given, {}, kind + " '" + name + "'");
  if (auto* llm = dynamic_cast<LlmProvider*>(c.get())) llm->open(p);
  if (auto* tpl = dynamic_cast<HazardTemplate*>(c.get())) tpl->open(p);
  return c;
}

std::vector<std::string> ComponentRegistry::component_names(const std::string& kind) const {
  std::vector<std::string> v;
  for (const auto& e : entries_)
    if (e.info.kind == kind) v.push_back(e.info.name);
  return v;
}

}  // namespace hf
