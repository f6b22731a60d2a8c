// Plugin entry for the evaluation sink.
#include "hazardforge/plugin.hpp"
#include "evaluation_sink.hpp"

HAZARDFORGE_PLUGIN("evaluation", "0.1.0", "Apache-2.0",
                   "Accuracy, confusion matrix and TTC error of risk metrics against ground truth") {
  reg.add<hf::EvaluationSink>();
}
