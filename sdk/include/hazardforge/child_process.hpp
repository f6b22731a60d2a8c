// Starting a child program: the one way the CLI's commands (campaign attempts, experiments, tests of a
// system) and stages (a system under test that is a program of its own) start processes.
#pragma once

#include "hazardforge/abi.hpp"

#include <sys/types.h>

#include <string>
#include <vector>

HF_SDK_BEGIN
namespace hf {

struct ChildIo {
  int stdin_fd = -1;    // the child's standard input (-1: the parent's)
  int stdout_fd = -1;   // its standard output (-1: `log` when given, else the parent's)
  std::string log;      // its standard output and error go to this file (standard error only when
                        // stdout_fd is given)
  bool append = false;  // append to `log` instead of truncating it
  std::string cwd;      // its working folder (empty: the parent's)
  int keep_fd = -1;     // a descriptor that stays open in the child (e.g. a lock it holds while it lives)
};

// Starts argv (argv[0] looked up on PATH when it has no '/') in a process group of its own, with an empty
// signal mask and SIGPIPE at its default, ended by SIGTERM when the thread that started it ends, however that
// happens (PR_SET_PDEATHSIG). The parent's descriptors opened close-on-exec stay out of it. Between fork and
// exec only async-signal-safe calls are made (the parent has threads). Throws hf::Error "cannot start
// 'PROGRAM': why" when it cannot be found, the log cannot be opened, the folder entered, or exec fails.
pid_t spawn_child(const std::vector<std::string>& argv, const ChildIo& io);

}  // namespace hf
HF_SDK_END
