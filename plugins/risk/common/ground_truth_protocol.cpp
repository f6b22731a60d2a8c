// The ground-truth TTC protocol over annotated boxes (GUIDE section 3), every constant a param.
#include "hazardforge/risk/ground_truth_protocol.hpp"

#include <algorithm>
#include <cmath>

#include "hazardforge/error.hpp"

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

}  // namespace hf
