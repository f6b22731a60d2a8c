// A child program with a pipe to its standard input and one from its standard output (its standard error to
// a file), and deadlines on every exchange.
#pragma once

#include <sys/types.h>

#include <chrono>
#include <filesystem>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

namespace hf::system {

class ProgramPipe {
 public:
  using Clock = std::chrono::steady_clock;
  // Starts `argv` (argv[0] searched on PATH when it has no '/') in `cwd`, its stderr appended to
  // `stderr_log`. Throws hf::Error when it cannot start.
  ProgramPipe(const std::vector<std::string>& argv, const std::filesystem::path& cwd,
              const std::filesystem::path& stderr_log);
  ~ProgramPipe();
  ProgramPipe(const ProgramPipe&) = delete;
  ProgramPipe& operator=(const ProgramPipe&) = delete;

  enum class Status { kOk, kTimeout, kClosed };
  // Writes all of `bytes` by the deadline, reading the program's output meanwhile (a program may answer
  // before it has read everything). kClosed: the program closed its input (exited).
  Status write_all(std::string_view bytes, Clock::time_point deadline);
  // The next line of its output (without '\n') by the deadline; kClosed at end of output. A line longer than
  // max_line bytes is cut there and reported through `too_long`.
  Status read_line(std::string& line, Clock::time_point deadline, size_t max_line, bool& too_long);
  // Closes its input and waits for it to exit until the deadline, then kills it. Its exit status: the exit
  // code, or 128 + the signal.
  int finish(Clock::time_point deadline);
  // Whether it has exited, and how (after kClosed): "exit code 3", "killed by signal 11 (Segmentation
  // fault)".
  std::string exit_text();
  pid_t pid() const { return pid_; }

 private:
  bool pump(Clock::time_point deadline, bool want_write);
  std::optional<int> reap(bool block);

  pid_t pid_ = -1;
  int in_ = -1, out_ = -1;
  std::string buffer_;
  bool out_eof_ = false;
  std::optional<int> status_;
};

}  // namespace hf::system
