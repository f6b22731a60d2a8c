// The camera's rotation between two frames from matched image features (essential matrix).
#pragma once

#include <optional>
#include <vector>

#include <opencv2/core.hpp>
#include <opencv2/features2d.hpp>

#include "hazardforge/types.hpp"

namespace hf::footage {

struct TwoViewMotion {
  double yaw = 0;        // rad, left positive: the ego's heading change from the previous frame to this one
  double yaw_sigma = 0;  // rad, from the agreement of two halves of the inliers (and a floor)
  int inliers = 0;       // feature pairs that agree with the essential matrix
  double inlier_fraction = 0;
  // The direction the camera moved in, in the previous frame's ego axes on the ground (rad, left positive,
  // 0 = along the ego's x axis as the camera model mounts it), and its sigma from interleaved subsets of the
  // inliers (and a floor). The length of the move is not observable from the two views; with the camera's
  // lever arm ahead of the rear axle, the direction and the turn give it (lever_arm.hpp).
  double heading = 0;
  double heading_sigma = 0;
  // The camera's pitch change from the previous frame (rad, positive = turned further down, the convention of
  // CameraModel::pitch()): the rotation about the ego's lateral axis. On a car the body follows the road, so
  // chained over a clip these changes trace the road's grade along the path (and the body's nods); sigma from
  // the two halves of the inliers, like the yaw's.
  double pitch = 0;
  double pitch_sigma = 0;
};

// Rotation between consecutive frames from SIFT features matched across the whole picture: an essential
// matrix (MAGSAC, 1 px at the working size) and the rotation and direction of travel it decomposes into, the
// rotation projected on the ego's vertical axis. SIFT rather than ORB: ORB's matches fix the rotation but not
// the direction of travel to the fraction of a degree the lever-arm scale needs. Unlike the road's bird's-eye
// view it needs no texture on the asphalt and no flat ground, and the far scene (buildings, trees, parked
// cars) fixes the rotation however large the step between frames (2 Hz keyframes turn by 10 degrees and
// more). The translation's length is not observable here; the ground view measures it.
class TwoViewRotation {
 public:
  struct Options {
    int max_width = 960;  // frames are downscaled to at most this width
    int features = 4000;
    double ratio = 0.8;      // Lowe's ratio test
    double ransac_px = 1.0;  // essential-matrix inlier threshold at the working size
    int min_inliers =
        100;  // real footage gives hundreds (293-1100 on the shared clips); a bare road a few dozen
    double min_inlier_fraction = 0.4;
    // A front camera on a car moves along its optical axis: the decomposed translation must point within
    // acos(min_forward) of it (a wrong decomposition, or a standstill where the translation is noise, does
    // not).
    double min_forward = 0.8;
    double min_parallax_px = 1.0;  // median image motion of the inliers at the working size (less: standing)
    double max_split_deg = 1.0;    // the two halves' heading changes must agree within this
    double max_homography_share = 0.8;    // refused when a homography fits this share of the matrix's inliers
    double min_sigma_deg = 0.1;           // floor of the heading change's sigma
    double min_heading_sigma_deg = 0.25;  // floor of the direction of travel's sigma
    int heading_subsets = 4;              // the direction's sigma from this many interleaved inlier subsets
  };
  explicit TwoViewRotation(const CameraModel& camera) : TwoViewRotation(camera, Options{}) {}
  TwoViewRotation(const CameraModel& camera, Options opt);
  // Pushes the next frame; the rotation from the previous one, or nullopt (first frame, too few agreeing
  // features, no forward motion, or a heading change beyond max_abs_yaw).
  std::optional<TwoViewMotion> add(const cv::Mat& bgr, double max_abs_yaw = 0.5);
  void reset() { prev_descriptors_.release(); }

 private:
  CameraModel cam_;
  Options opt_;
  double scale_ = 1.0;
  cv::Matx33d K_;
  cv::Vec3d up_cam_;    // the ego's vertical axis in camera coordinates
  cv::Vec3d left_cam_;  // the ego's lateral (left) axis in camera coordinates
  cv::Ptr<cv::SIFT> sift_;
  std::vector<cv::KeyPoint> prev_keypoints_;
  cv::Mat prev_descriptors_;
};

}  // namespace hf::footage
