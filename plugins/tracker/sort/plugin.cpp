// Plugin entry for the SORT tracker.
#include <hazardforge/plugin.hpp>

#include "sort_tracker.hpp"

HAZARDFORGE_PLUGIN("sort", "0.1.0", "Apache-2.0",
                   "SORT: Kalman filter + IoU Hungarian multi-object tracker") {
  reg.add<hf::SortTracker>();
}
