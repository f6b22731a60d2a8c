// Plugin entry for the monocular estimator.
#include "hazardforge/plugin.hpp"
#include "monocular_estimator.hpp"

HAZARDFORGE_PLUGIN("monocular", "0.1.0", "Apache-2.0",
                   "Monocular distance, lateral offset, velocity and heading of tracked objects") {
  reg.add<hf::MonocularEstimator>();
}
