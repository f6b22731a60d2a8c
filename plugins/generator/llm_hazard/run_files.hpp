// Files the generator leaves in the run folder: the append-only LLM call record.
#pragma once

#include <filesystem>
#include <string>

#include <hazardforge/atomic_file.hpp>
#include <hazardforge/types.hpp>

namespace hf::llm_hazard {

// llm/calls.jsonl: one JSON object per model call, written whole as it happens so an interrupted run keeps
// it.
class CallLog {
 public:
  explicit CallLog(std::filesystem::path path);
  void append(const Json& record);
  const std::filesystem::path& path() const { return path_; }

 private:
  std::filesystem::path path_;
  RecordFile out_;
};

}  // namespace hf::llm_hazard
