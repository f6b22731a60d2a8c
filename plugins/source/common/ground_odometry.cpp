// Ground-plane visual odometry: ground points tracked in the bird's-eye view and a RANSAC rigid fit give the
// distance travelled and the yaw change between consecutive frames.
#include <cmath>
#include <limits>
#include <optional>

#include "bev_tracker.hpp"
#include "hazardforge/angles.hpp"
#include "hazardforge/footage/attitude.hpp"
#include "hazardforge/footage/ego_motion.hpp"
#include "hazardforge/footage/two_view.hpp"

namespace hf::footage {

struct GroundOdometry::Impl {
  Impl(const CameraModel& c, const OdometryOptions& o) : cam(c), opt(o), tracker(c, o), rotation(c) {}
  CameraModel cam;
  OdometryOptions opt;
  detail::BevTracker tracker;
  TwoViewRotation rotation;
  double prev_t = 0;
  bool have_prev = false;
  std::optional<double> last_measured_t;
  double last_speed = 0;
  bool last_confirmed = false;  // the last measurement agreed with the one before it
};

GroundOdometry::GroundOdometry(const CameraModel& camera, OdometryOptions opt)
    : impl_(std::make_unique<Impl>(camera, opt)) {}
GroundOdometry::~GroundOdometry() = default;
GroundOdometry::GroundOdometry(GroundOdometry&&) noexcept = default;
GroundOdometry& GroundOdometry::operator=(GroundOdometry&&) noexcept = default;
int GroundOdometry::bonnet_rows() const {
  return impl_->tracker.bonnet_rows();
}
const cv::Mat& GroundOdometry::last_bev() const {
  return impl_->tracker.last_bev();
}

EgoMotionSample GroundOdometry::add(const cv::Mat& bgr, int64_t frame, double timestamp) {
  return add(bgr, frame, timestamp, std::nullopt);
}

EgoMotionSample GroundOdometry::add(const cv::Mat& bgr, int64_t frame, double timestamp,
                                    const std::optional<TwoViewMotion>& turn) {
  EgoMotionSample out;
  out.frame = frame;
  out.t = timestamp;
  Impl& s = *impl_;
  const double dt = timestamp - s.prev_t;
  const bool had_prev = s.have_prev;
  std::optional<double> prior;
  // The search is narrowed only around a speed two measurements in a row agreed on: a single wrong reading (a
  // static bonnet or overlay before the bonnet rows are known, a lead car filling the road view) would
  // otherwise hold every later search near it.
  if (s.last_measured_t && s.last_confirmed && timestamp - *s.last_measured_t <= s.opt.prior_max_age_s)
    prior = s.last_speed;
  std::optional<double> known_yaw;
  double known_yaw_sigma = 0;
  std::optional<TwoViewMotion> two_view;
  if (had_prev && dt < s.opt.two_view_min_interval_s) {
    // Video-rate frames: the far scene's shift when another cue measured it, else the road's turn (and no
    // stale frame is compared later).
    s.rotation.reset();
    if (turn && std::abs(turn->yaw) <= s.opt.max_yaw_rate * std::max(dt, 0.0) + 0.02) {
      known_yaw = turn->yaw;
      known_yaw_sigma = turn->yaw_sigma;
    }
  } else if (s.opt.two_view_rotation) {
    if (const auto r = s.rotation.add(bgr, s.opt.max_yaw_rate * std::max(dt, 0.0) + 0.02)) {
      known_yaw = r->yaw;
      known_yaw_sigma = r->yaw_sigma;
      two_view = r;
    }
  }
  const auto matches = s.tracker.add(bgr, had_prev ? dt : 0.0, prior, had_prev ? known_yaw : std::nullopt,
                                     s.opt.prewarp && had_prev && dt >= s.opt.two_view_min_interval_s);
  s.have_prev = !bgr.empty();
  s.prev_t = timestamp;
  if (!had_prev || !(dt > 1e-6)) return out;
  out.interval_s = dt;
  // The heading change from the whole picture (or the far scene) is a measurement of its own, also when the
  // road gives no speed.
  out.two_view = two_view;
  if (known_yaw) {
    out.yaw_measured = true;
    out.yaw_rate = *known_yaw / dt;
    out.yaw_rate_sigma = known_yaw_sigma / dt;
  }
  const int n = static_cast<int>(matches.size());
  if (n < s.opt.min_inliers) return out;
  std::vector<cv::Point2d> p, q;
  for (const auto& m : matches) {
    p.push_back(m.p);
    q.push_back(m.q);
  }
  std::vector<int> best;
  detail::Rigid2 m = detail::ransac_rigid(p, q, s.opt.ransac_threshold_m, s.opt.ransac_iterations, best);
  const int k = static_cast<int>(best.size());
  if (k < 2) return out;
  if (s.opt.pair_pitch && std::hypot(m.t.x, m.t.y) >= s.opt.pair_pitch_min_travel_m) {
    // The road's own pitch under this pair: the inliers re-projected to the ground with it, and fitted again.
    std::vector<cv::Point2d> ip, iq;
    for (int i : best) {
      ip.push_back(matches[static_cast<size_t>(i)].img_p);
      iq.push_back(matches[static_cast<size_t>(i)].img_q);
    }
    std::vector<cv::Point2d> gp, gq;
    const auto dp = ground_pitch_offset(s.cam, ip, iq, s.opt.pair_pitch_range_deg * M_PI / 180.0,
                                        s.opt.pair_pitch_sharpness);
    if (dp &&
        detail::pairs_on_ground(with_pitch_roll(s.cam, s.cam.pitch() + *dp, s.cam.roll()), ip, iq, gp, gq)) {
      for (size_t j = 0; j < best.size(); ++j) {
        p[static_cast<size_t>(best[j])] = gp[j];
        q[static_cast<size_t>(best[j])] = gq[j];
      }
      m = detail::fit_rigid(p, q, best);
      out.ground_pitch_offset = *dp;
    }
  }
  double ss = 0, spread = 0;
  cv::Point2d mq(0, 0);
  for (int i : best) mq += q[i];
  mq *= 1.0 / k;
  for (int i : best) {
    const cv::Point2d r = p[i] - m.apply(q[i]);
    ss += r.dot(r);
    spread += (q[i] - mq).dot(q[i] - mq);
  }
  const double sigma = std::sqrt(ss / std::max(1, 2 * k - 3));  // per-axis residual, m
  const double road_yaw = m.theta / dt, road_sigma = sigma / std::sqrt(std::max(spread, 1e-6)) / dt;
  // The road's free fit may turn differently from the whole picture when it locked onto something else (a
  // vehicle moving through the road view, the streaks of a wall): then its turn is not used (its distance
  // still is, the smoother weighs it against its neighbours).
  const bool turns_alike = !known_yaw || !(road_sigma > 0) ||
                           std::abs(road_yaw - out.yaw_rate) <=
                               s.opt.two_view_gate_sigma * std::hypot(road_sigma, out.yaw_rate_sigma);
  out.inliers = k;
  out.quality = static_cast<double>(k) / n;
  // p = R q + t: t is where the current ego origin sits in the previous ego frame; its x is the distance
  // driven.
  out.speed_mps = m.t.x / dt;
  out.speed_sigma = sigma / std::sqrt(static_cast<double>(k)) / dt;
  if (!known_yaw) {
    out.yaw_rate = road_yaw;
    out.yaw_rate_sigma = road_sigma;
  } else if (turns_alike && road_sigma > 0) {
    // Both agree: by inverse variance. Far apart frames favour the picture (its error is a fixed angle per
    // pair), close ones the road (its error shrinks with the interval's lever arm).
    const double wr = 1.0 / (road_sigma * road_sigma), wt = 1.0 / (out.yaw_rate_sigma * out.yaw_rate_sigma);
    out.yaw_rate = (wr * road_yaw + wt * out.yaw_rate) / (wr + wt);
    out.yaw_rate_sigma = 1.0 / std::sqrt(wr + wt);
  }
  out.measured = k >= s.opt.min_inliers && out.quality >= s.opt.min_inlier_fraction;
  if (out.measured) {
    out.speed_cue = EgoMotionSample::SpeedCue::kRoad;
    // Agreement as the narrowed search allows: the speed's change within prior_accel_mps2 over the time
    // between the two plus prior_relative of it, and 0.2 m over this pair.
    s.last_confirmed = s.last_measured_t && timestamp - *s.last_measured_t <= s.opt.prior_max_age_s &&
                       std::abs(out.speed_mps - s.last_speed) <=
                           s.opt.prior_accel_mps2 * (timestamp - *s.last_measured_t) +
                               s.opt.prior_relative * std::abs(s.last_speed) + 0.2 / dt;
    s.last_measured_t = timestamp;
    s.last_speed = out.speed_mps;
  }
  return out;
}

void rescale_height(std::vector<EgoMotionSample>& samples, double ratio) {
  for (auto& r : samples) {
    r.speed_mps *= ratio;
    r.speed_sigma *= ratio;
  }
}

const char* speed_cue_name(EgoMotionSample::SpeedCue cue) {
  switch (cue) {
    case EgoMotionSample::SpeedCue::kRoad:
      return "road";
    case EgoMotionSample::SpeedCue::kLeverArm:
      return "lever_arm";
    case EgoMotionSample::SpeedCue::kRoadAndLeverArm:
      return "road+lever_arm";
    case EgoMotionSample::SpeedCue::kNone:
      break;
  }
  return "none";
}

std::optional<double> ground_pitch_offset(const CameraModel& camera, const std::vector<cv::Point2d>& img_p,
                                          const std::vector<cv::Point2d>& img_q, double range_rad,
                                          double sharpness) {
  if (img_p.size() != img_q.size() || img_p.size() < 3) return std::nullopt;
  auto residual = [&](double dp) {
    detail::Rigid2 fit;
    const double e = detail::ground_residual(with_pitch_roll(camera, camera.pitch() + dp, camera.roll()),
                                             img_p, img_q, &fit);
    return e / std::max(1e-12, fit.t.dot(fit.t));  // NaN stays NaN
  };
  double best = std::numeric_limits<double>::infinity(), bp = 0;
  auto scan = [&](double lo, double hi, double step) {
    for (double dp = lo; dp <= hi + 1e-12; dp += step) {
      const double e = residual(dp);
      if (std::isfinite(e) && e < best) {
        best = e;
        bp = dp;
      }
    }
  };
  scan(-range_rad, range_rad, 0.25 * kRadPerDeg);
  if (!std::isfinite(best)) return std::nullopt;
  const double coarse = bp;
  scan(coarse - 0.3 * kRadPerDeg, coarse + 0.3 * kRadPerDeg, 0.025 * kRadPerDeg);
  if (bp <= -range_rad + 0.1 * kRadPerDeg || bp >= range_rad - 0.1 * kRadPerDeg) return std::nullopt;
  const double lo = residual(bp - kRadPerDeg), hi = residual(bp + kRadPerDeg);
  const double side = std::min(std::isfinite(lo) ? lo : std::numeric_limits<double>::infinity(),
                               std::isfinite(hi) ? hi : std::numeric_limits<double>::infinity());
  if (!(side > sharpness * best)) return std::nullopt;
  return bp;
}

}  // namespace hf::footage
