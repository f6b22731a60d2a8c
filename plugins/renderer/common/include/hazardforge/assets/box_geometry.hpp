// Oriented 3D boxes of road users: corners, projection into a camera, and which side of the object a camera
// sees.
#pragma once

#include <array>
#include <optional>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "hazardforge/angles.hpp"
#include "hazardforge/types.hpp"

namespace hf::render {

// Corner order used everywhere (object frame x forward, y left, z up; origin = ground-contact centre):
// 0 front-left-bottom, 1 front-right-bottom, 2 rear-right-bottom, 3 rear-left-bottom, 4..7 the same on top.
using BoxCorners = std::array<cv::Vec3d, 8>;

enum class Face { kFront, kRear, kLeft, kRight };

// The corners of a box of size (length, width, height) standing on the ground at (x, y) with heading `yaw`.
BoxCorners box_corners(double x, double y, double yaw, const cv::Vec3d& size_lwh, double z_bottom = 0.0);
// Corner indices of one face (counter-clockwise seen from outside, bottom edge first).
std::array<int, 4> face_corners(Face f);
// Outward normal direction of a face in the object frame, degrees (front 0, left 90, rear 180, right -90).
double face_azimuth_deg(Face f);

// Direction of the camera as seen from the object, in the object's frame, degrees in (-180, 180]:
// 0 = the camera is straight ahead of the object (it sees the front), 90 = on the object's left, 180 =
// behind.
double camera_azimuth_deg(const cv::Vec3d& camera_pos, double obj_x, double obj_y, double obj_yaw);

// The eight named views at 45 degree steps: front, front_left, left, rear_left, rear, rear_right, right,
// front_right, and their azimuths.
const std::vector<std::string>& view_names();
double view_azimuth_deg(const std::string& view);  // throws hf::Error for an unknown name
std::string view_for_azimuth(double azimuth_deg);  // nearest view
bool is_view_name(const std::string& view);

// Faces a camera at this azimuth sees well enough to map a picture onto (one for head-on views, two for
// three-quarter views).
std::vector<Face> visible_faces(double azimuth_deg);
// Corner indices of those faces, without repeats, in ascending order.
std::vector<int> visible_corners(double azimuth_deg);

// Vertical faces turned towards the camera in a picture of the box, from the winding of their projected
// corners (each face's corners are listed counter-clockwise seen from outside); faces whose projected area is
// below `min_share` of the visible total are slivers and left out.
std::vector<Face> facing_faces(const std::array<cv::Point2d, 8>& px, double min_share = 0.05);
// Share of each vertical face (front, left, rear, right) in the projected area of the faces turned to the
// camera.
std::array<double, 4> face_shares(const std::array<cv::Point2d, 8>& px);
// Corner indices of some faces, without repeats, ascending.
std::vector<int> corners_of(const std::vector<Face>& faces);

double angle_diff_deg(double a, double b);  // |a - b| on the circle, in [0, 180]

// Pixel of an ego-frame point with the camera's distortion applied (nullopt behind the camera).
std::optional<cv::Point2d> project_point(const CameraModel& cam, const cv::Vec3d& p_ego);

// Projection of a box: all eight pixels when every corner is at least `min_depth` in front of the camera.
struct ProjectedBox {
  std::array<cv::Point2d, 8> px;
  std::array<double, 8> depth{};  // camera z of each corner
  cv::Rect2d bounds;              // bounding rectangle of the eight pixels (not clipped)
};
std::optional<ProjectedBox> project_box(const CameraModel& cam, const BoxCorners& corners_ego,
                                        double min_depth = 0.1);

}  // namespace hf::render
