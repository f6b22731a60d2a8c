// Where a campaign's attempts run: child processes of this machine (local), or tasks of Slurm job arrays
// (docs/campaigns.md#on-a-slurm-cluster).
#pragma once

#include <filesystem>
#include <memory>
#include <string>
#include <vector>

namespace hf::apps {

struct TaskEnd {
  std::string id;     // start()'s id; empty: nothing is running
  int exit_code = 0;  // the command's exit status (128 + signal when killed)
  double cpu_s = 0;   // its user + system CPU time
};

class Executor {
 public:
  virtual ~Executor();
  // Starts `args` (argv[0] a program path) with its stdout and stderr in `log`; `keep_fd` (local only) stays
  // open in the child. Returns the task's id. A Slurm executor queues the task until flush().
  virtual std::string start(const std::vector<std::string>& args, const std::filesystem::path& log,
                            int keep_fd) = 0;
  // Hands the queued tasks to the scheduler (Slurm: one job array); local: nothing to do.
  virtual void flush() {}
  // Waits until a started task ends.
  virtual TaskEnd wait_any() = 0;
  // Asks every running task to stop (local: SIGINT; Slurm: scancel --signal=INT).
  virtual void interrupt_all() = 0;
  // What the lock file of a running task says about it (a pid, or "slurm JOBID_TASK").
  virtual std::string holder(const std::string& id) const = 0;
};

std::unique_ptr<Executor> local_executor();

struct SlurmOptions {
  std::string partition, account, time, mem;
  int cpus_per_task = 1;
  int throttle = 0;                      // at most this many tasks of an array at once (0: no %N)
  std::vector<std::string> sbatch_args;  // added to every sbatch
  double poll_s = 2.0;                   // how often squeue is asked
};
// Tasks as Slurm job arrays (sbatch --array, --requeue), their scripts and exit files in `state_dir` on the
// shared filesystem. A task whose job is requeued (preemption, node loss) runs again from the start; one
// counts as ended only once its exit file is complete. Throws hf::Error when sbatch is missing or refuses.
std::unique_ptr<Executor> slurm_executor(const SlurmOptions& o, const std::filesystem::path& state_dir);

// Whether a Slurm job or array task ("123" or "123_4") is still queued or running (squeue).
bool slurm_job_alive(const std::string& job);

}  // namespace hf::apps
