// Projection of annotated 3D boxes into the image: near-plane clipping, bounding rectangle, filters.
#include "ground_truth_detector.hpp"

#include <algorithm>
#include <array>
#include <cmath>

#include <opencv2/calib3d.hpp>

#include <hazardforge/geometry.hpp>

namespace hf {

namespace {
// COCO ids of the road-user labels, so ground-truth and YOLO detections share class ids.
int coco_id(const std::string& label) {
  if (label == "person") return 0;
  if (label == "bicycle") return 1;
  if (label == "car") return 2;
  if (label == "motorcycle") return 3;
  if (label == "bus") return 5;
  if (label == "truck") return 7;
  return -1;
}
}  // namespace

ComponentInfo GroundTruthDetector::describe() {
  ComponentInfo i = Detector::base_info("ground_truth", "dataset 3D annotations projected into image boxes");
  i.doc =
      "Projects Frame::annotations (3D boxes in the ego frame) with the frame's camera into 2D boxes, so a "
      "pipeline can run with perfect detections and its estimation and metric errors can be measured apart "
      "from perception errors. One Detections packet per frame, stamped with the frame's timestamp.";
  i.params = {
      ParamSpec::string_list("classes", {"car", "truck", "bus", "person", "bicycle", "motorcycle"})
          .describe("project labels (AnnotatedObject::label) to keep"),
      ParamSpec::number("min_visible_area", 0.0)
          .range(0, 1e8)
          .describe("drop boxes whose area inside the image is below this (px^2); zero-area boxes always go"),
      ParamSpec::integer("min_points", 1)
          .range(-1, 1000000)
          .describe(
              "drop objects with fewer lidar+radar points (nuScenes); unknown counts pass; -1 = ignore"),
      ParamSpec::number("max_distance", 0.0)
          .range(0, 100000)
          .describe(
              "drop objects whose centre is farther from the camera on the ground plane (m); 0 = no limit"),
      ParamSpec::boolean("prefer_dataset_boxes", true)
          .describe("use the dataset's own image box when it has one (KITTI) instead of projecting"),
      ParamSpec::boolean("require_annotations", true)
          .describe("a frame without annotations is an error; false = emit no detections for it"),
  };
  return i;
}

void GroundTruthDetector::open(StageContext& ctx) {
  const Params& p = ctx.params();
  Config c;
  c.classes = p.get_strings("classes");
  c.min_visible_area = p.get_double("min_visible_area");
  c.min_points = static_cast<int>(p.get_int("min_points"));
  c.max_distance = p.get_double("max_distance");
  c.prefer_dataset_boxes = p.get_bool("prefer_dataset_boxes");
  c.require_annotations = p.get_bool("require_annotations");
  configure(c);
}

Detections GroundTruthDetector::detect(StageContext& /*ctx*/, const Frame& frame) {
  return detect_frame(frame);
}

std::optional<cv::Rect2d> GroundTruthDetector::project_box(const CameraModel& cam,
                                                           const AnnotatedObject& obj) {
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
    if (cam_pts[k][2] >= kNearPlane) visible.emplace_back(cam_pts[k][0], cam_pts[k][1], cam_pts[k][2]);
  for (int a = 0; a < 8; ++a)
    for (int bit = 1; bit < 8; bit <<= 1) {
      const int b = a | bit;
      if (b == a) continue;
      const cv::Vec3d &p = cam_pts[a], &q = cam_pts[b];
      if ((p[2] >= kNearPlane) == (q[2] >= kNearPlane)) continue;
      const double u = (kNearPlane - p[2]) / (q[2] - p[2]);
      const cv::Vec3d x = p + u * (q - p);
      visible.emplace_back(x[0], x[1], kNearPlane);
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

Detections GroundTruthDetector::detect_frame(const Frame& frame) const {
  Detections out;
  out.frame_index = frame.index;
  out.detector = "ground_truth";
  const std::string what = "ground_truth detector: frame " + std::to_string(frame.index) +
                           (frame.source_id.empty() ? "" : " (" + frame.source_id + ")");
  cv::Size size =
      frame.image.empty() ? cv::Size(frame.camera.width, frame.camera.height) : frame.image.size();
  out.image_size = size;
  if (!frame.annotations) {
    if (cfg_.require_annotations)
      throw Error(what +
                  " carries no annotations; this detector needs a source that provides them "
                  "(or set require_annotations: false)");
    return out;
  }
  if (!frame.camera.valid()) throw Error(what + " has no valid camera model to project annotations with");
  if (size.area() <= 0) throw Error(what + " has neither an image nor a camera size");
  const cv::Rect2d image(0, 0, size.width, size.height);

  const auto& objs = frame.annotations->objects;
  for (size_t k = 0; k < objs.size(); ++k) {
    const AnnotatedObject& o = objs[k];
    if (std::find(cfg_.classes.begin(), cfg_.classes.end(), o.label) == cfg_.classes.end()) continue;
    if (cfg_.min_points >= 0 && o.num_points >= 0 && o.num_points < cfg_.min_points) continue;
    if (cfg_.max_distance > 0) {
      const cv::Vec3d& cam = frame.camera.t_ego_cam;
      if (std::hypot(o.center_ego[0] - cam[0], o.center_ego[1] - cam[1]) > cfg_.max_distance) continue;
    }
    std::optional<cv::Rect2d> box;
    if (cfg_.prefer_dataset_boxes && o.box2d)
      box = *o.box2d;
    else
      box = project_box(frame.camera, o);
    if (!box) continue;
    const cv::Rect2d clipped = *box & image;
    if (clipped.area() <= 0.0 || clipped.area() < cfg_.min_visible_area) continue;
    Detection d;
    d.box = cv::Rect2f(static_cast<float>(clipped.x), static_cast<float>(clipped.y),
                       static_cast<float>(clipped.width), static_cast<float>(clipped.height));
    d.class_id = coco_id(o.label);
    d.label = o.label;
    d.score = 1.f;
    d.annotation_index = static_cast<int>(k);
    d.truncated = truncation_flags(d.box, size);
    out.items.push_back(std::move(d));
  }
  return out;
}

}  // namespace hf
