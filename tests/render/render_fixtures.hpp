// Synthetic frames with known geometry for the renderer tests: cameras, textured backgrounds and roads,
// poses.
#pragma once

#include <cmath>
#include <filesystem>
#include <map>
#include <optional>
#include <random>

#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

#include "hazardforge/geometry.hpp"
#include "hazardforge/types.hpp"

namespace hf::test {

// The default appearance assets shipped in share/assets.
inline std::filesystem::path default_asset_dir() {
  return std::filesystem::path(share_dir()) / "assets";
}

// A nuScenes-like front camera: 1600x900, f = 1266 px, 1.5 m high, level, 1.5 m ahead of the rear axle.
inline CameraModel test_camera(double pitch = 0.0) {
  return CameraModel::pinhole(1600, 900, 1266, 1266, 800, 450, 1.5, pitch, 1.5);
}

// Band-limited random texture (sum of blurred noise octaves), deterministic for a seed.
inline cv::Mat noise_texture(cv::Size size, unsigned seed, double contrast = 60.0) {
  cv::RNG rng(seed);
  cv::Mat acc(size, CV_32F, cv::Scalar(0));
  for (double sigma : {1.5, 4.0, 12.0}) {
    cv::Mat n(size, CV_32F);
    rng.fill(n, cv::RNG::NORMAL, 0.0, 1.0);
    cv::GaussianBlur(n, n, cv::Size(), sigma);
    cv::Scalar m, sd;
    cv::meanStdDev(n, m, sd);
    acc += n / sd[0];
  }
  cv::Mat out;
  acc.convertTo(out, CV_8U, contrast / 3.0, 128);
  return out;
}

inline cv::Mat textured_image(cv::Size size = {1600, 900}, unsigned seed = 7) {
  cv::Mat g = noise_texture(size, seed), bgr;
  cv::cvtColor(g, bgr, cv::COLOR_GRAY2BGR);
  return bgr;
}

inline Frame make_frame(int64_t index, double t, const cv::Mat& image, const CameraModel& cam,
                        std::optional<cv::Matx44d> pose = std::nullopt) {
  Frame f;
  f.index = index;
  f.timestamp = t;
  f.image = image;
  f.camera = cam;
  f.ego.T_world_ego = pose;
  f.source_id = "synthetic";
  return f;
}

inline HazardTrajectory static_object(const std::string& cls, double x, double y, double heading, double t0,
                                      double t1, double anchor_time, cv::Vec3d size) {
  HazardTrajectory t;
  t.kind = "test";
  t.object_class = cls;
  t.size_lwh = size;
  t.anchor_time = anchor_time;
  t.points = {{t0, x, y, heading, 0.0, 0.0}, {t1, x, y, heading, 0.0, 0.0}};
  return t;
}

// A road image seen by `cam` from the ego pose (x, y, yaw) over a world-fixed ground texture (`tex` covers
// [x0, x0 + tex.cols * res] x [y0 - tex.rows * res / 2, y0 + tex.rows * res / 2]); rendered 3x supersampled
// so distant texture is filtered like a real lens would. Above the horizon: flat grey.
inline cv::Mat road_image(const CameraModel& cam, const cv::Mat& tex, double res, double x0, double ego_x,
                          double ego_y, double ego_yaw) {
  constexpr int kS = 3;
  // Ground point (ego frame) of every supersampled pixel, computed once per camera.
  static std::map<std::pair<int, double>, std::pair<cv::Mat, cv::Mat>> ground_cache;
  auto& g = ground_cache[{cam.width, cam.pitch()}];
  if (g.first.empty()) {
    g.first.create(cam.height * kS, cam.width * kS, CV_64F);
    g.second.create(g.first.size(), CV_64F);
    for (int v = 0; v < g.first.rows; ++v)
      for (int u = 0; u < g.first.cols; ++u) {
        auto p = cam.pixel_to_ground({(u + 0.5) / kS - 0.5, (v + 0.5) / kS - 0.5});
        g.first.at<double>(v, u) = p ? (*p)[0] : std::nan("");
        g.second.at<double>(v, u) = p ? (*p)[1] : std::nan("");
      }
  }
  cv::Mat mx(g.first.size(), CV_32F), my(g.first.size(), CV_32F);
  const double c = std::cos(ego_yaw), s = std::sin(ego_yaw);
  for (int v = 0; v < mx.rows; ++v) {
    const double* gx = g.first.ptr<double>(v);
    const double* gy = g.second.ptr<double>(v);
    float* ox = mx.ptr<float>(v);
    float* oy = my.ptr<float>(v);
    for (int u = 0; u < mx.cols; ++u) {
      if (std::isnan(gx[u])) {
        ox[u] = oy[u] = -1.f;
        continue;
      }
      const double wx = ego_x + c * gx[u] - s * gy[u], wy = ego_y + s * gx[u] + c * gy[u];
      ox[u] = static_cast<float>((wx - x0) / res);
      oy[u] = static_cast<float>(tex.rows / 2.0 - wy / res);
    }
  }
  cv::Mat big, out;
  cv::remap(tex, big, mx, my, cv::INTER_LINEAR, cv::BORDER_CONSTANT, cv::Scalar(128));
  cv::resize(big, out, cv::Size(cam.width, cam.height), 0, 0, cv::INTER_AREA);
  cv::Mat bgr;
  cv::cvtColor(out, bgr, cv::COLOR_GRAY2BGR);
  return bgr;
}

}  // namespace hf::test
