// Ego motion for anchoring a hazard in the world: dataset poses, the recording's ego track, or the frames'
// own speed and yaw rate (a source's, or the ground_odometry stage's measured on the frames) or a constant
// speed, turned into one pose per frame in a world-fixed frame.
#pragma once

#include <map>
#include <optional>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "hazardforge/types.hpp"

namespace hf::render {

// 4x4 pose helpers (world_from_ego).
cv::Matx44d planar_pose(double x, double y, double yaw);
cv::Matx44d invert_rigid(const cv::Matx44d& T);
double yaw_of(const cv::Matx44d& T);

enum class EgoMotionMode { kAuto, kPoses, kTrack, kConstantSpeed };
EgoMotionMode parse_ego_motion_mode(const std::string& s);

// Keeps one world_from_ego pose per frame seen so far, from the configured source, and answers
// "where was the ego at time t" for anchoring.
class EgoTrajectory {
 public:
  struct Options {
    EgoMotionMode mode = EgoMotionMode::kAuto;
    double speed_mps = -1.0;  // constant_speed: used when the frame carries no speed; < 0 = unknown
  };
  explicit EgoTrajectory(Options o);

  // Adds the pose of this frame. Throws hf::Error naming the frame when the chosen source cannot serve it.
  void update(const Frame& f);
  // Pose at stream time t, interpolated between frames; nullopt outside the frames seen.
  std::optional<cv::Matx44d> pose_at(double t) const;
  const cv::Matx44d& current() const { return current_; }
  // Ego velocity in its own current axes (m/s), from the last two poses.
  cv::Vec3d velocity_ego() const { return velocity_ego_; }
  // Ego yaw rate (rad/s, positive = left): the frame's when it carries one, else the heading change between
  // the last two poses (dataset poses, the track or dead reckoning); unknown on the first frame.
  std::optional<double> yaw_rate() const { return yaw_rate_; }
  // What produced the last pose: "poses", "track (video)", "frame speed (video)" (the frame's own speed, with
  // its source), "constant_speed" (the stated speed), "hold".
  const std::string& last_source() const { return last_source_; }
  double first_time() const { return history_.empty() ? 0.0 : history_.begin()->first; }
  std::vector<std::string> take_warnings();

 private:
  Options opt_;
  std::map<double, cv::Matx44d> history_;
  cv::Matx44d current_ = cv::Matx44d::eye();
  cv::Vec3d velocity_ego_{0, 0, 0};
  std::optional<double> yaw_rate_;
  std::optional<EgoMotionMode> resolved_;
  double prev_t_ = 0.0;
  std::optional<double> prev_speed_, prev_yaw_rate_;
  bool have_prev_ = false;
  cv::Vec3d last_rate_{0, 0, 0};  // (vx, vy, yaw rate) in the previous ego frame
  bool have_rate_ = false;
  std::string last_source_;
  std::vector<std::string> warnings_;
  bool warned_no_speed_ = false;
};

}  // namespace hf::render
