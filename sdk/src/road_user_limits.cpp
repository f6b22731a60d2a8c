// The road-user limits table: reading share/hazard_limits.yaml with every bad field named.
#include "hazardforge/road_user_limits.hpp"

#include "hazardforge/error.hpp"
#include "hazardforge/geometry.hpp"
#include "hazardforge/yaml_json.hpp"

namespace hf {

namespace {
struct LimitField {
  const char* name;
  double KinematicLimits::*member;
};
constexpr LimitField kLimitFields[] = {
    {"max_speed_mps", &KinematicLimits::max_speed_mps},
    {"max_accel_mps2", &KinematicLimits::max_accel_mps2},
    {"max_decel_mps2", &KinematicLimits::max_decel_mps2},
    {"max_jerk_mps3", &KinematicLimits::max_jerk_mps3},
    {"max_lateral_accel_mps2", &KinematicLimits::max_lateral_accel_mps2},
    {"max_lateral_speed_mps", &KinematicLimits::max_lateral_speed_mps},
    {"max_yaw_rate_dps", &KinematicLimits::max_yaw_rate_dps},
};
}  // namespace

LimitsTable LimitsTable::load(const std::string& path) {
  YamlDocument doc = load_yaml_file(path);
  LimitsTable table;
  table.file_ = path;
  if (!doc.value.is_object()) throw Error(doc.at(""), "hazard limits must be a mapping of class -> limits");
  for (auto it = doc.value.begin(); it != doc.value.end(); ++it) {
    const std::string ptr = "/" + it.key();
    if (!it->is_object()) throw Error(doc.at(ptr), "class '" + it.key() + "' needs a mapping of limits");
    KinematicLimits l;
    l.object_class = it.key();
    for (const LimitField& f : kLimitFields) {
      if (!it->contains(f.name) || !(*it)[f.name].is_number() || (*it)[f.name].get<double>() <= 0)
        throw Error(doc.at(ptr + "/" + f.name),
                    "class '" + it.key() + "': '" + f.name + "' must be a positive number");
      l.*f.member = (*it)[f.name].get<double>();
    }
    for (auto k = it->begin(); k != it->end(); ++k) {
      bool known = false;
      for (const LimitField& f : kLimitFields) known = known || k.key() == f.name;
      if (!known)
        throw Error(doc.at(ptr + "/" + k.key() + "#key"),
                    "class '" + it.key() + "': unknown limit '" + k.key() + "'");
    }
    table.limits_[l.object_class] = l;
  }
  return table;
}

std::string LimitsTable::default_path() {
  return share_dir() + "/hazard_limits.yaml";
}

const KinematicLimits& LimitsTable::at(const std::string& object_class) const {
  auto it = limits_.find(object_class);
  if (it == limits_.end()) {
    std::string known;
    for (const auto& c : classes()) known += (known.empty() ? "" : ", ") + c;
    throw Error("object_class '" + object_class + "' has no kinematic limits in " +
                (file_.empty() ? std::string("the limits table") : file_) + " (known: " + known + ")");
  }
  return it->second;
}

std::vector<std::string> LimitsTable::classes() const {
  std::vector<std::string> v;
  for (const auto& [k, l] : limits_) v.push_back(k);
  return v;
}

}  // namespace hf
