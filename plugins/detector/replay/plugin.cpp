// Plugin entry for the detection replay (a detector's recorded detections read back).
#include <hazardforge/plugin.hpp>

#include "detection_replay.hpp"

HAZARDFORGE_PLUGIN("detection_replay", "0.1.0", "Apache-2.0",
                   "detector that reads back the detections a detector recorded for the same frames") {
  reg.add<hf::DetectionReplay>();
}
