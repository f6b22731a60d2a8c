// Internal: the focal length (essential-matrix condition) and the epipole of pairs of views about a second apart.
#include "hazardforge/footage/two_view_calibration.hpp"

#include <algorithm>
#include <cmath>

#include <opencv2/calib3d.hpp>
#include <opencv2/imgproc.hpp>

#include "gray.hpp"
#include "median.hpp"

namespace hf::footage {

TwoViewCalibration::TwoViewCalibration(cv::Size image, Options opt) : image_(image), opt_(opt) {
  scale_ = image.width > opt_.max_width ? static_cast<double>(opt_.max_width) / image.width : 1.0;
  sift_ = cv::SIFT::create(opt_.features);
}

void TwoViewCalibration::add(const cv::Mat& bgr, int frame, bool new_segment) {
  if (new_segment || bgr.empty()) recent_.clear();
  if (bgr.empty()) return;
  cv::Mat gray = detail::gray8(bgr);
  if (gray.cols != image_.width || gray.rows != image_.height) cv::resize(gray, gray, image_);
  if (scale_ < 1.0) cv::resize(gray, gray, cv::Size(), scale_, scale_, cv::INTER_AREA);
  View v;
  sift_->detectAndCompute(gray, cv::noArray(), v.keypoints, v.descriptors);
  for (const View& prev : recent_)
    if (const auto r = pair(prev, v)) add_pair(*r, frame, scale_);
  recent_.push_back(std::move(v));
  if (static_cast<int>(recent_.size()) > opt_.pair_depth) recent_.erase(recent_.begin());
}

void TwoViewCalibration::add_pair(const PairResult& r, int frame, double scale) {
  ++tried_;
  if (r.accepted) accepted_.push_back(r.f / scale);
  if (r.epipole) epipoles_.push_back({*r.epipole / scale, frame});
}

std::optional<TwoViewCalibration::PairResult> TwoViewCalibration::pair(const View& a, const View& b) const {
  if (a.descriptors.empty() || b.descriptors.empty()) return std::nullopt;
  cv::BFMatcher matcher(cv::NORM_L2);
  std::vector<std::vector<cv::DMatch>> knn;
  matcher.knnMatch(a.descriptors, b.descriptors, knn, 2);
  std::vector<cv::Point2f> pa, pb;
  for (const auto& m : knn)
    if (m.size() == 2 && m[0].distance < opt_.ratio * m[1].distance) {
      pa.push_back(a.keypoints[static_cast<size_t>(m[0].queryIdx)].pt);
      pb.push_back(b.keypoints[static_cast<size_t>(m[0].trainIdx)].pt);
    }
  const cv::Size work(static_cast<int>(std::lround(image_.width * scale_)),
                      static_cast<int>(std::lround(image_.height * scale_)));
  return measure_pair(pa, pb, work, opt_);
}

std::optional<TwoViewCalibration::PairResult> TwoViewCalibration::measure_pair(
    const std::vector<cv::Point2f>& pa, const std::vector<cv::Point2f>& pb, cv::Size image, const Options& opt) {
  if (static_cast<int>(pa.size()) < opt.min_inliers || pa.size() != pb.size()) return std::nullopt;
  cv::Mat mask;
  const cv::Mat F = cv::findFundamentalMat(pa, pb, cv::USAC_ACCURATE, opt.ransac_px, 0.999, mask);
  if (F.rows != 3 || F.cols != 3 || cv::countNonZero(mask) < opt.min_inliers) return std::nullopt;
  const cv::Matx33d Fm(F);
  const double w = image.width, cx = w / 2.0, cy = image.height / 2.0;
  PairResult r;
  std::vector<cv::Point2f> ia, ib;
  std::vector<double> motion;
  for (size_t i = 0; i < pa.size(); ++i)
    if (mask.at<uchar>(static_cast<int>(i))) {
      ia.push_back(pa[i]);
      ib.push_back(pb[i]);
      motion.push_back(cv::norm(pb[i] - pa[i]));
    }
  // The cost (s1 - s2) / (s1 + s2) of E(f)'s two largest singular values, on a log grid of f.
  std::vector<double> fs(static_cast<size_t>(opt.grid)), cost(fs.size());
  const double l0 = std::log(opt.min_width_ratio * w), l1 = std::log(opt.max_width_ratio * w);
  for (size_t i = 0; i < fs.size(); ++i) {
    fs[i] = std::exp(l0 + (l1 - l0) * static_cast<double>(i) / static_cast<double>(fs.size() - 1));
    const cv::Matx33d K(fs[i], 0, cx, 0, fs[i], cy, 0, 0, 1);
    cv::Matx31d s;
    cv::SVD::compute(K.t() * Fm * K, s, cv::SVD::NO_UV);
    cost[i] = (s(0) - s(1)) / std::max(s(0) + s(1), 1e-300);
  }
  const size_t best = static_cast<size_t>(std::min_element(cost.begin(), cost.end()) - cost.begin());
  r.f = fs[best];
  r.sharpness = cost[best] / std::max(detail::median(cost), 1e-300);
  // The rotation between the views at that focal length.
  const cv::Matx33d K(r.f, 0, cx, 0, r.f, cy, 0, 0, 1);
  cv::Mat R, t;
  cv::recoverPose(cv::Mat(K.t() * Fm * K), ia, ib, cv::Mat(K), R, t);
  cv::Vec3d rv;
  cv::Rodrigues(R, rv);
  r.rotation_deg = cv::norm(rv) * 180.0 / CV_PI;
  // The epipole in the later view (F^T e = 0), when the pair shows forward travel: the decomposed translation
  // points along the optical axis (x_b = R x_a + t, t ~ (0, 0, -1); the flow's own direction is no test, the
  // turn sweeps it sideways) and the view moved enough to fix it.
  {
    cv::Mat u, s, vt;
    cv::SVD::compute(cv::Mat(Fm.t()), s, u, vt, cv::SVD::FULL_UV);
    const double ez = vt.at<double>(2, 2);
    if (std::abs(ez) > 1e-12 && detail::median(motion) >= opt.min_parallax_px && -t.at<double>(2) > 0.5) {
      const cv::Point2d e(vt.at<double>(2, 0) / ez, vt.at<double>(2, 1) / ez);
      if (e.x >= 0 && e.x < w && e.y >= 0 && e.y < image.height) r.epipole = e;
    }
  }
  const bool interior = best > 0 && best + 1 < fs.size();
  r.accepted = interior && r.sharpness <= opt.max_sharpness && r.rotation_deg >= opt.min_rotation_deg;
  return r;
}

std::optional<FocalEstimate> TwoViewCalibration::result() const {
  if (static_cast<int>(accepted_.size()) < opt_.min_pairs) return std::nullopt;
  const double f = detail::median(accepted_);
  std::vector<double> dev;
  for (double v : accepted_) dev.push_back(std::abs(v - f));
  const double mad = detail::median(dev);
  FocalEstimate e;
  e.fx = f;
  e.spread = mad / f;
  e.pairs = static_cast<int>(accepted_.size());
  e.pairs_tried = tried_;
  e.sigma = 1.2533 * 1.4826 * mad / std::sqrt(static_cast<double>(e.pairs));
  if (e.sigma > opt_.max_sigma * f || looks_level(f)) return std::nullopt;
  e.note = std::to_string(e.pairs) + " of " + std::to_string(tried_) +
           " frame pairs turning by at least " + std::to_string(static_cast<int>(opt_.min_rotation_deg)) +
           " deg fixed it, scatter " + std::to_string(e.spread * 100).substr(0, 4) + " %";
  return e;
}

bool TwoViewCalibration::looks_level(double f) const {
  if (epipoles_.size() < 3) return false;
  std::vector<double> rows;
  for (const Epipole& e : epipoles_) rows.push_back(e.point.y);
  return std::atan(std::abs(image_.height / 2.0 - detail::median(rows)) / f) < opt_.min_pitch_deg * CV_PI / 180.0;
}

std::string TwoViewCalibration::why_not() const {
  const std::string tried = std::to_string(tried_) + " frame pairs with enough matched features";
  if (static_cast<int>(accepted_.size()) < opt_.min_pairs)
    return std::to_string(accepted_.size()) + " of " + tried + " turned by " +
           std::to_string(static_cast<int>(opt_.min_rotation_deg)) + " deg or more with a clear minimum, " +
           std::to_string(opt_.min_pairs) + " needed: a straight drive does not fix the focal length";
  const double f = detail::median(accepted_);
  if (looks_level(f))
    return "the camera looks level (the direction of travel on the picture's centre row), and a level camera's "
           "turns do not fix the focal length";
  return "the " + std::to_string(accepted_.size()) + " turning pairs of " + tried +
         " scatter too much to fix it within " + std::to_string(static_cast<int>(opt_.max_sigma * 100)) + " %";
}

}  // namespace hf::footage
