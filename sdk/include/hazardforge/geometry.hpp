// Shared geometry for risk metrics and renderers: the in-path corridor and per-class size priors.
#pragma once

#include <map>
#include <string>
#include <vector>

#include "hazardforge/abi.hpp"
#include "hazardforge/params.hpp"
#include "hazardforge/types.hpp"

HF_SDK_BEGIN
namespace hf {

// An object is in the ego's path when it is ahead and |lateral| < ego_half_width + margin + object_width/2.
struct Corridor {
  double ego_half_width = 1.0;
  double margin = 0.5;
  bool contains(double longitudinal, double lateral, double object_width) const;
  bool contains(const ObjectState& s) const { return contains(s.distance_m, s.lateral_m, s.width_m); }
  // Params "corridor_half_width" and "corridor_margin", appended to every risk metric's declaration.
  static std::vector<ParamSpec> params();
  static Corridor from(const Params& p);
};

// Typical real-world size of a road-user class (m), read from share/class_sizes.yaml.
struct ClassSize {
  double height = 1.5;
  double width = 1.8;
  double length = 4.5;
};

class ClassPriors {
 public:
  // YAML mapping label -> {height, width, length}. Throws hf::Error naming the file and field.
  static ClassPriors load(const std::string& path);
  bool has(const std::string& label) const { return sizes_.count(label) != 0; }
  // Throws hf::Error naming the label and file when the class has no prior.
  const ClassSize& at(const std::string& label) const;
  const std::map<std::string, ClassSize>& all() const { return sizes_; }
  void set(const std::string& label, ClassSize s) { sizes_[label] = s; }

 private:
  std::map<std::string, ClassSize> sizes_;
  std::string file_;
};

// The folder holding the project's shared files (prompts, priors, schemas, assets): $HAZARDFORGE_SHARE,
// else the install's share/hazardforge, else the source tree's share/ (set at build time).
std::string share_dir();

}  // namespace hf
HF_SDK_END
