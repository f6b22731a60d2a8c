// Plugin entry for the realism test sink.
#include "hazardforge/plugin.hpp"
#include "realism_test_sink.hpp"

HAZARDFORGE_PLUGIN("realism_test", "0.1.0", "Apache-2.0",
                   "realism_test: a two-sample classifier test of inserted against real objects, and a contact sheet") {
  reg.add<hf::render::RealismTestSink>();
}
