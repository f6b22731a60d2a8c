// Closing speed of an estimated object and the TTC interval from its state covariance, shared by the TTC and
// DRAC metrics.
#pragma once

#include <algorithm>
#include <cmath>
#include <optional>

#include "hazardforge/types.hpp"

namespace hf::risk {

// The paper's denominator v_ego - v_obj * cos(psi) when the ego speed and the object's absolute speed and
// heading are known. Otherwise, with `relative_fallback`, the relative closing speed -v_rel.x (the same
// quantity when the ego drives along +x: v_obj * cos(psi) = v_ego + v_rel.x); else unknown.
inline std::optional<double> closing_speed(const ObjectState& s, const std::optional<double>& ego_speed,
                                           bool relative_fallback) {
  if (ego_speed && s.speed_mps && s.heading_rad) return *ego_speed - *s.speed_mps * std::cos(*s.heading_rad);
  if (relative_fallback && s.velocity_rel) return -(*s.velocity_rel)[0];
  return std::nullopt;
}

// About 90 % two-sided (1.645 sigma each side).
inline constexpr double kIntervalZ = 1.645;

// Interval of TTC = gap / closing from an inverse-TTC value g = closing / gap and its standard deviation: the
// inverse is near Gaussian and finite through zero closing, so the interval is 1 / (g +- z sigma), each end
// infinite when it does not close.
struct TtcInterval {
  double low = kInf;
  double high = kInf;
};
inline TtcInterval ttc_interval_from_inverse(double g, double sigma_g, double z = kIntervalZ) {
  TtcInterval r;
  const double hi = g + z * sigma_g, lo = g - z * sigma_g;
  r.low = hi > 0 ? 1.0 / hi : kInf;
  r.high = lo > 0 ? 1.0 / lo : kInf;
  return r;
}

// The same from a filtered state: covariance of (distance, lateral, v_rel.x, v_rel.y), closing = -v_rel.x.
// nullopt without a covariance or a positive gap.
inline std::optional<TtcInterval> ttc_interval(const ObjectState& s, double gap, double closing,
                                               double z = kIntervalZ) {
  if (!s.covariance || !(gap > 0)) return std::nullopt;
  const cv::Matx44d& P = *s.covariance;
  // g = closing / gap with closing = -vx: dg/dgap = -closing / gap^2, dg/dvx = -1 / gap.
  const double a = -closing / (gap * gap), b = -1.0 / gap;
  const double var = a * a * P(0, 0) + b * b * P(2, 2) + 2.0 * a * b * P(0, 2);
  return ttc_interval_from_inverse(closing / gap, std::sqrt(std::max(var, 0.0)), z);
}

}  // namespace hf::risk
