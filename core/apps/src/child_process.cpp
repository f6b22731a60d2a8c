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

#include "hazardforge/error.hpp"

extern char** environ;

namespace hf::apps {

using namespace hf::core;  // the host's public interface

pid_t spawn_logged(const std::vector<std::string>& args, const std::filesystem::path& log, int keep_fd) {
  // Everything the child uses is made before fork: between fork and exec it calls async-signal-safe functions
  // only (the parent has threads).
  const std::string program = args.at(0);
  const std::string log_path = log.string();
  std::vector<char*> argv;
  for (const auto& a : args) argv.push_back(const_cast<char*>(a.c_str()));
  argv.push_back(nullptr);
  const pid_t parent = getpid();
  int failed[2];  // the child's errno when it cannot start; closed by a successful exec
  if (pipe2(failed, O_CLOEXEC) != 0) throw Error("cannot start " + program + ": " + std::strerror(errno));
  const pid_t pid = fork();
  if (pid < 0) {
    const int err = errno;
    close(failed[0]);
    close(failed[1]);
    throw Error("cannot start " + program + ": " + std::strerror(err));
  }
  if (pid == 0) {
    auto fail = [&](int err) {
      if (write(failed[1], &err, sizeof err) < 0) {
      }
      _exit(127);
    };
    // Its own process group: a terminal's Ctrl-C reaches the parent only, which stops its children itself.
    setpgid(0, 0);
    // Ended with the parent, however the parent ends (SIGKILL included): SIGTERM lets a run stop as Ctrl-C
    // does. A parent already gone before this call would never send it.
    if (prctl(PR_SET_PDEATHSIG, SIGTERM) != 0) fail(errno);
    if (getppid() != parent) _exit(128 + SIGTERM);
    sigset_t none;
    sigemptyset(&none);
    sigprocmask(SIG_SETMASK, &none, nullptr);
    const int fd = open(log_path.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
    if (fd < 0) fail(errno);
    if (dup2(fd, STDOUT_FILENO) < 0 || dup2(fd, STDERR_FILENO) < 0) fail(errno);
    if (fd > STDERR_FILENO) close(fd);
    if (keep_fd >= 0 && fcntl(keep_fd, F_SETFD, 0) != 0) fail(errno);
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
    throw Error("cannot start " + program + ": " + std::strerror(err));
  }
  return pid;
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
