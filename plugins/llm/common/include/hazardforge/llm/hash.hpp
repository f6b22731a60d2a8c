// SHA-256 of prompts and replies, so call records can be compared across runs without diffing the text.
#pragma once

#include <string>
#include <string_view>

namespace hf::llm {

// Lower-case hex digest (64 characters), computed with OpenSSL.
std::string sha256_hex(std::string_view data);

}  // namespace hf::llm
