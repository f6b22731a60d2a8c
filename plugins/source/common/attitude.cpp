// Internal: per-frame pitch and roll deviations from the far scene's motion between consecutive frames.
#include "hazardforge/footage/attitude.hpp"

#include <algorithm>
#include <cmath>

#include <opencv2/calib3d.hpp>
#include <opencv2/imgproc.hpp>
#include <opencv2/video/tracking.hpp>

#include "gray.hpp"

namespace hf::footage {

namespace {
constexpr int kCornerMargin = 8;  // rows around the far-scene band the corner measure is computed on
}  // namespace

AttitudeTracker::AttitudeTracker(const CameraModel& camera, AttitudeOptions opt) : cam_(camera), opt_(opt) {
  scale_ = camera.width > opt_.max_width ? static_cast<double>(opt_.max_width) / camera.width : 1.0;
}

void AttitudeTracker::add(const cv::Mat& bgr, double t) {
  cv::Mat gray = detail::gray8(bgr);
  if (gray.cols != cam_.width || gray.rows != cam_.height)
    cv::resize(gray, gray, cv::Size(cam_.width, cam_.height));
  if (scale_ < 1.0) cv::resize(gray, gray, cv::Size(), scale_, scale_, cv::INTER_AREA);
  Step step;
  step.t = t;
  const cv::Mat prev = prev_;
  prev_ = gray;
  if (prev.empty() || steps_.empty() || t - steps_.back().t > opt_.max_interval_s + 1e-9) {
    steps_.push_back(step);
    return;
  }
  const double focus = std::isfinite(opt_.travel_x) ? opt_.travel_x : cam_.cx;
  const double cx = focus * scale_;
  const double hy = cam_.horizon_y(focus).value_or(cam_.cy) * scale_;
  const int y0 = std::clamp(static_cast<int>(hy - opt_.band_above * gray.rows), 0, gray.rows);
  const int y1 = std::clamp(static_cast<int>(hy + opt_.band_below * gray.rows), 0, gray.rows);
  std::vector<cv::Point2f> p0, p1, back;
  if (y1 - y0 >= 8) {
    // Corners of the band only: the corner measure is computed on the band and a margin of rows around it
    // (which its 3x3 gradient, block and maximum filters read), not on the whole frame and then masked. The
    // corners are the same ones, in the margin's coordinates.
    const int m0 = std::max(0, y0 - kCornerMargin), m1 = std::min(prev.rows, y1 + kCornerMargin);
    cv::Mat mask = cv::Mat::zeros(m1 - m0, prev.cols, CV_8U);
    mask.rowRange(y0 - m0, y1 - m0).setTo(255);
    cv::goodFeaturesToTrack(prev.rowRange(m0, m1), p0, opt_.max_corners, opt_.corner_quality,
                            opt_.min_corner_distance_px, mask);
    for (cv::Point2f& p : p0) p.y += static_cast<float>(m0);
  }
  if (static_cast<int>(p0.size()) >= opt_.min_inliers) {
    std::vector<uchar> st, st_back;
    std::vector<float> err;
    cv::calcOpticalFlowPyrLK(prev, gray, p0, p1, st, err, cv::Size(21, 21), 3);
    cv::calcOpticalFlowPyrLK(gray, prev, p1, back, st_back, err, cv::Size(21, 21), 3);
    std::vector<cv::Point2f> a, b;
    for (size_t i = 0; i < p0.size(); ++i) {
      if (!st[i] || !st_back[i] || cv::norm(back[i] - p0[i]) > opt_.fb_max_px) continue;
      a.emplace_back(p0[i].x - static_cast<float>(cx), p0[i].y - static_cast<float>(hy));
      b.emplace_back(p1[i].x - static_cast<float>(cx), p1[i].y - static_cast<float>(hy));
    }
    if (static_cast<int>(a.size()) >= opt_.min_inliers) {
      cv::Mat inl;
      const cv::Mat M = cv::estimateAffinePartial2D(a, b, inl, cv::RANSAC, opt_.ransac_px, 2000, 0.995);
      const int n = inl.empty() ? 0 : cv::countNonZero(inl);
      if (!M.empty() && n >= opt_.min_inliers &&
          n >= opt_.min_inlier_fraction * static_cast<double>(a.size())) {
        const double fy = cam_.fy * scale_;
        const double dpitch = -std::atan2(M.at<double>(1, 2), fy);
        const double droll = -std::atan2(M.at<double>(1, 0), M.at<double>(0, 0));
        const double fx = cam_.fx * scale_;
        const double dyaw = std::atan2(M.at<double>(0, 2), fx);
        const double limit = opt_.max_step_deg * CV_PI / 180.0;
        if (std::abs(dpitch) <= limit && std::abs(droll) <= limit && std::abs(dyaw) <= limit) {
          step.dpitch = dpitch;
          step.droll = droll;
          step.dyaw = dyaw;
          // Horizontal residuals of the inliers: the shift's standard error, plus the floor.
          double ss = 0;
          for (size_t i = 0; i < a.size(); ++i) {
            if (!inl.at<uchar>(static_cast<int>(i))) continue;
            const double rx =
                M.at<double>(0, 0) * a[i].x + M.at<double>(0, 1) * a[i].y + M.at<double>(0, 2) - b[i].x;
            ss += rx * rx;
          }
          const double se = std::sqrt(ss / std::max(1, n - 2)) / std::sqrt(static_cast<double>(n)) / fx;
          // The camera sits ahead of the axle it turns about: its sideways step shifts near scenery further,
          // by a share of the turn that grows as the scenery nears (a tenth for buildings 10-20 m away).
          step.dyaw_sigma = std::sqrt(se * se + std::pow(opt_.yaw_sigma_floor_deg * CV_PI / 180.0, 2) +
                                      std::pow(0.1 * dyaw, 2));
          step.measured = true;
          step.inliers = n;
          step.inlier_fraction = static_cast<double>(n) / static_cast<double>(a.size());
        }
      }
    }
  }
  steps_.push_back(step);
}

std::optional<TwoViewMotion> AttitudeTracker::last_turn() const {
  if (steps_.empty() || !steps_.back().measured) return std::nullopt;
  const Step& s = steps_.back();
  return TwoViewMotion{s.dyaw, s.dyaw_sigma, s.inliers, s.inlier_fraction};
}

std::vector<AttitudeSample> AttitudeTracker::result() const {
  const size_t n = steps_.size();
  std::vector<double> pitch(n, 0.0), roll(n, 0.0);
  for (size_t k = 1; k < n; ++k) {
    pitch[k] = pitch[k - 1] + steps_[k].dpitch;
    roll[k] = roll[k - 1] + steps_[k].droll;
  }
  const double limit = opt_.max_deviation_deg * CV_PI / 180.0;
  std::vector<AttitudeSample> out(n);
  for (size_t k = 0; k < n; ++k) {
    // The slow attitude: a Gaussian over the summed steps (weights renormalised at the clip's ends).
    // Only the frames within 3 sigma (the steps are in time order), so long clips cost O(frames x window).
    double w_sum = 0, p_sum = 0, r_sum = 0;
    const double reach = 3.0 * std::max(opt_.slow_s, 1e-6);
    const auto first = std::lower_bound(steps_.begin(), steps_.end(), steps_[k].t - reach,
                                        [](const Step& a, double t) { return a.t < t; });
    for (size_t j = static_cast<size_t>(first - steps_.begin()); j < n && steps_[j].t <= steps_[k].t + reach;
         ++j) {
      const double d = (steps_[j].t - steps_[k].t) / std::max(opt_.slow_s, 1e-6);
      const double w = std::exp(-0.5 * d * d);
      w_sum += w;
      p_sum += w * pitch[j];
      r_sum += w * roll[j];
    }
    AttitudeSample& s = out[k];
    s.t = steps_[k].t;
    s.pitch_rad = std::clamp(pitch[k] - p_sum / w_sum, -limit, limit);
    s.roll_rad = std::clamp(roll[k] - r_sum / w_sum, -limit, limit);
    s.measured = steps_[k].measured;
    s.inliers = steps_[k].inliers;
  }
  return out;
}

CameraModel with_pitch_roll(const CameraModel& camera, double pitch_rad, double roll_rad) {
  CameraModel c =
      CameraModel::pinhole(camera.width, camera.height, camera.fx, camera.fy, camera.cx, camera.cy,
                           camera.height_above_ground(), pitch_rad, camera.t_ego_cam[0], roll_rad);
  c.distortion = camera.distortion;
  c.t_ego_cam = camera.t_ego_cam;
  return c;
}

CameraModel with_attitude(const CameraModel& camera, const AttitudeSample& s) {
  return with_pitch_roll(camera, camera.pitch() + s.pitch_rad, camera.roll() + s.roll_rad);
}

}  // namespace hf::footage
