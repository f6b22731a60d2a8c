// {{placeholder}} rendering for the editable prompt files.
#include "prompt.hpp"

#include <algorithm>
#include <fstream>
#include <sstream>

#include <hazardforge/error.hpp>

namespace hf::llm_hazard {

namespace {

// Comments document the template for its editors; the model should not read them.
std::string strip_comments(const std::string& text) {
  std::string out;
  size_t pos = 0;
  while (true) {
    size_t b = text.find("<!--", pos);
    if (b == std::string::npos) break;
    size_t e = text.find("-->", b);
    if (e == std::string::npos) break;
    out.append(text, pos, b - pos);
    pos = e + 3;
    // Drop the line break after a comment that stood on its own lines.
    if (pos < text.size() && text[pos] == '\n' && (b == 0 || text[b - 1] == '\n')) ++pos;
  }
  out.append(text, pos);
  return out;
}

// Same text with comment bodies blanked (newlines kept), so placeholder checks skip them and keep line
// numbers.
std::string blank_comments(const std::string& text) {
  std::string out = text;
  for (size_t b = out.find("<!--"); b != std::string::npos; b = out.find("<!--", b)) {
    size_t e = out.find("-->", b);
    if (e == std::string::npos) break;
    for (size_t i = b; i < e + 3; ++i)
      if (out[i] != '\n') out[i] = ' ';
    b = e + 3;
  }
  return out;
}

int line_of(const std::string& text, size_t pos) {
  return 1 + static_cast<int>(std::count(text.begin(), text.begin() + static_cast<long>(pos), '\n'));
}

}  // namespace

PromptTemplate PromptTemplate::load(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw Error(path + ": cannot read the prompt template");
  std::stringstream ss;
  ss << in.rdbuf();
  return from_text(ss.str(), path);
}

PromptTemplate PromptTemplate::from_text(std::string text, std::string name) {
  PromptTemplate t;
  t.text_ = std::move(text);
  t.name_ = std::move(name);
  return t;
}

std::set<std::string> PromptTemplate::placeholders() const {
  std::set<std::string> names;
  const std::string checked = blank_comments(text_);
  for (size_t b = checked.find("{{"); b != std::string::npos; b = checked.find("{{", b + 2)) {
    size_t e = checked.find("}}", b);
    if (e == std::string::npos) break;
    names.insert(checked.substr(b + 2, e - b - 2));
  }
  return names;
}

std::string PromptTemplate::render(const std::map<std::string, std::string>& values) const {
  // Checked on the text with comments blanked, so line numbers match the file as written.
  const std::string checked = blank_comments(text_);
  for (size_t b = checked.find("{{"); b != std::string::npos; b = checked.find("{{", b + 2)) {
    size_t e = checked.find("}}", b);
    if (e == std::string::npos)
      throw Error(name_ + ":" + std::to_string(line_of(checked, b)) + ": '{{' without a closing '}}'");
    std::string key = checked.substr(b + 2, e - b - 2);
    if (!values.count(key)) {
      std::string known;
      for (const auto& [k, v] : values) known += (known.empty() ? "" : ", ") + k;
      throw Error(name_ + ":" + std::to_string(line_of(checked, b)) + ": unknown placeholder {{" + key +
                  "}} (known: " + known + ")");
    }
  }
  std::string src = strip_comments(text_);
  std::string out;
  size_t pos = 0;
  for (size_t b = src.find("{{"); b != std::string::npos; b = src.find("{{", pos)) {
    size_t e = src.find("}}", b);
    out.append(src, pos, b - pos);
    out += values.at(src.substr(b + 2, e - b - 2));
    pos = e + 2;
  }
  out.append(src, pos);
  return out;
}

}  // namespace hf::llm_hazard
