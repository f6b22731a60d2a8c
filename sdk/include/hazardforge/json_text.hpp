// JSON to text without throwing on invalid UTF-8: the one way files, logs and messages serialise JSON.
#pragma once

#include "hazardforge/abi.hpp"

#include <string>

HF_SDK_BEGIN
namespace hf {

// Invalid UTF-8 becomes U+FFFD instead of a json type_error: model replies, dataset descriptions, paths,
// --set values and error texts are not guaranteed to be UTF-8, and losing a record or a manifest over one
// byte hides the real cause.
inline std::string json_text(const nlohmann::json& j, int indent = -1) {
  return j.dump(indent, ' ', false, nlohmann::json::error_handler_t::replace);
}

}  // namespace hf
HF_SDK_END
