// JSON object extraction from free-form model replies (bare JSON, prose around it, ``` fences).
#include "hazardforge/llm/json.hpp"

#include <algorithm>
#include <optional>
#include <string_view>

#include <hazardforge/error.hpp>

namespace hf::llm {

namespace {

std::string_view trim(std::string_view s) {
  const char* ws = " \t\r\n";
  size_t b = s.find_first_not_of(ws);
  if (b == std::string_view::npos) return {};
  size_t e = s.find_last_not_of(ws);
  return s.substr(b, e - b + 1);
}

// nlohmann's messages start with "[json.exception.parse_error.101] "; the rest is what a reader needs.
std::string parse_message(const Json::exception& e) {
  std::string what = e.what();
  if (auto p = what.find("] "); p != std::string::npos) what = what.substr(p + 2);
  return what;
}

// Position one past the '}' closing the object opened at `open`, or npos if the text ends first.
size_t matching_brace(std::string_view s, size_t open) {
  int depth = 0;
  bool in_string = false;
  for (size_t i = open; i < s.size(); ++i) {
    char c = s[i];
    if (in_string) {
      if (c == '\\')
        ++i;
      else if (c == '"')
        in_string = false;
      continue;
    }
    if (c == '"')
      in_string = true;
    else if (c == '{')
      ++depth;
    else if (c == '}' && --depth == 0)
      return i + 1;
  }
  return std::string_view::npos;
}

struct Attempt {
  std::optional<Json> object;
  std::string error;  // first failure worth reporting
};

void try_candidate(std::string_view text, Attempt& a) {
  try {
    Json j = Json::parse(text.begin(), text.end());
    if (j.is_object())
      a.object = std::move(j);
    else if (a.error.empty() && j.is_array())
      a.error = "reply is a JSON array, not an object";
  } catch (const Json::exception& e) {
    // Not only parse errors: a number too large for a double ("1e11011") is an out_of_range error.
    if (a.error.empty()) a.error = "reply is not valid JSON: " + parse_message(e);
  }
}

// Objects inside the text, outermost first, each tried in turn.
void scan_objects(std::string_view text, Attempt& a) {
  constexpr int kMaxCandidates = 64;
  int tried = 0;
  for (size_t p = text.find('{'); p != std::string_view::npos && tried < kMaxCandidates;
       p = text.find('{', p + 1), ++tried) {
    size_t end = matching_brace(text, p);
    if (end == std::string_view::npos) {
      if (a.error.empty())
        a.error =
            "reply JSON object is cut off: the '{' at character " + std::to_string(p) + " is never closed";
      return;
    }
    try_candidate(text.substr(p, end - p), a);
    if (a.object) return;
  }
}

}  // namespace

int json_nesting_depth(std::string_view text) {
  int depth = 0, deepest = 0;
  bool in_string = false;
  for (size_t i = 0; i < text.size(); ++i) {
    const char c = text[i];
    if (in_string) {
      if (c == '\\')
        ++i;
      else if (c == '"')
        in_string = false;
    } else if (c == '"') {
      in_string = true;
    } else if (c == '{' || c == '[') {
      deepest = std::max(deepest, ++depth);
    } else if ((c == '}' || c == ']') && depth > 0) {
      --depth;
    }
  }
  return deepest;
}

Json extract_json_object(const std::string& reply) {
  std::string_view text = trim(reply);
  if (text.empty()) throw Error("reply is empty");
  if (const int depth = json_nesting_depth(text); depth > kMaxJsonDepth)
    throw Error("reply nests JSON " + std::to_string(depth) + " levels deep (at most " +
                std::to_string(kMaxJsonDepth) + ")");
  Attempt a;
  Json whole = Json::parse(text.begin(), text.end(), nullptr, /*allow_exceptions=*/false);
  if (whole.is_object()) return whole;
  if (whole.is_array()) throw Error("reply is a JSON array, not an object");

  // ``` fences (with or without a language tag) are how chat models usually wrap code.
  for (size_t open = text.find("```"); open != std::string_view::npos && !a.object;) {
    size_t body = text.find('\n', open);
    if (body == std::string_view::npos) break;
    size_t close = text.find("```", body);
    std::string_view inside =
        trim(text.substr(body + 1, close == std::string_view::npos ? text.npos : close - body - 1));
    if (!inside.empty() && inside.front() == '{')
      scan_objects(inside, a);
    else if (!inside.empty() && inside.front() == '[')
      try_candidate(inside, a);
    if (close == std::string_view::npos) break;
    open = text.find("```", close + 3);
  }
  if (!a.object) scan_objects(text, a);
  if (a.object) return *a.object;
  if (!a.error.empty()) throw Error(a.error);
  constexpr size_t kShown = 60;
  std::string start(text.substr(0, kShown));
  throw Error("reply contains no JSON object (it begins \"" + start +
              (text.size() > kShown ? "...\")" : "\")"));
}

}  // namespace hf::llm
