// Plugin entry: the xosc (OpenSCENARIO 1.2) sink.
#include "hazardforge/plugin.hpp"
#include "xosc_sink.hpp"

HAZARDFORGE_PLUGIN("xosc", "0.2.0", "Apache-2.0",
                   "exports planned hazards as ASAM OpenSCENARIO 1.2 scenarios on OpenDRIVE 1.6 roads") {
  reg.add<hf::XoscSink>();
}
