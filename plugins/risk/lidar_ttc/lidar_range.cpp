// Lidar points -> image, per-box robust range, and the constant-velocity TTC.
#include "lidar_range.hpp"

#include <algorithm>
#include <cmath>

namespace hf::lidar {

std::vector<ImagePoint> project_points(const std::vector<cv::Vec4f>& scan, const LidarCalibration& cal,
                                       const RangeOptions& o) {
  const cv::Vec3d t = cal.rect_to_cam2();
  std::vector<ImagePoint> out;
  out.reserve(scan.size() / 4);
  for (const cv::Vec4f& p : scan) {
    if (p[2] < o.ground_z) continue;
    const cv::Vec3d rect = cal.velo_to_rect(cv::Vec3d(p[0], p[1], p[2]));
    const cv::Vec3d h = cal.P2 * cv::Vec4d(rect[0], rect[1], rect[2], 1.0);
    if (h[2] < kMinDepth) continue;  // h[2] = camera-2 depth (P2's last row is [0 0 1 t_z])
    ImagePoint ip;
    ip.px = cv::Point2d(h[0] / h[2], h[1] / h[2]);
    ip.range = o.axis == RangeAxis::kCamera ? h[2] : static_cast<double>(p[0]);
    ip.lateral = -(rect[0] + t[0]);
    out.push_back(ip);
  }
  return out;
}

cv::Rect2d shrink(const cv::Rect2d& box, double fraction) {
  return {box.x + fraction * box.width / 2.0, box.y + fraction * box.height / 2.0,
          box.width * (1.0 - fraction), box.height * (1.0 - fraction)};
}

double range_statistic(std::vector<double> r, const RangeOptions& o) {
  if (r.empty() || static_cast<int>(r.size()) < o.min_points) return NAN;
  std::sort(r.begin(), r.end());
  if (o.statistic == RangeStatistic::kPercentile) {
    const double pos = o.percentile / 100.0 * static_cast<double>(r.size() - 1);
    const size_t lo = static_cast<size_t>(std::floor(pos));
    const size_t hi = std::min(lo + 1, r.size() - 1);
    return r[lo] + (pos - static_cast<double>(lo)) * (r[hi] - r[lo]);
  }
  const size_t k = std::min(r.size(), static_cast<size_t>(std::max(o.k_closest, 1)));
  return k % 2 ? r[k / 2] : (r[k / 2 - 1] + r[k / 2]) / 2.0;
}

std::vector<BoxRange> box_ranges(const std::vector<ImagePoint>& pts, const std::vector<cv::Rect2d>& boxes,
                                 const RangeOptions& o) {
  std::vector<cv::Rect2d> shrunk;
  for (const auto& b : boxes) shrunk.push_back(shrink(b, o.box_shrink));
  std::vector<std::vector<double>> ranges(boxes.size()), laterals(boxes.size());
  for (const ImagePoint& p : pts) {
    int owner = -1;
    bool ambiguous = false;
    for (size_t k = 0; k < shrunk.size(); ++k) {
      const cv::Rect2d& b = shrunk[k];
      if (p.px.x < b.x || p.px.x > b.x + b.width || p.px.y < b.y || p.px.y > b.y + b.height) continue;
      if (owner >= 0) ambiguous = true;
      owner = static_cast<int>(k);
    }
    if (owner < 0 || ambiguous) continue;
    ranges[static_cast<size_t>(owner)].push_back(p.range);
    laterals[static_cast<size_t>(owner)].push_back(p.lateral);
  }
  std::vector<BoxRange> out(boxes.size());
  for (size_t k = 0; k < boxes.size(); ++k) {
    BoxRange& b = out[k];
    b.points = static_cast<int>(ranges[k].size());
    if (ranges[k].empty()) continue;
    b.nearest = *std::min_element(ranges[k].begin(), ranges[k].end());
    auto& lat = laterals[k];
    std::sort(lat.begin(), lat.end());
    const size_t n = lat.size();
    b.lateral = n % 2 ? lat[n / 2] : (lat[n / 2 - 1] + lat[n / 2]) / 2.0;
    b.range = range_statistic(ranges[k], o);
  }
  return out;
}

CvTtc constant_velocity_ttc(const std::vector<std::pair<double, double>>& history, int window,
                            double min_closing_mps) {
  CvTtc r;
  const size_t n = std::min(history.size(), static_cast<size_t>(std::max(window, 2)));
  if (n < 2) return r;
  const auto first = history.end() - static_cast<long>(n);
  double mt = 0, md = 0;
  for (auto it = first; it != history.end(); ++it) {
    mt += it->first;
    md += it->second;
  }
  mt /= static_cast<double>(n);
  md /= static_cast<double>(n);
  double stt = 0, std_ = 0;
  for (auto it = first; it != history.end(); ++it) {
    stt += (it->first - mt) * (it->first - mt);
    std_ += (it->first - mt) * (it->second - md);
  }
  if (!(stt > 0)) return r;
  r.closing = -std_ / stt;
  const double d = history.back().second;
  r.ttc = r.closing > min_closing_mps ? d / r.closing : INFINITY;
  return r;
}

}  // namespace hf::lidar
