// The paper's TTC: d / (v_ego - v_obj cos psi), infinite when the object recedes or keeps pace.
#include "ttc_paper_metric.hpp"

#include <cmath>

#include "hazardforge/risk/closing_speed.hpp"

namespace hf {

ComponentInfo TtcPaperMetric::describe() {
  ComponentInfo i = RiskMetric::base_info("ttc_paper", "time-to-collision d / (v_ego - v_obj cos psi) (s)");
  i.doc =
      "Per object TTC = d / (v_ego - v_obj cos psi) with d = distance_m. Infinite when the denominator is at "
      "most min_closing_mps (receding or equal speed); unknown (null, ignored by the scene value) while the "
      "object has no velocity yet. States with a covariance (estimator kalman) also give the TTC's ~90 % "
      "interval (low, high), used by the unsafe_when rule.";
  i.params.push_back(ParamSpec::number("min_closing_mps", 0.1)
                         .range(0, 100)
                         .describe("denominators at or below this (m/s) give an infinite TTC"));
  i.params.push_back(ParamSpec::boolean("relative_fallback", true)
                         .describe("without an ego speed, use the relative closing speed -v_rel.x as the "
                                   "denominator; false = the TTC is unknown"));
  return i;
}

RiskAssessment TtcPaperMetric::assess(StageContext& ctx, const ObjectStates& states, const Frame*) {
  const double eps = ctx.params().get_double("min_closing_mps");
  const bool fallback = ctx.params().get_bool("relative_fallback");
  RiskAssessment r;
  r.stage = "ttc_paper";
  r.unit = "s";
  r.lower_is_riskier = true;
  for (const ObjectState& s : states.objects) {
    const auto closing = risk::closing_speed(s, states.ego_speed_mps, fallback);
    const double ttc = !closing ? std::nan("") : *closing <= eps ? kInf : s.distance_m / *closing;
    ObjectRisk o{s.track_id, ttc, false};
    // A filtered state carries its covariance: the TTC gets an interval (the value stays the paper's).
    if (closing)
      if (const auto iv = risk::ttc_interval(s, s.distance_m, *closing)) {
        o.low = iv->low;
        o.high = iv->high;
      }
    r.objects.push_back(o);
  }
  return r;
}

}  // namespace hf
