// Oriented 3D boxes of road users: corners, projection into a camera, and which side of the object a camera
// sees.
#include "hazardforge/assets/box_geometry.hpp"

#include <algorithm>
#include <cmath>

#include <opencv2/calib3d.hpp>

#include "hazardforge/angles.hpp"
#include "hazardforge/error.hpp"

namespace hf::render {

namespace {
// A face takes a picture when the camera sees it within 67.5 degrees of its normal: one face for head-on
// views, two for three-quarter views.
const double kFaceVisibleCos = std::cos(67.5 / kDegPerRad);
}  // namespace

BoxCorners box_corners(double x, double y, double yaw, const cv::Vec3d& s, double z_bottom) {
  const double c = std::cos(yaw), sn = std::sin(yaw);
  const double hl = s[0] / 2, hw = s[1] / 2;
  // (along, across) offsets of the bottom corners in the order documented in the header.
  const double off[4][2] = {{hl, hw}, {hl, -hw}, {-hl, -hw}, {-hl, hw}};
  BoxCorners out;
  for (int i = 0; i < 4; ++i) {
    const double px = x + c * off[i][0] - sn * off[i][1];
    const double py = y + sn * off[i][0] + c * off[i][1];
    out[i] = cv::Vec3d(px, py, z_bottom);
    out[i + 4] = cv::Vec3d(px, py, z_bottom + s[2]);
  }
  return out;
}

std::array<int, 4> face_corners(Face f) {
  switch (f) {
    case Face::kFront:
      return {0, 1, 5, 4};
    case Face::kRear:
      return {2, 3, 7, 6};
    case Face::kLeft:
      return {3, 0, 4, 7};
    case Face::kRight:
      return {1, 2, 6, 5};
  }
  return {0, 1, 5, 4};
}

double face_azimuth_deg(Face f) {
  switch (f) {
    case Face::kFront:
      return 0.0;
    case Face::kLeft:
      return 90.0;
    case Face::kRear:
      return 180.0;
    case Face::kRight:
      return -90.0;
  }
  return 0.0;
}

double angle_diff_deg(double a, double b) {
  return std::abs(wrap_deg(a - b));
}

double camera_azimuth_deg(const cv::Vec3d& cam, double ox, double oy, double yaw) {
  return wrap_deg(std::atan2(cam[1] - oy, cam[0] - ox) * kDegPerRad - yaw * kDegPerRad);
}

const std::vector<std::string>& view_names() {
  static const std::vector<std::string> kNames = {"front", "front_left", "left",  "rear_left",
                                                  "rear",  "rear_right", "right", "front_right"};
  return kNames;
}

bool is_view_name(const std::string& v) {
  const auto& n = view_names();
  return std::find(n.begin(), n.end(), v) != n.end();
}

double view_azimuth_deg(const std::string& view) {
  const auto& n = view_names();
  auto it = std::find(n.begin(), n.end(), view);
  if (it == n.end()) {
    std::string all;
    for (const auto& s : n) all += (all.empty() ? "" : ", ") + s;
    throw Error("unknown view '" + view + "' (expected one of " + all + ")");
  }
  return wrap_deg(45.0 * static_cast<double>(it - n.begin()));
}

std::string view_for_azimuth(double az) {
  const int bin = static_cast<int>(std::lround(wrap_deg(az) / 45.0));  // -4..4
  return view_names()[static_cast<size_t>((bin + 8) % 8)];
}

std::vector<Face> visible_faces(double az) {
  std::vector<Face> out;
  for (Face f : {Face::kFront, Face::kLeft, Face::kRear, Face::kRight})
    if (std::cos((az - face_azimuth_deg(f)) / kDegPerRad) > kFaceVisibleCos) out.push_back(f);
  return out;
}

std::vector<int> corners_of(const std::vector<Face>& faces) {
  std::vector<int> idx;
  for (Face f : faces)
    for (int c : face_corners(f)) idx.push_back(c);
  std::sort(idx.begin(), idx.end());
  idx.erase(std::unique(idx.begin(), idx.end()), idx.end());
  return idx;
}

std::vector<int> visible_corners(double az) {
  return corners_of(visible_faces(az));
}

std::array<double, 4> face_shares(const std::array<cv::Point2d, 8>& px) {
  std::array<double, 4> share{};
  double total = 0;
  const Face order[4] = {Face::kFront, Face::kLeft, Face::kRear, Face::kRight};
  for (int k = 0; k < 4; ++k) {
    const auto c = face_corners(order[k]);
    double a = 0;  // shoelace in image axes (y down): positive = counter-clockwise from outside = facing us
    for (int i = 0; i < 4; ++i) {
      const cv::Point2d& p = px[c[i]];
      const cv::Point2d& q = px[c[(i + 1) % 4]];
      a += p.x * q.y - q.x * p.y;
    }
    share[k] = std::max(a, 0.0);
    total += share[k];
  }
  if (total > 0)
    for (double& v : share) v /= total;
  return share;
}

std::vector<Face> facing_faces(const std::array<cv::Point2d, 8>& px, double min_share) {
  const auto share = face_shares(px);
  const Face order[4] = {Face::kFront, Face::kLeft, Face::kRear, Face::kRight};
  std::vector<Face> out;
  for (int k = 0; k < 4; ++k)
    if (share[k] > 0 && share[k] >= min_share) out.push_back(order[k]);
  return out;
}

std::optional<cv::Point2d> project_point(const CameraModel& cam, const cv::Vec3d& p_ego) {
  if (cam.distortion.empty()) return cam.project_ego(p_ego);
  const cv::Vec3d pc = cam.ego_to_cam(p_ego);
  if (pc[2] <= 0.01) return std::nullopt;
  std::vector<cv::Point3d> obj{cv::Point3d(pc[0], pc[1], pc[2])};
  std::vector<cv::Point2d> img;
  cv::projectPoints(obj, cv::Vec3d(0, 0, 0), cv::Vec3d(0, 0, 0), cv::Mat(cam.K()), cam.distortion, img);
  return img[0];
}

std::optional<ProjectedBox> project_box(const CameraModel& cam, const BoxCorners& corners, double min_depth) {
  ProjectedBox pb;
  double x0 = 1e300, y0 = 1e300, x1 = -1e300, y1 = -1e300;
  for (int i = 0; i < 8; ++i) {
    const cv::Vec3d pc = cam.ego_to_cam(corners[i]);
    if (pc[2] < min_depth) return std::nullopt;
    auto p = project_point(cam, corners[i]);
    if (!p) return std::nullopt;
    pb.px[i] = *p;
    pb.depth[i] = pc[2];
    x0 = std::min(x0, p->x);
    y0 = std::min(y0, p->y);
    x1 = std::max(x1, p->x);
    y1 = std::max(y1, p->y);
  }
  pb.bounds = cv::Rect2d(x0, y0, x1 - x0, y1 - y0);
  return pb;
}

}  // namespace hf::render
