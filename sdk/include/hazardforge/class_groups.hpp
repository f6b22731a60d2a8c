// Labels that name one kind of object for association and duplicate suppression (car / truck / bus ...).
#pragma once

#include <map>
#include <sstream>
#include <string>
#include <vector>

#include "hazardforge/abi.hpp"

HF_SDK_BEGIN
namespace hf {

// Which labels count as the same class for association. Detectors flicker between neighbouring COCO classes
// (car / truck / bus) on one object; grouping them keeps such a track alive under a class gate.
class ClassGroups {
 public:
  ClassGroups() = default;
  // Each entry is a comma-separated group, e.g. "car,truck,bus". A label in no group is only equal to itself.
  explicit ClassGroups(const std::vector<std::string>& groups) {
    int g = 0;
    for (const std::string& entry : groups) {
      std::stringstream ss(entry);
      std::string label;
      while (std::getline(ss, label, ',')) {
        label.erase(0, label.find_first_not_of(' '));
        label.erase(label.find_last_not_of(' ') + 1);
        if (!label.empty()) group_[label] = g;
      }
      ++g;
    }
  }
  bool same(const std::string& a, const std::string& b) const {
    if (a == b) return true;
    auto ia = group_.find(a), ib = group_.find(b);
    return ia != group_.end() && ib != group_.end() && ia->second == ib->second;
  }

 private:
  std::map<std::string, int> group_;
};

inline const std::vector<std::string>& default_class_groups() {
  static const std::vector<std::string> g = {"car,truck,bus", "bicycle,motorcycle"};
  return g;
}

}  // namespace hf
HF_SDK_END
