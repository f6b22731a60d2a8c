// Plugin entry for the llm_hazard generator.
#include <hazardforge/plugin.hpp>

#include "llm_hazard_stage.hpp"

HAZARDFORGE_PLUGIN("llm_hazard", "0.1.0", "Apache-2.0", "LLM-guided hazard generation for safe scenes") {
  reg.add<hf::llm_hazard::LlmHazardGenerator>();
}
