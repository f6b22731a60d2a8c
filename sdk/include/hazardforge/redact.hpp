// Credentials never reach files or logs: userinfo and query strings are cut out of every URL shown.
#pragma once

#include "hazardforge/abi.hpp"

#include <string>
#include <string_view>

HF_SDK_BEGIN
namespace hf {

// Every URL in `text` ("scheme://...") with its userinfo ("user:pass@") and its query string ("?key=...")
// replaced by "***": "http://u:p@host:1/v1?key=k" -> "http://***@host:1/v1?***". Text without URLs is
// returned unchanged, so it is safe to apply to whole messages.
std::string redact_urls(std::string_view text);

// redact_urls() applied to every string (keys and values) of a JSON document, e.g. a resolved config.
nlohmann::json redact_json_urls(const nlohmann::json& j);

}  // namespace hf
HF_SDK_END
