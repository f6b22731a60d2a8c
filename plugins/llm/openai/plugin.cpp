// Plugin entry for the OpenAI-compatible LLM provider.
#include <hazardforge/plugin.hpp>

#include "openai_provider.hpp"

HAZARDFORGE_PLUGIN("openai", "0.1.0", "Apache-2.0",
                   "LLM provider for OpenAI-compatible chat completion servers") {
  reg.add<hf::llm::OpenAiProvider>();
}
