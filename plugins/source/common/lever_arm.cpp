// Internal: the distance driven between two views from the camera's lever arm ahead of the rear axle.
#include "hazardforge/footage/lever_arm.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

#include "hazardforge/angles.hpp"
#include "median.hpp"

namespace hf::footage {

namespace {}  // namespace

std::optional<double> lever_arm_chord(double turn, double heading, double lever_m) {
  // The camera's move d = c u(turn/2) + L (cos turn - 1, sin turn) is parallel to u(heading):
  // c sin(heading - turn/2) = L (sin turn cos heading + (1 - cos turn) sin heading).
  const double den = std::sin(heading - 0.5 * turn);
  const double num =
      lever_m * (std::sin(turn) * std::cos(heading) + (1.0 - std::cos(turn)) * std::sin(heading));
  if (!(std::abs(den) > 1e-9) || !std::isfinite(num)) return std::nullopt;
  const double c = num / den;
  if (!(c > 0) || !std::isfinite(c)) return std::nullopt;
  return c;
}

LeverArmOptions with_travel_column(LeverArmOptions opt, const CameraModel& camera, double travel_x) {
  if (std::isfinite(travel_x)) opt.prior_bias = std::atan2(camera.cx - travel_x, camera.fx);
  return opt;
}

LeverArmScale::LeverArmScale(double lever_m, LeverArmOptions opt) : lever_m_(lever_m), opt_(opt) {}

void LeverArmScale::observe(const EgoMotionSample& s) {
  if (!s.two_view || !std::isfinite(s.two_view->heading_sigma)) return;
  if (std::abs(s.two_view->yaw) < opt_.straight_turn_deg * kRadPerDeg)
    straight_.push_back(s.two_view->heading);
}

double LeverArmScale::bias() const {
  return from_straight_pairs() ? detail::median(straight_) : opt_.prior_bias;
}

double LeverArmScale::bias_sigma() const {
  if (!from_straight_pairs()) return opt_.prior_bias_sigma_deg * kRadPerDeg;
  // The median's sigma from the pairs' spread (MAD), as of a normal sample.
  const double m = detail::median(straight_);
  std::vector<double> dev;
  for (double h : straight_) dev.push_back(std::abs(h - m));
  const double sd = 1.4826 * detail::median(dev);
  return 1.2533 * sd / std::sqrt(static_cast<double>(straight_.size()));
}

EgoMotionSample LeverArmScale::fuse(EgoMotionSample s) const {
  if (!s.two_view || !(lever_m_ > 0) || !std::isfinite(s.two_view->heading_sigma)) return s;
  const double turn = s.two_view->yaw;
  const double interval = s.interval_s;
  if (std::abs(turn) < opt_.min_turn_deg * kRadPerDeg || !(interval > 1e-6)) return s;
  const double heading = s.two_view->heading - bias();
  const auto c = lever_arm_chord(turn, heading, lever_m_);
  if (!c) return s;
  // Its sigma from the direction's (the pair's halves and the bias) and the turn's, by central differences.
  const double sh = std::hypot(s.two_view->heading_sigma, bias_sigma());
  const double st = s.two_view->yaw_sigma;
  auto spread = [&](double dh, double dtu) {
    const auto a = lever_arm_chord(turn + dtu, heading + dh, lever_m_);
    const auto b = lever_arm_chord(turn - dtu, heading - dh, lever_m_);
    if (!a || !b) return std::numeric_limits<double>::infinity();
    return 0.5 * std::abs(*a - *b);
  };
  const double sc = std::hypot(spread(sh, 0), spread(0, st));
  if (!(sc <= opt_.max_relative_sigma * *c)) return s;
  // The rear axle drove the arc over the chord.
  const double arc = std::abs(turn) > 1e-9 ? 0.5 * std::abs(turn) / std::sin(0.5 * std::abs(turn)) : 1.0;
  const double v = arc * *c / interval, sv = arc * sc / interval;
  s.lever_speed_mps = v;
  s.lever_speed_sigma = sv;
  if (!s.measured) {
    s.speed_mps = v;
    s.speed_sigma = sv;
    s.measured = true;
    s.speed_cue = EgoMotionSample::SpeedCue::kLeverArm;
    return s;
  }
  const double sr = std::hypot(s.speed_sigma, opt_.road_sigma_floor_mps);
  s.road_speed_mps = s.speed_mps;
  if (std::abs(s.speed_mps - v) <= opt_.gate_sigma * std::hypot(sr, sv)) {
    const double wr = 1.0 / (sr * sr), wl = 1.0 / (sv * sv);
    s.speed_mps = (wr * s.speed_mps + wl * v) / (wr + wl);
    s.speed_sigma = 1.0 / std::sqrt(wr + wl);
    s.speed_cue = EgoMotionSample::SpeedCue::kRoadAndLeverArm;
  } else if (sv <= opt_.trust_relative_sigma * v) {
    s.speed_mps = v;
    s.speed_sigma = sv;
    s.speed_cue = EgoMotionSample::SpeedCue::kLeverArm;
  } else {
    s.road_speed_mps.reset();
  }
  return s;
}

LeverArmScale apply_lever_arm(std::vector<EgoMotionSample>& raw, double lever_m, LeverArmOptions opt) {
  LeverArmScale scale(lever_m, opt);
  for (const auto& s : raw) scale.observe(s);
  for (auto& s : raw) s = scale.fuse(s);
  return scale;
}

}  // namespace hf::footage
