// The component registry: what plugins registered, looked up by name (optionally "kind/name").
// Shared by the host and the stage test harness so both validate and create components the same way.
#pragma once

#include <map>
#include <string>
#include <vector>

#include "hazardforge/abi.hpp"
#include "hazardforge/plugin.hpp"

HF_SDK_BEGIN
namespace hf {

struct RegisteredComponent {
  ComponentInfo info;
  ComponentMaker make = nullptr;
  std::string library;         // path of the shared library that registered it ("" = built in)
  std::string plugin_name;     // descriptor name
  std::string plugin_version;  // descriptor version
};

class ComponentRegistry : public Registrar, public ComponentFactory {
 public:
  // Components added from now on are attributed to this library / plugin.
  void set_origin(std::string library, std::string plugin_name, std::string plugin_version);
  // Throws hf::Error if the same kind/name is already registered, naming both libraries.
  void add_component(ComponentInfo info, ComponentMaker make) override;

  // Looks up "name" or "kind/name". With `stages_only`, providers and templates are not candidates.
  // On failure `error` says why: unknown (with the nearest name) or ambiguous (listing the kinds).
  const RegisteredComponent* find(const std::string& name, bool stages_only, std::string* error) const;
  const RegisteredComponent* find(const std::string& kind, const std::string& name) const;
  const std::vector<RegisteredComponent>& all() const { return entries_; }

  std::unique_ptr<Component> create_component(const std::string& kind, const std::string& name,
                                              const Json& params) const override;
  std::vector<std::string> component_names(const std::string& kind) const override;
  // Same, with the run's `scene:` block filling the component's scene-bound params (a value the creating
  // stage passes wins).
  std::unique_ptr<Component> create_component(const std::string& kind, const std::string& name, const Json& params,
                                              const Json& scene) const;

  // Validates `given` against the component's declared params; throws hf::DiagnosticError.
  static Params make_params(const ComponentInfo& info, const Json& given, const std::filesystem::path& base_dir,
                            const std::string& owner);

 private:
  std::vector<RegisteredComponent> entries_;
  std::string library_, plugin_name_, plugin_version_;
};

}  // namespace hf
HF_SDK_END
