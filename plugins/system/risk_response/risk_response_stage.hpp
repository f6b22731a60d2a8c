// The risk_response stage: what a graph of stages answers as a system under test.
#pragma once

#include "hazardforge/stage.hpp"

namespace hf::system {

// Stage "risk_response" (kind system).
//  inputs:  detections (Detections), risk (RiskAssessment, a TTC-like metric: lower is riskier).
//  outputs: response (SystemResponse): the detections; the TTC of the object the metric finds most critical
//           (its deciding value); a warning when the metric labels the frame Unsafe; a brake request when
//           that TTC is below brake_below_s.
class RiskResponseStage : public Stage {
 public:
  static ComponentInfo describe();
  void open(StageContext& ctx) override;
  void process(StageContext& ctx, const Inputs& in, Outputs& out) override;

 private:
  double brake_below_ = 0.0;
};

}  // namespace hf::system
