// Finds the JSON object in a model's reply: bare, wrapped in prose, or inside ``` fences. Never evaluates it.
#pragma once

#include <string>

#include <hazardforge/error.hpp>
#include <hazardforge/types.hpp>

namespace hf::llm {

// The first JSON object in `reply`. Throws hf::Error with one sentence a model can act on when retried:
// "reply is empty", "reply contains no JSON object", "reply is not valid JSON: ...", "reply JSON object is
// cut off: ..." or "reply is a JSON array, not an object".
Json extract_json_object(const std::string& reply);

}  // namespace hf::llm
