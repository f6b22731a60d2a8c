// Per-track Kalman filter: constant velocity in the ego frame, ego-motion compensated, gated updates.
#include "hazardforge/estimation/track_filter.hpp"

#include <algorithm>
#include <cmath>

namespace hf::estimation {

void TrackFilter::init(double t, const cv::Vec2d& z, const cv::Matx22d& R) {
  s_ = {z[0], z[1], 0.0, 0.0};
  P_ = cv::Matx44d::zeros();
  for (int i = 0; i < 2; ++i)
    for (int j = 0; j < 2; ++j) P_(i, j) = R(i, j);
  const double v2 = cfg_.init_velocity_sd * cfg_.init_velocity_sd;
  P_(2, 2) = P_(3, 3) = v2;
  t_ = t;
  last_update_ = t;
  initialised_ = true;
  noise_scale_ = 1.0;
  mean_nis_ = 2.0;
  updates_ = 1;
  rejected_ = 0;
}

void TrackFilter::predict(double t, const EgoDelta& ego) {
  const double dt = t - t_;
  if (!(dt > 0)) return;
  absolute_ = ego.absolute;
  last_dt_ = dt;
  // Object moves with its velocity; then the frame moves by the ego's displacement and turns by dyaw.
  const double c = std::cos(ego.dyaw), s = std::sin(ego.dyaw);
  const cv::Matx22d Rt(c, s, -s, c);  // rotation from the previous into the current ego axes
  const cv::Vec2d p(s_[0] + s_[2] * dt - ego.dx, s_[1] + s_[3] * dt - ego.dy);
  const cv::Vec2d pn = Rt * p;
  const cv::Vec2d vn = Rt * cv::Vec2d(s_[2], s_[3]);
  s_ = {pn[0], pn[1], vn[0], vn[1]};
  cv::Matx44d F = cv::Matx44d::zeros();
  for (int i = 0; i < 2; ++i)
    for (int j = 0; j < 2; ++j) {
      F(i, j) = Rt(i, j);
      F(i, j + 2) = Rt(i, j) * dt;
      F(i + 2, j + 2) = Rt(i, j);
    }
  double a2 = cfg_.accel_sd * cfg_.accel_sd;
  if (!ego.absolute) a2 += cfg_.relative_accel_sd * cfg_.relative_accel_sd;
  // Discrete white-noise acceleration, the same on both axes (so it is rotation invariant).
  const double q11 = a2 * dt * dt * dt / 3.0, q12 = a2 * dt * dt / 2.0, q22 = a2 * dt;
  cv::Matx44d Q = cv::Matx44d::zeros();
  for (int i = 0; i < 2; ++i) {
    Q(i, i) = q11;
    Q(i, i + 2) = Q(i + 2, i) = q12;
    Q(i + 2, i + 2) = q22;
  }
  P_ = F * P_ * F.t() + Q;
  t_ = t;
}

TrackFilter::Update TrackFilter::update_position(const cv::Vec2d& z, const cv::Matx22d& R_stated) {
  const cv::Matx22d R = R_stated * noise_scale_;
  const cv::Vec2d y(z[0] - s_[0], z[1] - s_[1]);
  cv::Matx22d S;
  for (int i = 0; i < 2; ++i)
    for (int j = 0; j < 2; ++j) S(i, j) = P_(i, j) + R(i, j);
  const cv::Matx22d Si = S.inv();
  const double d2 = y.dot(Si * y);
  // The speed this measurement implies if taken at face value: the position jump over the last step on top of
  // the predicted velocity (absolute mode), or relative to the ego (relative mode: the ego's own speed is
  // unknown, so only the object's class limit plus a plausible ego speed bounds it).
  bool impossible = false;
  if (updates_ >= 1 && last_dt_ > 0) {
    const cv::Vec2d v(s_[2] + y[0] / last_dt_, s_[3] + y[1] / last_dt_);
    const double bound = absolute_ ? cfg_.max_speed_mps : cfg_.max_speed_mps + 40.0;
    impossible = std::hypot(v[0], v[1]) > bound && d2 > 1.0;
  }
  if (impossible || d2 > cfg_.gate_chi2) {
    if (++rejected_ >= cfg_.reinit_after) {
      init(t_, z, R_stated);
      return Update::kRestarted;
    }
    return impossible ? Update::kImpossible : Update::kGated;
  }
  rejected_ = 0;
  // The innovation of the noise as stated (not yet scaled) tells how much the detector really jitters.
  {
    cv::Matx22d S0;
    for (int i = 0; i < 2; ++i)
      for (int j = 0; j < 2; ++j) S0(i, j) = P_(i, j) + R_stated(i, j);
    const double nis = y.dot(S0.inv() * y);
    mean_nis_ = (1.0 - cfg_.noise_memory) * mean_nis_ + cfg_.noise_memory * nis;
  }
  cv::Matx<double, 4, 2> PHt;
  for (int i = 0; i < 4; ++i)
    for (int j = 0; j < 2; ++j) PHt(i, j) = P_(i, j);
  const cv::Matx<double, 4, 2> K = PHt * Si;
  s_ += K * y;
  cv::Matx<double, 4, 4> KH = cv::Matx44d::zeros();
  for (int i = 0; i < 4; ++i)
    for (int j = 0; j < 2; ++j) KH(i, j) = K(i, j);
  const cv::Matx44d IKH = cv::Matx44d::eye() - KH;
  // Joseph form keeps P symmetric and positive with the strongly correlated range/velocity states.
  cv::Matx44d KRKt = K * R * K.t();
  P_ = IKH * P_ * IKH.t() + KRKt;
  clamp_speed();
  ++updates_;
  last_update_ = t_;
  noise_scale_ = std::clamp(mean_nis_ / 2.0, 1.0, cfg_.max_noise_scale);
  return Update::kAccepted;
}

void TrackFilter::clamp_speed() {
  // A state faster than the class can move is a filter transient, not a measurement: project it back onto the
  // limit (absolute mode only; a relative velocity also holds the ego's unknown speed).
  if (!absolute_) return;
  const double v = std::hypot(s_[2], s_[3]);
  if (v > cfg_.max_speed_mps && v > 0) {
    s_[2] *= cfg_.max_speed_mps / v;
    s_[3] *= cfg_.max_speed_mps / v;
  }
}

TrackFilter::Update TrackFilter::update_inverse_ttc(double z, double var, double cam_x, double ego_vx) {
  const double depth = s_[0] - cam_x;
  if (!(depth > 0.5) || !(var > 0)) return Update::kGated;
  const double vrel = s_[2] - ego_vx;
  const double h = -vrel / depth;
  // h = -(vx - ego_vx) / (x - cam_x): dh/dx = vrel / depth^2, dh/dvx = -1 / depth.
  const cv::Matx14d H(vrel / (depth * depth), 0.0, -1.0 / depth, 0.0);
  const double S = (H * P_ * H.t())(0, 0) + var;
  const double y = z - h;
  if (y * y / S > cfg_.scale_gate_chi2) return Update::kGated;
  const cv::Matx41d K = (P_ * H.t()) * (1.0 / S);
  for (int i = 0; i < 4; ++i) s_[i] += K(i, 0) * y;
  const cv::Matx44d IKH = cv::Matx44d::eye() - K * H;
  P_ = IKH * P_ * IKH.t() + (K * K.t()) * var;
  clamp_speed();
  last_update_ = t_;
  return Update::kAccepted;
}

TrackFilter::Update TrackFilter::update_bearing(const cv::Vec2d& origin, const cv::Vec2d& dir, double var) {
  if (!initialised_ || !(dir[0] > 1e-6) || !(var > 0)) return Update::kGated;
  // The ray at the predicted range gives the sideways position there; the range's own uncertainty spreads it
  // by the ray's slope. One bearing cannot tell a sideways step from a step along the ray, so only the
  // sideways part of the state (y, vy) is updated and the range and its rate (x, vx: the ego's motion, the
  // keypoint scale, earlier ranges) are kept as they are (a Schmidt, or "consider", update).
  const double slope = dir[1] / dir[0];
  const double z = origin[1] + (s_[0] - origin[0]) * slope;
  const double range_part = P_(0, 0) * slope * slope;
  const double r = var * bearing_noise_scale_ + range_part;
  const double S = P_(1, 1) + r;
  const double y = z - s_[1];
  if (y * y / S > cfg_.scale_gate_chi2) return Update::kGated;
  // Covariance matching as for positions: a box whose column jitters more than the stated noise (a cut box's
  // visible part changes its width) is learnt from the innovations (expectation 1 for one degree of freedom).
  mean_bearing_nis_ = (1.0 - cfg_.noise_memory) * mean_bearing_nis_ +
                      cfg_.noise_memory * y * y / (P_(1, 1) + var + range_part);
  bearing_noise_scale_ = std::clamp(mean_bearing_nis_, 1.0, cfg_.max_noise_scale);
  cv::Matx41d K = cv::Matx41d(P_(0, 1), P_(1, 1), P_(2, 1), P_(3, 1)) * (1.0 / S);
  K(0, 0) = 0.0;
  K(2, 0) = 0.0;
  for (int i = 0; i < 4; ++i) s_[i] += K(i, 0) * y;
  const cv::Matx14d H(0.0, 1.0, 0.0, 0.0);
  const cv::Matx44d IKH = cv::Matx44d::eye() - K * H;
  P_ = IKH * P_ * IKH.t() + (K * K.t()) * r;
  clamp_speed();
  return Update::kAccepted;
}

void TrackFilter::set_class_limits(double max_speed_mps, double accel_sd) {
  cfg_.max_speed_mps = max_speed_mps;
  cfg_.accel_sd = accel_sd;
  clamp_speed();
}

void TrackFilter::rescale(double k, double cam_x, double ego_vx) {
  s_[0] = cam_x + k * (s_[0] - cam_x);
  s_[1] *= k;
  s_[2] = ego_vx + k * (s_[2] - ego_vx);
  s_[3] *= k;
  P_ = P_ * (k * k);
  clamp_speed();
}

}  // namespace hf::estimation
