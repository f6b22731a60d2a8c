// Detector that projects the dataset's 3D annotations into image boxes (perception error kept apart).
#pragma once

#include <optional>
#include <string>
#include <vector>

#include <hazardforge/stage.hpp>

namespace hf {

// Stage "ground_truth" (detector; a risk metric of the same name exists, so graphs may need
// `stage: detector/ground_truth`).
// Ports: frames (Frame, with annotations and camera) -> detections (Detections), one packet per frame,
//   stamped with the frame's timestamp; score 1, annotation_index = index into Frame::annotations.
// Each annotated 3D box (ego frame) is projected with the frame's camera: the 8 corners, with the edges that
//   cross the camera's near plane (z = 0.1 m) cut there, so boxes partly behind the camera keep their visible
//   part and boxes wholly behind it are dropped; the bounding rectangle is clipped to the image. With
//   `prefer_dataset_boxes`, a box the dataset gives in the image (KITTI) is used instead.
// Params: classes (labels kept), min_visible_area (px^2 after clipping), min_points (lidar+radar points in
//   the box, nuScenes; objects with an unknown count pass; -1 = ignore), max_distance (m, ground-plane
//   distance from the camera to the box centre; 0 = no limit), prefer_dataset_boxes, require_annotations.
class GroundTruthDetector : public Detector {
 public:
  static ComponentInfo describe();
  void open(StageContext& ctx) override;
  Detections detect(StageContext& ctx, const Frame& frame) override;

  struct Config {
    std::vector<std::string> classes = {"car", "truck", "bus", "person", "bicycle", "motorcycle"};
    double min_visible_area = 0.0;
    int min_points = 1;
    double max_distance = 0.0;
    bool prefer_dataset_boxes = true;
    bool require_annotations = true;
  };

  void configure(const Config& c) { cfg_ = c; }
  Detections detect_frame(const Frame& frame) const;

 private:
  Config cfg_;
};

}  // namespace hf
