// KITTI source: tracking sequences (images, calib, labels) and raw image folders with a tracking-format
// calib.
#pragma once

#include <filesystem>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "hazardforge/stage.hpp"

namespace hf::source {

// Emits KITTI image_02 frames with the P2 camera and, when labels exist, the tracking labels in the ego
// frame. Ports: out `frames` (Frame; annotations when labelled). Timestamps: (KITTI frame number - first
// emitted frame number) / fps (10 Hz); meta.kitti_frame holds the number. Ego frame: origin on the ground
// below camera 2 (camera_forward = 0 by default), x forward, level camera
//   `camera_height` m up. Velocities are relative to the camera (KITTI tracking has no ego motion): see
//   docs/sources-and-sinks.md.
// Params: layout, root, split, sequence, images, calib, labels, images_required, pattern, fps, image_width,
//   image_height, camera_height, camera_pitch_deg, camera_forward, ego_speed_mps, max_velocity_dt, label_map,
//   annotations, start_frame, max_frames.
class KittiSource : public SourceStage {
 public:
  static ComponentInfo describe();
  void open(StageContext& ctx) override;
  bool next(StageContext& ctx, Outputs& out) override;
  std::optional<int64_t> frame_count() const override { return static_cast<int64_t>(frames_.size()); }

 private:
  struct Item {
    int kitti_frame = 0;
    std::filesystem::path image;  // empty = no image (blank frame)
    std::shared_ptr<const Annotations> annotations;
  };
  std::vector<Item> items_;
  std::vector<size_t> frames_;  // indices into items_ that are emitted
  CameraModel camera_;
  EgoState ego_;
  double fps_ = 10;
  std::string layout_;
  std::string scene_;  // the sequence, or the drive's folder
  size_t pos_ = 0;
};

}  // namespace hf::source
