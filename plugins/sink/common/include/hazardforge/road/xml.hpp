// Small indented XML writer with attribute escaping, shared by the OpenDRIVE and OpenSCENARIO exports.
#pragma once

#include <string>
#include <utility>
#include <vector>

#include "hazardforge/markup.hpp"

namespace hf::road {

using hf::xml_escape;  // the SDK's one escaping rule

// xsd:double text with at most `decimals` decimals (trailing zeros removed); INF/-INF/NaN for non-finite.
std::string xml_num(double v, int decimals = 4);

using XmlAttrs = std::vector<std::pair<std::string, std::string>>;

class XmlWriter {
 public:
  void open(const std::string& tag, const XmlAttrs& attrs = {});
  void empty(const std::string& tag, const XmlAttrs& attrs = {});
  void close();
  void comment(const std::string& text);
  std::string str() const;

 private:
  void line(const std::string& s);
  std::string out_;
  std::vector<std::string> stack_;
};

}  // namespace hf::road
