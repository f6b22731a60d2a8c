// Plugin entry for the system_responses sink.
#include "hazardforge/plugin.hpp"
#include "system_responses_sink.hpp"

HAZARDFORGE_PLUGIN("system_responses", "0.1.0", "Apache-2.0",
                   "system_responses: a system under test's answers as JSON lines") {
  reg.add<hf::sinks::SystemResponsesSink>();
}
