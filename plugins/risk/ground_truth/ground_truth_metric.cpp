// Ground-truth TTC protocol over annotated boxes (GUIDE section 3), every constant a param.
#include "ground_truth_metric.hpp"

#include <algorithm>
#include <cmath>

namespace hf {

RiskAssessment GroundTruthProtocol::assess(const Annotations& ann, const EgoState& ego,
                                           const std::string& what) const {
  if (!ann.ego_velocity_ego)
    throw Error(what +
                ": the annotations carry no ego velocity (Annotations::ego_velocity_ego); the ground_truth "
                "metric needs it (the source derives it from neighbouring keyframe poses)");
  const cv::Vec3d v_ego = *ann.ego_velocity_ego;
  const EgoPath path = corridor.path_for(ego.speed_mps, ego.yaw_rate);
  RiskAssessment r;
  r.stage = "ground_truth";
  r.unit = "s";
  r.lower_is_riskier = true;
  r.threshold = threshold;
  r.scene_value = kInf;
  for (size_t i = 0; i < ann.objects.size(); ++i) {
    const AnnotatedObject& o = ann.objects[i];
    const bool wanted = std::any_of(category_prefixes.begin(), category_prefixes.end(),
                                    [&](const std::string& p) { return o.category.rfind(p, 0) == 0; });
    if (!wanted) continue;
    const double x = o.center_ego[0], y = o.center_ego[1];
    const double l = o.size_lwh[0], w = o.size_lwh[1];
    ObjectRisk risk;
    risk.track_id = static_cast<int64_t>(i);
    risk.in_path = corridor.contains(x, y, w, path);
    std::optional<cv::Vec3d> v_obj = o.velocity_ego;
    if (!v_obj && static_when_unknown) v_obj = cv::Vec3d(0, 0, 0);
    if (!v_obj) {
      risk.value = std::nan("");
    } else {
      const double closing = -((*v_obj)[0] - v_ego[0]);
      const double gap = x - front_overhang - l / 2.0;
      risk.value = closing > min_closing_mps ? std::max(gap, 0.0) / closing : kInf;
    }
    if (risk.in_path && !std::isnan(risk.value) && risk.value < r.scene_value) {
      r.scene_value = risk.value;
      r.critical_track = risk.track_id;
    }
    r.objects.push_back(risk);
  }
  r.label = r.scene_value < threshold ? SafetyLabel::kUnsafe : SafetyLabel::kSafe;
  return r;
}

std::vector<ParamSpec> GroundTruthProtocol::params(const DatasetParams& d) {
  std::vector<ParamSpec> specs = {ParamSpec::number("threshold", 1.5)
                                      .range(0, 1000)
                                      .describe("Unsafe when the scene TTC is below this (s)")};
  for (ParamSpec& p : Corridor::params(false)) specs.push_back(std::move(p));
  for (ParamSpec& p :
       std::vector<ParamSpec>{ParamSpec::number("front_overhang", d.front_overhang)
                                  .range(-10, 20)
                                  .describe(d.front_overhang_doc),
                              ParamSpec::number("min_closing_mps", 0.1)
                                  .range(0, 100)
                                  .describe("closing speeds at or below this (m/s) give an infinite TTC"),
                              ParamSpec::string_list("categories", d.categories).describe(d.categories_doc),
                              ParamSpec::string("missing_object_velocity", "ignore")
                                  .one_of({"ignore", "static"})
                                  .describe(d.missing_velocity_doc)})
    specs.push_back(std::move(p));
  return specs;
}

GroundTruthProtocol GroundTruthProtocol::from(const Params& p) {
  GroundTruthProtocol g;
  g.category_prefixes = p.get_strings("categories");
  g.corridor = Corridor::from(p);
  g.front_overhang = p.get_double("front_overhang");
  g.min_closing_mps = p.get_double("min_closing_mps");
  g.threshold = p.get_double("threshold");
  g.static_when_unknown = p.get_string("missing_object_velocity") == "static";
  return g;
}

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
