// Internal: rotation and direction of travel between consecutive frames from an essential matrix of matched
// SIFT features.
#include "hazardforge/footage/two_view.hpp"

#include <cmath>
#include <limits>

#include <opencv2/calib3d.hpp>
#include <opencv2/imgproc.hpp>

#include "gray.hpp"

namespace hf::footage {

TwoViewRotation::TwoViewRotation(const CameraModel& camera, Options opt) : cam_(camera), opt_(opt) {
  scale_ = camera.width > opt_.max_width ? static_cast<double>(opt_.max_width) / camera.width : 1.0;
  K_ = cv::Matx33d(camera.fx * scale_, 0, camera.cx * scale_, 0, camera.fy * scale_, camera.cy * scale_, 0, 0,
                   1);
  const cv::Vec3d o = camera.ego_to_cam({0, 0, 0}), z = camera.ego_to_cam({0, 0, 1});
  up_cam_ = cv::normalize(z - o);
  left_cam_ = cv::normalize(camera.ego_to_cam({0, 1, 0}) - o);
  sift_ = cv::SIFT::create(opt_.features);
}

std::optional<TwoViewMotion> TwoViewRotation::add(const cv::Mat& bgr, double max_abs_yaw) {
  if (bgr.empty()) {
    reset();
    return std::nullopt;
  }
  cv::Mat gray = detail::gray8(bgr);
  if (gray.cols != cam_.width || gray.rows != cam_.height)
    cv::resize(gray, gray, cv::Size(cam_.width, cam_.height));
  if (scale_ < 1.0) cv::resize(gray, gray, cv::Size(), scale_, scale_, cv::INTER_AREA);
  std::vector<cv::KeyPoint> kp;
  cv::Mat desc;
  sift_->detectAndCompute(gray, cv::noArray(), kp, desc);
  const std::vector<cv::KeyPoint> prev_kp = std::move(prev_keypoints_);
  const cv::Mat prev_desc = prev_descriptors_;
  prev_keypoints_ = kp;
  prev_descriptors_ = desc;
  if (prev_desc.empty() || desc.empty()) return std::nullopt;
  cv::BFMatcher matcher(cv::NORM_L2);
  std::vector<std::vector<cv::DMatch>> knn;
  matcher.knnMatch(prev_desc, desc, knn, 2);
  std::vector<cv::Point2f> a, b;
  for (const auto& m : knn)
    if (m.size() == 2 && m[0].distance < opt_.ratio * m[1].distance) {
      a.push_back(prev_kp[static_cast<size_t>(m[0].queryIdx)].pt);
      b.push_back(kp[static_cast<size_t>(m[0].trainIdx)].pt);
    }
  if (static_cast<int>(a.size()) < opt_.min_inliers) return std::nullopt;
  cv::Mat mask;
  const cv::Mat E = cv::findEssentialMat(a, b, cv::Mat(K_), cv::USAC_MAGSAC, 0.999, opt_.ransac_px, mask);
  if (E.rows != 3 || E.cols != 3) return std::nullopt;  // degenerate, or several solutions stacked
  // One plane (the road alone, a wall filling the view) or a turn on the spot fits a homography as well as an
  // essential matrix, and then the decomposition is not determined: refuse when a homography explains nearly
  // as many pairs (the model selection of feature-based SLAM).
  {
    cv::Mat hmask;
    const cv::Mat H = cv::findHomography(a, b, cv::RANSAC, opt_.ransac_px, hmask);
    if (!H.empty() && cv::countNonZero(hmask) >= opt_.max_homography_share * cv::countNonZero(mask))
      return std::nullopt;
  }
  // Inliers of the essential matrix (recoverPose then keeps those in front of both cameras, which for a short
  // baseline drops the far scene, though it fixes the rotation best).
  const int inliers = cv::countNonZero(mask);
  cv::Mat R, t, cheiral = mask.clone();
  cv::recoverPose(E, a, b, cv::Mat(K_), R, t, cheiral);
  TwoViewMotion out;
  out.inliers = inliers;
  out.inlier_fraction = static_cast<double>(inliers) / static_cast<double>(a.size());
  if (inliers < opt_.min_inliers || out.inlier_fraction < opt_.min_inlier_fraction) return std::nullopt;
  // x_current = R x_previous + t: a camera driving forward sees the scene come towards it, t ~ (0, 0, -1).
  if (!(-t.at<double>(2) >= opt_.min_forward)) return std::nullopt;
  std::vector<double> motion;
  for (size_t i = 0; i < a.size(); ++i)
    if (mask.at<uchar>(static_cast<int>(i))) motion.push_back(cv::norm(b[i] - a[i]));
  std::nth_element(motion.begin(), motion.begin() + static_cast<std::ptrdiff_t>(motion.size() / 2),
                   motion.end());
  if (motion.empty() || motion[motion.size() / 2] < opt_.min_parallax_px) return std::nullopt;
  // R maps the previous camera's coordinates into the current one's: the camera turned by R^T. Its rotation
  // vector projected on the vertical axis is the heading change (left positive about the ego's up axis).
  auto turn_of = [](const cv::Mat& rot) {
    cv::Vec3d w;
    cv::Rodrigues(rot.t(), w);
    return w;
  };
  const cv::Vec3d turn = turn_of(R);
  out.yaw = turn.dot(up_cam_);
  // A turn about the ego's left axis by a positive angle tips the forward axis down: the pitch() convention.
  out.pitch = turn.dot(left_cam_);
  // The camera's centre moved to -R^T t in the previous camera's coordinates; its direction on the ground in
  // the previous ego axes.
  auto heading_of = [&](const cv::Mat& rot, const cv::Mat& tr) {
    const cv::Mat c = -rot.t() * tr;
    const cv::Vec3d d =
        cam_.cam_to_ego({c.at<double>(0), c.at<double>(1), c.at<double>(2)}) - cam_.cam_to_ego({0, 0, 0});
    return std::atan2(d[1], d[0]);
  };
  out.heading = heading_of(R, t);
  // Its uncertainty from the data: the inliers split in two interleaved halves give two independent
  // estimates; each has twice the variance of the whole, so the whole's sigma is about half their difference.
  // Halves that disagree by more than max_split_deg mean the geometry is not fixed (short baseline, one
  // plane).
  std::vector<cv::Point2f> a1, b1, a2, b2;
  size_t k = 0;
  for (size_t i = 0; i < a.size(); ++i) {
    if (!mask.at<uchar>(static_cast<int>(i))) continue;
    const bool first = (k++ % 2) == 0;
    (first ? a1 : a2).push_back(a[i]);
    (first ? b1 : b2).push_back(b[i]);
  }
  double split = 0.0, pitch_split = 0.0;
  bool first_half = true;
  for (const auto& [pa, pb] : {std::pair(&a1, &b1), std::pair(&a2, &b2)}) {
    cv::Mat mk;
    const cv::Mat Eh =
        cv::findEssentialMat(*pa, *pb, cv::Mat(K_), cv::USAC_MAGSAC, 0.999, opt_.ransac_px, mk);
    if (Eh.rows != 3 || Eh.cols != 3) return std::nullopt;
    cv::Mat Rh, th;
    cv::recoverPose(Eh, *pa, *pb, cv::Mat(K_), Rh, th, mk);
    const cv::Vec3d w = turn_of(Rh);
    split = first_half ? w.dot(up_cam_) : std::abs(split - w.dot(up_cam_));
    pitch_split = first_half ? w.dot(left_cam_) : std::abs(pitch_split - w.dot(left_cam_));
    first_half = false;
  }
  if (split > opt_.max_split_deg * M_PI / 180.0) return std::nullopt;
  out.yaw_sigma = std::hypot(opt_.min_sigma_deg * M_PI / 180.0, split / 2.0);
  out.pitch_sigma = std::hypot(opt_.min_sigma_deg * M_PI / 180.0, pitch_split / 2.0);
  // The direction of travel is coupled to the rotation (a small turn and a sideways step look alike on far
  // points), and two halves often agree by chance: its sigma comes from heading_subsets interleaved subsets
  // (the whole's sigma is their standard deviation over sqrt(subsets)). A subset whose decomposition does not
  // drive forward leaves the direction undetermined (the rotation is still fixed by the far scene).
  const int subsets = std::max(2, opt_.heading_subsets);
  std::vector<std::vector<cv::Point2f>> sa(static_cast<size_t>(subsets)), sb(static_cast<size_t>(subsets));
  k = 0;
  for (size_t i = 0; i < a.size(); ++i) {
    if (!mask.at<uchar>(static_cast<int>(i))) continue;
    sa[k % static_cast<size_t>(subsets)].push_back(a[i]);
    sb[k % static_cast<size_t>(subsets)].push_back(b[i]);
    ++k;
  }
  std::vector<double> headings;
  for (int q = 0; q < subsets; ++q) {
    if (sa[static_cast<size_t>(q)].size() < 8) break;
    cv::Mat mk;
    const cv::Mat Eq = cv::findEssentialMat(sa[static_cast<size_t>(q)], sb[static_cast<size_t>(q)],
                                            cv::Mat(K_), cv::USAC_MAGSAC, 0.999, opt_.ransac_px, mk);
    if (Eq.rows != 3 || Eq.cols != 3) break;
    cv::Mat Rq, tq;
    cv::recoverPose(Eq, sa[static_cast<size_t>(q)], sb[static_cast<size_t>(q)], cv::Mat(K_), Rq, tq, mk);
    if (!(-tq.at<double>(2) >= opt_.min_forward)) break;
    headings.push_back(heading_of(Rq, tq));
  }
  out.heading_sigma = std::numeric_limits<double>::infinity();
  if (static_cast<int>(headings.size()) == subsets) {
    double mean = 0, ss = 0;
    for (double h : headings) mean += h / subsets;
    for (double h : headings) ss += (h - mean) * (h - mean);
    out.heading_sigma = std::hypot(opt_.min_heading_sigma_deg * M_PI / 180.0,
                                   std::sqrt(ss / (subsets - 1)) / std::sqrt(static_cast<double>(subsets)));
  }
  if (std::abs(out.yaw) > max_abs_yaw) return std::nullopt;
  return out;
}

}  // namespace hf::footage
