// Camera horizon (pitch and roll of the camera over the road) estimated from a monocular front-camera clip alone.
#pragma once

#include <limits>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "hazardforge/types.hpp"

namespace hf::footage {

struct HorizonEstimate {
  double pitch_rad = 0;     // downward pitch, CameraModel::pitch() convention
  double roll_rad = 0;      // CameraModel::roll() convention (0 with a note when the clip does not show it)
  double horizon_y = 0;     // row of the horizon at the principal point's column cx
  // 0..1: how well the frames agreed. The product of (a) the fraction of per-frame horizon rows within the
  // inlier gate of their median, (b) min(1, frames_used / full_confidence_frames) and
  // (c) exp(-0.5 (s / (0.01 * image height))^2), s = standard deviation of the inlier rows.
  double confidence = 0;
  int frames_used = 0;      // frames that contributed at least one accepted cue
  // cues that contributed, joined by '+': vanishing_point, flow_foe, road_homography, ground_motion, epipole
  std::string method;
  std::vector<std::string> notes;  // human-readable caveats (few cues, roll unobservable, ...)
  // Per-cue diagnostics: accepted per-frame samples of each cue and the median horizon row they gave.
  int vanishing_points = 0, foe_points = 0, homographies = 0, ground_motions = 0, epipoles = 0;
  double roll_sigma_rad = 0;  // spread of the roll evidence (0 when roll was not observable)
  double horizon_sigma_px = 0;  // standard deviation of the inlier rows
  // Median horizon row at cx of each cue's inlier samples (NaN when the cue gave none): a cue that disagrees
  // with the others points at a bias (road slope, curve, turning) rather than noise.
  double vp_row = 0, foe_row = 0, homography_row = 0, ground_motion_row = 0, epipole_row = 0;
  // Column where the road's direction meets the horizon: the median column of the inlier vanishing points
  // (NaN with fewer than 3). Away from cx, the camera is mounted turned against the direction of travel.
  double travel_x = std::numeric_limits<double>::quiet_NaN();
};

struct HorizonOptions {
  // Frames are analysed at most this wide (downscaled internally; results are in full-resolution pixels).
  int work_width = 960;
  // Vanishing point of road lines: Canny + probabilistic Hough on the lower part of the image.
  double lines_top_fraction = 0.35;   // segments are searched below this fraction of the image height
  double min_segment_fraction = 0.035;  // shortest segment, fraction of the work width
  double min_segment_angle_deg = 12;  // nearly horizontal segments say nothing about depth
  double max_segment_angle_deg = 80;  // nearly vertical ones are poles and building edges
  double vp_angle_tol_deg = 1.5;      // a segment supports a vanishing point when it points at it within this
  int vp_min_support = 4;             // segments (both leaning directions together) a vanishing point needs
  // Focus of expansion of sparse optical flow (KLT) between consecutive frames.
  int flow_max_corners = 600;
  double flow_min_px = 1.0;           // shorter flow vectors (at work resolution) carry no direction
  double foe_angle_tol_deg = 3.0;
  double foe_min_inlier_fraction = 0.5;
  int foe_min_inliers = 30;
  // Ground plane normal from the homography of road points between consecutive frames.
  double homography_reproj_px = 1.5;
  int homography_min_inliers = 25;
  double homography_min_translation = 0.03;  // |t| / plane distance below this leaves the normal unconstrained
  // Ground motion: road points tracked in a bird's-eye view between consecutive frames must move rigidly on the
  // ground plane; the pitch and roll that make them do so (grid search, then refinement) are this cue's sample.
  int ground_min_matches = 20;
  double ground_min_travel_m = 0.4;     // less travel between frames leaves pitch unconstrained
  double ground_pitch_range_deg = 8.0;  // searched pitch: +- this
  double ground_roll_range_deg = 4.0;
  double ground_sharpness = 1.5;        // the residual 1 deg away from the best pitch must be this many times larger
  // Combination over the clip.
  double inlier_gate_fraction = 0.02;  // per-frame rows farther than max(3 MAD, this * height) from the median
  int full_confidence_frames = 10;
  // Roll is reported only from at least min_roll_samples plane samples (homography / ground motion) whose spread
  // (scaled MAD) is below max_roll_sigma_deg and whose median has a standard error below max_roll_error_deg, or
  // from a horizon line through the vanishing points / FOEs with a slope error below max_roll_error_deg;
  // otherwise it is 0 with a note.
  int min_roll_samples = 8;
  double max_roll_sigma_deg = 1.0;
  double max_roll_error_deg = 0.25;
};

// Accumulates horizon evidence over a clip. `intrinsics` gives K and the image size; its pitch/roll are ignored.
// Frames must be undistorted (straight lines straight).
class HorizonEstimator {
 public:
  explicit HorizonEstimator(const CameraModel& intrinsics, HorizonOptions opt = {});
  void add(const cv::Mat& bgr, double timestamp);  // frames in order, any subset of the clip
  // A point of the horizon found elsewhere: the epipole of two views of forward travel (TwoViewCalibration),
  // px at the intrinsics' size; `frame` names the later view.
  void add_epipole(const cv::Point2d& e, int frame);
  std::optional<HorizonEstimate> result() const;     // nullopt when there was no usable evidence

  // The intrinsics with the estimated pitch and roll applied (height and forward offset kept).
  static CameraModel apply(const CameraModel& intrinsics, const HorizonEstimate& h);

 private:
  struct Sample {
    enum Cue { kVanishingPoint, kFoe, kHomography, kGroundMotion, kEpipole } cue;
    double x = 0, y = 0;       // a point on the horizon (full-resolution px) for VP / FOE / epipole
    double row_at_cx = 0;      // horizon row at cx for the plane cues (homography, ground motion)
    double roll = 0;           // plane cues only
    int frame = 0;
  };
  CameraModel cam_;
  CameraModel work_cam_;
  HorizonOptions opt_;
  double scale_ = 1.0;
  int frame_ = 0;
  cv::Mat prev_gray_;
  std::vector<Sample> samples_;
  void ground_motion_cue(const cv::Mat& bgr, int frame, double dt);
  double prev_t_ = 0;
  struct Ground;
  std::shared_ptr<Ground> ground_;  // bird's-eye tracker of the ground-motion cue
};

}  // namespace hf::footage
