// Time-to-collision from the image scale change of the box.
#pragma once

#include "hazardforge/stage.hpp"

namespace hf {

// Risk metric "ttc_scale": TTC = 1 / scale_rate, scale_rate = d ln(h) / dt (s, lower is riskier).
// Ports: states (ObjectStates) [+ frames] -> risk (RiskAssessment), one per frame, stamped with the frame's
// time. Params: min_scale_rate, and the shared threshold / corridor params.
class TtcScaleMetric : public RiskMetric {
 public:
  static ComponentInfo describe();
  RiskAssessment assess(StageContext& ctx, const ObjectStates& states, const Frame* frame) override;
};

}  // namespace hf
