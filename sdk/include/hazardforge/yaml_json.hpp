// YAML text to JSON with the source position of every value, so errors can point at file:line:col.
#pragma once

#include <map>
#include <string>

#include "hazardforge/abi.hpp"
#include "hazardforge/error.hpp"
#include "hazardforge/params.hpp"

HF_SDK_BEGIN
namespace hf {

// Positions keyed by JSON pointer ("/nodes/2/params/conf"); a mapping key's own position is under
// pointer + "#key".
using LocationMap = std::map<std::string, SourceLocation>;

struct YamlDocument {
  Json value;
  LocationMap locations;
  SourceLocation at(const std::string& pointer) const;  // nearest known ancestor's location
};

// Scalars become bool / integer / double / string the way YAML 1.2 core schema reads them; "~"/null -> null.
// Throws hf::Error "file:line:col: error: ..." on a YAML syntax error, and when aliases expand to more than
// 100,000 values or 10 MB (nested aliases, "billion laughs").

YamlDocument parse_yaml(const std::string& text, const std::string& file_name);
// A file larger than kMaxYamlFileBytes is refused ("PATH: error: larger than ...") before it is all read.
inline constexpr size_t kMaxYamlFileBytes = 64 * 1024 * 1024;
YamlDocument load_yaml_file(const std::string& path);

}  // namespace hf
HF_SDK_END
