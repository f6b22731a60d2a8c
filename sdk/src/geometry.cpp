// In-path corridor, class size priors, and locating the project's share folder.
#include "hazardforge/geometry.hpp"

#include <dlfcn.h>

#include <cmath>
#include <cstdlib>
#include <filesystem>

#include "hazardforge/yaml_json.hpp"

namespace hf {

bool Corridor::contains(double longitudinal, double lateral, double object_width) const {
  return longitudinal > 0 && std::abs(lateral) < ego_half_width + margin + object_width / 2.0;
}

std::vector<ParamSpec> Corridor::params() {
  return {ParamSpec::number("corridor_half_width", 1.0).range(0, 10).describe("ego half-width (m)"),
          ParamSpec::number("corridor_margin", 0.5)
              .range(0, 10)
              .describe("extra lateral margin (m); in path when |y| < half_width + margin + object_width/2")};
}

Corridor Corridor::from(const Params& p) {
  Corridor c;
  if (p.has("corridor_half_width")) c.ego_half_width = p.get_double("corridor_half_width");
  if (p.has("corridor_margin")) c.margin = p.get_double("corridor_margin");
  return c;
}

ClassPriors ClassPriors::load(const std::string& path) {
  YamlDocument doc = load_yaml_file(path);
  ClassPriors pr;
  pr.file_ = path;
  if (!doc.value.is_object()) throw Error(doc.at(""), "class size priors must be a mapping of label -> sizes");
  for (auto it = doc.value.begin(); it != doc.value.end(); ++it) {
    const std::string ptr = "/" + it.key();
    if (!it->is_object()) throw Error(doc.at(ptr), "class '" + it.key() + "' needs {height, width, length}");
    ClassSize s;
    for (const char* f : {"height", "width", "length"}) {
      if (!it->contains(f) || !(*it)[f].is_number() || (*it)[f].get<double>() <= 0)
        throw Error(doc.at(ptr + "/" + f), "class '" + it.key() + "': '" + f + "' must be a positive number (m)");
    }
    s.height = (*it)["height"].get<double>();
    s.width = (*it)["width"].get<double>();
    s.length = (*it)["length"].get<double>();
    pr.sizes_[it.key()] = s;
  }
  return pr;
}

const ClassSize& ClassPriors::at(const std::string& label) const {
  auto it = sizes_.find(label);
  if (it == sizes_.end())
    throw Error("no size prior for class '" + label + "'" + (file_.empty() ? "" : " in " + file_));
  return it->second;
}

std::string share_dir() {
  if (const char* env = std::getenv("HAZARDFORGE_SHARE"); env && *env) return env;
  Dl_info info{};
  if (dladdr(reinterpret_cast<void*>(&share_dir), &info) && info.dli_fname) {
    namespace fs = std::filesystem;
    fs::path installed = fs::path(info.dli_fname).parent_path().parent_path() / "share" / "hazardforge";
    if (fs::exists(installed / "class_sizes.yaml")) return installed.string();
  }
  return HF_SOURCE_SHARE_DIR;
}

}  // namespace hf
