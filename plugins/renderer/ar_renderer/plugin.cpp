// Plugin entry for the augmented-reality renderer.
#include "ar_renderer.hpp"
#include "hazardforge/plugin.hpp"

HAZARDFORGE_PLUGIN("ar_renderer", "0.1.0", "Apache-2.0",
                   "ar_renderer: composites planned hazards into real video, anchored in the world") {
  reg.add<hf::render::ArRenderer>();
}
