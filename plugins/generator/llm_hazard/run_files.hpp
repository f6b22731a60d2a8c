// Files the generator leaves in the run folder: the append-only LLM call record and atomically written specs.
#pragma once

#include <filesystem>
#include <fstream>
#include <string>

#include <hazardforge/types.hpp>

namespace hf::llm_hazard {

// llm/calls.jsonl: one JSON object per model call, flushed as it is written so an interrupted run keeps it.
class CallLog {
 public:
  explicit CallLog(std::filesystem::path path);
  void append(const Json& record);
  const std::filesystem::path& path() const { return path_; }

 private:
  std::filesystem::path path_;
  std::ofstream out_;
};

// Writes to "<path>.tmp" in the same folder, then renames, so readers never see half a file.
void write_file_atomic(const std::filesystem::path& path, const std::string& text);

}  // namespace hf::llm_hazard
