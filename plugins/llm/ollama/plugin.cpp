// Plugin entry for the ollama LLM provider.
#include <hazardforge/plugin.hpp>

#include "ollama_provider.hpp"

HAZARDFORGE_PLUGIN("ollama", "0.1.0", "Apache-2.0", "LLM provider for a local Ollama server") {
  reg.add<hf::llm::OllamaProvider>();
}
