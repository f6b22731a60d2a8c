// Indented XML writer with attribute escaping.
#include "hazardforge/road/xml.hpp"

#include <cmath>

#include "hazardforge/number_text.hpp"

namespace hf::road {

std::string xml_num(double v, int decimals) {
  // XML Schema's spelling of the non-finite doubles; finite ones take the project's one number format.
  if (std::isnan(v)) return "NaN";
  if (std::isinf(v)) return v > 0 ? "INF" : "-INF";
  return num_text(v, decimals);
}

void XmlWriter::open(const std::string& tag, const XmlAttrs& attrs) {
  std::string s = "<" + tag;
  for (const auto& [k, v] : attrs) s += " " + k + "=\"" + xml_escape(v) + "\"";
  line(s + ">");
  stack_.push_back(tag);
}

void XmlWriter::empty(const std::string& tag, const XmlAttrs& attrs) {
  std::string s = "<" + tag;
  for (const auto& [k, v] : attrs) s += " " + k + "=\"" + xml_escape(v) + "\"";
  line(s + "/>");
}

void XmlWriter::close() {
  const std::string tag = stack_.back();
  stack_.pop_back();
  line("</" + tag + ">");
}

void XmlWriter::comment(const std::string& text) {
  std::string safe;
  for (char c : xml_escape(text)) safe += (c == '-' && !safe.empty() && safe.back() == '-') ? ' ' : c;
  line("<!-- " + safe + " -->");
}

std::string XmlWriter::str() const {
  return "<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n" + out_;
}

void XmlWriter::line(const std::string& s) {
  out_ += std::string(2 * stack_.size(), ' ') + s + "\n";
}

}  // namespace hf::road
