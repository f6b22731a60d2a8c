// The kit's medians (internal): one implementation of each.
#pragma once

#include <algorithm>
#include <cstddef>
#include <limits>
#include <vector>

namespace hf::footage::detail {

// The median (the mean of the two middle values for an even count); NaN for none.
inline double median(std::vector<double> v) {
  if (v.empty()) return std::numeric_limits<double>::quiet_NaN();
  const size_t m = v.size() / 2;
  std::nth_element(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(m), v.end());
  double r = v[m];
  if (v.size() % 2 == 0) r = 0.5 * (r + *std::max_element(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(m)));
  return r;
}

// The upper of the two middle values for an even count (a value of the sample itself); 0 for none.
inline double upper_median(std::vector<double> v) {
  if (v.empty()) return 0.0;
  const size_t m = v.size() / 2;
  std::nth_element(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(m), v.end());
  return v[m];
}

}  // namespace hf::footage::detail
