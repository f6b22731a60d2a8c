// Refusals as "code: text" lines, so a test states both what a check says and how it classifies it.
#pragma once

#include <ostream>
#include <string>
#include <vector>

#include "hazardforge/refusal.hpp"

namespace hf::test {

inline std::string coded(const Refusal& r) {
  return r.code + ": " + r.text;
}

inline std::vector<std::string> coded(const std::vector<Refusal>& reasons) {
  std::vector<std::string> out;
  for (const Refusal& r : reasons) out.push_back(coded(r));
  return out;
}

}  // namespace hf::test

namespace hf {
// For gtest messages ("<< reasons.front()") and failure output.
inline std::ostream& operator<<(std::ostream& os, const Refusal& r) {
  return os << r.code << ": " << r.text;
}
}  // namespace hf
