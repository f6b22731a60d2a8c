// The scene's light from the shadows beside the recording's vehicles (see scene_light.hpp).
#include "scene_light.hpp"

#include "hazardforge/angles.hpp"

#include <algorithm>
#include <cmath>

#include <opencv2/imgproc.hpp>

namespace hf::render {

namespace {

double median(std::vector<double> v) {
  if (v.empty()) return 0.0;
  const auto mid = v.begin() + static_cast<std::ptrdiff_t>(v.size() / 2);
  std::nth_element(v.begin(), mid, v.end());
  return *mid;
}

}  // namespace

void SceneLightEstimator::add(const cv::Mat& bgr, const CameraModel& cam,
                              const std::vector<VehicleView>& vehicles, double heading) {
  if (bgr.empty() || vehicles.empty() || !cam.valid()) return;
  cv::Mat gray;
  if (bgr.channels() == 3)
    cv::cvtColor(bgr, gray, cv::COLOR_BGR2GRAY);
  else
    gray = bgr;
  cv::blur(gray, gray, cv::Size(5, 5));  // road texture and noise average out within a sample
  const cv::Rect2d image(2, 2, gray.cols - 4, gray.rows - 4);
  std::vector<cv::Rect2f> solid;  // the ground is hidden behind every vehicle's box
  for (const auto& v : vehicles)
    solid.emplace_back(v.box.x - 2, v.box.y - 2, v.box.width + 4, v.box.height + 4);
  const cv::Vec2d cam_xy(cam.t_ego_cam[0], cam.t_ego_cam[1]);
  // Brightness of the road at a ground point (ego frame), or -1 where it is not seen.
  auto road_at = [&](const cv::Vec2d& p) -> double {
    const auto px = cam.project_ego({p[0], p[1], 0.0});
    if (!px || !image.contains(*px)) return -1.0;
    const auto h = cam.horizon_y(px->x);
    if (h && px->y < *h + 3.0) return -1.0;
    for (const auto& s : solid)
      if (s.contains(cv::Point2f(static_cast<float>(px->x), static_cast<float>(px->y)))) return -1.0;
    return gray.at<uint8_t>(static_cast<int>(px->y), static_cast<int>(px->x));
  };
  // Distances (m) from the footprint's edge: the shadow band, and the lit road farther out.
  static const double near_s[] = {0.2, 0.5, 0.8, 1.1, 1.4};
  static const double far_s[] = {2.6, 3.2, 3.8};
  const int K = std::max(4, opt_.directions);
  for (const auto& v : vehicles) {
    if (v.box.height < opt_.min_box_px) continue;
    const double bx = v.box.x, by = v.box.y + v.box.height;
    const auto g = cam.pixel_to_ground({bx + v.box.width / 2.0, by});
    const auto gl = cam.pixel_to_ground({bx, by}), gr = cam.pixel_to_ground({bx + v.box.width, by});
    if (!g || !gl || !gr) continue;
    // The footprint: its near edge across the line of sight, the body's overhang nearer than the wheels'
    // contact point (the box's bottom); its length along the line of sight.
    cv::Vec2d u = cv::Vec2d((*g)[0], (*g)[1]) - cam_xy;
    const double range = cv::norm(u);
    if (!(range > 1.0)) continue;
    u /= range;
    const double alpha = std::atan2(u[1], u[0]);
    const double half_across = 0.5 * std::max(v.width_m, cv::norm(*gl - *gr));
    const double half_along = 0.5 * v.length_m;
    const cv::Vec2d centre =
        cv::Vec2d((*g)[0], (*g)[1]) + (half_along - opt_.overhang_fraction * v.length_m) * u;
    std::vector<double> lit;
    std::vector<std::vector<double>> near(static_cast<size_t>(K));
    for (int k = 0; k < K; ++k) {
      const double phi = alpha + 2 * CV_PI * k / K;
      const double c = std::cos(phi - alpha), s = std::sin(phi - alpha);
      const double edge = std::min(std::abs(c) > 1e-9 ? half_along / std::abs(c) : 1e9,
                                   std::abs(s) > 1e-9 ? half_across / std::abs(s) : 1e9);
      const cv::Vec2d dir(std::cos(phi), std::sin(phi));
      for (double d : near_s) near[static_cast<size_t>(k)].push_back(road_at(centre + (edge + d) * dir));
      for (double d : far_s)
        if (const double b = road_at(centre + (edge + d) * dir); b >= 0) lit.push_back(b);
    }
    if (lit.size() < 6) continue;
    const double ref = median(lit);
    if (!(ref > 10.0)) continue;
    // Per side: how dark its band is (the second darkest of its samples: a shadow covers at least two, a
    // single dark speck on the road does not count) and right beside the footprint (the first two samples).
    std::vector<double> dark(static_cast<size_t>(K), -1.0), beside;
    for (int k = 0; k < K; ++k) {
      std::vector<double> d;
      for (double x : near[static_cast<size_t>(k)]) d.push_back(x >= 0 ? 1.0 - x / ref : -1.0);
      if (d[0] > -1.0 || d[1] > -1.0) beside.push_back(std::max(d[0], d[1]));
      std::vector<double> valid;
      for (double x : d)
        if (x > -1.0) valid.push_back(x);
      if (valid.size() < 2) continue;
      std::sort(valid.rbegin(), valid.rend());
      dark[static_cast<size_t>(k)] = valid[1];
    }
    std::vector<double> seen;
    for (double d : dark)
      if (d > -1.0) seen.push_back(d);
    if (static_cast<int>(seen.size()) < K / 2) continue;
    const double typical = median(seen);
    int best = 0;
    for (int k = 1; k < K; ++k)
      if (dark[static_cast<size_t>(k)] > dark[static_cast<size_t>(best)]) best = k;
    Sample s;
    s.darkness = dark[static_cast<size_t>(best)];
    s.contrast = s.darkness - typical;
    s.beside = std::max(0.0, median(beside));
    s.directional = s.contrast >= opt_.min_contrast && s.darkness >= opt_.min_darkness;
    // The shadow's side is the centre of the dark sector (the sides darker than halfway between the typical
    // and the darkest), not its darkest ray: a long flank is dark over a wide sector.
    double cx = 0, cy = 0;
    for (int k = 0; k < K; ++k) {
      const double d = dark[static_cast<size_t>(k)];
      if (d <= -1.0 || d < typical + 0.5 * s.contrast) continue;
      const double w = d - typical, phi = alpha + 2 * CV_PI * k / K;
      cx += w * std::cos(phi);
      cy += w * std::sin(phi);
    }
    s.azimuth = std::atan2(cy, cx) + heading;
    // The shadow reaches as far as its band stays at least half as dark as at its darkest, along the ray
    // nearest the dark sector's centre (the darkest ray may graze a long flank's shadow).
    const int along =
        static_cast<int>(std::lround(angle_diff(std::atan2(cy, cx), alpha) / (2 * CV_PI / K)) + K) % K;
    const auto& b = near[static_cast<size_t>(dark[static_cast<size_t>(along)] > -1.0 ? along : best)];
    double peak = 0, last = 0;
    for (size_t j = 0; j < b.size(); ++j)
      if (b[j] >= 0) peak = std::max(peak, 1.0 - b[j] / ref);
    for (size_t j = 0; j < b.size(); ++j)
      if (b[j] >= 0 && 1.0 - b[j] / ref >= 0.5 * peak) last = near_s[j];
    s.length_per_height = (last + 0.15) / std::max(0.5, v.height_m);
    samples_.push_back(s);
  }
}

SceneLight SceneLightEstimator::estimate() const {
  SceneLight out;
  out.samples = static_cast<int>(samples_.size());
  if (samples_.empty()) return out;
  double sx = 0, sy = 0, sw = 0;
  std::vector<double> dark, len, beside;
  for (const auto& s : samples_) {
    beside.push_back(s.beside);
    if (!s.directional) continue;
    ++out.directional_samples;
    sx += s.contrast * std::cos(s.azimuth);
    sy += s.contrast * std::sin(s.azimuth);
    sw += s.contrast;
    dark.push_back(s.darkness);
    len.push_back(s.length_per_height);
  }
  out.consistency = sw > 0 ? std::hypot(sx, sy) / sw : 0.0;
  out.directional = out.directional_samples >= opt_.min_samples &&
                    out.directional_samples >= opt_.min_share * out.samples &&
                    out.consistency >= opt_.min_consistency;
  if (out.directional) {
    out.azimuth = std::atan2(sy, sx);
    out.darkness = std::clamp(median(dark), 0.0, 0.95);
    out.length_per_height = median(len);
  } else {
    out.darkness = std::clamp(median(beside), 0.0, 0.95);
  }
  return out;
}

}  // namespace hf::render
