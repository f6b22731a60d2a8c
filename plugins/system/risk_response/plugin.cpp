// Plugin entry for the risk_response stage.
#include "hazardforge/plugin.hpp"
#include "risk_response_stage.hpp"

HAZARDFORGE_PLUGIN("risk_response", "0.1.0", "Apache-2.0",
                   "risk_response: a graph's detections and risk as a system under test's answer") {
  reg.add<hf::system::RiskResponseStage>();
}
