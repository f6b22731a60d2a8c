// Plugin entry for the kalman estimator.
#include "hazardforge/plugin.hpp"
#include "kalman_estimator.hpp"

HAZARDFORGE_PLUGIN("kalman", "0.1.0", "Apache-2.0",
                   "Filtered object states: fused range, Kalman filter, keypoint scale change") {
  reg.add<hf::KalmanEstimator>();
}
