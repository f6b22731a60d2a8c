// A rendered road world seen by a camera of known geometry, for the footage kit's and the sources' tests: a
// straight road along the world x axis (asphalt noise, dashed lane lines, edge lines, verges), rendered per
// pixel by inverse mapping (pixel -> ground in the ego frame -> world -> texture).
#pragma once

#include <algorithm>
#include <cmath>
#include <random>
#include <vector>

#include <opencv2/imgproc.hpp>

#include "hazardforge/angles.hpp"
#include "hazardforge/types.hpp"

namespace hf::test::road {

using hf::CameraModel;

// A straight road along the world x axis: asphalt noise (features of ~10 cm), dashed lane lines (3 m dash, 9
// m gap) at +-1.75 m and +-5.25 m, solid edge lines at +-7 m, kerb-side grass beyond. Stored as a texture
// pyramid so that each pixel samples the level matching its ground footprint (no aliasing far away).
class RoadWorld {
 public:
  static constexpr double kRes = 0.04;  // m per texel at level 0
  static constexpr double kX0 = -20, kY0 = -20;
  RoadWorld() {
    const int w = static_cast<int>(160 / kRes),
              h = static_cast<int>(40 / kRes);  // x: -20..140 m, y: -20..20 m
    cv::Mat noise(h, w, CV_32F);
    cv::RNG rng(1234);
    rng.fill(noise, cv::RNG::NORMAL, 0, 1);
    cv::GaussianBlur(noise, noise, cv::Size(0, 0), 1.2);
    cv::normalize(noise, noise, 0, 1, cv::NORM_MINMAX);
    cv::Mat coarse(h / 16, w / 16, CV_32F);
    rng.fill(coarse, cv::RNG::NORMAL, 0, 1);
    cv::resize(coarse, coarse, noise.size(), 0, 0, cv::INTER_CUBIC);
    cv::Mat tex = 40 + 90 * noise + 8 * coarse;
    auto paint = [&](double y, double width, bool dashed) {
      for (int c = 0; c < w; ++c) {
        const double x = kX0 + c * kRes;
        if (dashed && std::fmod(x + 1000.0, 12.0) >= 3.0) continue;
        const int r0 = static_cast<int>((y - width / 2 - kY0) / kRes),
                  r1 = static_cast<int>((y + width / 2 - kY0) / kRes);
        for (int r = r0; r <= r1; ++r) tex.at<float>(r, c) = 215;
      }
    };
    for (double y : {-5.25, -1.75, 1.75, 5.25}) paint(y, 0.15, true);
    for (double y : {-7.0, 7.0}) paint(y, 0.2, false);
    for (int r = 0; r < h; ++r) {
      const double y = kY0 + r * kRes;
      if (std::abs(y) > 8.0)
        for (int c = 0; c < w; ++c) tex.at<float>(r, c) = 0.6f * tex.at<float>(r, c) + 10;  // darker verge
    }
    levels_.push_back(tex);
    for (int i = 0; i < 6; ++i) {
      cv::Mat d;
      cv::pyrDown(levels_.back(), d);
      levels_.push_back(d);
    }
  }
  // Grey level at world (x, y) for a ground footprint of `foot` metres.
  float sample(double x, double y, double foot) const {
    const double lev =
        std::clamp(std::log2(std::max(foot, 1e-6) / kRes), 0.0, static_cast<double>(levels_.size() - 1));
    const int l = static_cast<int>(lev);
    const cv::Mat& t = levels_[l];
    const double s = kRes * std::pow(2.0, l);
    const double u = (x - kX0) / s, v = (y - kY0) / s;
    const int u0 = static_cast<int>(std::floor(u)), v0 = static_cast<int>(std::floor(v));
    if (u0 < 0 || v0 < 0 || u0 + 1 >= t.cols || v0 + 1 >= t.rows) return 70.f;
    const double a = u - u0, b = v - v0;
    return static_cast<float>((1 - a) * (1 - b) * t.at<float>(v0, u0) +
                              a * (1 - b) * t.at<float>(v0, u0 + 1) + (1 - a) * b * t.at<float>(v0 + 1, u0) +
                              a * b * t.at<float>(v0 + 1, u0 + 1));
  }

 private:
  std::vector<cv::Mat> levels_;
};

inline const RoadWorld& world() {
  static const RoadWorld w;
  return w;
}

struct Pose {
  double x = 0, y = 0, yaw = 0;
};

// Inverse mapping: every pixel's ray meets the ground in the ego frame, the ego pose takes it to the world,
// the texture gives its grey level. Sky above the horizon (and beyond 150 m) is a smooth gradient.
inline cv::Mat render(const CameraModel& cam, const Pose& pose) {
  cv::Mat img(cam.height, cam.width, CV_8UC3);
  const double c = std::cos(pose.yaw), s = std::sin(pose.yaw);
  for (int v = 0; v < cam.height; ++v) {
    for (int u = 0; u < cam.width; ++u) {
      const auto g = cam.pixel_to_ground({u + 0.5, v + 0.5});
      double val;
      if (!g || std::hypot((*g)[0], (*g)[1]) > 150) {
        val = 170 + 40.0 * v / cam.height;
      } else {
        const auto g2 = cam.pixel_to_ground({u + 0.5, v + 1.5});
        const double foot = g2 ? std::max(cv::norm(*g - *g2), cv::norm(*g) / cam.fx) : 1.0;
        const double wx = pose.x + c * (*g)[0] - s * (*g)[1], wy = pose.y + s * (*g)[0] + c * (*g)[1];
        val = world().sample(wx, wy, foot);
      }
      const auto b = cv::saturate_cast<uchar>(val);
      img.at<cv::Vec3b>(v, u) = cv::Vec3b(b, b, b);
    }
  }
  return img;
}

// A building front: plaster (the asphalt's noise, brighter) with windows of varied size and shade on a 3 m
// grid, each cell's window drawn from a hash of the cell (no two neighbours alike, so features match
// unambiguously).
inline double facade(double x, double z, bool left, double foot) {
  const int i = static_cast<int>(std::floor(x / 3.0)), j = static_cast<int>(std::floor(z / 3.0));
  unsigned h =
      static_cast<unsigned>(i * 73856093) ^ static_cast<unsigned>(j * 19349663) ^ (left ? 83492791u : 0u);
  h ^= h >> 13;
  h *= 0x5bd1e995u;
  h ^= h >> 15;
  const double u = x - 3.0 * i, v = z - 3.0 * j;
  const double w = 0.8 + 1.4 * static_cast<double>(h % 97) / 96.0,
               ht = 0.8 + 1.2 * static_cast<double>((h / 97) % 89) / 88.0;
  const bool window = (h % 5) != 0 && std::abs(u - 1.5) < w / 2 && std::abs(v - 1.5) < ht / 2;
  const double plaster = 60 + 1.1 * world().sample(x, std::fmod(std::abs(z), 12.0) - 19.0, foot);
  return window ? 25.0 + static_cast<double>((h >> 8) % 60) : plaster;
}

// The same road between two rows of building fronts (world y = +-wall_y, up to 12 m high, textured like the
// asphalt): a scene with depth, for what needs more than one plane (the essential matrix of two views). Every
// pixel's ray meets the ground or a wall, whichever is nearer.
inline cv::Mat render_with_walls(const CameraModel& cam, const Pose& pose, double wall_y = 11.0) {
  cv::Mat img(cam.height, cam.width, CV_8UC3);
  const double c = std::cos(pose.yaw), s = std::sin(pose.yaw);
  const cv::Vec3d o = cam.cam_to_ego({0, 0, 0});
  const double ox = pose.x + c * o[0] - s * o[1], oy = pose.y + s * o[0] + c * o[1], oz = o[2];
  for (int v = 0; v < cam.height; ++v) {
    for (int u = 0; u < cam.width; ++u) {
      const cv::Vec3d e = cam.cam_to_ego({(u + 0.5 - cam.cx) / cam.fx, (v + 0.5 - cam.cy) / cam.fy, 1.0}) - o;
      const double dx = c * e[0] - s * e[1], dy = s * e[0] + c * e[1], dz = e[2];
      double t = 1e9;
      int what = 0;  // 0 sky, 1 ground, 2 wall
      if (dz < -1e-9) t = -oz / dz, what = 1;
      if (std::abs(dy) > 1e-9) {
        const double tw = ((dy > 0 ? wall_y : -wall_y) - oy) / dy;
        if (tw > 0 && tw < t && oz + tw * dz < 12.0) t = tw, what = 2;
      }
      const double range = t * cv::norm(e);
      double val;
      if (what == 0 || range > 150) {
        val = 170 + 40.0 * v / cam.height;
      } else {
        const double foot = std::max(range / cam.fx, 0.01);
        const double wx = ox + t * dx, wy = oy + t * dy, wz = oz + t * dz;
        val = what == 1 ? world().sample(wx, wy, foot) : facade(wx, wz, wy > 0, foot);
      }
      const auto b = cv::saturate_cast<uchar>(val);
      img.at<cv::Vec3b>(v, u) = cv::Vec3b(b, b, b);
    }
  }
  return img;
}

// Constant speed and yaw rate from a start pose: the exact arc.
inline Pose pose_at(double t, double speed, double yaw_rate, Pose start = {}) {
  Pose p = start;
  p.yaw = start.yaw + yaw_rate * t;
  if (std::abs(yaw_rate) < 1e-9) {
    p.x += speed * t * std::cos(start.yaw);
    p.y += speed * t * std::sin(start.yaw);
  } else {
    const double r = speed / yaw_rate;
    p.x += r * (std::sin(p.yaw) - std::sin(start.yaw));
    p.y += -r * (std::cos(p.yaw) - std::cos(start.yaw));
  }
  return p;
}

}  // namespace hf::test::road
