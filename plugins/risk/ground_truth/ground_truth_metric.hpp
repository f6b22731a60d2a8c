// Reference TTC and Safe/Unsafe label of a frame, computed from the dataset's annotated boxes and ego motion.
#pragma once

#include "hazardforge/risk/ground_truth_protocol.hpp"
#include "hazardforge/stage.hpp"

namespace hf {

// Risk metric "ground_truth" (kind risk_metric, not a RiskMetric subclass: its objects are annotations, not
// tracks). Per annotated vehicle.* / human.* object: relative velocity = v_obj - v_ego (ego axes), in path
// when x > 0 and |y| < half_width + margin + w/2 (corridor_path straight, the default; ego_path measures s
// and d along the arc of the frame's ego speed and yaw rate instead of x and y), gap = x - front_overhang -
// l/2, closing = -v_rel.x, TTC = max(gap, 0) / closing when closing > min_closing_mps else infinite; scene
// TTC = min over in-path objects; Unsafe below threshold. ObjectRisk.track_id is the annotation's index in
// Frame::annotations. Ports: frames (Frame with annotations) [+ states, optional and unused, so the node has
// a risk metric's shape]
// -> risk (RiskAssessment), one per frame, stamped with the frame's time.
// Params: threshold, corridor_half_width, corridor_margin, corridor_path, front_overhang, min_closing_mps,
// categories, missing_object_velocity.
class GroundTruthRiskMetric : public Stage {
 public:
  static ComponentInfo describe();
  void open(StageContext& ctx) override;
  void process(StageContext& ctx, const Inputs& in, Outputs& out) override;

 private:
  GroundTruthProtocol protocol_;
};

}  // namespace hf
