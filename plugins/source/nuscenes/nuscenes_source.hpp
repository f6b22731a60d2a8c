// nuScenes keyframe source: camera images with intrinsics, mounting, ego poses and 3D annotations in the ego
// frame.
#pragma once

#include <filesystem>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "hazardforge/stage.hpp"

namespace hf::source {

// Reads the nuScenes tables of `dataroot`/`version` and emits the `channel` keyframes of the chosen scenes.
// Ports: out `frames` (Frame with camera model, EgoState with T_world_ego/speed/velocity, Annotations).
// Timestamps: seconds since the first emitted keyframe (nuScenes timestamps are microseconds); a later scene
//   continues `scene_gap_s` after the previous one ends, so time never goes backwards.
// Params: dataroot, version, scenes, channel, annotations, max_velocity_dt, label_map, images_required,
//   resize_width, resize_height, scene_gap_s, max_frames, ego_track (Frame::ego_track: the scene's recorded
//   ego poses [{t, x, y, yaw}], world frame, stream seconds, on every frame of the scene).
class NuScenesSource : public SourceStage {
 public:
  struct KeyFrame {
    std::string scene, scene_description, sample_token, sample_data_token, filename;
    int64_t timestamp_us = 0;       // sample_data (image capture) time
    int64_t pose_timestamp_us = 0;  // ego_pose time, used for ego velocity
    double t = 0.0;
    bool scene_start = false;
    CameraModel camera;  // at the native image size
    cv::Matx33d R_world_ego;
    cv::Vec3d t_world_ego;
    EgoState ego;
    std::shared_ptr<const Annotations> annotations;
    std::shared_ptr<const EgoTrack> ego_track;  // the scene's recorded ego track (shared by its keyframes)
  };

  static ComponentInfo describe();
  void open(StageContext& ctx) override;
  bool next(StageContext& ctx, Outputs& out) override;
  std::optional<int64_t> frame_count() const override { return static_cast<int64_t>(frames_.size()); }

  const std::vector<KeyFrame>& keyframes() const { return frames_; }

 private:
  std::filesystem::path dataroot_;
  std::vector<KeyFrame> frames_;
  bool images_required_ = true;
  bool ego_track_ = true;
  int resize_w_ = 0, resize_h_ = 0;
  size_t pos_ = 0;
};

// Project class of a dataset category by the longest matching prefix in `label_map` ("vehicle.bus" matches
// "vehicle.bus.rigid"); "" when nothing matches.
std::string map_label(const std::string& category, const Json& label_map);

}  // namespace hf::source
