// Plugin entry for the ground-truth risk metric.
#include "hazardforge/plugin.hpp"
#include "ground_truth_metric.hpp"

HAZARDFORGE_PLUGIN("ground_truth_risk", "0.1.0", "Apache-2.0",
                   "Reference Safe/Unsafe labels and TTC from dataset annotations") {
  reg.add<hf::GroundTruthRiskMetric>();
}
