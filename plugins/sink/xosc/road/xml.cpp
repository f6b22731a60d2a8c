// Indented XML writer with attribute escaping.
#include "hazardforge/road/xml.hpp"

#include <cmath>
#include <cstdio>

namespace hf::road {

std::string xml_escape(const std::string& text) {
  std::string out;
  out.reserve(text.size());
  for (unsigned char c : text) {
    switch (c) {
      case '&':
        out += "&amp;";
        break;
      case '<':
        out += "&lt;";
        break;
      case '>':
        out += "&gt;";
        break;
      case '"':
        out += "&quot;";
        break;
      case '\'':
        out += "&apos;";
        break;
      default:
        // XML 1.0 allows no control characters but tab, newline and carriage return.
        if (c < 0x20 && c != '\t' && c != '\n' && c != '\r') break;
        out += static_cast<char>(c);
    }
  }
  return out;
}

std::string xml_num(double v, int decimals) {
  if (std::isnan(v)) return "NaN";
  if (std::isinf(v)) return v > 0 ? "INF" : "-INF";
  char buf[64];
  std::snprintf(buf, sizeof buf, "%.*f", decimals, v);
  std::string s = buf;
  if (s.find('.') != std::string::npos) {
    while (s.back() == '0') s.pop_back();
    if (s.back() == '.') s.pop_back();
  }
  if (s == "-0") s = "0";
  return s;
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
