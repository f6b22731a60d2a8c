// Run-folder writers for llm_hazard.
#include "run_files.hpp"

#include <hazardforge/error.hpp>
#include <hazardforge/json_text.hpp>

namespace hf::llm_hazard {

JsonLines::JsonLines(std::filesystem::path path) : path_(std::move(path)) {
  out_.open(path_, RecordFile::Mode::kAppend);
}

void JsonLines::append(const Json& record) {
  out_.write(json_text(record) + '\n');
}

}  // namespace hf::llm_hazard
