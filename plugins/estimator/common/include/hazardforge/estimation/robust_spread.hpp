// Robust spread of a stream of zero-mean samples, learnt as the data arrive.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <deque>
#include <utility>
#include <vector>

namespace hf::estimation {

// The standard deviation of the last `capacity` samples from their median absolute value (1.4826 x MAD about
// zero), so a few outliers (an identity switch, a box cut by an occluder) do not inflate it. blended()
// shrinks it towards a stated prior with the weight of prior_samples samples, so the value moves smoothly
// from what was stated to what was measured.
class RobustSpread {
 public:
  explicit RobustSpread(std::size_t capacity = 400) : capacity_(capacity) {}
  void add(double x) {
    if (!std::isfinite(x)) return;
    values_.push_back(std::abs(x));
    if (values_.size() > capacity_) values_.pop_front();
  }
  std::size_t size() const { return values_.size(); }
  double sigma() const {
    if (values_.empty()) return 0.0;
    std::vector<double> v(values_.begin(), values_.end());
    std::nth_element(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(v.size() / 2), v.end());
    return 1.4826 * v[v.size() / 2];
  }
  // The measured spread shrunk towards the prior, in log space (a spread is a scale):
  // exp((n0 ln prior + n ln sigma) / (n0 + n)).
  double blended(double prior, double prior_samples) const {
    return blend(prior, prior_samples, sigma(), static_cast<double>(values_.size()));
  }
  static double blend(double prior, double prior_samples, double measured, double samples) {
    if (!(samples > 0) || !(measured > 0) || !(prior > 0))
      return samples > 0 && !(prior > 0) ? measured : prior;
    return std::exp((prior_samples * std::log(prior) + samples * std::log(measured)) /
                    (prior_samples + samples));
  }

 private:
  std::size_t capacity_;
  std::deque<double> values_;
};

// Lag-one correlation of a noise from pairs of consecutive samples (x_{t-1}, x_t) over the last `capacity`
// pairs: sum x_{t-1} x_t / sqrt(sum x_{t-1}^2 sum x_t^2); 0 until there are pairs.
class LagCorrelation {
 public:
  explicit LagCorrelation(std::size_t capacity = 400) : capacity_(capacity) {}
  void add_pair(double previous, double current) {
    if (!std::isfinite(previous) || !std::isfinite(current)) return;
    pairs_.emplace_back(previous, current);
    if (pairs_.size() > capacity_) pairs_.pop_front();
  }
  std::size_t size() const { return pairs_.size(); }
  double correlation() const {
    double sxy = 0, sxx = 0, syy = 0;
    for (const auto& [x, y] : pairs_) {
      sxy += x * y;
      sxx += x * x;
      syy += y * y;
    }
    return sxx > 0 && syy > 0 ? sxy / std::sqrt(sxx * syy) : 0.0;
  }

 private:
  std::size_t capacity_;
  std::deque<std::pair<double, double>> pairs_;
};

}  // namespace hf::estimation
