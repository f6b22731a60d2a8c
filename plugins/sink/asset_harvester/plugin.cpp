// Plugin entry for the asset harvester sink.
#include "asset_harvester.hpp"
#include "hazardforge/plugin.hpp"

HAZARDFORGE_PLUGIN("asset_harvester", "0.1.0", "Apache-2.0",
                   "asset_harvester: cuts annotated real objects into appearance assets for ar_renderer") {
  reg.add<hf::render::AssetHarvester>();
}
