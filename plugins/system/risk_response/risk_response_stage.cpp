// RiskResponseStage: a risk metric's verdict read as a warning system's answer.
#include "risk_response_stage.hpp"

#include <cmath>

#include "hazardforge/error.hpp"

namespace hf::system {

ComponentInfo RiskResponseStage::describe() {
  ComponentInfo i;
  i.name = "risk_response";
  i.kind = kind::kSystem;
  i.summary = "a graph's detections and TTC risk read as a system under test's answer (warning, brake)";
  i.doc =
      "Turns an assessment chain into a warning system for hazardforge test: the answer per frame holds the "
      "chain's detections, its TTC (the metric's deciding value over the objects in the ego's path), a "
      "warning when the metric labels the frame Unsafe (its own threshold), and a brake request when that "
      "TTC "
      "is below brake_below_s. The metric must be TTC-like (lower is riskier).";
  i.inputs = {port<Detections>("detections", "the chain's detections"),
              port<RiskAssessment>("risk", "the chain's TTC-like risk")};
  i.outputs = {port<SystemResponse>("response", "the chain's answer: detections, TTC, warning, brake")};
  i.params = {ParamSpec::number("brake_below_s", 0.0)
                  .range(0.0, 10.0)
                  .describe("request braking when the TTC is below this (0: never)")};
  return i;
}

void RiskResponseStage::open(StageContext& ctx) {
  brake_below_ = ctx.params().get_double("brake_below_s");
}

void RiskResponseStage::process(StageContext& /*ctx*/, const Inputs& in, Outputs& out) {
  const Detections& d = in.require<Detections>("detections");
  const RiskAssessment& r = in.require<RiskAssessment>("risk");
  if (!r.lower_is_riskier)
    throw Error("risk metric '" + r.metric + "' (" + r.stage +
                ") is not TTC-like (higher is riskier): a system's TTC cannot be read from it");
  SystemResponse s;
  s.frame_index = d.frame_index;
  s.detections = d.items;
  const double v = deciding_value(r);
  if (std::isfinite(v)) s.ttc_s = v;
  s.warning = r.label == SafetyLabel::kUnsafe;
  s.brake = s.ttc_s && brake_below_ > 0 && *s.ttc_s < brake_below_;
  out.emit("response", std::move(s));
}

}  // namespace hf::system
