// Internal: the road in a metric bird's-eye view and the ground points tracked between two views. Shared by the
// odometry (which fits the rigid motion) and the horizon estimator (which asks which pitch and roll make it rigid).
#pragma once

#include <optional>
#include <vector>

#include <opencv2/core.hpp>

#include "hazardforge/footage/ego_motion.hpp"
#include "hazardforge/types.hpp"

namespace hf::footage::detail {

struct GroundMatch {
  cv::Point2d p, q;          // ego-frame ground point (x forward, y left) in the previous and the current frame
  cv::Point2d img_p, img_q;  // the same points in full-resolution image pixels
};

struct Rigid2 {
  double theta = 0;
  cv::Point2d t;
  cv::Point2d apply(const cv::Point2d& q) const;
};

// Least-squares rotation + translation with p ~ R q + t over the pairs listed in idx.
Rigid2 fit_rigid(const std::vector<cv::Point2d>& p, const std::vector<cv::Point2d>& q, const std::vector<int>& idx);
// Weighted mean squared residual of the least-squares rigid fit over the pairs listed in idx, each weighted by
// 1 / distance^2 (ground errors grow with distance^2) and compared as if 10 m away.
double rigid_residual(const std::vector<cv::Point2d>& p, const std::vector<cv::Point2d>& q, const std::vector<int>& idx,
                      Rigid2* fit = nullptr);
// The image points of matched pairs (full-resolution pixels, as GroundMatch::img_p / img_q) put on the road with
// `cam`, as ego-frame ground points; false when one of them lies above the horizon.
bool pairs_on_ground(const CameraModel& cam, const std::vector<cv::Point2d>& img_p, const std::vector<cv::Point2d>& img_q,
                     std::vector<cv::Point2d>& p, std::vector<cv::Point2d>& q);
// rigid_residual of all the pairs put on the road with `cam`; NaN when one lies above the horizon.
double ground_residual(const CameraModel& cam, const std::vector<cv::Point2d>& img_p,
                       const std::vector<cv::Point2d>& img_q, Rigid2* fit = nullptr);
// RANSAC over point pairs, then least squares on the inliers; returns the inlier indices in `inliers`.
Rigid2 ransac_rigid(const std::vector<cv::Point2d>& p, const std::vector<cv::Point2d>& q, double threshold,
                    int iterations, std::vector<int>& inliers);

class BevTracker {
 public:
  BevTracker(const CameraModel& camera, const OdometryOptions& opt);
  // Pushes a frame taken dt seconds after the previous one; returns the ground points tracked from the
  // previous frame (empty for the first one). prior_speed (m/s), when given, narrows the coarse distance
  // search; known_yaw (rad, the heading change from the previous frame, e.g. from the two-view rotation)
  // narrows the coarse yaw search to +- 1.5 degrees around it. prewarp: the previous view is warped by the
  // coarse motion before KLT (patches turned alike).
  std::vector<GroundMatch> add(const cv::Mat& bgr, double dt,
                               std::optional<double> prior_speed = std::nullopt,
                               std::optional<double> known_yaw = std::nullopt, bool prewarp = false);
  void reset() { prev_bev_.release(); }
  int bonnet_rows() const { return bonnet_rows_; }
  const cv::Mat& last_bev() const { return prev_bev_; }
  // Yaw change (rad, left positive) of the coarse alignment of the last pair; nullopt when there was none.
  std::optional<double> last_coarse_yaw() const { return last_coarse_yaw_; }

 private:
  void build_maps();
  void update_bonnet(const cv::Mat& gray);
  bool patch_agrees(const cv::Mat& a, const cv::Mat& b, cv::Point2f pa, cv::Point2f pb) const;
  cv::Point2d bev_to_ego(const cv::Point2f& b) const;
  cv::Point2d bev_to_image(const cv::Point2f& b) const;
  // Coarse alignment of two views (search over distance and yaw) as the KLT starting guess: returns the 2x3 map
  // from previous-view pixels to current-view pixels.
  cv::Matx23d coarse_alignment(const cv::Mat& prev, const cv::Mat& cur, double dt,
                               std::optional<double> prior_speed, std::optional<double> known_yaw) const;
  cv::Matx23d motion_to_pixels(double dist, double yaw, double k) const;
  CameraModel cam_;
  OdometryOptions opt_;
  double scale_ = 1.0;
  // Only the image rows the road view and the bonnet analysis read are converted and reduced: the source rows
  // from crop_top_ down, which start at crop_off_ = crop_top_ * scale_ rows of the reduced frame.
  int crop_top_ = 0;
  double crop_off_ = 0;
  int reduced_height_ = 0;  // rows of the whole reduced frame
  cv::Mat map_x_, map_y_, valid_, weight_;
  cv::Mat prev_gray_, prev_bev_;
  int bonnet_rows_ = 0;
  int maps_bonnet_rows_ = -1;
  std::vector<double> bonnet_votes_;
  mutable std::optional<double> last_coarse_yaw_;
};

}  // namespace hf::footage::detail
