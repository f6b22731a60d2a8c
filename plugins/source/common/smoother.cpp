// Whole-clip smoothing of raw ego-motion samples: median pre-gate, forward Kalman filter with innovation gating,
// Rauch-Tung-Striebel backward pass.
#include <algorithm>
#include <cmath>

#include <opencv2/core.hpp>

#include "hazardforge/footage/ego_motion.hpp"
#include "median.hpp"

namespace hf::footage {

namespace {

using Vec3 = cv::Matx31d;
using Mat3 = cv::Matx33d;

}  // namespace

std::vector<EgoMotionSample> smooth_ego_motion(const std::vector<EgoMotionSample>& raw, SmoothOptions opt,
                                               SmoothReport* report) {
  SmoothReport rep;
  const size_t n = raw.size();
  std::vector<EgoMotionSample> out = raw;
  if (n == 0) {
    if (report) *report = rep;
    return out;
  }

  // 1. Median pre-gate against the neighbours: a single wild measurement (a truck filling the road, a bump)
  //    must not drag the filter before its innovation gate has something to compare with.
  std::vector<bool> use(n, false);
  std::vector<size_t> measured;
  for (size_t i = 0; i < n; ++i)
    if (raw[i].measured && std::isfinite(raw[i].speed_mps) && std::isfinite(raw[i].yaw_rate)) measured.push_back(i);
  // The raw speeds' own sigmas against their scatter about the same medians: normalised residuals of the
  // frames with a full neighbourhood.
  std::vector<double> residual;
  const int w = std::max(1, opt.median_window);
  for (size_t k = 0; k < measured.size(); ++k) {
    std::vector<double> vs, ws;
    for (int d = -w; d <= w; ++d) {
      const long j = static_cast<long>(k) + d;
      if (d == 0 || j < 0 || j >= static_cast<long>(measured.size())) continue;
      vs.push_back(raw[measured[j]].speed_mps);
      ws.push_back(raw[measured[j]].yaw_rate);
    }
    bool ok = true;
    if (vs.size() >= 2) {
      const double mv = detail::median(vs), mw = detail::median(ws);
      const EgoMotionSample& s = raw[measured[k]];
      if (std::abs(s.speed_mps - mv) > std::max(opt.median_gate_mps, opt.median_gate_rel * std::abs(mv))) ok = false;
      // A two-view yaw rate (yaw_measured) follows a real turn from frame to frame; the gate is for the
      // road's.
      if (!s.yaw_measured && std::abs(s.yaw_rate - mw) > opt.median_gate_yaw) ok = false;
      if (ok && vs.size() == static_cast<size_t>(2 * w))
        residual.push_back((s.speed_mps - mv) / std::hypot(s.speed_sigma, opt.speed_sigma_floor));
    }
    use[measured[k]] = ok;
  }
  // Where the raw speeds scatter more than their sigmas say (the road view's sigma is its fit's, not the
  // frame-to-frame noise of what it tracked), the sigmas are scaled up to the scatter: an overconfident
  // filter rejects, restarts on and follows single readings. Only up, never down; the scatter of a residual
  // about the median of 2w neighbours is sqrt(1 + pi / (2 (2w + 1))) of a sample's.
  double noise_scale = 1.0;
  if (static_cast<int>(residual.size()) >= opt.min_scatter_samples) {
    for (double& r : residual) r = std::abs(r);
    const double spread = 1.4826 * detail::median(residual) / std::sqrt(1.0 + M_PI / (2.0 * (2 * w + 1)));
    if (std::isfinite(spread)) noise_scale = std::max(1.0, spread);
  }
  rep.noise_scale = noise_scale;
  rep.scatter_frames = static_cast<int>(residual.size());

  // 2. Forward Kalman filter over x = (speed, acceleration, yaw rate).
  std::vector<Vec3> xf(n), xp(n);
  std::vector<Mat3> Pf(n), Pp(n), F(n);
  size_t first = n;
  for (size_t i = 0; i < n; ++i)
    if (use[i]) {
      first = i;
      break;
    }
  Vec3 x(first < n ? raw[first].speed_mps : 0.0, 0.0, first < n ? raw[first].yaw_rate : 0.0);
  Mat3 P = Mat3::diag(cv::Vec3d(opt.initial_speed_sigma * opt.initial_speed_sigma, 4.0, 0.25));
  int rejected_run = 0;
  std::vector<bool> yaw_used(n, false);
  const double qj = opt.accel_noise * opt.accel_noise, qw = opt.yaw_accel_noise * opt.yaw_accel_noise;
  for (size_t i = 0; i < n; ++i) {
    double dt = i == 0 ? 0.0 : raw[i].t - raw[i - 1].t;
    if (!(dt > 0)) dt = 0.0;
    // Acceleration decays towards 0 with time constant accel_tau (Singer model): across a long gap the speed
    // levels off instead of running away with the last acceleration.
    const double decay = std::exp(-dt / opt.accel_tau);
    F[i] = Mat3(1, opt.accel_tau * (1 - decay), 0, 0, decay, 0, 0, 0, 1);
    Mat3 Q(qj * dt * dt * dt / 3, qj * dt * dt / 2, 0, qj * dt * dt / 2, qj * dt, 0, 0, 0, qw * dt);
    x = F[i] * x;
    P = F[i] * P * F[i].t() + Q;
    xp[i] = x;
    Pp[i] = P;
    if (use[i]) {
      const EgoMotionSample& s = raw[i];
      const double rv = noise_scale * noise_scale *
                        (s.speed_sigma * s.speed_sigma + opt.speed_sigma_floor * opt.speed_sigma_floor);
      const double rw = s.yaw_rate_sigma * s.yaw_rate_sigma + opt.yaw_sigma_floor * opt.yaw_sigma_floor;
      // Speed and yaw rate are measured independently: two scalar updates. A raw speed is the distance over
      // the interval since the previous frame, the mean speed over it: with the acceleration a, the speed
      // half an interval before this frame, H = (1, -interval/2, 0).
      const double lag = std::isfinite(s.interval_s) && s.interval_s > 0 ? 0.5 * s.interval_s : 0.0;
      const Vec3 h(1.0, -lag, 0.0);
      const double iv = s.speed_mps - (x(0) - lag * x(1));
      const double sv = h.dot(P * h) + rv;
      const double iw = s.yaw_rate - x(2);
      const double sw = P(2, 2) + rw;
      const bool outlier =
          std::abs(iv) > opt.gate_sigma * std::sqrt(sv) || std::abs(iw) > opt.gate_sigma * std::sqrt(sw);
      if (outlier) ++rejected_run;
      if (outlier && rejected_run < opt.restart_after) {
        use[i] = false;
        ++rep.rejected;
      } else {
        if (outlier) {
          ++rep.restarts;
          // Several measurements in a row disagree with the filter, and with each other they passed the median
          // gate: the filter, not the road, is wrong (it locked on a bad start). Restart from this measurement.
          // The state is then this measurement (speed and yaw rate); it is not applied a second time.
          x = Vec3(s.speed_mps, 0.0, s.yaw_rate);
          P = Mat3::diag(cv::Vec3d(rv + 1.0, 4.0, rw + 0.01));
        } else {
          const Vec3 ph = P * h;
          const Vec3 kv = ph * (1.0 / sv);
          x = x + kv * iv;
          P = P - kv * ph.t();
          const double sw2 = P(2, 2) + rw;
          Vec3 kw(P(0, 2) / sw2, P(1, 2) / sw2, P(2, 2) / sw2);
          x = x + kw * (s.yaw_rate - x(2));
          P = P - kw * Vec3(P(2, 0), P(2, 1), P(2, 2)).t();
        }
        rejected_run = 0;
      }
    }
    if (!use[i] && raw[i].yaw_measured && std::isfinite(raw[i].yaw_rate)) {
      // The yaw rate alone (the two-view rotation without a road measurement of the speed): one scalar
      // update, gated like the others.
      const EgoMotionSample& s = raw[i];
      const double rw = s.yaw_rate_sigma * s.yaw_rate_sigma + opt.yaw_sigma_floor * opt.yaw_sigma_floor;
      const double sw = P(2, 2) + rw;
      const double iw = s.yaw_rate - x(2);
      if (std::abs(iw) <= opt.gate_sigma * std::sqrt(sw)) {
        Vec3 kw(P(0, 2) / sw, P(1, 2) / sw, P(2, 2) / sw);
        x = x + kw * iw;
        P = P - kw * Vec3(P(2, 0), P(2, 1), P(2, 2)).t();
        yaw_used[i] = true;
      }
    }
    xf[i] = x;
    Pf[i] = P;
  }

  // 3. RTS backward pass.
  Vec3 xs = xf[n - 1];
  Mat3 Ps = Pf[n - 1];
  for (size_t k = n; k-- > 0;) {
    if (k < n - 1) {
      const Mat3 C = Pf[k] * F[k + 1].t() * Pp[k + 1].inv(cv::DECOMP_SVD);
      xs = xf[k] + C * (xs - xp[k + 1]);
      Ps = Pf[k] + C * (Ps - Pp[k + 1]) * C.t();
    }
    EgoMotionSample& o = out[k];
    o.speed_mps = std::max(xs(0), opt.min_speed);
    o.yaw_rate = xs(2);
    if (opt.max_curvature > 0) {
      const double most = opt.max_curvature * std::abs(o.speed_mps);
      o.yaw_rate = std::clamp(o.yaw_rate, -most, most);
    }
    o.speed_sigma = std::sqrt(std::max(Ps(0, 0), 0.0));
    o.yaw_rate_sigma = std::sqrt(std::max(Ps(2, 2), 0.0));
    o.measured = use[k];
    o.yaw_measured = use[k] || yaw_used[k];
  }
  if (report) *report = rep;
  return out;
}

}  // namespace hf::footage
