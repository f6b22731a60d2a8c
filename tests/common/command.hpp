// Running a command line from a test: its exit code and its combined stdout/stderr.
#pragma once

#include <sys/wait.h>

#include <array>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <string>

#include <nlohmann/json.hpp>

namespace hf::test {

struct CommandResult {
  int code = -1;  // exit code; -1 when the command could not start or was killed by a signal
  std::string out;
};

inline CommandResult run_command(const std::string& cmd) {
  CommandResult c;
  FILE* p = popen((cmd + " 2>&1").c_str(), "r");
  if (!p) return c;
  std::array<char, 4096> buf{};
  while (size_t n = fread(buf.data(), 1, buf.size(), p)) c.out.append(buf.data(), n);
  const int st = pclose(p);
  c.code = WIFEXITED(st) ? WEXITSTATUS(st) : -1;
  return c;
}

// A path quoted for the shell (paths with single quotes are not expected in tests).
inline std::string quote(const std::filesystem::path& p) {
  return "'" + p.string() + "'";
}

inline nlohmann::json read_json_file(const std::filesystem::path& p) {
  std::ifstream in(p);
  return nlohmann::json::parse(in);
}

}  // namespace hf::test
