// Reference TTC and Safe/Unsafe label of a frame, computed from the dataset's annotated boxes and ego motion.
#pragma once

#include <string>
#include <vector>

#include "hazardforge/corridor.hpp"
#include "hazardforge/stage.hpp"

namespace hf {

// The ground-truth protocol's constants (docs/evaluation.md), one param each.
struct GroundTruthProtocol {
  std::vector<std::string> category_prefixes{"vehicle.", "human."};
  // The protocol's corridor is straight ahead (the paper's labels); corridor_path: ego_path bends it along
  // the ego's recorded yaw rate.
  Corridor corridor{1.0, 0.5, false};
  double front_overhang = 3.4;  // ego x of the front bumper (rear axle to bumper), m
  double min_closing_mps = 0.1;
  double threshold = 1.5;
  bool static_when_unknown = false;  // objects without a velocity: false = ignored, true = treated as parked

  // Fills objects, scene value, critical object and label; `ego` gives the speed and yaw rate the corridor
  // follows. Throws hf::Error naming `what` when the ego velocity is missing.
  RiskAssessment assess(const Annotations& ann, const EgoState& ego, const std::string& what) const;

  // The protocol's params, shared by every metric built on it; the dataset-specific ones (the bumper offset,
  // the category names and what an object without a velocity means there) come with their own default and
  // doc.
  struct DatasetParams {
    double front_overhang;
    std::string front_overhang_doc;
    std::vector<std::string> categories;
    std::string categories_doc;
    std::string missing_velocity_doc;
  };
  static std::vector<ParamSpec> params(const DatasetParams& d);
  static GroundTruthProtocol from(const Params& p);
};

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
