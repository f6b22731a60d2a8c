// Shared hazard kinematics: limits table, S-curve speed profiles, min-jerk shifts, TTC series, peak
// measurement.
#include "hazardforge/hazard/kinematics.hpp"

#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>

#include "hazardforge/angles.hpp"
#include "hazardforge/geometry.hpp"
#include "hazardforge/number_text.hpp"
#include "hazardforge/yaml_json.hpp"

namespace hf::hazard {

// ---- Speed profiles
// ----------------------------------------------------------------------------------------------

void SpeedProfile::push(double dur, double j) {
  if (dur <= 0) return;
  pieces_.push_back({t_end_, dur, s_end_, v_end_, a_end_, j});
  s_end_ += v_end_ * dur + a_end_ * dur * dur / 2 + j * dur * dur * dur / 6;
  v_end_ += a_end_ * dur + j * dur * dur / 2;
  a_end_ += j * dur;
  t_end_ += dur;
}

SpeedProfile& SpeedProfile::hold(double duration) {
  push(duration, 0.0);
  return *this;
}

double SpeedProfile::change_duration(double v0, double v1, double max_accel, double max_jerk) {
  const double dv = std::abs(v1 - v0);
  if (dv < 1e-12) return 0.0;
  if (dv >= max_accel * max_accel / max_jerk) return dv / max_accel + max_accel / max_jerk;
  return 2.0 * std::sqrt(dv / max_jerk);
}

SpeedProfile& SpeedProfile::change_speed(double v1, double max_accel, double max_jerk) {
  if (max_accel <= 0 || max_jerk <= 0)
    throw Error("SpeedProfile: acceleration and jerk limits must be positive");
  const double v0 = v_end_;
  const double dv = std::abs(v1 - v0);
  if (dv < 1e-12) return *this;
  const double sign = v1 > v0 ? 1.0 : -1.0;
  if (dv >= max_accel * max_accel / max_jerk) {
    const double tj = max_accel / max_jerk;
    push(tj, sign * max_jerk);
    push(dv / max_accel - tj, 0.0);
    push(tj, -sign * max_jerk);
  } else {
    const double tj = std::sqrt(dv / max_jerk);
    push(tj, sign * max_jerk);
    push(tj, -sign * max_jerk);
  }
  v_end_ = v1;  // remove rounding so later pieces start exactly at the target
  a_end_ = 0.0;
  return *this;
}

SpeedProfile::State SpeedProfile::at(double t) const {
  const double v_start = pieces_.empty() ? v_end_ : pieces_.front().v0;
  if (t <= 0) return {v_start * t, v_start, 0, 0};
  if (t >= t_end_) return {s_end_ + v_end_ * (t - t_end_), v_end_, 0, 0};
  auto it = std::upper_bound(pieces_.begin(), pieces_.end(), t,
                             [](double tt, const Piece& p) { return tt < p.t0; });
  const Piece& p = *(it - 1);
  const double u = t - p.t0;
  State st;
  st.s = p.s0 + p.v0 * u + p.a0 * u * u / 2 + p.j * u * u * u / 6;
  st.v = std::max(0.0, p.v0 + p.a0 * u + p.j * u * u / 2);
  st.a = p.a0 + p.j * u;
  st.j = p.j;
  return st;
}

std::optional<double> SpeedProfile::time_at_distance(double s) const {
  if (s <= 0) return 0.0;
  if (s > s_end_) {
    if (v_end_ <= 1e-9) return std::nullopt;
    return t_end_ + (s - s_end_) / v_end_;
  }
  double lo = 0, hi = t_end_;
  for (int i = 0; i < 100; ++i) {
    const double mid = (lo + hi) / 2;
    (at(mid).s < s ? lo : hi) = mid;
  }
  return hi;
}

// ---- Min-jerk shift
// ----------------------------------------------------------------------------------------------

Shift min_jerk_shift(double distance, double duration, double t) {
  if (duration <= 0) return {t > 0 ? distance : 0.0, 0, 0, 0};
  if (t <= 0) return {0, 0, 0, 0};
  if (t >= duration) return {distance, 0, 0, 0};
  const double u = t / duration, T = duration;
  const double u2 = u * u, u3 = u2 * u;
  Shift s;
  s.p = distance * (10 * u3 - 15 * u3 * u + 6 * u3 * u2);
  s.v = distance / T * (30 * u2 - 60 * u3 + 30 * u3 * u);
  s.a = distance / (T * T) * (60 * u - 180 * u2 + 120 * u3);
  s.j = distance / (T * T * T) * (60 - 360 * u + 360 * u2);
  return s;
}

double min_jerk_duration(double distance, double max_rate, double max_accel, double max_jerk) {
  const double d = std::abs(distance);
  if (d < 1e-12) return 0.0;
  return std::max(
      {1.875 * d / max_rate, std::sqrt(5.773502691896258 * d / max_accel), std::cbrt(60.0 * d / max_jerk)});
}

// ---- TTC
// ---------------------------------------------------------------------------------------------------------

std::vector<ParamSpec> TtcConventions::params() {
  std::vector<ParamSpec> specs = Corridor::params();
  for (ParamSpec& p :
       std::vector<ParamSpec>{ParamSpec::number("ego_front_m", 3.4)
                                  .range(0, 20)
                                  .describe("ego rear axle to front bumper (m): gap = x - ego_front_m - l/2"),
                              ParamSpec::number("min_closing_mps", 0.1)
                                  .range(0, 10)
                                  .describe("closing speed (m/s) below which TTC is infinite")})
    specs.push_back(std::move(p));
  return specs;
}

TtcConventions TtcConventions::from(const Params& p) {
  TtcConventions c;
  c.corridor = Corridor::from(p);
  if (p.has("ego_front_m")) c.ego_front = p.get_double("ego_front_m");
  if (p.has("min_closing_mps")) c.min_closing = p.get_double("min_closing_mps");
  return c;
}

TtcSample ttc_at(const TrajectoryPoint& ego, const TrajectoryPoint& obj, const cv::Vec3d& size_lwh,
                 const TtcConventions& conv, const hf::EgoPath& path) {
  const double c = std::cos(ego.heading), s = std::sin(ego.heading);
  const double dx = obj.x - ego.x, dy = obj.y - ego.y;
  TtcSample r;
  r.t = obj.t;
  r.x_rel = c * dx + s * dy;
  r.y_rel = -s * dx + c * dy;
  const double dvx = obj.speed * std::cos(obj.heading) - ego.speed * c;
  const double dvy = obj.speed * std::sin(obj.heading) - ego.speed * s;
  r.closing = -(c * dvx + s * dvy);
  r.in_path = conv.corridor.contains(r.x_rel, r.y_rel, size_lwh[1], path);
  r.gap = r.x_rel - conv.ego_front - size_lwh[0] / 2;
  r.ttc = (r.in_path && r.closing > conv.min_closing) ? std::max(r.gap, 0.0) / r.closing : kInf;
  return r;
}

std::vector<TtcSample> ttc_series(const std::vector<TrajectoryPoint>& ego,
                                  const std::vector<TrajectoryPoint>& obj, const cv::Vec3d& size_lwh,
                                  const TtcConventions& conv) {
  if (ego.size() != obj.size())
    throw Error("TTC of two trajectories: the ego has " + std::to_string(ego.size()) +
                " samples, the object " + std::to_string(obj.size()));
  std::vector<TtcSample> out;
  out.reserve(obj.size());
  for (size_t i = 0; i < obj.size(); ++i) {
    if (std::abs(ego[i].t - obj[i].t) > 1e-6)
      throw Error("TTC of two trajectories: sample " + std::to_string(i) +
                  " is at t=" + num_text(obj[i].t, 3) + " s for the object but t=" + num_text(ego[i].t, 3) +
                  " s for the ego");
    out.push_back(
        ttc_at(ego[i], obj[i], size_lwh, conv, conv.corridor.path_for(ego[i].speed, yaw_rate_at(ego, i))));
  }
  return out;
}

std::optional<double> yaw_rate_at(const std::vector<TrajectoryPoint>& ego, size_t i) {
  if (ego.size() < 2 || i >= ego.size()) return std::nullopt;
  const size_t a = i == 0 ? 0 : i - 1, b = i + 1 >= ego.size() ? ego.size() - 1 : i + 1;
  const double dt = ego[b].t - ego[a].t;
  if (!(dt > 0)) return std::nullopt;
  return angle_diff(ego[b].heading, ego[a].heading) / dt;
}

double min_ttc(const std::vector<TtcSample>& series) {
  double m = kInf;
  for (const auto& s : series) m = std::min(m, s.ttc);
  return m;
}

// ---- Measurement
// -------------------------------------------------------------------------------------------------

MotionStats measure(const std::vector<TrajectoryPoint>& p) {
  MotionStats st;
  const size_t n = p.size();
  if (n < 2) return st;
  const double dt = (p.back().t - p.front().t) / static_cast<double>(n - 1);
  if (dt <= 0) throw Error("measure(): trajectory samples must have increasing time stamps");
  auto vel = [&](size_t k) {
    const size_t a = k == 0 ? 0 : k - 1, b = k + 1 >= n ? n - 1 : k + 1;
    return cv::Vec2d(p[b].x - p[a].x, p[b].y - p[a].y) / ((b - a) * dt);
  };
  for (size_t k = 0; k < n; ++k) st.max_speed = std::max(st.max_speed, cv::norm(vel(k)));
  for (size_t k = 1; k + 1 < n; ++k) {
    const cv::Vec2d a(p[k + 1].x - 2 * p[k].x + p[k - 1].x, p[k + 1].y - 2 * p[k].y + p[k - 1].y);
    const cv::Vec2d acc = a / (dt * dt);
    st.max_accel = std::max(st.max_accel, cv::norm(acc));
    cv::Vec2d v = vel(k);
    const double sp = cv::norm(v);
    const cv::Vec2d dir = sp > 0.2 ? v / sp : cv::Vec2d(std::cos(p[k].heading), std::sin(p[k].heading));
    const double along = acc.dot(dir);
    const double across = std::abs(acc[0] * dir[1] - acc[1] * dir[0]);
    st.max_long_accel = std::max(st.max_long_accel, along);
    st.max_long_decel = std::max(st.max_long_decel, -along);
    st.max_lat_accel = std::max(st.max_lat_accel, across);
  }
  for (size_t k = 1; k + 2 < n; ++k) {
    const cv::Vec2d j(p[k + 2].x - 3 * p[k + 1].x + 3 * p[k].x - p[k - 1].x,
                      p[k + 2].y - 3 * p[k + 1].y + 3 * p[k].y - p[k - 1].y);
    st.max_jerk = std::max(st.max_jerk, cv::norm(j) / (dt * dt * dt));
  }
  for (size_t k = 0; k + 1 < n; ++k)
    st.max_yaw_rate = std::max(st.max_yaw_rate, std::abs(angle_diff(p[k + 1].heading, p[k].heading)) / dt);
  return st;
}

std::vector<std::string> exceeded_limits(const MotionStats& s, const KinematicLimits& l, double tol) {
  std::vector<std::string> r;
  const std::string& c = l.object_class;
  auto over = [&](double v, double lim) { return v > lim * (1 + tol) + 1e-6; };
  if (over(s.max_speed, l.max_speed_mps))
    r.push_back("peak speed " + num_text(s.max_speed) + " m/s exceeds the " + c + " limit of " +
                num_text(l.max_speed_mps) + " m/s");
  if (over(s.max_long_accel, l.max_accel_mps2))
    r.push_back("peak acceleration " + num_text(s.max_long_accel) + " m/s^2 exceeds the " + c + " limit of " +
                num_text(l.max_accel_mps2) + " m/s^2");
  if (over(s.max_long_decel, l.max_decel_mps2))
    r.push_back("peak deceleration " + num_text(s.max_long_decel) + " m/s^2 exceeds the " + c + " limit of " +
                num_text(l.max_decel_mps2) + " m/s^2");
  if (over(s.max_lat_accel, l.max_lateral_accel_mps2))
    r.push_back("peak lateral acceleration " + num_text(s.max_lat_accel) + " m/s^2 exceeds the " + c +
                " limit of " + num_text(l.max_lateral_accel_mps2) + " m/s^2");
  if (over(s.max_jerk, l.max_jerk_mps3))
    r.push_back("peak jerk " + num_text(s.max_jerk) + " m/s^3 exceeds the " + c + " limit of " +
                num_text(l.max_jerk_mps3) + " m/s^3");
  const double yaw_dps = s.max_yaw_rate * 180.0 / CV_PI;
  if (over(yaw_dps, l.max_yaw_rate_dps))
    r.push_back("peak turn rate " + num_text(yaw_dps, 1) + " deg/s exceeds the " + c + " limit of " +
                num_text(l.max_yaw_rate_dps, 1) + " deg/s");
  return r;
}

// ---- Small utilities
// ---------------------------------------------------------------------------------------------

std::optional<cv::Vec2d> ground_velocity(const ObjectState& o, double ego_speed_mps, double chi2) {
  std::optional<cv::Vec2d> v;
  if (o.velocity_rel)
    v = cv::Vec2d(ego_speed_mps + (*o.velocity_rel)[0], (*o.velocity_rel)[1]);
  else if (o.speed_mps && o.heading_rad && std::isfinite(*o.speed_mps))
    v = cv::Vec2d(*o.speed_mps * std::cos(*o.heading_rad), *o.speed_mps * std::sin(*o.heading_rad));
  if (!v || !o.covariance || !(chi2 > 0)) return v;
  const cv::Matx22d S((*o.covariance)(2, 2), (*o.covariance)(2, 3), (*o.covariance)(3, 2),
                      (*o.covariance)(3, 3));
  if (!(cv::determinant(S) > 1e-12)) return v;
  const double d2 = v->dot(S.inv() * *v);
  return d2 < chi2 ? cv::Vec2d(0, 0) : *v;
}

}  // namespace hf::hazard
