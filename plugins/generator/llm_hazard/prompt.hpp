// Prompt templates read from share/prompts/ at run time: {{placeholder}} substitution, HTML comments removed.
#pragma once

#include <map>
#include <set>
#include <string>

namespace hf::llm_hazard {

class PromptTemplate {
 public:
  // Throws hf::Error naming the file when it cannot be read.
  static PromptTemplate load(const std::string& path);
  static PromptTemplate from_text(std::string text, std::string name);

  // Fills every {{name}}. A placeholder without a value throws hf::Error "<file>:<line>: unknown placeholder
  // {{name}} (known: ...)", so a typo in an edited template is caught on the first run.
  std::string render(const std::map<std::string, std::string>& values) const;
  std::set<std::string> placeholders() const;
  const std::string& name() const { return name_; }
  const std::string& text() const { return text_; }

 private:
  std::string text_;
  std::string name_;
};

}  // namespace hf::llm_hazard
