// Plugin entry: the KITTI dataset source.
#include "hazardforge/plugin.hpp"
#include "kitti_source.hpp"

HAZARDFORGE_PLUGIN("kitti", "0.1.0", "Apache-2.0", "KITTI tracking sequences and raw image folders") {
  reg.add<hf::source::KittiSource>();
}
