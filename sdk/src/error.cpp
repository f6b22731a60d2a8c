// Formatting of diagnostics and the SDK's exception types.
#include "hazardforge/error.hpp"

#include <sstream>

namespace hf {

std::string SourceLocation::str() const {
  std::string s = file;
  if (line > 0) {
    s += ":" + std::to_string(line);
    if (column > 0) s += ":" + std::to_string(column);
  }
  return s;
}

std::string Diagnostic::str() const {
  const char* sev = severity == Severity::kError ? "error" : severity == Severity::kWarning ? "warning" : "note";
  std::string loc = where.str();
  return (loc.empty() ? std::string() : loc + ": ") + sev + ": " + message;
}

std::string format_diagnostics(const std::vector<Diagnostic>& diags) {
  std::ostringstream os;
  for (size_t i = 0; i < diags.size(); ++i) os << (i ? "\n" : "") << diags[i].str();
  return os.str();
}

Error::Error(const SourceLocation& where, const std::string& message)
    : std::runtime_error(Diagnostic{Diagnostic::Severity::kError, where, message}.str()) {}
Error::~Error() = default;

DiagnosticError::DiagnosticError(std::vector<Diagnostic> diags)
    : Error(format_diagnostics(diags)), diags_(std::move(diags)) {}
DiagnosticError::~DiagnosticError() = default;

}  // namespace hf
