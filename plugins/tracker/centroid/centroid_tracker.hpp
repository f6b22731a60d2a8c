// Nearest-centroid multi-object tracker (the method the original assessment pipeline used).
#pragma once

#include <memory>
#include <optional>
#include <string>
#include <vector>

#include <hazardforge/stage.hpp>

#include "hazardforge/tracking/track_common.hpp"

namespace hf {

// Stage "centroid" (tracker).
// Ports: detections (Detections) + frames (Frame) -> tracks (Tracks), one packet per frame, stamped with the
//   frame's timestamp; every live track is emitted, also those unmatched now (misses > 0, box held).
// Association: the distance between each track's reference centre (its last centre, or with `predict` that
//   centre moved on by the track's velocity to this frame's time) and each detection's centre; pairs farther
//   than `max_distance` px (0 = 0.1 x the image diagonal) or, with `match_class`, of different labels (labels
//   in one of `class_groups`, default car/truck/bus and bicycle/motorcycle, count as equal) are never
//   matched. `association` = greedy (globally sorted distances, smallest first, as the original) or hungarian
//   (minimum total distance).
// A track unmatched for more than `max_disappeared` consecutive frames is dropped; ids are never reused.
// velocity_px: smoothed centre displacement between matched observations over their timestamp difference
//   (`velocity_smoothing` = weight of the newest step).
class CentroidTracker : public Tracker {
 public:
  static ComponentInfo describe();
  void open(StageContext& ctx) override;
  Tracks update(StageContext& ctx, const Detections& dets, const Frame& frame) override;

  struct Config {
    double max_distance = 0.0;  // px; 0 = kAutoGateFraction x image diagonal
    int max_disappeared = 10;
    std::vector<std::string> class_groups = tracking::default_class_groups();
    bool match_class = true;
    bool hungarian = false;
    bool predict = true;
    double velocity_smoothing = 0.5;
    bool compensate_turn = false;  // move the tracks with the picture when the ego turns (poses or yaw rate)
  };
  static constexpr double kAutoGateFraction = 0.1;
  void configure(const Config& c) {
    cfg_ = c;
    groups_ = tracking::ClassGroups(c.class_groups);
  }
  // The tracker without a stage context (tests, tools): timestamps come from the frame.
  Tracks step(const Detections& dets, const Frame& frame);

 private:
  struct Entry {
    int64_t id = -1;
    cv::Rect2f box;
    tracking::VelocityEstimator velocity;
    tracking::LabelVote vote;
    float score = 0.f;
    int age = 0, hits = 0, misses = 0;
    int detection_index = -1, annotation_index = -1;
    unsigned truncated = 0;  // of the last matched detection
  };
  Config cfg_;
  tracking::ClassGroups groups_{tracking::default_class_groups()};
  std::vector<Entry> tracks_;
  int64_t next_id_ = 1;
  bool have_time_ = false;
  double last_time_ = 0.0;
  int64_t last_frame_ = -1;
  std::optional<double> heading_;  // the ego's heading at the last frame (rad), for compensate_turn
};

}  // namespace hf
