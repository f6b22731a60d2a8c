// Escaping text for XML and HTML: the one implementation every writer of markup (OpenSCENARIO/OpenDRIVE files,
// HTML reports, campaign galleries) uses.
#pragma once

#include <string>

#include "hazardforge/abi.hpp"

HF_SDK_BEGIN
namespace hf {

// &, <, >, " and ' as entities; control characters XML 1.0 does not allow (all below 0x20 except tab, newline
// and carriage return) are dropped. Safe in element text and in quoted attribute values of XML and HTML.
std::string xml_escape(const std::string& text);

}  // namespace hf
HF_SDK_END
