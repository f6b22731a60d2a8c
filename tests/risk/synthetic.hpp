// Synthetic cameras, boxes and frames of known geometry for the risk tests.
#pragma once

#include <string>

#include "hazardforge/types.hpp"

namespace hf::test {

// nuScenes-like front camera: 1600x900, f = 1250 px, 1.5 m above the road, 1.7 m ahead of the rear axle.
inline CameraModel front_camera(double pitch = 0.0, double height = 1.5) {
  return CameraModel::pinhole(1600, 900, 1250, 1250, 800, 450, height, pitch, 1.7);
}

// Image box of an upright object whose ground-contact centre (near face) is at ego (x, y): bottom edge at the
// ground point's row, top edge at the row of the point `height` m above it, width from `width` m at that
// depth.
inline cv::Rect2f box_of(const CameraModel& cam, double x, double y, double height, double width) {
  const cv::Point2d bottom = *cam.project_ego({x, y, 0.0});
  const cv::Point2d top = *cam.project_ego({x, y, height});
  const double depth = cam.ego_to_cam({x, y, 0.0})[2];
  const double w = cam.fx * width / depth;
  return cv::Rect2f(static_cast<float>(bottom.x - w / 2), static_cast<float>(top.y), static_cast<float>(w),
                    static_cast<float>(bottom.y - top.y));
}

inline Frame frame_at(int64_t index, double t, const CameraModel& cam, std::optional<double> ego_speed = {}) {
  Frame f;
  f.index = index;
  f.timestamp = t;
  f.camera = cam;
  f.ego.speed_mps = ego_speed;
  f.source_id = "synthetic_" + std::to_string(index);
  return f;
}

inline Track track(int64_t id, const std::string& label, const cv::Rect2f& box, int misses = 0) {
  Track t;
  t.id = id;
  t.label = label;
  t.box = box;
  t.score = 0.9f;
  t.misses = misses;
  return t;
}

}  // namespace hf::test
