// SORT tracker (Bewley et al., "Simple Online and Realtime Tracking", 2016): Kalman boxes, IoU assignment.
#pragma once

#include <memory>
#include <string>
#include <vector>

#include <opencv2/video/tracking.hpp>

#include <hazardforge/stage.hpp>

#include "hazardforge/tracking/track_common.hpp"

namespace hf {

// Stage "sort" (tracker).
// Ports: detections (Detections) + frames (Frame) -> tracks (Tracks), one packet per frame, stamped with the
//   frame's timestamp.
// Each track is a constant-velocity Kalman filter on [cx, cy, s = area, r = aspect] (r constant), stepped
//   once per frame. Detections are assigned to the predicted boxes by the Hungarian algorithm on IoU; pairs
//   below `iou_threshold` (or of different labels with `match_class`, `class_groups` as in the centroid
//   tracker) are never matched. A track is emitted when it was matched this frame and has `min_hits`
//   consecutive hits (every matched track during the first `min_hits` frames); after a miss it must rebuild
//   that streak. With `emit_unmatched`, a track once confirmed is emitted every frame until it is dropped,
//   with its predicted box and misses > 0 while unmatched. A track unmatched for more than `max_age` frames
//   is dropped; ids are never reused.
// Emitted boxes are the filter's estimate (after the update when matched). velocity_px: smoothed
//   displacement of the matched detections' centres over their timestamp difference.
class SortTracker : public Tracker {
 public:
  static ComponentInfo describe();
  void open(StageContext& ctx) override;
  Tracks update(StageContext& ctx, const Detections& dets, const Frame& frame) override;

  struct Config {
    double iou_threshold = 0.3;
    int min_hits = 3;
    int max_age = 1;
    std::vector<std::string> class_groups = tracking::default_class_groups();
    bool match_class = false;
    bool emit_unmatched = false;
    double velocity_smoothing = 0.5;
  };
  void configure(const Config& c) {
    cfg_ = c;
    groups_ = tracking::ClassGroups(c.class_groups);
  }
  Tracks step(const Detections& dets, const Frame& frame);

 private:
  struct Entry {
    int64_t id = -1;
    cv::KalmanFilter kf;
    tracking::VelocityEstimator velocity;
    tracking::LabelVote vote;
    float score = 0.f;
    int age = 0, hits = 0, hit_streak = 0, misses = 0;
    bool confirmed = false;  // has been emitted as a matched track at least once
    int detection_index = -1, annotation_index = -1;
    unsigned truncated = 0;  // of the last matched detection
    cv::Rect2f box() const;
  };
  Entry make_entry(const Detection& d, int index, double t);
  static void predict(Entry& e);
  Config cfg_;
  tracking::ClassGroups groups_{tracking::default_class_groups()};
  std::vector<Entry> tracks_;
  int64_t next_id_ = 1;
  int64_t frame_count_ = 0;
  bool have_time_ = false;
  double last_time_ = 0.0;
  int64_t last_frame_ = -1;
};

}  // namespace hf
