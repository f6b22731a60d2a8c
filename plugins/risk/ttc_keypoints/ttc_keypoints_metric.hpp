// Time-to-collision from the scale change of keypoints tracked inside each box (Mobileye-style camera TTC).
#pragma once

#include <deque>
#include <map>

#include <hazardforge/estimation/keypoint_scale.hpp>
#include <hazardforge/stage.hpp>

namespace hf {

// Risk metric "ttc_keypoints" (s, lower is riskier).
// Ports: states (ObjectStates: boxes by track) + frames (Frame: the image, required) -> risk
// (RiskAssessment),
//   one per frame, stamped with the frame's time.
// Per matched box, corners inside it are tracked from the previous frame (KLT, forward-backward checked) and
// the median ratio r of pairwise distances is the scale change (hazardforge/estimation/keypoint_scale.hpp).
// Over the pairs of the last window_s seconds, R = product of r and T = their total time; TTC = T / (R - 1)
// (for one frame pair the classic -dt / (1 - r)), exact for a constant closing speed. Interval from the
// ratios' standard errors. Needs no distance, class prior or ego speed, and is not misled by a box cut by the
// image border or a jittering box edge.
// Params: window_s, min_scale_rate, max_points, and the shared threshold / corridor params.
class TtcKeypointsMetric : public RiskMetric {
 public:
  static ComponentInfo describe();
  void open(StageContext& ctx) override;
  RiskAssessment assess(StageContext& ctx, const ObjectStates& states, const Frame* frame) override;

 private:
  struct Pair {
    double t = 0.0, dt = 0.0, log_ratio = 0.0, var = 0.0;
  };
  estimation::KeypointScaleTracker tracker_;
  std::map<int64_t, std::deque<Pair>> history_;
  double window_s_ = 0.5;
  double min_rate_ = 0.01;
};

}  // namespace hf
