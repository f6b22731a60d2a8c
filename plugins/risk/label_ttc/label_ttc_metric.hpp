// Risk metric "label_ttc": reference TTC of every labelled track from its 3D positions (KITTI tracking
// labels).
#pragma once

#include "hazardforge/risk/ground_truth_protocol.hpp"
#include "hazardforge/stage.hpp"

namespace hf {

// Risk metric "label_ttc" (kind risk_metric). The ground-truth protocol of docs/evaluation.md applied to
// labels whose motion is relative to the camera: KITTI tracking labels carry no ego motion, so the `kitti`
// source gives each label's camera-relative velocity (central difference of the same track's 3D positions)
// in the ego frame of camera 2 (x along the optical axis, y left, origin on the ground below the camera).
// Per label of one of `categories`: in path when x > 0 and |y| < corridor_half_width + corridor_margin +
// w/2 (corridor_path straight; ego_path follows Frame.ego's yaw rate, which KITTI tracking frames lack); gap
// = x - front_overhang - l/2 (front_overhang 0: from the camera, as ttc_paper's default distance); closing =
// -v_rel.x (along the camera's forward axis); TTC = max(gap, 0) / closing when closing > min_closing_mps,
// else infinite; unknown (NaN, not counted) for a track labelled in one frame only. Scene TTC = minimum over
// in-path labels; Unsafe below threshold. ObjectRisk.track_id = the KITTI track id. Ports: frames (Frame with
// annotations) [+ states, optional and unused] -> risk (RiskAssessment), one per frame, stamped with the
// frame's time. Params: threshold, corridor_half_width, corridor_margin, corridor_path, front_overhang,
// min_closing_mps, categories,
//   missing_object_velocity.
class LabelTtcMetric : public Stage {
 public:
  static ComponentInfo describe();
  void open(StageContext& ctx) override;
  void process(StageContext& ctx, const Inputs& in, Outputs& out) override;

 private:
  GroundTruthProtocol protocol_;
};

}  // namespace hf
