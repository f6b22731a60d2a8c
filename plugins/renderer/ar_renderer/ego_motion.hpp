// Ego motion for anchoring a hazard in the world: dataset poses, or road-plane optical flow, or a constant
// speed, turned into one pose per frame in a world-fixed frame.
#pragma once

#include <map>
#include <optional>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "hazardforge/types.hpp"

namespace hf::render {

// Planar motion between consecutive frames: p_cur = R(dyaw) * p_prev + (dx, dy) for a world-fixed point given
// in the previous and current ego frames (a car moving forward by d sees dx = -d).
struct PlanarMotion {
  double dx = 0.0, dy = 0.0, dyaw = 0.0;
  int inliers = 0;
  int tracked = 0;
  bool ok = false;
  std::string why;  // when !ok: what made the estimate degenerate
};

struct FlowOptions {
  double scale = 0.5;  // image scale at which features are tracked
  int max_corners = 250;
  double quality = 0.005;
  int min_distance_px = 7;        // at the tracking scale
  double horizon_margin_px = 12;  // full-resolution rows skipped below the horizon
  double min_range_m = 3.0;       // road points used, by ground distance ahead of the camera
  double max_range_m = 35.0;
  int min_inliers = 25;
  double min_inlier_ratio = 0.3;  // road-plane inliers / tracked features below this = degenerate
  double ransac_px = 3.0;         // RANSAC reprojection threshold (full-resolution pixels)
  double fb_max_px =
      0.0;          // forward-backward tracking disagreement allowed (full-resolution px); 0 = no check
  int win_px = 15;  // LK window at the tracking scale (small: road texture shears as the ego advances)
  double weight_power = 2;  // ground points weigh 1 / range^power in the rigid fit (far points are coarse)
  double max_speed_mps = 70.0;
};

// The part of one frame the flow works on: the road band (rows whose road lies between min_range_m and
// max_range_m, plus a margin), grey, at the tracking scale, as an LK pyramid.
struct FlowFrame {
  std::vector<cv::Mat> pyramid;
  int row0 = 0;                   // first full-resolution row of the band
  double sx = 1, sy = 1;          // tracking scale (band pixels per full-resolution pixel)
  int far_row = 0, near_row = 0;  // rows of the band (tracking scale) where features are taken
  bool empty() const { return pyramid.empty(); }
};

// What one frame's flow hands to the next: the features to track on (band pixels of the frame just
// processed) and the road-plane homography just found (full-resolution pixels, previous -> current), which
// predicts where the features will be in the next frame — LK starts from there instead of from zero motion.
struct FlowCarry {
  std::vector<cv::Point2f> points;
  std::optional<cv::Matx33d> homography;
  void clear() {
    points.clear();
    homography.reset();
  }
};

// Road-plane ego motion from sparse LK flow: features below the horizon and outside detected objects are
// tracked between the two frames, a RANSAC homography keeps those on the road plane, and the plane's known
// geometry (camera height and mounting) turns the inliers into metric ground points whose rigid 2D motion is
// the ego's.
class FlowEgoMotion {
 public:
  explicit FlowEgoMotion(FlowOptions o = {}) : opt_(o) {}
  // Grey road band and its pyramid (empty when the camera sees no road in range).
  FlowFrame prepare(const cv::Mat& bgr_or_gray, const CameraModel& cam) const;
  // Motion between two prepared frames. `exclude` boxes (full-resolution pixels) are left out. With `carry`,
  // features are reused across frames (KLT): on input the points to track in `prev` (band pixels) and the
  // last motion's homography (LK's starting guess), on output the inliers' positions in `cur` and this
  // motion's homography; new features are detected only when fewer than half remain.
  PlanarMotion estimate(const FlowFrame& prev, const FlowFrame& cur, const CameraModel& cam,
                        const std::vector<cv::Rect2f>& exclude, FlowCarry* carry = nullptr) const;
  // Same, from two full images.
  PlanarMotion estimate(const cv::Mat& prev, const cv::Mat& cur, const CameraModel& cam,
                        const std::vector<cv::Rect2f>& exclude) const;
  const FlowOptions& options() const { return opt_; }

 private:
  // One tracking attempt: LK from `guess` (the last homography) over the two finest pyramid levels, or from
  // zero motion over all levels.
  PlanarMotion track(const FlowFrame& prev, const FlowFrame& cur, const CameraModel& cam,
                     const std::vector<cv::Rect2f>& exclude, FlowCarry* carry,
                     const std::optional<cv::Matx33d>& guess) const;
  FlowOptions opt_;
};

// Row of the horizon (topmost pixel row whose ray still hits the ground), clamped to the image.
int horizon_row(const CameraModel& cam);

// 4x4 pose helpers (world_from_ego).
cv::Matx44d planar_pose(double x, double y, double yaw);
cv::Matx44d invert_rigid(const cv::Matx44d& T);
double yaw_of(const cv::Matx44d& T);

enum class EgoMotionMode { kAuto, kPoses, kTrack, kFlow, kConstantSpeed };
EgoMotionMode parse_ego_motion_mode(const std::string& s);

// Keeps one world_from_ego pose per frame seen so far, from the configured source, and answers
// "where was the ego at time t" for anchoring.
class EgoTrajectory {
 public:
  struct Options {
    EgoMotionMode mode = EgoMotionMode::kAuto;
    double speed_mps = -1.0;  // constant_speed / fallback when the frame carries none; < 0 = unknown
    double smoothing = 0.5;   // exponential smoothing of flow velocities (0 = none)
    FlowOptions flow;
  };
  explicit EgoTrajectory(Options o) : opt_(o), flow_(o.flow) {}

  // Adds the pose of this frame. Throws hf::Error naming the frame when the chosen source cannot serve it.
  void update(const Frame& f, const std::vector<cv::Rect2f>& exclude);
  // Pose at stream time t, interpolated between frames; nullopt outside the frames seen.
  std::optional<cv::Matx44d> pose_at(double t) const;
  const cv::Matx44d& current() const { return current_; }
  // Ego velocity in its own current axes (m/s), from the last two poses.
  cv::Vec3d velocity_ego() const { return velocity_ego_; }
  // Ego yaw rate (rad/s, positive = left): the frame's when it carries one, else the heading change between
  // the last two poses (dataset poses, flow or dead reckoning); unknown on the first frame.
  std::optional<double> yaw_rate() const { return yaw_rate_; }
  // What produced the last pose: "poses", "track (video)", "flow", "constant_speed", "hold".
  const std::string& last_source() const { return last_source_; }
  const PlanarMotion& last_flow() const { return last_flow_; }
  double first_time() const { return history_.empty() ? 0.0 : history_.begin()->first; }
  std::vector<std::string> take_warnings();

 private:
  Options opt_;
  FlowEgoMotion flow_;
  std::map<double, cv::Matx44d> history_;
  cv::Matx44d current_ = cv::Matx44d::eye();
  cv::Vec3d velocity_ego_{0, 0, 0};
  std::optional<double> yaw_rate_;
  std::optional<EgoMotionMode> resolved_;
  FlowFrame prev_flow_;
  FlowCarry carry_;
  double prev_t_ = 0.0;
  std::optional<double> prev_speed_, prev_yaw_rate_;
  bool have_prev_ = false;
  cv::Vec3d smoothed_rate_{0, 0, 0};  // (vx, vy, yaw rate) in the previous ego frame
  bool have_rate_ = false;
  PlanarMotion last_flow_;
  std::string last_source_;
  std::vector<std::string> warnings_;
  bool warned_no_speed_ = false;
};

}  // namespace hf::render
