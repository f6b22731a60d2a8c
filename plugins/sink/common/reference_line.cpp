// Reference-line fitting (lines and G1 Hermite paramPoly3 pieces within a tolerance) and the s/t mapping.
#include "hazardforge/road/reference_line.hpp"

#include "hazardforge/angles.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>
#include <stdexcept>

namespace hf::road {

namespace {

constexpr double kDenseStep = 0.05;  // m between the dense samples used for length, evaluation, projection
constexpr double kMinLine = 5.0;     // m; shorter straight runs are left to the curve pieces

struct Pose {
  double x, y, h;
};

// Cubic Hermite from the pose `a` to the point/heading `b`, tangent lengths equal to the chord: close to an
// arc-length parametrisation for the gentle bends of a road, and exact for a straight line.
Geometry hermite(const Pose& a, const Pose& b) {
  Geometry g;
  g.x = a.x, g.y = a.y, g.hdg = a.h;
  const double c = std::cos(a.h), s = std::sin(a.h);
  const double ue = c * (b.x - a.x) + s * (b.y - a.y), ve = -s * (b.x - a.x) + c * (b.y - a.y);
  const double dh = wrap_angle(b.h - a.h);
  const double L = std::hypot(ue, ve);
  const double t1u = L * std::cos(dh), t1v = L * std::sin(dh);
  g.bu = L, g.bv = 0;
  g.cu = 3 * ue - 2 * L - t1u, g.cv = 3 * ve - t1v;
  g.du = -2 * ue + L + t1u, g.dv = -2 * ve + t1v;
  return g;
}

int steps_for(double approx_length) {
  return std::max(8, static_cast<int>(std::ceil(approx_length / kDenseStep)));
}

// Dense polyline of a piece (world frame), including both ends.
std::vector<PathPoint> piece_points(const Geometry& g, double approx_length) {
  const int n = steps_for(approx_length);
  std::vector<PathPoint> out;
  out.reserve(n + 1);
  const double c = std::cos(g.hdg), s = std::sin(g.hdg);
  for (int k = 0; k <= n; ++k) {
    const double p = static_cast<double>(k) / n;
    PathPoint uv = g.line ? PathPoint{p * g.length, 0.0} : poly_point(g, p);
    out.push_back({g.x + c * uv.x - s * uv.y, g.y + s * uv.x + c * uv.y});
  }
  return out;
}

double polyline_length(const std::vector<PathPoint>& pts) {
  double len = 0;
  for (size_t k = 1; k < pts.size(); ++k) len += std::hypot(pts[k].x - pts[k - 1].x, pts[k].y - pts[k - 1].y);
  return len;
}

double distance_to_polyline(const PathPoint& q, const std::vector<PathPoint>& pts) {
  double best = std::numeric_limits<double>::infinity();
  for (size_t k = 1; k < pts.size(); ++k) {
    const double ax = pts[k - 1].x, ay = pts[k - 1].y, dx = pts[k].x - ax, dy = pts[k].y - ay;
    const double l2 = dx * dx + dy * dy;
    const double u = l2 > 0 ? std::clamp(((q.x - ax) * dx + (q.y - ay) * dy) / l2, 0.0, 1.0) : 0.0;
    best = std::min(best, std::hypot(q.x - ax - u * dx, q.y - ay - u * dy));
  }
  return best;
}

}  // namespace

PathPoint poly_point(const Geometry& g, double p) {
  return {((g.du * p + g.cu) * p + g.bu) * p, ((g.dv * p + g.cv) * p + g.bv) * p};
}

PathPoint poly_tangent(const Geometry& g, double p) {
  return {(3 * g.du * p + 2 * g.cu) * p + g.bu, (3 * g.dv * p + 2 * g.cv) * p + g.bv};
}

ReferenceLine ReferenceLine::fit(const std::vector<PathPoint>& path, double tolerance, double max_piece) {
  std::vector<PathPoint> pts;
  for (const PathPoint& p : path)
    if (pts.empty() || std::hypot(p.x - pts.back().x, p.y - pts.back().y) > 1e-6) pts.push_back(p);
  if (pts.size() < 2) throw std::invalid_argument("a reference line needs at least two distinct path points");
  const size_t n = pts.size();
  std::vector<double> s(n, 0.0), h(n, 0.0);
  for (size_t k = 1; k < n; ++k)
    s[k] = s[k - 1] + std::hypot(pts[k].x - pts[k - 1].x, pts[k].y - pts[k - 1].y);
  auto chord = [&](size_t a, size_t b) { return std::atan2(pts[b].y - pts[a].y, pts[b].x - pts[a].x); };
  for (size_t k = 0; k < n; ++k) {
    const size_t a = k == 0 ? 0 : k - 1, b = std::min(n - 1, k + 1);
    h[k] = chord(a, b);
  }
  // A chord's direction is the tangent at its middle; at the ends, extrapolate from the last two chords.
  if (n >= 3) {
    h[0] = chord(0, 1) - 0.5 * wrap_angle(chord(1, 2) - chord(0, 1));
    h[n - 1] = chord(n - 2, n - 1) + 0.5 * wrap_angle(chord(n - 2, n - 1) - chord(n - 3, n - 2));
  }

  ReferenceLine line;
  Pose cur{pts[0].x, pts[0].y, h[0]};
  size_t i0 = 0;
  double s_road = 0;
  // The piece from `cur` to path point j, or nothing when some path point between is further than the
  // tolerance from it.
  auto try_piece = [&](size_t j, Geometry& out) {
    Geometry g = hermite(cur, {pts[j].x, pts[j].y, h[j]});
    const double approx = s[j] - s[i0];
    const bool straight = std::abs(g.bv) < 1e-12 && std::abs(g.cv) < 1e-3 * tolerance &&
                          std::abs(g.dv) < 1e-3 * tolerance && std::abs(wrap_angle(h[j] - cur.h)) < 1e-6;
    if (straight) {
      g = Geometry{};
      g.x = cur.x, g.y = cur.y, g.hdg = cur.h, g.line = true;
      g.length = approx;
    }
    const std::vector<PathPoint> curve = piece_points(g, approx);
    for (size_t k = i0 + 1; k <= j; ++k)
      if (distance_to_polyline(pts[k], curve) > tolerance) return false;
    if (!g.line) g.length = polyline_length(curve);
    out = g;
    return true;
  };
  // The longest straight run from `cur`: the last path index whose points all lie within a quarter of the
  // tolerance of the line along cur.h, with the path's heading there still along it.
  auto straight_run = [&]() {
    const double c = std::cos(cur.h), sn = std::sin(cur.h);
    size_t last = i0;
    for (size_t k = i0 + 1; k < n; ++k) {
      const double off = -sn * (pts[k].x - cur.x) + c * (pts[k].y - cur.y);
      if (std::abs(off) > tolerance / 4 ||
          c * (pts[k].x - cur.x) + sn * (pts[k].y - cur.y) > max_piece + 1e-6)
        break;
      if (std::abs(wrap_angle(h[k] - cur.h)) < 1e-3) last = k;
    }
    return last;
  };
  while (i0 + 1 < n) {
    // Straight stretches of some length become lines, so a straight road reads as one.
    if (const size_t j = straight_run(); j > i0 && s[j] - s[i0] >= kMinLine) {
      Geometry g;
      g.x = cur.x, g.y = cur.y, g.hdg = cur.h, g.line = true;
      g.length = std::cos(cur.h) * (pts[j].x - cur.x) + std::sin(cur.h) * (pts[j].y - cur.y);
      g.s = s_road;
      s_road += g.length;
      line.pieces_.push_back(g);
      cur = {g.x + g.length * std::cos(g.hdg), g.y + g.length * std::sin(g.hdg), g.hdg};
      i0 = j;
      continue;
    }
    // Longest acceptable piece: grow in doubling steps, then bisect between the last fit and the first miss.
    Geometry best;
    size_t good = i0 + 1;
    if (!try_piece(good, best)) {
      // Two neighbouring samples always make a piece: the Hermite curve interpolates both.
      best = hermite(cur, {pts[good].x, pts[good].y, h[good]});
      best.length = polyline_length(piece_points(best, s[good] - s[i0]));
    }
    size_t step = 1, bad = n;
    while (true) {
      const size_t j = std::min(n - 1, good + step);
      if (j == good || s[j] - s[i0] > max_piece + 1e-6) {
        bad = j == good ? n : j;
        break;
      }
      Geometry g;
      if (!try_piece(j, g)) {
        bad = j;
        break;
      }
      good = j, best = g, step *= 2;
      if (j == n - 1) break;
    }
    while (bad < n && bad > good + 1) {
      const size_t mid = (good + bad) / 2;
      Geometry g;
      if (s[mid] - s[i0] <= max_piece + 1e-6 && try_piece(mid, g))
        good = mid, best = g;
      else
        bad = mid;
    }
    best.s = s_road;
    s_road += best.length;
    line.pieces_.push_back(best);
    if (best.line)
      cur = {best.x + best.length * std::cos(best.hdg), best.y + best.length * std::sin(best.hdg), best.hdg};
    else
      cur = {pts[good].x, pts[good].y, h[good]};
    i0 = good;
  }
  line.densify();
  return line;
}

void ReferenceLine::densify() {
  dense_.clear();
  for (const Geometry& g : pieces_) {
    const std::vector<PathPoint> pts = piece_points(g, g.length);
    const int n = static_cast<int>(pts.size()) - 1;
    double s = g.s;
    for (int k = 0; k <= n; ++k) {
      if (k > 0) s += std::hypot(pts[k].x - pts[k - 1].x, pts[k].y - pts[k - 1].y);
      if (k == n && &g != &pieces_.back()) break;  // the next piece starts here
      double hdg = g.hdg;
      if (!g.line) {
        const PathPoint d = poly_tangent(g, static_cast<double>(k) / n);
        hdg = g.hdg + std::atan2(d.y, d.x);
      }
      dense_.push_back({s, pts[k].x, pts[k].y, wrap_angle(hdg)});
    }
  }
}

double ReferenceLine::length() const {
  return pieces_.empty() ? 0.0 : pieces_.back().s + pieces_.back().length;
}

RoadPose ReferenceLine::at(double s) const {
  s = std::clamp(s, 0.0, length());
  auto it =
      std::upper_bound(dense_.begin(), dense_.end(), s, [](double v, const Sample& d) { return v < d.s; });
  if (it == dense_.begin()) return {dense_.front().x, dense_.front().y, dense_.front().hdg};
  if (it == dense_.end()) return {dense_.back().x, dense_.back().y, dense_.back().hdg};
  const Sample& b = *it;
  const Sample& a = *(it - 1);
  const double u = b.s > a.s ? (s - a.s) / (b.s - a.s) : 0.0;
  return {a.x + u * (b.x - a.x), a.y + u * (b.y - a.y), wrap_angle(a.hdg + u * wrap_angle(b.hdg - a.hdg))};
}

PathPoint ReferenceLine::to_xy(double s, double t) const {
  const RoadPose p = at(s);
  return {p.x - t * std::sin(p.hdg), p.y + t * std::cos(p.hdg)};
}

PathPoint ReferenceLine::to_st(double x, double y) const {
  size_t best = 0;
  double best_d = std::numeric_limits<double>::infinity();
  for (size_t k = 0; k < dense_.size(); ++k) {
    const double d = (dense_[k].x - x) * (dense_[k].x - x) + (dense_[k].y - y) * (dense_[k].y - y);
    if (d < best_d) best_d = d, best = k;
  }
  // Refine on the tangent at the nearest sample (the samples are a few centimetres apart).
  const Sample& a = dense_[best];
  const double c = std::cos(a.hdg), sn = std::sin(a.hdg);
  const double along = c * (x - a.x) + sn * (y - a.y);
  const double s = std::clamp(a.s + along, 0.0, length());
  const RoadPose p = at(s);
  return {s, std::cos(p.hdg) * (y - p.y) - std::sin(p.hdg) * (x - p.x)};
}

}  // namespace hf::road
