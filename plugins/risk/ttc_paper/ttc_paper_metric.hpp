// The paper's time-to-collision metric.
#pragma once

#include "hazardforge/stage.hpp"

namespace hf {

// Risk metric "ttc_paper": TTC = d / (v_ego - v_obj cos psi) per object (s, lower is riskier).
// Ports: states (ObjectStates) [+ frames] -> risk (RiskAssessment), one per frame, stamped with the frame's
// time. Params: min_closing_mps, relative_fallback, and the shared threshold / corridor params.
class TtcPaperMetric : public RiskMetric {
 public:
  static ComponentInfo describe();
  RiskAssessment assess(StageContext& ctx, const ObjectStates& states, const Frame* frame) override;
};

}  // namespace hf
