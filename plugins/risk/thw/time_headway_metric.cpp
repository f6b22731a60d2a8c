// Time headway d / v_ego: how close the ego follows, whatever the object itself does.
#include "time_headway_metric.hpp"

#include <cmath>

namespace hf {

ComponentInfo TimeHeadwayMetric::describe() {
  ComponentInfo i = RiskMetric::base_info("thw", "time headway d / v_ego (s)");
  i.doc =
      "Per object THW = d / v_ego with d = distance_m. Infinite when the ego speed is at most "
      "min_ego_speed_mps; unknown (null) when the ego speed is unknown.";
  i.params.push_back(ParamSpec::number("min_ego_speed_mps", 0.1)
                         .range(0, 100)
                         .describe("ego speeds at or below this (m/s) give an infinite headway"));
  return i;
}

RiskAssessment TimeHeadwayMetric::assess(StageContext& ctx, const ObjectStates& states, const Frame*) {
  const double eps = ctx.params().get_double("min_ego_speed_mps");
  const std::optional<double>& v = states.ego_speed_mps;
  RiskAssessment r;
  r.stage = "thw";
  r.unit = "s";
  r.lower_is_riskier = true;
  for (const ObjectState& s : states.objects) {
    const double thw = !v ? std::nan("") : *v <= eps ? kInf : s.distance_m / *v;
    r.objects.push_back({s.track_id, thw, false});
  }
  return r;
}

}  // namespace hf
