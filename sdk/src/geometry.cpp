// Class size priors, box truncation, annotated boxes in the image, and locating the project's share folder.
#include "hazardforge/geometry.hpp"

#include <dlfcn.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdlib>
#include <filesystem>

#include <opencv2/calib3d.hpp>

#include "hazardforge/yaml_json.hpp"

namespace hf {

unsigned truncation_flags(const cv::Rect2f& box, const cv::Size& image, double margin_px) {
  unsigned f = 0;
  if (box.x <= margin_px) f |= truncation::kLeft;
  if (box.y <= margin_px) f |= truncation::kTop;
  if (box.x + box.width >= image.width - margin_px) f |= truncation::kRight;
  if (box.y + box.height >= image.height - margin_px) f |= truncation::kBottom;
  return f;
}

std::optional<cv::Rect2d> annotation_image_box(const CameraModel& cam, const AnnotatedObject& obj,
                                               double near_m) {
  const double c = std::cos(obj.yaw_ego), s = std::sin(obj.yaw_ego);
  const double hl = obj.size_lwh[0] / 2, hw = obj.size_lwh[1] / 2, hh = obj.size_lwh[2] / 2;
  // Corner k has signs (bit0: length, bit1: width, bit2: height); edges join corners one bit apart.
  std::array<cv::Vec3d, 8> cam_pts;
  for (int k = 0; k < 8; ++k) {
    const double dx = (k & 1 ? hl : -hl), dy = (k & 2 ? hw : -hw), dz = (k & 4 ? hh : -hh);
    const cv::Vec3d ego = obj.center_ego + cv::Vec3d(c * dx - s * dy, s * dx + c * dy, dz);
    cam_pts[k] = cam.ego_to_cam(ego);
  }
  std::vector<cv::Point3d> visible;
  for (int k = 0; k < 8; ++k)
    if (cam_pts[k][2] >= near_m) visible.emplace_back(cam_pts[k][0], cam_pts[k][1], cam_pts[k][2]);
  for (int a = 0; a < 8; ++a)
    for (int bit = 1; bit < 8; bit <<= 1) {
      const int b = a | bit;
      if (b == a) continue;
      const cv::Vec3d &p = cam_pts[a], &q = cam_pts[b];
      if ((p[2] >= near_m) == (q[2] >= near_m)) continue;
      const double u = (near_m - p[2]) / (q[2] - p[2]);
      const cv::Vec3d x = p + u * (q - p);
      visible.emplace_back(x[0], x[1], near_m);
    }
  if (visible.empty()) return std::nullopt;

  std::vector<cv::Point2d> px;
  if (cam.distortion.empty()) {
    for (const cv::Point3d& v : visible)
      px.emplace_back(cam.fx * v.x / v.z + cam.cx, cam.fy * v.y / v.z + cam.cy);
  } else {
    cv::projectPoints(visible, cv::Vec3d(0, 0, 0), cv::Vec3d(0, 0, 0), cv::Mat(cam.K()), cam.distortion, px);
  }
  double x0 = px[0].x, x1 = px[0].x, y0 = px[0].y, y1 = px[0].y;
  for (const cv::Point2d& q : px) {
    x0 = std::min(x0, q.x);
    x1 = std::max(x1, q.x);
    y0 = std::min(y0, q.y);
    y1 = std::max(y1, q.y);
  }
  return cv::Rect2d(x0, y0, x1 - x0, y1 - y0);
}

ClassPriors ClassPriors::load(const std::string& path) {
  YamlDocument doc = load_yaml_file(path);
  ClassPriors pr;
  pr.file_ = path;
  if (!doc.value.is_object()) throw Error(doc.at(""), "class size priors must be a mapping of label -> sizes");
  for (auto it = doc.value.begin(); it != doc.value.end(); ++it) {
    const std::string ptr = "/" + it.key();
    if (!it->is_object()) throw Error(doc.at(ptr), "class '" + it.key() + "' needs {height, width, length}");
    ClassSize s;
    for (const char* f : {"height", "width", "length"}) {
      if (!it->contains(f) || !(*it)[f].is_number() || (*it)[f].get<double>() <= 0)
        throw Error(doc.at(ptr + "/" + f), "class '" + it.key() + "': '" + f + "' must be a positive number (m)");
    }
    s.height = (*it)["height"].get<double>();
    s.width = (*it)["width"].get<double>();
    s.length = (*it)["length"].get<double>();
    pr.sizes_[it.key()] = s;
  }
  return pr;
}

const ClassSize& ClassPriors::at(const std::string& label) const {
  auto it = sizes_.find(label);
  if (it == sizes_.end())
    throw Error("no size prior for class '" + label + "'" + (file_.empty() ? "" : " in " + file_));
  return it->second;
}

std::string share_dir() {
  if (const char* env = std::getenv("HAZARDFORGE_SHARE"); env && *env) return env;
  Dl_info info{};
  if (dladdr(reinterpret_cast<void*>(&share_dir), &info) && info.dli_fname) {
    namespace fs = std::filesystem;
    fs::path installed = fs::path(info.dli_fname).parent_path().parent_path() / "share" / "hazardforge";
    if (fs::exists(installed / "class_sizes.yaml")) return installed.string();
  }
  return HF_SOURCE_SHARE_DIR;
}

}  // namespace hf
