// Plugin entry for the ground-truth detector (annotations projected into the image).
#include <hazardforge/plugin.hpp>

#include "ground_truth_detector.hpp"

HAZARDFORGE_PLUGIN("ground_truth_detector", "0.1.0", "Apache-2.0",
                   "detector that projects dataset 3D annotations into image boxes") {
  reg.add<hf::GroundTruthDetector>();
}
