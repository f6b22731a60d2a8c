// Run-folder writers for llm_hazard.
#include "run_files.hpp"

#include <hazardforge/error.hpp>

namespace hf::llm_hazard {

CallLog::CallLog(std::filesystem::path path) : path_(std::move(path)) {
  std::error_code ec;
  std::filesystem::create_directories(path_.parent_path(), ec);
  out_.open(path_, std::ios::app);
  if (!out_) throw Error(path_.string() + ": cannot open the LLM call record for writing");
}

void CallLog::append(const Json& record) {
  // Replies are model text: replace invalid UTF-8 rather than lose the record.
  out_ << record.dump(-1, ' ', false, Json::error_handler_t::replace) << '\n';
  out_.flush();
  if (!out_) throw Error(path_.string() + ": write failed");
}

void write_file_atomic(const std::filesystem::path& path, const std::string& text) {
  std::error_code ec;
  std::filesystem::create_directories(path.parent_path(), ec);
  std::filesystem::path tmp = path;
  tmp += ".tmp";
  {
    std::ofstream out(tmp, std::ios::trunc);
    out << text;
    out.flush();
    if (!out) throw Error(tmp.string() + ": write failed");
  }
  std::filesystem::rename(tmp, path, ec);
  if (ec) throw Error(path.string() + ": cannot replace with " + tmp.string() + ": " + ec.message());
}

}  // namespace hf::llm_hazard
