// EgoPath: the recorded ego track as a smooth path in the anchor frame (or a straight constant-speed line),
// with road coordinates along it.
#include "hazardforge/hazard/ego_path.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>

#include "hazardforge/angles.hpp"
#include "hazardforge/hazard/kinematics.hpp"
#include "hazardforge/number_text.hpp"

namespace hf::hazard {

namespace {

constexpr double kDenseStep = 0.01;    // s between the path's dense samples
constexpr double kMovingSpeed = 0.05;  // m/s; slower than this the heading is held, not derived

// Second derivatives of the natural cubic spline through (t, v) (tridiagonal system, Thomas algorithm: a
// dozen lines, no library needed for it).
std::vector<double> natural_spline(const std::vector<double>& t, const std::vector<double>& v) {
  const size_t n = t.size();
  std::vector<double> m(n, 0.0);
  if (n < 3) return m;
  std::vector<double> diag(n, 0.0), upper(n, 0.0), rhs(n, 0.0);
  for (size_t i = 1; i + 1 < n; ++i) {
    const double h0 = t[i] - t[i - 1], h1 = t[i + 1] - t[i];
    diag[i] = 2 * (h0 + h1);
    upper[i] = h1;
    rhs[i] = 6 * ((v[i + 1] - v[i]) / h1 - (v[i] - v[i - 1]) / h0);
  }
  // Forward elimination over the interior rows (m[0] = m[n-1] = 0).
  for (size_t i = 2; i + 1 < n; ++i) {
    const double lower = t[i] - t[i - 1];
    const double f = lower / diag[i - 1];
    diag[i] -= f * upper[i - 1];
    rhs[i] -= f * rhs[i - 1];
  }
  for (size_t i = n - 2; i >= 1; --i) {
    m[i] = (rhs[i] - (i + 2 < n ? upper[i] * m[i + 1] : 0.0)) / diag[i];
    if (i == 1) break;
  }
  return m;
}

// Value of that spline at x (clamped to the end segments).
double eval_spline(const std::vector<double>& t, const std::vector<double>& v, const std::vector<double>& m,
                   double x) {
  size_t i = static_cast<size_t>(std::upper_bound(t.begin(), t.end(), x) - t.begin());
  i = std::clamp<size_t>(i, 1, t.size() - 1) - 1;
  const double h = t[i + 1] - t[i];
  const double a = (t[i + 1] - x) / h, b = (x - t[i]) / h;
  return a * v[i] + b * v[i + 1] + ((a * a * a - a) * m[i] + (b * b * b - b) * m[i + 1]) * h * h / 6;
}

}  // namespace

EgoPath EgoPath::straight(double speed) {
  EgoPath p;
  p.speed_ = speed;
  return p;
}

EgoPath EgoPath::recorded(const std::vector<EgoTrackSample>& track, double anchor_time,
                          const std::string& where, double smoothing_s) {
  if (track.size() < 2)
    throw Error(where + ": ego_track has " + std::to_string(track.size()) +
                " sample(s); a recorded path needs at least two");
  if (anchor_time < track.front().t - 1e-6 || anchor_time > track.back().t + 1e-6)
    throw Error(where + ": the anchor time " + num_text(anchor_time, 3) +
                " s is outside the ego_track's span [" + num_text(track.front().t, 3) + ", " +
                num_text(track.back().t, 3) + "] s");
  std::vector<double> t, x, y;
  for (const auto& s : track) t.push_back(s.t), x.push_back(s.x), y.push_back(s.y);
  const std::vector<double> mx = natural_spline(t, x), my = natural_spline(t, y);

  // The anchor frame is the recorded pose at the anchor time (heading interpolated between its samples).
  const double ta = std::clamp(anchor_time, t.front(), t.back());
  size_t i = static_cast<size_t>(std::upper_bound(t.begin(), t.end(), ta) - t.begin());
  i = std::clamp<size_t>(i, 1, t.size() - 1) - 1;
  const double u = (ta - t[i]) / (t[i + 1] - t[i]);
  const double yaw0 = track[i].yaw + u * wrap_angle(track[i + 1].yaw - track[i].yaw);
  const double x0 = eval_spline(t, x, mx, ta), y0 = eval_spline(t, y, my, ta);
  const double c = std::cos(yaw0), s = std::sin(yaw0);

  EgoPath p;
  p.recorded_ = true;
  const int n = std::max(2, static_cast<int>(std::ceil((t.back() - t.front()) / kDenseStep)) + 1);
  const double step = (t.back() - t.front()) / (n - 1);
  std::vector<double> tk(n), wx(n), wy(n);
  for (int k = 0; k < n; ++k) {
    tk[k] = k + 1 == n ? t.back() : t.front() + k * step;
    wx[k] = eval_spline(t, x, mx, tk[k]);
    wy[k] = eval_spline(t, y, my, tk[k]);
  }
  // Pose noise of a few centimetres makes the interpolating spline's curvature wiggle between the samples; a
  // path offset sideways (an adjacent lane) turns that into jerk spikes. A Gaussian along time removes it;
  // the path is then shifted back through the recorded pose at the anchor. Beyond the ends the positions are
  // continued by point reflection through the end pose, which a steady motion passes unchanged: a kernel cut
  // off at the end would average only the positions on one side, and a short track (a clip of 1.5 s at
  // 27 m/s) would read 40 % slow throughout.
  if (smoothing_s > 0) {
    const int half = static_cast<int>(std::ceil(3 * smoothing_s / step));
    std::vector<double> kernel(2 * half + 1);
    double sum = 0;
    for (int j = -half; j <= half; ++j)
      sum += kernel[j + half] = std::exp(-0.5 * std::pow(j * step / smoothing_s, 2));
    auto padded = [n](const std::vector<double>& w, int j) {
      if (j < 0) return 2 * w.front() - w[static_cast<size_t>(std::min(-j, n - 1))];
      if (j >= n) return 2 * w.back() - w[static_cast<size_t>(std::max(2 * (n - 1) - j, 0))];
      return w[static_cast<size_t>(j)];
    };
    std::vector<double> sx(n), sy(n);
    for (int k = 0; k < n; ++k) {
      double ax = 0, ay = 0;
      for (int j = k - half; j <= k + half; ++j) {
        const double w = kernel[j - k + half];
        ax += w * padded(wx, j), ay += w * padded(wy, j);
      }
      sx[k] = ax / sum, sy[k] = ay / sum;
    }
    const int ka = std::clamp(static_cast<int>((ta - t.front()) / step), 0, n - 2);
    const double ua = (ta - tk[ka]) / step;
    const double shift_x = x0 - (sx[ka] + ua * (sx[ka + 1] - sx[ka]));
    const double shift_y = y0 - (sy[ka] + ua * (sy[ka + 1] - sy[ka]));
    for (int k = 0; k < n; ++k) wx[k] = sx[k] + shift_x, wy[k] = sy[k] + shift_y;
  }
  std::optional<double> held;  // heading while (nearly) standing
  for (int k = 0; k < n; ++k) {
    // Velocity and acceleration by central differences (one-sided at the ends) of the dense positions.
    const int a0 = std::max(0, k - 1), a1 = std::min(n - 1, k + 1);
    const double dt1 = (a1 - a0) * step;
    const double gvx = (wx[a1] - wx[a0]) / dt1, gvy = (wy[a1] - wy[a0]) / dt1;
    const int b = std::clamp(k, 1, n - 2);
    const double gax = (wx[b + 1] - 2 * wx[b] + wx[b - 1]) / (step * step),
                 gay = (wy[b + 1] - 2 * wy[b] + wy[b - 1]) / (step * step);
    Node nd{};
    nd.t = tk[k];
    const double dx = wx[k] - x0, dy = wy[k] - y0;
    nd.x = c * dx + s * dy;
    nd.y = -s * dx + c * dy;
    const double vx = c * gvx + s * gvy, vy = -s * gvx + c * gvy;
    const double ax = c * gax + s * gay, ay = -s * gax + c * gay;
    nd.speed = std::hypot(vx, vy);
    // Backwards against the heading it had: pose noise while standing (or a short reverse), never a U-turn;
    // the heading is held, so the path does not fold back on itself.
    const bool backwards = held && vx * std::cos(*held) + vy * std::sin(*held) < 0;
    if (nd.speed > kMovingSpeed && !backwards) {
      nd.heading = std::atan2(vy, vx);
      nd.accel = (vx * ax + vy * ay) / nd.speed;
      nd.curvature = (vx * ay - vy * ax) / (nd.speed * nd.speed * nd.speed);
      held = nd.heading;
    } else {
      // Standing: keep the heading it had (or the recorded yaw before it ever moved).
      size_t j = static_cast<size_t>(std::upper_bound(t.begin(), t.end(), tk[k]) - t.begin());
      j = std::clamp<size_t>(j, 1, t.size()) - 1;
      nd.heading = held.value_or(wrap_angle(track[j].yaw - yaw0));
    }
    if (!p.nodes_.empty()) {
      const Node& prev = p.nodes_.back();
      nd.s = prev.s + std::hypot(nd.x - prev.x, nd.y - prev.y);
    }
    p.nodes_.push_back(nd);
  }
  // Arc length from the ego's position at the anchor time.
  p.anchor_t_ = anchor_time;
  const double s_anchor = p.at_time(0.0).s;
  for (Node& nd : p.nodes_) nd.s -= s_anchor;
  return p;
}

EgoPath::Node EgoPath::extrapolate(const Node& end, double dt) const {
  Node n = end;
  n.t = end.t + dt;
  const double ds = end.speed * dt;
  n.s = end.s + ds;
  n.x = end.x + ds * std::cos(end.heading);
  n.y = end.y + ds * std::sin(end.heading);
  n.accel = 0;
  n.curvature = 0;
  return n;
}

EgoPath::Node EgoPath::at_time(double tau) const {
  const double t = anchor_t_ + tau;
  if (t <= nodes_.front().t) return extrapolate(nodes_.front(), t - nodes_.front().t);
  if (t >= nodes_.back().t) return extrapolate(nodes_.back(), t - nodes_.back().t);
  const auto it =
      std::upper_bound(nodes_.begin(), nodes_.end(), t, [](double v, const Node& n) { return v < n.t; });
  const Node& b = *it;
  const Node& a = *(it - 1);
  const double u = (t - a.t) / (b.t - a.t);
  Node n;
  n.t = t;
  n.s = a.s + u * (b.s - a.s);
  n.x = a.x + u * (b.x - a.x);
  n.y = a.y + u * (b.y - a.y);
  n.heading = a.heading + u * wrap_angle(b.heading - a.heading);
  n.speed = a.speed + u * (b.speed - a.speed);
  n.accel = a.accel + u * (b.accel - a.accel);
  n.curvature = a.curvature + u * (b.curvature - a.curvature);
  return n;
}

TrajectoryPoint EgoPath::at(double tau) const {
  TrajectoryPoint p;
  if (!recorded_) {
    p.x = speed_ * tau;
    p.speed = speed_;
    return p;
  }
  const Node n = at_time(tau);
  p.x = n.x;
  p.y = n.y;
  p.heading = wrap_angle(n.heading);
  p.speed = n.speed;
  p.accel = n.accel;
  return p;
}

EgoPath EgoPath::seen_from(double tau) const {
  if (!recorded_) return *this;  // a straight line at constant speed looks the same from anywhere on it
  const Node o = at_time(tau);
  const double c = std::cos(o.heading), s = std::sin(o.heading);
  EgoPath p = *this;
  p.anchor_t_ = anchor_t_ + tau;
  for (Node& n : p.nodes_) {
    const double dx = n.x - o.x, dy = n.y - o.y;
    n.x = c * dx + s * dy;
    n.y = -s * dx + c * dy;
    n.heading = wrap_angle(n.heading - o.heading);
    n.s -= o.s;
  }
  return p;
}

double EgoPath::s_at(double tau) const {
  return recorded_ ? at_time(tau).s : speed_ * tau;
}

std::optional<double> EgoPath::time_at(double s) const {
  if (s <= 0) return 0.0;
  if (!recorded_) {
    if (speed_ <= 0) return std::nullopt;
    return s / speed_;
  }
  const Node& last = nodes_.back();
  if (s > last.s) {
    if (last.speed <= 1e-6) return std::nullopt;
    return last.t + (s - last.s) / last.speed - anchor_t_;
  }
  const auto it =
      std::lower_bound(nodes_.begin(), nodes_.end(), s, [](const Node& n, double v) { return n.s < v; });
  if (it == nodes_.begin()) return std::max(0.0, it->t - anchor_t_);
  const Node& a = *(it - 1);
  const Node& b = *it;
  const double u = b.s > a.s ? (s - a.s) / (b.s - a.s) : 1.0;
  return std::max(0.0, a.t + u * (b.t - a.t) - anchor_t_);
}

EgoPath::Pose EgoPath::point(double s) const {
  Pose p;
  if (!recorded_) {
    p.x = s;
    return p;
  }
  auto along = [&](const Node& n, double ds) {
    Pose q;
    q.x = n.x + ds * std::cos(n.heading);
    q.y = n.y + ds * std::sin(n.heading);
    q.heading = wrap_angle(n.heading);
    return q;
  };
  if (s <= nodes_.front().s) return along(nodes_.front(), s - nodes_.front().s);
  if (s >= nodes_.back().s) return along(nodes_.back(), s - nodes_.back().s);
  const auto it =
      std::lower_bound(nodes_.begin(), nodes_.end(), s, [](const Node& n, double v) { return n.s < v; });
  const Node& b = *it;
  const Node& a = *(it - 1);
  const double u = b.s > a.s ? (s - a.s) / (b.s - a.s) : 1.0;
  p.x = a.x + u * (b.x - a.x);
  p.y = a.y + u * (b.y - a.y);
  p.heading = wrap_angle(a.heading + u * wrap_angle(b.heading - a.heading));
  p.curvature = a.curvature + u * (b.curvature - a.curvature);
  return p;
}

cv::Vec2d EgoPath::to_anchor(double s, double d) const {
  const Pose p = point(s);
  return {p.x - d * std::sin(p.heading), p.y + d * std::cos(p.heading)};
}

cv::Vec2d EgoPath::to_road(double x, double y) const {
  if (!recorded_) return {x, y};
  double best = std::numeric_limits<double>::infinity();
  cv::Vec2d out(x, y);
  auto consider = [&](double sx, double sy, double heading, double s0, double lo, double hi) {
    // Nearest point of the segment {(sx, sy) + u (cos h, sin h) : lo <= u <= hi} and the signed offset.
    const double c = std::cos(heading), sn = std::sin(heading);
    const double u = std::clamp((x - sx) * c + (y - sy) * sn, lo, hi);
    const double px = sx + u * c, py = sy + u * sn;
    const double dist = std::hypot(x - px, y - py);
    if (dist < best) {
      best = dist;
      out = {s0 + u, c * (y - py) - sn * (x - px)};
    }
  };
  const double inf = std::numeric_limits<double>::infinity();
  consider(nodes_.front().x, nodes_.front().y, nodes_.front().heading, nodes_.front().s, -inf, 0.0);
  for (size_t k = 0; k + 1 < nodes_.size(); ++k) {
    const Node& a = nodes_[k];
    const Node& b = nodes_[k + 1];
    const double len = b.s - a.s;
    if (len <= 1e-9) continue;
    consider(a.x, a.y, std::atan2(b.y - a.y, b.x - a.x), a.s, 0.0, len);
  }
  consider(nodes_.back().x, nodes_.back().y, nodes_.back().heading, nodes_.back().s, 0.0, inf);
  return out;
}

EgoPath::Mapped EgoPath::map(double s, double d, double ds, double dd,
                             std::optional<double> rel_heading) const {
  const Pose p = point(s);
  const double c = std::cos(p.heading), sn = std::sin(p.heading);
  Mapped m;
  m.x = p.x - d * sn;
  m.y = p.y + d * c;
  // A point at offset d moves (1 - curvature d) times as fast along the path as its centre line.
  const double along = (1 - p.curvature * d) * ds;
  m.vx = c * along - sn * dd;
  m.vy = sn * along + c * dd;
  if (rel_heading) m.heading = wrap_angle(*rel_heading + p.heading);
  return m;
}

}  // namespace hf::hazard
