// Plugin entry for the side-by-side (before/after) video sink.
#include "hazardforge/plugin.hpp"
#include "side_by_side_sink.hpp"

HAZARDFORGE_PLUGIN("side_by_side", "0.1.0", "Apache-2.0",
                   "side_by_side: original and augmented frames next to each other as MP4 and PNG stills") {
  reg.add<hf::render::SideBySideSink>();
}
