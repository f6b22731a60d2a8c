// TTC from the box's image scale change: for a pinhole camera h ~ 1/Z, so d ln(h)/dt = closing / Z = 1 / TTC.
#include "ttc_scale_metric.hpp"

#include <cmath>

namespace hf {

ComponentInfo TtcScaleMetric::describe() {
  ComponentInfo i =
      RiskMetric::base_info("ttc_scale", "time-to-collision 1 / (d ln h / dt) from box growth (s)");
  i.doc =
      "Per object TTC = 1 / scale_rate, scale_rate = d ln(h)/dt of the box height. Needs no distance, size "
      "prior or ego speed. Infinite when the box does not grow faster than min_scale_rate; unknown (null) "
      "while the track has no scale rate yet.";
  i.params.push_back(ParamSpec::number("min_scale_rate", 0.01)
                         .range(0, 100)
                         .describe("scale rates at or below this (1/s) give an infinite TTC"));
  return i;
}

RiskAssessment TtcScaleMetric::assess(StageContext& ctx, const ObjectStates& states, const Frame*) {
  const double eps = ctx.params().get_double("min_scale_rate");
  RiskAssessment r;
  r.stage = "ttc_scale";
  r.unit = "s";
  r.lower_is_riskier = true;
  for (const ObjectState& s : states.objects) {
    const double ttc = !s.scale_rate ? std::nan("") : *s.scale_rate <= eps ? kInf : 1.0 / *s.scale_rate;
    r.objects.push_back({s.track_id, ttc, false});
  }
  return r;
}

}  // namespace hf
