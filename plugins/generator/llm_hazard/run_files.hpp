// Files the generator leaves in the run folder: the append-only LLM call record and the road record.
#pragma once

#include <filesystem>
#include <string>

#include <hazardforge/atomic_file.hpp>
#include <hazardforge/types.hpp>

namespace hf::llm_hazard {

// An append-only JSON-lines file (llm/calls.jsonl: one object per model call; road.jsonl): each record written
// whole as it happens, so an interrupted run keeps it.
class JsonLines {
 public:
  explicit JsonLines(std::filesystem::path path);
  void append(const Json& record);
  const std::filesystem::path& path() const { return path_; }

 private:
  std::filesystem::path path_;
  RecordFile out_;
};

}  // namespace hf::llm_hazard
