// Child `hazardforge` processes for commands that run many graphs (experiment, campaign, test): started by
// hf::spawn_child with their output in a log file, reaped one at a time with their exit code and CPU time.
#pragma once

#include <sys/types.h>

#include <filesystem>
#include <string>
#include <vector>

namespace hf::apps {

// Starts args[0] with args, stdout and stderr to `log` (created or truncated). The child runs in its own
// process group and gets SIGTERM when the thread that started it ends, however that happens (SIGKILL
// included; PR_SET_PDEATHSIG), so no child outlives the command that started it. `keep_fd`, when given, stays
// open in the child (e.g. a lock it holds for as long as it lives); the parent's other descriptors opened
// close-on-exec do not. Throws hf::Error naming the program when it cannot start.
pid_t spawn_logged(const std::vector<std::string>& args, const std::filesystem::path& log, int keep_fd = -1);

struct ChildExit {
  pid_t pid = 0;      // 0: no child left
  int exit_code = 0;  // the exit status, or 128 + signal
  double cpu_s = 0;   // user + system CPU time of the child
};

// Waits for any child of this process to end.
ChildExit wait_any_child();

}  // namespace hf::apps
