// Signals that need no StageContext: cancelling a blocking call inside a component, and reporting input that
// was only partly usable. Both are per thread, so a stage's call chain (stage -> LLM provider) shares them.
#pragma once

#include "hazardforge/abi.hpp"

#include <functional>
#include <string>

HF_SDK_BEGIN
namespace hf {

// While alive, cancellation_requested() on this thread returns check(). A stage wraps a call into a component
// that has no StageContext (an LLM provider) so that Ctrl-C reaches it: CancellationScope s([&] { return
// ctx.stop_requested(); }). Scopes nest; the innermost one answers.
class CancellationScope {
 public:
  explicit CancellationScope(std::function<bool()> check);
  ~CancellationScope();
  CancellationScope(const CancellationScope&) = delete;
  CancellationScope& operator=(const CancellationScope&) = delete;

 private:
  std::function<bool()> check_;
  const CancellationScope* outer_;
  friend bool cancellation_requested();
};

// False when no scope is active on this thread.
bool cancellation_requested();

// While alive, report_incomplete() on this thread goes to `sink`. The host installs one per node thread and
// ends the run "incomplete" with every reason in its manifest; the StageRunner records them as log lines.
class IncompleteReportScope {
 public:
  explicit IncompleteReportScope(std::function<void(const std::string&)> sink);
  ~IncompleteReportScope();
  IncompleteReportScope(const IncompleteReportScope&) = delete;
  IncompleteReportScope& operator=(const IncompleteReportScope&) = delete;

 private:
  std::function<void(const std::string&)> sink_;
  const IncompleteReportScope* outer_;
  friend void report_incomplete(const std::string& reason);
};

// A stage went on with input it could use only in part because the user allowed it (e.g. a video decoding
// fewer frames than its container declares, with allow_partial). Throws hf::Error(reason) when nothing on
// this thread records it: partial input must never pass silently.
void report_incomplete(const std::string& reason);

}  // namespace hf
HF_SDK_END
