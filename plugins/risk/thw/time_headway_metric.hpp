// Time headway: how long the ego needs to reach where the object is now.
#pragma once

#include "hazardforge/stage.hpp"

namespace hf {

// Risk metric "thw": THW = d / v_ego per object (s, lower is riskier).
// Ports: states (ObjectStates) [+ frames] -> risk (RiskAssessment), one per frame, stamped with the frame's
// time. Params: min_ego_speed_mps, and the shared threshold / corridor params.
class TimeHeadwayMetric : public RiskMetric {
 public:
  static ComponentInfo describe();
  RiskAssessment assess(StageContext& ctx, const ObjectStates& states, const Frame* frame) override;
};

}  // namespace hf
