// SystemResponsesSink: SystemResponse packets as JSON lines.
#include "system_responses_sink.hpp"

#include "hazardforge/json_text.hpp"
#include "hazardforge/output_path.hpp"

namespace hf::sinks {

ComponentInfo SystemResponsesSink::describe() {
  ComponentInfo i;
  i.name = "system_responses";
  i.kind = kind::kSink;
  i.summary = "a system under test's answers, one JSON line per frame (system/responses.jsonl)";
  i.doc =
      "Writes what a system under test answered for each frame: its detections, TTC, warning and brake "
      "request, with the frame's timestamp. hazardforge test scores these lines against the scenario's "
      "labels (docs/testing-a-system.md).";
  i.inputs = {port<SystemResponse>("response", "the system's answer per frame")};
  i.params = {ParamSpec::string("file", "system/responses.jsonl").describe("below the run's output folder")};
  return i;
}

void SystemResponsesSink::open(StageContext& ctx) {
  file_ = std::make_unique<RecordFile>(output_param_path(ctx, "file"), RecordFile::Mode::kTruncate);
}

void SystemResponsesSink::process(StageContext& ctx, const Inputs& in, Outputs& /*out*/) {
  Json j = in.require<SystemResponse>("response");
  j["timestamp"] = finite_or_null(ctx.timestamp());
  file_->write(json_text(j) + "\n");
}

}  // namespace hf::sinks
