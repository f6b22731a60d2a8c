// ProgramPipe: a child started by hf::spawn_child with pipes, poll() for every deadline, SIGPIPE held off
// while writing.
#include "program_pipe.hpp"

#include <fcntl.h>
#include <poll.h>
#include <pthread.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <csignal>
#include <cstdlib>
#include <cstring>

#include "hazardforge/child_process.hpp"
#include "hazardforge/error.hpp"

namespace hf::system {

namespace fs = std::filesystem;

namespace {

int remaining_ms(ProgramPipe::Clock::time_point deadline) {
  const auto left =
      std::chrono::duration_cast<std::chrono::milliseconds>(deadline - ProgramPipe::Clock::now());
  return static_cast<int>(std::clamp<long long>(left.count(), 0, 60'000));
}

}  // namespace

ProgramPipe::ProgramPipe(const std::vector<std::string>& argv, const fs::path& cwd,
                         const fs::path& stderr_log) {
  int to_child[2], from_child[2];
  if (pipe2(to_child, O_CLOEXEC) != 0)
    throw Error(std::string("cannot make a pipe: ") + std::strerror(errno));
  if (pipe2(from_child, O_CLOEXEC) != 0) {
    close(to_child[0]);
    close(to_child[1]);
    throw Error(std::string("cannot make a pipe: ") + std::strerror(errno));
  }
  ChildIo io;
  io.stdin_fd = to_child[0];
  io.stdout_fd = from_child[1];
  io.log = stderr_log.string();
  io.append = true;
  io.cwd = cwd.string();
  try {
    pid_ = spawn_child(argv, io);
  } catch (const Error&) {
    for (int fd : {to_child[0], to_child[1], from_child[0], from_child[1]}) close(fd);
    throw;
  }
  close(to_child[0]);
  close(from_child[1]);
  in_ = to_child[1];
  out_ = from_child[0];
  fcntl(in_, F_SETFL, fcntl(in_, F_GETFL) | O_NONBLOCK);
  fcntl(out_, F_SETFL, fcntl(out_, F_GETFL) | O_NONBLOCK);
}

ProgramPipe::~ProgramPipe() {
  if (in_ >= 0) close(in_);
  if (out_ >= 0) close(out_);
  if (pid_ > 0 && !status_) {
    kill(pid_, SIGKILL);
    reap(true);
  }
}

std::optional<int> ProgramPipe::reap(bool block) {
  if (status_ || pid_ <= 0) return status_;
  int st = 0;
  pid_t r = 0;
  do {
    r = waitpid(pid_, &st, block ? 0 : WNOHANG);
  } while (r < 0 && errno == EINTR);
  if (r == pid_) status_ = WIFEXITED(st) ? WEXITSTATUS(st) : 128 + WTERMSIG(st);
  return status_;
}

// One poll() round: reads whatever output there is; returns whether the input can take more bytes.
bool ProgramPipe::pump(Clock::time_point deadline, bool want_write) {
  pollfd fds[2] = {{out_, POLLIN, 0}, {in_, POLLOUT, 0}};
  const nfds_t n = (want_write && in_ >= 0) ? 2 : 1;
  if (out_eof_ && n == 1) return false;
  const int r = poll(out_eof_ ? fds + 1 : fds, out_eof_ ? 1 : n, remaining_ms(deadline));
  if (r <= 0) return false;
  if (!out_eof_ && (fds[0].revents & (POLLIN | POLLHUP | POLLERR))) {
    char chunk[65536];
    for (;;) {
      const ssize_t got = read(out_, chunk, sizeof chunk);
      if (got > 0) {
        buffer_.append(chunk, static_cast<size_t>(got));
        if (buffer_.size() > (64u << 20))
          throw Error("the program wrote more than 64 MiB without a line break");
        continue;
      }
      if (got == 0) out_eof_ = true;
      break;  // EAGAIN or EOF
    }
  }
  return n == 2 && (fds[1].revents & (POLLOUT | POLLERR | POLLHUP));
}

ProgramPipe::Status ProgramPipe::write_all(std::string_view bytes, Clock::time_point deadline) {
  sigset_t pipe_set, old;
  sigemptyset(&pipe_set);
  sigaddset(&pipe_set, SIGPIPE);
  size_t done = 0;
  while (done < bytes.size()) {
    if (Clock::now() >= deadline) return Status::kTimeout;
    if (!pump(deadline, true)) continue;
    // SIGPIPE held off in this thread while writing: a program that is gone gives EPIPE, not the host's
    // death.
    pthread_sigmask(SIG_BLOCK, &pipe_set, &old);
    const ssize_t w = write(in_, bytes.data() + done, bytes.size() - done);
    const int err = errno;
    if (w < 0 && err == EPIPE) {
      const timespec zero{0, 0};
      sigtimedwait(&pipe_set, nullptr, &zero);
    }
    pthread_sigmask(SIG_SETMASK, &old, nullptr);
    if (w > 0)
      done += static_cast<size_t>(w);
    else if (w < 0 && err == EPIPE)
      return Status::kClosed;
    else if (w < 0 && err != EAGAIN && err != EINTR)
      throw Error(std::string("cannot write to the program: ") + std::strerror(err));
  }
  return Status::kOk;
}

ProgramPipe::Status ProgramPipe::read_line(std::string& line, Clock::time_point deadline, size_t max_line,
                                           bool& too_long) {
  too_long = false;
  for (;;) {
    const size_t nl = buffer_.find('\n');
    if (nl != std::string::npos || buffer_.size() > max_line) {
      const size_t len = std::min(nl, max_line);
      too_long = nl == std::string::npos || nl > max_line;
      line = buffer_.substr(0, len);
      buffer_.erase(0, nl == std::string::npos ? buffer_.size() : nl + 1);
      return Status::kOk;
    }
    if (out_eof_) return Status::kClosed;
    if (Clock::now() >= deadline) return Status::kTimeout;
    pump(deadline, false);
  }
}

int ProgramPipe::finish(Clock::time_point deadline) {
  if (in_ >= 0) {
    close(in_);
    in_ = -1;
  }
  while (!reap(false)) {
    if (Clock::now() >= deadline) {
      kill(pid_, SIGKILL);
      reap(true);
      break;
    }
    // Keep reading its output so that it is not stuck writing into a full pipe.
    if (!out_eof_) {
      pump(std::min(deadline, Clock::now() + std::chrono::milliseconds(50)), false);
      buffer_.clear();
    } else {
      pollfd none{-1, 0, 0};
      poll(&none, 0, 20);
    }
  }
  return *status_;
}

std::string ProgramPipe::exit_text() {
  const auto st = reap(false);
  if (!st) {
    // Its output is closed: it is exiting; give it a moment to be reaped.
    for (int i = 0; i < 50 && !reap(false); ++i) {
      pollfd none{-1, 0, 0};
      poll(&none, 0, 20);
    }
  }
  if (!status_) return "it closed its output but is still running";
  if (*status_ > 128) {
    const int sig = *status_ - 128;
    return "killed by signal " + std::to_string(sig) + " (" + strsignal(sig) + ")";
  }
  return "exit code " + std::to_string(*status_);
}

}  // namespace hf::system
