// Plugin entry for the offline (serverless) LLM provider.
#include <hazardforge/plugin.hpp>

#include "offline_planner.hpp"

HAZARDFORGE_PLUGIN("offline", "0.1.0", "Apache-2.0",
                   "Deterministic offline hazard planner speaking the LLM provider interface") {
  reg.add<hf::llm::OfflinePlanner>();
}
