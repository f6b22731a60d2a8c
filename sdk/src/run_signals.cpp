// Per-thread cancellation and incomplete-input reports.
#include "hazardforge/run_signals.hpp"

#include "hazardforge/error.hpp"

namespace hf {

namespace {
thread_local const CancellationScope* t_cancel = nullptr;
thread_local const IncompleteReportScope* t_incomplete = nullptr;
}  // namespace

CancellationScope::CancellationScope(std::function<bool()> check)
    : check_(std::move(check)), outer_(t_cancel) {
  t_cancel = this;
}
CancellationScope::~CancellationScope() {
  t_cancel = outer_;
}

bool cancellation_requested() {
  return t_cancel != nullptr && t_cancel->check_ && t_cancel->check_();
}

IncompleteReportScope::IncompleteReportScope(std::function<void(const std::string&)> sink)
    : sink_(std::move(sink)), outer_(t_incomplete) {
  t_incomplete = this;
}
IncompleteReportScope::~IncompleteReportScope() {
  t_incomplete = outer_;
}

void report_incomplete(const std::string& reason) {
  if (t_incomplete == nullptr || !t_incomplete->sink_) throw Error(reason);
  t_incomplete->sink_(reason);
}

}  // namespace hf
