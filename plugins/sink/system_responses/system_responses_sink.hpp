// The system_responses sink: a system under test's answers, one JSON line per frame.
#pragma once

#include <filesystem>
#include <memory>

#include "hazardforge/atomic_file.hpp"
#include "hazardforge/stage.hpp"

namespace hf::sinks {

// Stage "system_responses" (kind sink).
//  inputs:  response (SystemResponse).
//  outputs: none; appends {"frame", "timestamp", "detections", "ttc_s", "warning", "brake"} to <file> as each
//           frame's answer arrives (a run stopped half-way keeps the frames answered).
class SystemResponsesSink : public Stage {
 public:
  static ComponentInfo describe();
  void open(StageContext& ctx) override;
  void process(StageContext& ctx, const Inputs& in, Outputs& out) override;

 private:
  std::unique_ptr<RecordFile> file_;
};

}  // namespace hf::sinks
