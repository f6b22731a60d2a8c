// Numbers as text for messages, logs, reports and file names: the one implementation of each rule.
#pragma once

#include <cmath>
#include <cstdio>
#include <sstream>
#include <string>

#include "hazardforge/abi.hpp"

HF_SDK_BEGIN
namespace hf {

namespace number_text_detail {
inline std::string non_finite(double v) {
  return std::isnan(v) ? "nan" : (v > 0 ? "inf" : "-inf");
}
// "-0", "-0.00": a zero printed with a sign reads badly and differs between platforms.
inline void drop_negative_zero(std::string& s) {
  if (!s.empty() && s[0] == '-' && s.find_first_not_of("-0.") == std::string::npos) s.erase(0, 1);
}
}  // namespace number_text_detail

// Exactly `decimals` decimals ("3.10"): tables and reports whose columns line up. Non-finite values are
// "nan", "inf", "-inf".
inline std::string fixed_text(double v, int decimals) {
  if (!std::isfinite(v)) return number_text_detail::non_finite(v);
  char buf[64];
  std::snprintf(buf, sizeof buf, "%.*f", decimals, v);
  std::string s = buf;
  number_text_detail::drop_negative_zero(s);
  return s;
}

// At most `decimals` decimals, trailing zeros dropped ("3.1", "12"): numbers inside sentences.
inline std::string num_text(double v, int decimals = 2) {
  std::string s = fixed_text(v, decimals);
  if (std::isfinite(v) && s.find('.') != std::string::npos) {
    while (s.back() == '0') s.pop_back();
    if (s.back() == '.') s.pop_back();
  }
  number_text_detail::drop_negative_zero(s);
  return s;
}

// Six significant digits, as a C++ stream prints a double ("0.001", "1e+06"): parameter values and ranges
// whose magnitude is not known in advance.
inline std::string general_text(double v) {
  std::ostringstream os;
  os << v;
  return os.str();
}

}  // namespace hf
HF_SDK_END
