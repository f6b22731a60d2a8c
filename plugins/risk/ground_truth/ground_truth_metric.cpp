// Ground-truth TTC protocol over annotated boxes (GUIDE section 3), every constant a param.
#include "ground_truth_metric.hpp"

#include <algorithm>
#include <cmath>

namespace hf {

ComponentInfo GroundTruthRiskMetric::describe() {
  ComponentInfo i;
  i.name = "ground_truth";
  i.kind = kind::kRiskMetric;
  i.summary = "reference TTC and Safe/Unsafe label from dataset annotations (boxes, velocities, ego motion)";
  i.doc =
      "Implements the ground-truth protocol of docs/evaluation.md on Frame::annotations: objects whose "
      "category starts with one of `categories`; relative velocity = v_obj - v_ego in ego axes; in path when "
      "x > 0 and |y| < corridor_half_width + corridor_margin + w/2 (corridor_path straight, the protocol; "
      "ego_path: "
      "along the arc of the frame's ego speed and yaw rate, arc length s > 0 and offset |d| below the same "
      "bound); gap = x - front_overhang - l/2; closing "
      "= "
      "-v_rel.x; TTC = max(gap, 0) / closing when closing > min_closing_mps, else infinite; scene TTC = min "
      "over in-path objects; Unsafe when below threshold. ObjectRisk.track_id = annotation index. One "
      "assessment per frame, stamped with the frame's time.";
  i.inputs = {
      port<Frame>("frames", "frames carrying dataset annotations with ego and object velocities"),
      optional(port<ObjectStates>("states", "unused; lets the node stand where a risk metric is expected"))};
  i.outputs = {port<RiskAssessment>("risk", "per-annotation TTC, scene TTC and the reference label")};
  i.params = GroundTruthProtocol::params(
      {3.4,
       "rear axle (ego origin) to front bumper (m); gap = x - front_overhang - l/2",
       {"vehicle.", "human."},
       "category prefixes of the objects that count (nuScenes category names)",
       "objects whose velocity cannot be derived (a single annotation): ignore = unknown TTC, not counted "
       "(as the "
       "devkit's NaN); static = treated as not moving"});
  return i;
}

void GroundTruthRiskMetric::open(StageContext& ctx) {
  protocol_ = GroundTruthProtocol::from(ctx.params());
}

void GroundTruthRiskMetric::process(StageContext& ctx, const Inputs& in, Outputs& out) {
  const Frame& f = in.require<Frame>("frames");
  const std::string what =
      "frame " + std::to_string(f.index) + (f.source_id.empty() ? "" : " (" + f.source_id + ")");
  if (!f.annotations)
    throw Error(what +
                ": no annotations; the ground_truth metric needs a source that carries them (e.g. nuscenes)");
  RiskAssessment r = protocol_.assess(*f.annotations, f.ego, what);
  r.frame_index = f.index;
  r.metric = ctx.node_id();
  out.emit("risk", std::move(r));
}

}  // namespace hf
