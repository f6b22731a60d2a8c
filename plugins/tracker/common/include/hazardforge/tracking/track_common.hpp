// Pieces both trackers share: box geometry, the smoothed image-plane velocity and the majority label vote.
#pragma once

#include <algorithm>
#include <map>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include <hazardforge/class_groups.hpp>
#include <hazardforge/geometry.hpp>

namespace hf::tracking {

inline cv::Point2f centre(const cv::Rect2f& b) {
  return {b.x + 0.5f * b.width, b.y + 0.5f * b.height};
}

// Velocity of a box centre in px/s from the displacement between successive *matched* observations divided by
// their timestamp difference (so a gap of several frames is one long step, not several zero steps), smoothed
// exponentially: v = alpha * v_step + (1 - alpha) * v. The first step initialises v directly, so constant
// motion is reported exactly from the second observation on.
class VelocityEstimator {
 public:
  explicit VelocityEstimator(double alpha = 0.5) : alpha_(alpha) {}

  void observe(const cv::Point2f& c, double t) {
    if (has_obs_ && t > last_t_) {
      const cv::Point2d step((c.x - last_.x) / (t - last_t_), (c.y - last_.y) / (t - last_t_));
      v_ = has_v_ ? alpha_ * step + (1.0 - alpha_) * v_ : step;
      has_v_ = true;
    }
    last_ = c;
    last_t_ = t;
    has_obs_ = true;
  }
  bool known() const { return has_v_; }
  cv::Point2f velocity() const { return {static_cast<float>(v_.x), static_cast<float>(v_.y)}; }
  // Where the centre would be at time t under constant velocity (the last observation when v is unknown).
  cv::Point2f predict(double t) const {
    if (!has_v_) return last_;
    const double dt = t - last_t_;
    return {static_cast<float>(last_.x + v_.x * dt), static_cast<float>(last_.y + v_.y * dt)};
  }
  double last_time() const { return last_t_; }
  // The camera turned: the last observation moves with the picture (the velocity, measured in a picture that
  // did not turn, stays).
  void shift_last(const cv::Point2f& d) { last_ += d; }

 private:
  double alpha_;
  bool has_obs_ = false;
  bool has_v_ = false;
  cv::Point2f last_;
  double last_t_ = 0.0;
  cv::Point2d v_{0.0, 0.0};
};

// Majority label over the track's matched detections; ties go to the most recent one, so a track whose
// detector flickers between car and truck keeps the label it was given most often.
class LabelVote {
 public:
  void add(const std::string& label) {
    ++counts_[label];
    last_ = label;
  }
  std::string label() const {
    std::string best = last_;
    int best_n = last_.empty() ? 0 : counts_.at(last_);
    for (const auto& [l, n] : counts_)
      if (n > best_n) {
        best = l;
        best_n = n;
      }
    return best;
  }

 private:
  std::map<std::string, int> counts_;
  std::string last_;
};

// Label groups live in the SDK (detectors merge duplicate boxes by the same groups).
using ClassGroups = hf::ClassGroups;
inline const std::vector<std::string>& default_class_groups() {
  return hf::default_class_groups();
}

}  // namespace hf::tracking
