// Error and diagnostic types shared by the host and plugins: one message naming the file, field or frame.
#pragma once

#include "hazardforge/abi.hpp"

#include <stdexcept>
#include <string>
#include <vector>

HF_SDK_BEGIN
namespace hf {

// A position in a user-facing input file (YAML config, dataset table, reply). Line/column are 1-based; 0 = unknown.
struct SourceLocation {
  std::string file;
  int line = 0;
  int column = 0;
  std::string str() const;  // "file:line:col" (omits unknown parts)
};

// One compiler-style message: "file:line:col: error: text".
struct Diagnostic {
  enum class Severity { kError, kWarning, kNote };
  Severity severity = Severity::kError;
  SourceLocation where;
  std::string message;
  std::string str() const;
};

std::string format_diagnostics(const std::vector<Diagnostic>& diags);

// Thrown by stages and SDK helpers for bad input. `what()` is already the complete user-facing message.
class Error : public std::runtime_error {
 public:
  explicit Error(const std::string& message) : std::runtime_error(message) {}
  Error(const SourceLocation& where, const std::string& message);
  ~Error() override;
};

// Several diagnostics collected before giving up (graph validation, schema validation).
class DiagnosticError : public Error {
 public:
  explicit DiagnosticError(std::vector<Diagnostic> diags);
  ~DiagnosticError() override;
  const std::vector<Diagnostic>& diagnostics() const { return diags_; }

 private:
  std::vector<Diagnostic> diags_;
};

}  // namespace hf
HF_SDK_END
