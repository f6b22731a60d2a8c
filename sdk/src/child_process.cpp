// spawn_child: fork and exec with the child's failure reported back through a close-on-exec pipe.
#include "hazardforge/child_process.hpp"

#include <fcntl.h>
#include <sys/prctl.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <csignal>
#include <cstdlib>
#include <cstring>
#include <filesystem>

#include "hazardforge/error.hpp"

extern char** environ;

HF_SDK_BEGIN
namespace hf {

namespace {

std::string resolve_program(const std::string& name) {
  if (name.find('/') != std::string::npos) return name;
  const char* path = std::getenv("PATH");
  const std::string dirs = path ? path : "/usr/local/bin:/usr/bin:/bin";
  size_t start = 0;
  while (start <= dirs.size()) {
    const size_t end = std::min(dirs.find(':', start), dirs.size());
    const std::string dir = dirs.substr(start, end - start);
    const std::filesystem::path candidate = std::filesystem::path(dir.empty() ? "." : dir) / name;
    std::error_code ec;
    if (access(candidate.c_str(), X_OK) == 0 && !std::filesystem::is_directory(candidate, ec))
      return candidate.string();
    start = end + 1;
  }
  throw Error("cannot start '" + name + "': not found on PATH");
}

}  // namespace

pid_t spawn_child(const std::vector<std::string>& argv_in, const ChildIo& io) {
  if (argv_in.empty() || argv_in[0].empty()) throw Error("cannot start a program: its command is empty");
  // Everything the child uses is made before fork.
  const std::string program = resolve_program(argv_in[0]);
  std::vector<std::string> args = argv_in;
  std::vector<char*> argv;
  for (auto& a : args) argv.push_back(a.data());
  argv.push_back(nullptr);
  const int log_flags = O_WRONLY | O_CREAT | (io.append ? O_APPEND : O_TRUNC);
  const pid_t parent = getpid();
  int failed[2];  // the child's errno when it cannot start; closed by a successful exec
  if (pipe2(failed, O_CLOEXEC) != 0) throw Error("cannot start '" + program + "': " + std::strerror(errno));
  const pid_t pid = fork();
  if (pid < 0) {
    const int err = errno;
    close(failed[0]);
    close(failed[1]);
    throw Error("cannot start '" + program + "': " + std::strerror(err));
  }
  if (pid == 0) {
    auto fail = [&](int err) {
      if (write(failed[1], &err, sizeof err) < 0) {
      }
      _exit(127);
    };
    // Its own process group: a terminal's Ctrl-C reaches the parent only, which stops its children itself.
    setpgid(0, 0);
    if (prctl(PR_SET_PDEATHSIG, SIGTERM) != 0) fail(errno);
    if (getppid() != parent) _exit(128 + SIGTERM);  // the parent is already gone
    sigset_t none;
    sigemptyset(&none);
    sigprocmask(SIG_SETMASK, &none, nullptr);
    signal(SIGPIPE, SIG_DFL);
    if (io.stdin_fd >= 0 && dup2(io.stdin_fd, STDIN_FILENO) < 0) fail(errno);
    if (io.stdout_fd >= 0 && dup2(io.stdout_fd, STDOUT_FILENO) < 0) fail(errno);
    if (!io.log.empty()) {
      const int fd = open(io.log.c_str(), log_flags, 0644);
      if (fd < 0) fail(errno);
      if ((io.stdout_fd < 0 && dup2(fd, STDOUT_FILENO) < 0) || dup2(fd, STDERR_FILENO) < 0) fail(errno);
      if (fd > STDERR_FILENO) close(fd);
    }
    if (io.keep_fd >= 0 && fcntl(io.keep_fd, F_SETFD, 0) != 0) fail(errno);
    if (!io.cwd.empty() && chdir(io.cwd.c_str()) != 0) fail(errno);
    execve(program.c_str(), argv.data(), environ);
    fail(errno);
  }
  close(failed[1]);
  int err = 0;
  ssize_t n = 0;
  do {
    n = read(failed[0], &err, sizeof err);
  } while (n < 0 && errno == EINTR);
  close(failed[0]);
  if (n == static_cast<ssize_t>(sizeof err)) {
    waitpid(pid, nullptr, 0);
    throw Error("cannot start '" + program + "'" + (io.cwd.empty() ? "" : " in '" + io.cwd + "'") + ": " +
                std::strerror(err));
  }
  return pid;
}

}  // namespace hf
HF_SDK_END
