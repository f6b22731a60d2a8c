// Class size priors, box truncation, and locating the project's share folder.
#include "hazardforge/geometry.hpp"

#include <dlfcn.h>

#include <cmath>
#include <cstdlib>
#include <filesystem>

#include "hazardforge/yaml_json.hpp"

namespace hf {

unsigned truncation_flags(const cv::Rect2f& box, const cv::Size& image, double margin_px) {
  unsigned f = 0;
  if (box.x <= margin_px) f |= truncation::kLeft;
  if (box.y <= margin_px) f |= truncation::kTop;
  if (box.x + box.width >= image.width - margin_px) f |= truncation::kRight;
  if (box.y + box.height >= image.height - margin_px) f |= truncation::kBottom;
  return f;
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
