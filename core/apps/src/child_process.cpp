// Child processes with a log file, in their own process group, ended with their parent, reaped with their CPU
// time (wait4).
#include "hazardforge/apps/child_process.hpp"

#include <fcntl.h>
#include <sys/prctl.h>
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cerrno>
#include <csignal>
#include <cstring>

#include "hazardforge/child_process.hpp"
#include "hazardforge/error.hpp"


namespace hf::apps {

using namespace hf::core;  // the host's public interface

pid_t spawn_logged(const std::vector<std::string>& args, const std::filesystem::path& log, int keep_fd) {
  ChildIo io;
  io.log = log.string();
  io.keep_fd = keep_fd;
  return spawn_child(args, io);
}

ChildExit wait_any_child() {
  ChildExit e;
  int status = 0;
  struct rusage ru {};
  pid_t pid = 0;
  do {
    pid = wait4(-1, &status, 0, &ru);
  } while (pid < 0 && errno == EINTR);
  if (pid <= 0) return e;
  e.pid = pid;
  e.exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status);
  e.cpu_s = static_cast<double>(ru.ru_utime.tv_sec + ru.ru_stime.tv_sec) +
            static_cast<double>(ru.ru_utime.tv_usec + ru.ru_stime.tv_usec) * 1e-6;
  return e;
}

}  // namespace hf::apps
