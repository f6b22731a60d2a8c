// Monocular state estimation: distance from box height or road contact, velocity from each track's history.
#pragma once

#include <deque>
#include <map>
#include <optional>
#include <set>
#include <string>
#include <vector>

#include "hazardforge/geometry.hpp"
#include "hazardforge/stage.hpp"

namespace hf {

// Geometry the estimator is made of, exposed so tests can check each step against closed forms.
namespace monocular {
// Pinhole range: an object of real height H (m) imaged h px tall by a lens of focal length fy (px) is at
// optical depth d = fy * H / h.
double pinhole_depth(double fy, double real_height_m, double box_height_px);
// Ego-frame point seen at pixel `px` at optical depth `depth` (camera z): X = (u - cx) Z / fx, Y = (v - cy) Z
// / fy, then CameraModel::cam_to_ego.
cv::Vec3d place_at_depth(const CameraModel& cam, const cv::Point2d& px, double depth);
// Image row of the horizon (rays parallel to the road plane) at column u; nullopt when the camera's y axis is
// parallel to the road (horizon undefined).
std::optional<double> horizon_row(const CameraModel& cam, double u);
// Least-squares slope dy/dt; nullopt with fewer than two distinct times.
std::optional<double> ls_slope(const std::vector<double>& t, const std::vector<double>& y);
}  // namespace monocular

// Estimator "monocular": per tracked box, the object's ground-contact point in the ego frame, its
// longitudinal distance, lateral offset, relative and absolute velocity, heading, image scale rate and
// in-path flag.
//
// Ports: tracks (Tracks) + frames (Frame: camera model, ego speed/yaw rate, timestamp) -> states
// (ObjectStates), one packet per frame, stamped with the frame's time. Velocities use the frame timestamps.
// Params: class_sizes, distance_method (pinhole | ground | fused), fused_horizon_margin_px, border_margin_px,
// distance_origin (camera | bumper | ego_origin), front_overhang, velocity_window, velocity_min_age,
// ego_speed_mps, use_yaw_rate, max_misses, min_box_height_px, corridor_half_width, corridor_margin.
// See docs/risk-metrics.md for the formulas.
class MonocularEstimator : public Estimator {
 public:
  static ComponentInfo describe();
  void open(StageContext& ctx) override;
  ObjectStates estimate(StageContext& ctx, const Tracks& tracks, const Frame& frame) override;

 private:
  enum class Method { kPinhole, kGround, kFused };
  enum class Origin { kCamera, kBumper, kEgoOrigin };
  // The frame positions are differentiated in: fixed to the world (dataset pose, or dead-reckoned from ego
  // speed and yaw rate) so the slope is the absolute velocity, or the moving ego frame when the ego speed is
  // unknown.
  enum class Reference { kNone, kPose, kOdometry, kEgo };
  struct Sample {
    double t = 0.0;
    double x = 0.0;  // in the reference frame, m
    double y = 0.0;
    double log_h = 0.0;  // ln(box height in px)
  };

  // Pose of the current ego frame in the reference frame; resets the histories when the reference changes.
  cv::Matx44d reference_pose(const Frame& frame, Reference ref, double ego_speed);

  ClassPriors priors_;
  Corridor corridor_;
  Method method_ = Method::kPinhole;
  Origin origin_ = Origin::kCamera;
  double front_overhang_ = 3.4;
  double horizon_margin_px_ = 40.0;
  double border_margin_px_ = 2.0;
  size_t window_ = 5;
  size_t min_age_ = 3;
  std::optional<double> ego_speed_param_;
  bool use_yaw_rate_ = true;
  double min_box_height_px_ = 2.0;
  int max_misses_ = 2;
  std::map<int64_t, std::deque<Sample>> history_;
  Reference reference_ = Reference::kNone;
  cv::Vec3d odometry_{0, 0, 0};  // x, y, yaw of the ego in the dead-reckoned frame
  double last_t_ = 0.0;
  std::set<std::string> warned_labels_;
};

}  // namespace hf
