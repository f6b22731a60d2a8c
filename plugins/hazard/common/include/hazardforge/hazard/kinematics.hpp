// Shared hazard kinematics: per-class limits, jerk-limited profiles, lane-change shapes, TTC of two
// trajectories.
#pragma once

#include <filesystem>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include "hazardforge/corridor.hpp"
#include "hazardforge/params.hpp"
#include "hazardforge/road_user_limits.hpp"
#include "hazardforge/types.hpp"

namespace hf::hazard {

// One-dimensional motion made of constant-jerk pieces: distance s, speed v, acceleration a along a path.
// Speed changes are S-curves (acceleration ramps with bounded jerk at both ends), so the result stays within
// an acceleration and a jerk limit at every instant.
class SpeedProfile {
 public:
  struct State {
    double s = 0, v = 0, a = 0, j = 0;
  };

  explicit SpeedProfile(double v0 = 0.0) : v_end_(v0) {}
  // Constant speed for `duration` seconds.
  SpeedProfile& hold(double duration);
  // Changes speed to v1 with |a| <= max_accel and |jerk| <= max_jerk, starting and ending with a = 0.
  SpeedProfile& change_speed(double v1, double max_accel, double max_jerk);

  // State at time t >= 0 after the start; past the end the final speed is held.
  State at(double t) const;
  double duration() const { return t_end_; }
  double end_speed() const { return v_end_; }
  double end_distance() const { return s_end_; }
  // Earliest time at which the distance reaches `s`; nullopt when it never does (the motion stops first).
  std::optional<double> time_at_distance(double s) const;
  // Duration of change_speed(v1, ...) from speed v0, without building it.
  static double change_duration(double v0, double v1, double max_accel, double max_jerk);

 private:
  struct Piece {
    double t0, dur, s0, v0, a0, j;
  };
  void push(double dur, double j);
  std::vector<Piece> pieces_;
  double t_end_ = 0, s_end_ = 0, v_end_ = 0, a_end_ = 0;
};

// Rest-to-rest minimum-jerk shift (quintic 10u^3 - 15u^4 + 6u^5) of `distance` over `duration`.
struct Shift {
  double p = 0, v = 0, a = 0, j = 0;
};
Shift min_jerk_shift(double distance, double duration, double t);
// Shortest duration for which a min-jerk shift of `distance` keeps its peak rate, acceleration and jerk
// within the given limits (peaks: 1.875 D/T, 5.7735 D/T^2, 60 D/T^3).
double min_jerk_duration(double distance, double max_rate, double max_accel, double max_jerk);

// The ground-truth protocol's TTC conventions (GUIDE section 3), every constant configurable. In-path is the
// SDK's corridor (params corridor_half_width, corridor_margin, corridor_path), so a planned hazard is judged
// in path exactly as the risk metrics judge it.
struct TtcConventions {
  Corridor corridor;         // along the ego's path by default
  double ego_front = 3.4;    // m, rear axle (ego origin) to front bumper; gap = x - ego_front - l/2
  double min_closing = 0.1;  // m/s; below it TTC is infinite
  static std::vector<ParamSpec> params();
  static TtcConventions from(const Params& p);
};

struct TtcSample {
  double t = 0;                 // stream time
  double x_rel = 0, y_rel = 0;  // object centre in the ego frame at t
  bool in_path = false;
  double gap = kInf;   // m
  double closing = 0;  // m/s, positive = approaching
  double ttc = kInf;   // s; infinite when not in path or not closing
};

// TTC of one object sample seen from one ego sample (both in the same fixed frame); `path` is the ego's
// predicted path from that sample (straight by default), which the corridor follows unless it is straight.
TtcSample ttc_at(const TrajectoryPoint& ego, const TrajectoryPoint& obj, const cv::Vec3d& size_lwh,
                 const TtcConventions& conv, const hf::EgoPath& path = {});
// The ego's yaw rate at sample i (rad/s): central difference of the headings (one-sided at the ends);
// unknown for a single sample.
std::optional<double> yaw_rate_at(const std::vector<TrajectoryPoint>& ego, size_t i);
// Pairs samples by index; both trajectories must share their time stamps (throws hf::Error otherwise). The
// corridor at sample i follows the ego's planned motion there: its speed and yaw_rate_at(ego, i).
std::vector<TtcSample> ttc_series(const std::vector<TrajectoryPoint>& ego,
                                  const std::vector<TrajectoryPoint>& obj, const cv::Vec3d& size_lwh,
                                  const TtcConventions& conv);
double min_ttc(const std::vector<TtcSample>& series);

// Peak kinematic quantities of a sampled trajectory, from finite differences of the positions only (so they
// also hold for trajectories this library did not make).
struct MotionStats {
  double max_speed = 0;
  double max_accel = 0;       // |a| (vector)
  double max_long_accel = 0;  // along the motion, speeding up
  double max_long_decel = 0;  // along the motion, braking (positive)
  double max_lat_accel = 0;   // across the motion
  double max_jerk = 0;        // |da/dt| (vector)
  double max_yaw_rate = 0;    // rad/s, from the headings
};
MotionStats measure(const std::vector<TrajectoryPoint>& points);
// One reason per limit the stats exceed (relative tolerance for sampling error), naming the class.
std::vector<std::string> exceeded_limits(const MotionStats& stats, const KinematicLimits& limits,
                                         double tolerance = 0.02);

// A tracked object's ground velocity (absolute, in the ego's axes, m/s) as planning and the scene rules read
// it: the estimate's, or zero when the estimator's own covariance cannot tell it from standing still (the
// velocity's Mahalanobis distance from zero below `chi2`, 5.99 = 95 % for two dimensions). A parked car whose
// measured range drifts while the ego turns (its box's nearest point slides along its flank) is parked, not
// oncoming. nullopt when the object has no velocity; without a covariance, or with chi2 = 0, the estimate is
// taken as it is (planning a lead's braking wants its best speed, also an uncertain one; predicting where it
// will be wants no motion it cannot show).
std::optional<cv::Vec2d> ground_velocity(const ObjectState& o, double ego_speed_mps, double chi2 = 5.99);

}  // namespace hf::hazard
