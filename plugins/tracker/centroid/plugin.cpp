// Plugin entry for the nearest-centroid tracker.
#include <hazardforge/plugin.hpp>

#include "centroid_tracker.hpp"

HAZARDFORGE_PLUGIN("centroid", "0.1.0", "Apache-2.0", "nearest-centroid multi-object tracker") {
  reg.add<hf::CentroidTracker>();
}
