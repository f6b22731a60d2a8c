// Ego motion for anchoring a hazard in the world: dataset poses, the ego track, the frames' own speed or a
// constant speed.
#include "ego_motion.hpp"

#include <algorithm>
#include <cmath>

#include <opencv2/calib3d.hpp>

#include "hazardforge/angles.hpp"
#include "hazardforge/error.hpp"

namespace hf::render {

namespace {

cv::Matx33d rot_of(const cv::Matx44d& T) {
  return {T(0, 0), T(0, 1), T(0, 2), T(1, 0), T(1, 1), T(1, 2), T(2, 0), T(2, 1), T(2, 2)};
}

cv::Matx44d compose(const cv::Matx33d& R, const cv::Vec3d& t) {
  return {R(0, 0), R(0, 1), R(0, 2), t[0], R(1, 0), R(1, 1), R(1, 2), t[1],
          R(2, 0), R(2, 1), R(2, 2), t[2], 0,       0,       0,       1};
}

}  // namespace

cv::Matx44d planar_pose(double x, double y, double yaw) {
  const double c = std::cos(yaw), s = std::sin(yaw);
  return compose(cv::Matx33d(c, -s, 0, s, c, 0, 0, 0, 1), cv::Vec3d(x, y, 0));
}

cv::Matx44d invert_rigid(const cv::Matx44d& T) {
  const cv::Matx33d Rt = rot_of(T).t();
  const cv::Vec3d t(T(0, 3), T(1, 3), T(2, 3));
  return compose(Rt, -(Rt * t));
}

double yaw_of(const cv::Matx44d& T) {
  return std::atan2(T(1, 0), T(0, 0));
}

EgoMotionMode parse_ego_motion_mode(const std::string& s) {
  if (s == "auto") return EgoMotionMode::kAuto;
  if (s == "poses") return EgoMotionMode::kPoses;
  if (s == "constant_speed") return EgoMotionMode::kConstantSpeed;
  if (s == "track") return EgoMotionMode::kTrack;
  if (s == "flow")
    throw Error(
        "ego_motion 'flow' is no longer the renderer's: measure the ego motion on the frames with the "
        "ground_odometry stage ({id: odometry, stage: ground_odometry, inputs: {frames: <source>.frames}}) "
        "and "
        "give the renderer odometry.frames; ego_motion auto then follows their speed and yaw rate");
  throw Error("ego_motion '" + s + "' is not one of auto, poses, track, constant_speed");
}

// ---- EgoTrajectory
// ---------------------------------------------------------------------------------------------

EgoTrajectory::EgoTrajectory(Options o) : opt_(std::move(o)) {}

std::vector<std::string> EgoTrajectory::take_warnings() {
  std::vector<std::string> w;
  w.swap(warnings_);
  return w;
}

void EgoTrajectory::update(const Frame& f) {
  if (!resolved_) {
    EgoMotionMode m = opt_.mode;
    if (m == EgoMotionMode::kAuto)
      m = f.ego.T_world_ego                                 ? EgoMotionMode::kPoses
          : f.ego_track && f.ego_track->samples.size() >= 2 ? EgoMotionMode::kTrack
                                                            : EgoMotionMode::kConstantSpeed;
    resolved_ = m;
  }
  const double t = f.timestamp;
  const double dt = have_prev_ ? t - prev_t_ : 0.0;
  const cv::Matx44d prev_pose = current_;
  if (*resolved_ == EgoMotionMode::kPoses) {
    if (!f.ego.T_world_ego)
      throw Error(frame_name(f) +
                  ": ego_motion 'poses' needs the ego pose (Frame.ego.T_world_ego), which this "
                  "frame lacks; use ego_motion: constant_speed (the frames' speed, or ego_speed_mps) for "
                  "sources without poses");
    // The road the ego drives on is its ground plane, in the planner as here: its pose on the map (x, y,
    // heading), without the body's pitch and roll. Datasets' attitude comes from an IMU while their height
    // stays fixed (nuScenes: z = 0 throughout, pitch -4.6..2.8 deg in scene-0916), and chaining that pitch
    // over the tens of metres between a hazard's anchor frame and the current one lifted it off the road
    // (0.35 m at frame 30 of the nuScenes cut-in: drawn a third taller than its box, and called a bus).
    const cv::Matx44d& T = *f.ego.T_world_ego;
    current_ = planar_pose(T(0, 3), T(1, 3), yaw_of(T));
    last_source_ = "poses";
  } else if (*resolved_ == EgoMotionMode::kTrack) {
    if (!f.ego_track || f.ego_track->samples.size() < 2)
      throw Error(
          frame_name(f) +
          ": ego_motion 'track' needs the recording's ego track (Frame.ego_track: dataset poses or the "
          "ego motion the video source estimated), which this frame lacks");
    const EgoTrackSample e = f.ego_track->at(t);
    current_ = planar_pose(e.x, e.y, e.yaw);
    last_source_ = "track (" + f.ego_track->source + ")";
  } else if (!have_prev_) {
    current_ = cv::Matx44d::eye();  // dead reckoning starts at the first frame
    last_source_ = f.ego.speed_mps ? "frame speed (" + f.ego.source + ")" : "constant_speed";
  } else {
    cv::Vec3d rate;  // (vx, vy, yaw rate) in the previous ego frame
    std::optional<double> v = f.ego.speed_mps;
    double w = f.ego.yaw_rate.value_or(0.0);
    if (v && prev_speed_) {  // the interval's mean (trapezoid), when both ends carry a speed
      v = 0.5 * (*v + *prev_speed_);
      w = 0.5 * (w + prev_yaw_rate_.value_or(w));
    }
    if (v) {
      rate = cv::Vec3d(*v, 0.0, w);
      last_source_ = "frame speed (" + (f.ego.source.empty() ? std::string("unknown") : f.ego.source) + ")";
    } else if (opt_.speed_mps >= 0) {
      rate = cv::Vec3d(opt_.speed_mps, 0.0, w);
      last_source_ = "constant_speed";
    } else if (have_rate_) {
      rate = last_rate_;  // hold the last estimate through a short stretch without a speed
      last_source_ = "hold";
    } else {
      rate = cv::Vec3d(0, 0, 0);
      last_source_ = "hold";
      if (!warned_no_speed_) {
        warnings_.push_back(
            frame_name(f) +
            ": no ego speed known (the frame carries none and ego_speed_mps is unset; for a "
            "source without ego motion, the ground_odometry stage measures it on the frames): "
            "assuming the ego is still");
        warned_no_speed_ = true;
      }
    }
    last_rate_ = rate;
    have_rate_ = true;
    // Integrate along the arc: translate along the mid-interval heading.
    const double psi = rate[2] * dt, c = std::cos(psi / 2), s = std::sin(psi / 2);
    const cv::Vec3d step(dt * (c * rate[0] - s * rate[1]), dt * (s * rate[0] + c * rate[1]), 0.0);
    const double cp = std::cos(psi), sp = std::sin(psi);
    current_ = prev_pose * compose(cv::Matx33d(cp, -sp, 0, sp, cp, 0, 0, 0, 1), step);
  }

  // Velocity in the current ego axes: dataset velocity when given, else the pose difference.
  const cv::Matx33d Rt = rot_of(current_).t();
  if (f.ego.velocity_world) {
    velocity_ego_ = Rt * *f.ego.velocity_world;
  } else if (have_prev_ && dt > 1e-6) {
    const cv::Vec3d dp(current_(0, 3) - prev_pose(0, 3), current_(1, 3) - prev_pose(1, 3),
                       current_(2, 3) - prev_pose(2, 3));
    velocity_ego_ = Rt * (dp / dt);
  } else if (f.ego.speed_mps) {
    velocity_ego_ = cv::Vec3d(*f.ego.speed_mps, 0, 0);
  } else if (opt_.speed_mps >= 0) {
    velocity_ego_ = cv::Vec3d(opt_.speed_mps, 0, 0);
  }
  if (f.ego.yaw_rate)
    yaw_rate_ = f.ego.yaw_rate;
  else if (have_prev_ && dt > 1e-6)
    yaw_rate_ = angle_diff(yaw_of(current_), yaw_of(prev_pose)) / dt;
  history_[t] = current_;
  prev_speed_ = f.ego.speed_mps;
  prev_yaw_rate_ = f.ego.yaw_rate;
  prev_t_ = t;
  have_prev_ = true;
}

std::optional<cv::Matx44d> EgoTrajectory::pose_at(double t) const {
  if (history_.empty()) return std::nullopt;
  constexpr double kEps = 1e-6;
  auto hi = history_.lower_bound(t - kEps);
  if (hi == history_.end()) return std::nullopt;
  if (std::abs(hi->first - t) <= kEps) return hi->second;
  if (hi == history_.begin()) return std::nullopt;
  auto lo = std::prev(hi);
  const double u = (t - lo->first) / (hi->first - lo->first);
  const cv::Matx33d Ra = rot_of(lo->second), Rb = rot_of(hi->second);
  cv::Vec3d w;
  cv::Rodrigues(cv::Mat(Ra.t() * Rb), w);
  cv::Matx33d Ru;
  cv::Rodrigues(w * u, Ru);
  const cv::Vec3d ta(lo->second(0, 3), lo->second(1, 3), lo->second(2, 3));
  const cv::Vec3d tb(hi->second(0, 3), hi->second(1, 3), hi->second(2, 3));
  return compose(Ra * Ru, ta + u * (tb - ta));
}

}  // namespace hf::render
