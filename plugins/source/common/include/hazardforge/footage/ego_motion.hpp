// Metric ego motion (forward speed, yaw rate) from a monocular front camera over a flat road.
#pragma once

#include <cstdint>
#include <memory>
#include <optional>
#include <vector>

#include <opencv2/core.hpp>

#include "hazardforge/footage/two_view.hpp"
#include "hazardforge/types.hpp"

namespace hf::footage {

struct EgoMotionSample {
  int64_t frame = 0;
  double t = 0;
  double interval_s = 0;      // from the previous frame (0 for the first)
  double speed_mps = 0;       // forward speed
  double yaw_rate = 0;        // rad/s, positive = turning left
  bool measured = false;      // false = no usable measurement at this frame (filled by the filter/smoother)
  bool yaw_measured = false;  // the yaw rate alone was measured (the two-view rotation), also without a speed
  double speed_sigma = 0, yaw_rate_sigma = 0;  // 1-sigma (raw: from the fit residuals; smoothed: posterior)
  double quality = 0;                          // inlier fraction of the raw measurement
  int inliers = 0;                             // ground points that agreed with the fitted motion
  std::optional<double> ground_pitch_offset;   // rad: the road's pitch under this pair, when it was measured
  // The whole picture's two-view geometry of this pair (frames at least two_view_min_interval_s apart, when
  // the essential matrix was trusted): the turn and the camera's direction of travel. LeverArmScale
  // (lever_arm.hpp) turns them into a distance driven in the bends, where the road view is weakest.
  std::optional<TwoViewMotion> two_view;
  // Which cue the raw speed came from.
  enum class SpeedCue { kNone, kRoad, kLeverArm, kRoadAndLeverArm };
  SpeedCue speed_cue = SpeedCue::kNone;
  std::optional<double> road_speed_mps;   // the road view's own reading, when the lever arm changed the speed
  std::optional<double> lever_speed_mps;  // the lever arm's reading, when it was computed (and its sigma)
  double lever_speed_sigma = 0;
};

// The road view's readings of odometry run at one camera height, for a camera `ratio` times as high: speeds and
// their sigmas scale with the height. The lever arm's and the whole picture's cues do not depend on it.
void rescale_height(std::vector<EgoMotionSample>& samples, double ratio);

// "road", "lever_arm", "road+lever_arm" or "none" (for ego_motion.jsonl and the probe).
const char* speed_cue_name(EgoMotionSample::SpeedCue cue);

struct OdometryOptions {
  // Bird's-eye view of the road in ego coordinates (x forward of the rear axle, y left), metres.
  double bev_resolution_m = 0.05;
  double near_m = 3.0;         // raised automatically to the first visible road row (and above the bonnet)
  double far_m = 22;         // longitudinal footprint of a pixel grows with distance^2; beyond this it is mush
  double half_width_m = 6.0;   // the ego lane and its neighbours; parked cars and kerbs beyond add outliers
  double horizon_margin_deg = 2.0;  // rows closer to the horizon than this are never used
  // Features in the bird's-eye view and their KLT tracks.
  int max_corners = 500;
  double corner_quality = 0.005;
  double min_corner_distance_px = 6;
  // Coarse alignment before KLT (frames far apart, turning): distance driven and yaw change are searched within
  // these limits (times the frame interval) for the best correlation of the two views; the best seeds the tracks.
  double max_speed_mps = 45.0;
  double max_yaw_rate = 0.6;  // rad/s
  // After a measured frame (within prior_max_age_s) the distance search is narrowed to the last measured speed
  // +- (prior_accel_mps2 * dt + prior_relative * speed) * dt: weak texture along the lane lines leaves the
  // driven distance ambiguous, the speed does not jump. Only once two measurements in a row agreed within that
  // window: a single wrong reading (a static bonnet before its rows are known) would hold every later search.
  double prior_max_age_s = 1.0;
  double prior_accel_mps2 = 4.0;
  double prior_relative = 0.25;
  int klt_window = 21;
  int klt_levels = 2;
  // Between frames closer than two_view_min_interval_s whose coarse alignment found the motion, KLT starts
  // within a pixel or two of it and refines with this many pyramid levels instead.
  int klt_levels_refine = 0;
  double fb_max_px = 1.0;      // forward-backward tracking error above this drops a track
  // A track also needs a patch (2 r + 1 square) with this much contrast (grey-level std) in both views and a
  // zero-mean normalised cross-correlation of at least min_patch_zncc between them.
  int patch_radius_px = 7;
  double min_patch_contrast = 3.0;
  double min_patch_zncc = 0.8;
  // The heading change between frames from the whole picture's features (essential matrix): the far scene
  // fixes the rotation however far the car turned between frames, and the road's coarse search is then only
  // over the distance driven (and +- 1.5 degrees).
  bool two_view_rotation = true;
  // ... on frames at least this far apart (it costs ~25-30 ms a frame; between video frames the road's own
  // turn is precise, between 2 Hz keyframes it is not).
  double two_view_min_interval_s = 0.15;
  // The road's own turn is not used when it differs from the picture's by more than this many sigmas of the
  // two combined (else the two are averaged by inverse variance).
  double two_view_gate_sigma = 3.0;
  // On frames as far apart, the previous road view is warped by the coarse motion before KLT, so the patches
  // turn alike (KLT's window and the patch check assume a shift; 2 Hz keyframes turn by 10 degrees and more).
  bool prewarp = true;
  // The road's pitch under each pair: a fixed camera pitch misreads distances wherever the body pitches (braking,
  // bumps) or the road ahead climbs or falls relative to the wheels (a grade change, a banked bend); every
  // distance then scales alike only in one direction, so the road's motion between the views stops being
  // rigid. Between views at least pair_pitch_min_travel_m apart, the pitch offset (within +- range) that makes
  // the inliers' motion most nearly rigid is taken, when the minimum is clear (ground_pitch_offset); the
  // horizon's ground cue uses the same range, travel and sharpness.
  bool pair_pitch = true;
  double pair_pitch_range_deg = 8.0;
  double pair_pitch_min_travel_m = 0.4;
  double pair_pitch_sharpness = 1.5;
  // Rigid 2-D fit on the ground (RANSAC on point pairs, then least squares on the inliers).
  double ransac_threshold_m = 0.15;
  int ransac_iterations = 300;
  int min_inliers = 12;
  double min_inlier_fraction = 0.3;
  // Bonnet detection: bottom rows whose frame-to-frame change (relative to their own vertical gradient) stays
  // below this fraction of the upper quartile of the bottom band's rows (the road there streams past fastest).
  double bonnet_change_ratio = 0.5;
  double bonnet_max_fraction = 0.3;  // never more than this fraction of the image height is taken as bonnet
};

// Ground-plane visual odometry: camera with known pitch, roll, height (CameraModel) -> metric motion between
// consecutive frames. The road in front of the car is warped to a metric bird's-eye view once per frame; a flat
// road then moves between frames by a 2-D rigid transform which KLT tracks and a RANSAC fit recover (moving
// vehicles are outliers).
class GroundOdometry {
 public:
  explicit GroundOdometry(const CameraModel& camera, OdometryOptions opt = {});
  // Raw (unfiltered) motion from the previous frame to this one; measured=false for the first frame or when the
  // road gives no reliable measurement.
  EgoMotionSample add(const cv::Mat& bgr, int64_t frame, double timestamp);
  // The same, with the heading change from the previous frame measured by another cue (AttitudeTracker's far
  // scene, left positive, with its sigma): on frames closer than two_view_min_interval_s it takes the place
  // of the whole picture's rotation (which is not run there), narrows the road's coarse search and is
  // averaged with the road's own turn by inverse variance, or replaces it when the two disagree.
  EgoMotionSample add(const cv::Mat& bgr, int64_t frame, double timestamp,
                      const std::optional<TwoViewMotion>& turn);
  // Rows at the bottom of the image taken to be the bonnet (0 until two frames were seen).
  int bonnet_rows() const;
  // The latest bird's-eye view (for inspection).
  const cv::Mat& last_bev() const;
  ~GroundOdometry();
  GroundOdometry(GroundOdometry&&) noexcept;
  GroundOdometry& operator=(GroundOdometry&&) noexcept;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

struct SmoothOptions {
  double accel_noise = 1.0;        // m/s^3 white jerk driving the acceleration (comfortable driving changes)
  double yaw_accel_noise = 0.3;    // rad/s^2 random walk of the yaw rate
  double speed_sigma_floor = 0.2;  // m/s added in quadrature to every raw speed sigma
  double yaw_sigma_floor = 0.02;   // rad/s
  double accel_tau = 2.0;          // s: the acceleration is a first-order Markov process with this time constant
  double gate_sigma = 4.0;         // innovations beyond this many sigma are outliers ...
  int restart_after = 3;           // ... unless this many in a row are: then the filter restarts from them
  // Before filtering, a raw sample farther from the median of its +-median_window measured neighbours than
  // max(median_gate_mps, median_gate_rel * |median|) in speed, or median_gate_yaw in yaw rate, is dropped.
  int median_window = 2;
  // The raw speeds' sigmas are scaled up to their scatter about those medians when at least this many frames
  // with a full neighbourhood measure it.
  int min_scatter_samples = 8;
  double median_gate_mps = 1.5;
  double median_gate_rel = 0.25;
  double median_gate_yaw = 0.1;
  double initial_speed_sigma = 10.0;
  // A front camera's ego drives forwards: near a standstill, other road users moving through the road region
  // can make the odometry read a small reverse speed (-0.2..-0.5 m/s on the KITTI raw clip while queued), which
  // would fold the ego's recorded path back on itself. The smoothed speed is held at or above this (-inf: the
  // ego may reverse).
  double min_speed = 0.0;
  // A car turns only while it moves: its yaw rate is at most its speed over its tightest turning radius
  // (passenger cars: about 5 m to the outer wheel). Near a standstill the far scene's sideways shift is other
  // road users moving past (-0.1..-0.35 deg/s on the KITTI raw clip's queue after the ego has stopped), and
  // integrated over a stop at a red light it would turn the recorded path by degrees. The smoothed yaw rate
  // is held within speed * max_curvature; <= 0: not limited.
  double max_curvature = 0.2;  // 1/m
};

// The pitch offset (rad, the convention of CameraModel::pitch()) to add to `camera` for which the ground points
// seen at img_p in one view and img_q in the next move most nearly rigidly between them: the weighted
// residual of the least-squares rigid fit, relative to the travel (a pitch that shrinks every distance is no
// better). Searched over +- range_rad (0.25 deg steps, then 0.025 deg); nullopt when the minimum lies at the
// range's edge, when the residual 1 deg to either side is not `sharpness` times the minimum (the points' depth
// range does not pin the pitch down), or when fewer than 3 points stay on the ground at the best pitch.
std::optional<double> ground_pitch_offset(const CameraModel& camera, const std::vector<cv::Point2d>& img_p,
                                          const std::vector<cv::Point2d>& img_q, double range_rad,
                                          double sharpness = 1.5);

// Filters a whole clip's raw samples (forward Kalman + RTS smoother over speed, acceleration, yaw rate), with
// outlier rejection, so every frame gets a value and a sigma. Samples marked measured on output are the raw
// measurements that were kept; rejected ones come back measured=false with filled values.
// `report`, when given, says how the filter treated the clip's readings.
struct SmoothReport {
  double noise_scale = 1.0;  // the raw speeds' sigmas were multiplied by this (their scatter; >= 1)
  int scatter_frames = 0;    // frames whose residuals measured that scatter
  int rejected = 0;          // readings the filter's gate dropped (not counting the median pre-gate's)
  int restarts = 0;          // times the filter restarted from readings that kept disagreeing with it
};
std::vector<EgoMotionSample> smooth_ego_motion(const std::vector<EgoMotionSample>& raw, SmoothOptions opt = {},
                                               SmoothReport* report = nullptr);

}  // namespace hf::footage
