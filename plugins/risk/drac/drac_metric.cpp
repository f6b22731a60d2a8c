// DRAC = closing^2 / (2 d): the constant deceleration the ego needs to stop closing in before reaching the
// object.
#include "drac_metric.hpp"

#include <cmath>

#include "hazardforge/risk/closing_speed.hpp"

namespace hf {

ComponentInfo DracMetric::describe() {
  ComponentInfo i =
      RiskMetric::base_info("drac", "deceleration rate to avoid collision closing^2 / (2 d) (m/s^2)");
  i.doc =
      "Per object DRAC = closing^2 / (2 d), closing = v_ego - v_obj cos psi (the TTC denominator), d = "
      "distance_m. Zero when closing is at most min_closing_mps; infinite at d <= 0; unknown (null) while "
      "the object has no velocity. Higher is riskier: Unsafe above the threshold (3.35 m/s^2 by default).";
  for (ParamSpec& p : i.params)
    if (p.name == "threshold") p.default_value = 3.35;
  i.params.push_back(ParamSpec::number("min_closing_mps", 0.1)
                         .range(0, 100)
                         .describe("closing speeds at or below this (m/s) need no deceleration (DRAC 0)"));
  i.params.push_back(
      ParamSpec::boolean("relative_fallback", true)
          .describe("without an ego speed, use the relative closing speed -v_rel.x; false = the "
                    "DRAC is unknown"));
  return i;
}

RiskAssessment DracMetric::assess(StageContext& ctx, const ObjectStates& states, const Frame*) {
  const double eps = ctx.params().get_double("min_closing_mps");
  const bool fallback = ctx.params().get_bool("relative_fallback");
  RiskAssessment r;
  r.stage = "drac";
  r.unit = "m/s2";
  r.lower_is_riskier = false;
  for (const ObjectState& s : states.objects) {
    const auto closing = risk::closing_speed(s, states.ego_speed_mps, fallback);
    double drac = std::nan("");
    if (closing)
      drac = *closing <= eps ? 0.0 : s.distance_m <= 0 ? kInf : (*closing) * (*closing) / (2 * s.distance_m);
    r.objects.push_back({s.track_id, drac, false});
  }
  return r;
}

}  // namespace hf
