// Finds the JSON object in a model's reply: bare, wrapped in prose, or inside ``` fences. Never evaluates it.
#pragma once

#include <string>
#include <string_view>

#include <hazardforge/error.hpp>
#include <hazardforge/types.hpp>

namespace hf::llm {

// JSON nesting deeper than this is refused before parsing: dumping and validating JSON recurse, so a reply
// nested 100k levels deep would overflow the stack. A hazard spec needs 2 levels.
inline constexpr int kMaxJsonDepth = 64;

// Deepest nesting of [ and { in `text`, ignoring brackets inside JSON strings.
int json_nesting_depth(std::string_view text);

// The first JSON object in `reply`. Throws hf::Error with one sentence a model can act on when retried:
// "reply is empty", "reply nests JSON N levels deep (at most 64)", "reply contains no JSON object", "reply is
// not valid JSON: ...", "reply JSON object is cut off: ..." or "reply is a JSON array, not an object".
Json extract_json_object(const std::string& reply);

}  // namespace hf::llm
