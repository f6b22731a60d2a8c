// Per-track Kalman filter over ground position and velocity in the moving ego frame, with gating.
#pragma once

#include <optional>

#include <opencv2/core.hpp>

namespace hf::estimation {

// How the ego moved between the previous and the current frame, in the previous ego frame (x forward, y
// left): translation (dx, dy) and heading change dyaw. `absolute` = the ego's own speed is known, so the
// filter's velocity is the object's absolute velocity (a parked car has zero); otherwise the displacement is
// zero and the velocity is relative to the ego.
struct EgoDelta {
  double dx = 0.0, dy = 0.0, dyaw = 0.0;
  bool absolute = false;
};

struct TrackFilterConfig {
  double accel_sd = 2.5;           // m/s^2: white-noise acceleration of the object (process noise)
  double relative_accel_sd = 1.5;  // m/s^2 added without ego speed: the ego's own acceleration
  double init_velocity_sd = 10.0;  // m/s: spread of the velocity before the second measurement
  double gate_chi2 = 13.82;        // 2-dof position innovation gate (99.9 %)
  double scale_gate_chi2 = 10.83;  // 1-dof gate of the scale (inverse-TTC) measurement (99.9 %)
  double max_speed_mps = 60.0;     // the class's limit: a measurement implying more is physically impossible
  int reinit_after = 3;            // consecutive rejected positions after which the state restarts there
  // Covariance matching: the position noise is scaled by the track's running mean of the normalised
  // innovation squared over its expectation (2), between 1 and max_noise_scale — so a detector that jitters
  // more than the stated box_jitter_px is learnt from the track itself.
  double noise_memory = 0.2;  // weight of the newest update in the running mean
  double max_noise_scale = 25.0;
};

// State s = (x, y, vx, vy): the object's ground point in the current ego frame (m) and its velocity in the
// current ego axes (m/s; absolute when the ego speed is known, else relative). Constant velocity between
// frames; the ego's motion moves and turns the frame under it.
class TrackFilter {
 public:
  enum class Update { kAccepted, kGated, kImpossible, kRestarted };

  explicit TrackFilter(TrackFilterConfig c = {}) : cfg_(c) {}
  bool initialised() const { return initialised_; }
  int updates() const { return updates_; }  // accepted position updates since (re)start
  double time() const { return t_; }
  double last_update() const { return last_update_; }  // time of the last accepted measurement
  double noise_scale() const { return noise_scale_; }  // current factor on the position noise

  // First position (or a restart): velocity zero with init_velocity_sd — "standing still" when the ego's motion
  // is known (absolute velocities), "moving with the ego" otherwise; both wide open.
  void init(double t, const cv::Vec2d& z, const cv::Matx22d& R);
  // Moves the state to time t and into the current ego frame.
  void predict(double t, const EgoDelta& ego);
  // Ground-position measurement with covariance R. Gated by the Mahalanobis distance and by the speed it
  // implies; after reinit_after consecutive rejections the filter restarts at z (returns kRestarted).
  Update update_position(const cv::Vec2d& z, const cv::Matx22d& R);
  // Scale change of the object's image: z = (ratio - 1) / dt = closing speed / depth, with depth = x - cam_x
  // and closing = -(vx - ego_vx) (ego_vx = the ego's own speed along x in absolute mode, 0 in relative).
  Update update_inverse_ttc(double z, double var, double cam_x, double ego_vx);
  // Bearing only (a box whose range cues are cut off by the image border, a person seen from the waist up):
  // the object lies on the ground line through `origin` along `dir` (the camera's position and the viewing
  // ray's direction, ego frame); var = variance of the object's offset across that line (m^2) at its range.
  // Moves the state across the ray and leaves the range to the prediction and the other cues. Gated by the
  // 1-dof innovation (scale_gate_chi2); its noise is scaled by covariance matching on its own innovations. No
  // range is measured, so last_update() does not move.
  Update update_bearing(const cv::Vec2d& origin, const cv::Vec2d& dir, double var);
  // Rescales the state about the camera (positions and relative velocity by k): when the class prior behind
  // the range changes (a track relabelled car -> truck), so TTC = range / closing is unchanged.
  void rescale(double k, double cam_x, double ego_vx);
  // The class's limits (a relabelled track takes its new class's), applied to the state at once.
  void set_class_limits(double max_speed_mps, double accel_sd);

  const cv::Vec4d& state() const { return s_; }
  const cv::Matx44d& covariance() const { return P_; }

 private:
  void clamp_speed();
  TrackFilterConfig cfg_;
  bool initialised_ = false;
  bool absolute_ = false;
  int updates_ = 0;
  int rejected_ = 0;
  double t_ = 0.0;
  double last_dt_ = 0.0;
  double last_update_ = 0.0;
  double noise_scale_ = 1.0;
  double mean_nis_ = 2.0;
  double bearing_noise_scale_ = 1.0;  // the same for bearing-only updates (their own innovations)
  double mean_bearing_nis_ = 1.0;
  cv::Vec4d s_{0, 0, 0, 0};
  cv::Matx44d P_ = cv::Matx44d::eye();
};

}  // namespace hf::estimation
