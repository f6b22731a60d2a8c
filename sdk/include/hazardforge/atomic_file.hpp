// Writing files in a run folder: atomic replacement and record files that never end in half a record.
#pragma once

#include "hazardforge/abi.hpp"

#include <sys/types.h>

#include <filesystem>
#include <string>
#include <string_view>

HF_SDK_BEGIN
namespace hf {

// Writes `bytes` to `path` through a fresh temporary file in the same folder (created with O_EXCL and
// O_NOFOLLOW, so a planted file or symlink is never written through), flushed to disk, then renamed over
// `path`: a reader sees the old file or the new one, never half of one. The temporary file is removed on any
// failure. Throws hf::Error "PATH: cannot write: <cause>" (e.g. "No space left on device").
void write_file_atomic(const std::filesystem::path& path, std::string_view bytes);

// Removes whatever is at `path` (a planted symlink is removed, not followed) and creates an empty regular
// file there, exclusively. For files another writer (an encoder process, cv::VideoWriter) fills by name.
void claim_output_file(const std::filesystem::path& path);

// A record file written line by line (JSON lines, CSV). Opened with O_NOFOLLOW, so a symlink planted at its
// name is refused rather than followed. write() either appends the whole text or, when the disk is full,
// cuts the file back to its previous end and throws: the file never ends in half a record.
class RecordFile {
 public:
  enum class Mode { kTruncate, kAppend };
  RecordFile() = default;
  RecordFile(const std::filesystem::path& path, Mode mode) { open(path, mode); }
  RecordFile(const RecordFile&) = delete;
  RecordFile& operator=(const RecordFile&) = delete;
  RecordFile(RecordFile&& o) noexcept;
  RecordFile& operator=(RecordFile&& o) noexcept;
  ~RecordFile();

  void open(const std::filesystem::path& path, Mode mode);
  void write(std::string_view text);
  void close();
  bool is_open() const { return fd_ >= 0; }
  const std::filesystem::path& path() const { return path_; }

 private:
  int fd_ = -1;
  off_t end_ = 0;
  std::filesystem::path path_;
};

}  // namespace hf
HF_SDK_END
