// URL redaction: the one place that decides what of a URL may be shown.
#include "hazardforge/redact.hpp"

#include <cctype>

namespace hf {

namespace {

bool url_end(char c) {
  return std::isspace(static_cast<unsigned char>(c)) || c == '"' || c == '\'' || c == '<' || c == '>' ||
         c == '`';
}

bool scheme_char(char c) {
  return std::isalnum(static_cast<unsigned char>(c)) || c == '+' || c == '-' || c == '.';
}

}  // namespace

std::string redact_urls(std::string_view text) {
  std::string out;
  out.reserve(text.size());
  size_t pos = 0;
  while (true) {
    const size_t sep = text.find("://", pos);
    if (sep == std::string_view::npos) break;
    size_t s = sep;
    while (s > pos && scheme_char(text[s - 1])) --s;
    if (s == sep || !std::isalpha(static_cast<unsigned char>(text[s]))) {
      out.append(text.substr(pos, sep + 3 - pos));
      pos = sep + 3;
      continue;
    }
    size_t end = sep + 3;
    while (end < text.size() && !url_end(text[end])) ++end;
    out.append(text.substr(pos, sep + 3 - pos));
    const std::string_view rest = text.substr(sep + 3, end - sep - 3);
    size_t auth_end = rest.find_first_of("/?#");
    if (auth_end == std::string_view::npos) auth_end = rest.size();
    const std::string_view authority = rest.substr(0, auth_end);
    if (const size_t at = authority.rfind('@'); at != std::string_view::npos) {
      out += "***";
      out.append(authority.substr(at));
    } else {
      out.append(authority);
    }
    const std::string_view tail = rest.substr(auth_end);
    if (const size_t q = tail.find('?'); q != std::string_view::npos) {
      out.append(tail.substr(0, q + 1));
      out += "***";
      if (const size_t h = tail.find('#', q); h != std::string_view::npos) out.append(tail.substr(h));
    } else {
      out.append(tail);
    }
    pos = end;
  }
  out.append(text.substr(pos));
  return out;
}

nlohmann::json redact_json_urls(const nlohmann::json& j) {
  if (j.is_string()) return redact_urls(std::string_view(j.get_ref<const std::string&>()));
  if (j.is_array()) {
    nlohmann::json a = nlohmann::json::array();
    for (const auto& v : j) a.push_back(redact_json_urls(v));
    return a;
  }
  if (j.is_object()) {
    nlohmann::json o = nlohmann::json::object();
    for (auto it = j.begin(); it != j.end(); ++it)
      o[redact_urls(std::string_view(it.key()))] = redact_json_urls(it.value());
    return o;
  }
  return j;
}

}  // namespace hf
