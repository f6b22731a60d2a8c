// Annotated 3D boxes as detections: projected into the image (hf::annotation_image_box), clipped, filtered.
#include "ground_truth_detector.hpp"

#include <algorithm>
#include <cmath>

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
      box = annotation_image_box(frame.camera, o);
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
