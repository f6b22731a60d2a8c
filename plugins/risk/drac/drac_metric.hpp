// Deceleration rate to avoid a collision.
#pragma once

#include "hazardforge/stage.hpp"

namespace hf {

// Risk metric "drac": DRAC = closing^2 / (2 d) per object (m/s^2, higher is riskier; Unsafe above the
// threshold, default 3.35 m/s^2).
// Ports: states (ObjectStates) [+ frames] -> risk (RiskAssessment), one per frame, stamped with the frame's
// time. Params: min_closing_mps, relative_fallback, and the shared threshold / corridor params.
class DracMetric : public RiskMetric {
 public:
  static ComponentInfo describe();
  RiskAssessment assess(StageContext& ctx, const ObjectStates& states, const Frame* frame) override;
};

}  // namespace hf
