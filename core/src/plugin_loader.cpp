// dlopen-based plugin loading with the descriptor handshake (size, ABI major/minor, ABI tag) checked first.
#include "hazardforge/core/plugin_loader.hpp"

#include "hazardforge/core/elf_symbols.hpp"

#include <dlfcn.h>
#include <unistd.h>

#include <algorithm>
#include <cstdlib>
#include <set>
#include <sstream>

namespace hf::core {

namespace {

// Collects a plugin's registrations so that a failing or clashing plugin registers nothing.
class StagingRegistrar : public Registrar {
 public:
  std::vector<std::pair<ComponentInfo, ComponentMaker>> items;
  void add_component(ComponentInfo info, ComponentMaker make) override { items.emplace_back(std::move(info), make); }
};

std::string abi_str(uint32_t major, uint32_t minor) { return std::to_string(major) + "." + std::to_string(minor); }

}  // namespace

void PluginLoader::load(const std::filesystem::path& library) {
  const std::string path = library.string();
  if (!std::filesystem::exists(library)) throw Error(path + ": plugin library not found");
  for (const auto& p : plugins_)
    if (std::filesystem::equivalent(p.path, library)) return;  // already loaded

  // dlopen runs a library's constructors: a file that does not even export the entry symbol is refused first.
  if (!elf_exports_symbol(library, HF_PLUGIN_ENTRY_SYMBOL))
    throw Error(path + ": not a HazardForge plugin: entry symbol '" HF_PLUGIN_ENTRY_SYMBOL "' not found");
  dlerror();
  void* handle = dlopen(path.c_str(), RTLD_NOW | RTLD_LOCAL);
  if (!handle) {
    const char* e = dlerror();
    throw Error("cannot load plugin " + path + ": " + (e ? e : "unknown dlopen error"));
  }
  // Never dlclose: stage objects and their vtables must outlive every use, and some libraries
  // (OpenCV, CUDA, TLS users) misbehave on unload.
  dlerror();
  void* sym = dlsym(handle, HF_PLUGIN_ENTRY_SYMBOL);
  if (!sym) {
    throw Error(path + ": not a HazardForge plugin: entry symbol '" HF_PLUGIN_ENTRY_SYMBOL "' not found");
  }
  auto entry = reinterpret_cast<hf_plugin_entry_fn>(sym);
  const hf_plugin_descriptor* d = entry();
  if (!d) throw Error(path + ": plugin entry returned no descriptor");
  if (d->struct_size < sizeof(hf_plugin_descriptor)) {
    throw Error(path + ": plugin descriptor is " + std::to_string(d->struct_size) + " bytes, host expects " +
                std::to_string(sizeof(hf_plugin_descriptor)));
  }
  if (d->abi_major != HF_SDK_ABI_MAJOR) {
    throw Error(path + ": plugin built for SDK ABI " + abi_str(d->abi_major, d->abi_minor) + ", host has " +
                abi_str(HF_SDK_ABI_MAJOR, HF_SDK_ABI_MINOR) + " (major versions must match)");
  }
  if (d->abi_minor > HF_SDK_ABI_MINOR) {
    throw Error(path + ": plugin built for SDK ABI " + abi_str(d->abi_major, d->abi_minor) + ", host has " +
                abi_str(HF_SDK_ABI_MAJOR, HF_SDK_ABI_MINOR) + " (plugin needs a newer host)");
  }
  const std::string tag = d->abi_tag ? d->abi_tag : "";
  if (tag != HF_ABI_TAG) {
    throw Error(path + ": ABI tag mismatch: plugin '" + tag + "', host '" HF_ABI_TAG "'");
  }
  const std::string name = d->name ? d->name : "";
  if (name.empty() || !d->register_components) throw Error(path + ": plugin descriptor has no name or register function");

  StagingRegistrar staging;
  char err[1024] = {0};
  if (d->register_components(&staging, err, sizeof err) != 0) {
    throw Error(path + ": plugin '" + name + "' failed to register: " + err);
  }
  // Check every registration before adding any, so a clash leaves the registry as it was.
  std::set<std::pair<std::string, std::string>> seen;
  for (const auto& [info, make] : staging.items) {
    if (const RegisteredComponent* prev = registry_.find(info.kind, info.name)) {
      throw Error("duplicate " + info.kind + " '" + info.name + "': registered by " +
                  (prev->library.empty() ? std::string("<built-in>") : prev->library) + " and by " + path);
    }
    if (!seen.insert({info.kind, info.name}).second)
      throw Error(path + ": plugin '" + name + "' registers " + info.kind + " '" + info.name + "' twice");
  }
  LoadedPlugin lp{library, name, d->version ? d->version : "", d->license ? d->license : "",
                  d->description ? d->description : "", {}};
  registry_.set_origin(path, lp.name, lp.version);
  for (auto& [info, make] : staging.items) {
    lp.components.push_back(info.kind + "/" + info.name);
    registry_.add_component(std::move(info), make);
  }
  registry_.set_origin("", "", "");
  plugins_.push_back(std::move(lp));
}

void PluginLoader::load_dir(const std::filesystem::path& dir, std::vector<std::string>& errors) {
  std::error_code ec;
  if (!std::filesystem::is_directory(dir, ec)) return;
  std::vector<std::filesystem::path> libs;
  for (const auto& e : std::filesystem::directory_iterator(dir, ec))
    if (e.is_regular_file() && e.path().extension() == ".so") libs.push_back(e.path());
  std::sort(libs.begin(), libs.end());
  for (const auto& lib : libs) {
    try {
      load(lib);
    } catch (const Error& e) {
      errors.push_back(e.what());
    }
  }
}

std::filesystem::path executable_dir() {
  std::error_code ec;
  auto p = std::filesystem::read_symlink("/proc/self/exe", ec);
  return ec ? std::filesystem::current_path() : p.parent_path();
}

std::vector<std::filesystem::path> plugin_search_path(const std::vector<std::string>& cli_paths,
                                                      const std::vector<std::filesystem::path>& config_paths) {
  std::vector<std::filesystem::path> out;
  for (const auto& p : cli_paths) out.emplace_back(p);
  if (const char* env = std::getenv("HAZARDFORGE_PLUGIN_PATH"); env && *env) {
    std::stringstream ss(env);
    std::string item;
    while (std::getline(ss, item, ':'))
      if (!item.empty()) out.emplace_back(item);
  }
  for (const auto& p : config_paths) out.push_back(p);
  out.push_back((executable_dir() / ".." / "lib" / "hazardforge" / "plugins").lexically_normal());
  // The install may use lib64 or a multiarch libdir.
  out.push_back((executable_dir() / ".." / HF_PLUGIN_INSTALL_REL).lexically_normal());
  std::vector<std::filesystem::path> unique;
  for (auto& p : out)
    if (std::find(unique.begin(), unique.end(), p) == unique.end()) unique.push_back(p);
  return unique;
}

}  // namespace hf::core
