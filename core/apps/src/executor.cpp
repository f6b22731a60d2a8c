// Executors: child processes of this machine, or tasks of Slurm job arrays polled through squeue and the exit
// files their script writes.
#include "hazardforge/apps/executor.hpp"

#include <sys/types.h>
#include <sys/wait.h>

#include <chrono>
#include <csignal>
#include <cstdio>
#include <fstream>
#include <map>
#include <optional>
#include <set>
#include <sstream>
#include <thread>

#include "hazardforge/apps/child_process.hpp"
#include "hazardforge/atomic_file.hpp"
#include "hazardforge/error.hpp"

namespace hf::apps {

namespace fs = std::filesystem;

Executor::~Executor() = default;

namespace {

class LocalExecutor : public Executor {
 public:
  std::string start(const std::vector<std::string>& args, const fs::path& log, int keep_fd) override {
    const pid_t pid = spawn_logged(args, log, keep_fd);
    const std::string id = std::to_string(pid);
    running_[pid] = id;
    return id;
  }
  TaskEnd wait_any() override {
    while (!running_.empty()) {
      const ChildExit ex = wait_any_child();
      if (ex.pid <= 0) break;
      auto it = running_.find(ex.pid);
      if (it == running_.end()) continue;  // a child this executor did not start
      TaskEnd e{it->second, ex.exit_code, ex.cpu_s};
      running_.erase(it);
      return e;
    }
    return {};
  }
  void interrupt_all() override {
    for (const auto& [pid, id] : running_) kill(pid, SIGINT);
  }
  std::string holder(const std::string& id) const override { return id; }

 private:
  std::map<pid_t, std::string> running_;
};

std::string shell_quote(const std::string& s) {
  std::string q = "'";
  for (char c : s) q += c == '\'' ? std::string("'\\''") : std::string(1, c);
  return q + "'";
}

// Runs a command line, its stdout (and stderr) returned; the exit status in `code`.
std::string capture(const std::vector<std::string>& args, int& code) {
  std::string cmd;
  for (const auto& a : args) cmd += (cmd.empty() ? "" : " ") + shell_quote(a);
  FILE* p = popen((cmd + " 2>&1").c_str(), "r");
  if (!p) throw Error("cannot run " + args.at(0));
  std::string out;
  char buf[4096];
  while (size_t n = fread(buf, 1, sizeof buf, p)) out.append(buf, n);
  const int st = pclose(p);
  code = WIFEXITED(st) ? WEXITSTATUS(st) : 128 + (WIFSIGNALED(st) ? WTERMSIG(st) : 0);
  return out;
}

// "0m1.250s" -> 1.25
double minutes_seconds(const std::string& t) {
  const auto m = t.find('m');
  if (m == std::string::npos) return 0;
  try {
    return std::stod(t.substr(0, m)) * 60 + std::stod(t.substr(m + 1));
  } catch (const std::exception&) {
    return 0;
  }
}

// The task script of a job array: task N runs the argv in N.args (NUL-separated) with its output in the file
// N.log names, then writes its exit status (N.exit, complete or absent) and the CPU time of what it ran.
constexpr const char* kTaskScript = R"(#!/bin/bash
# A task of a hazardforge campaign's job array: runs the command in $SLURM_ARRAY_TASK_ID.args of $HF_TASK_DIR.
# Its exit status goes to N.exit only when the command ended on its own: a task Slurm stops (requeue,
# preemption, scancel) leaves none, and a requeued task runs again from the start.
dir=$HF_TASK_DIR
i=$SLURM_ARRAY_TASK_ID
rm -f "$dir/$i.exit"
mapfile -d '' args < "$dir/$i.args"
log=$(cat "$dir/$i.log")
stopped=
trap 'stopped=1; kill -INT "$child" 2>/dev/null' INT TERM
"${args[@]}" > "$log" 2>&1 &
child=$!
while :; do wait "$child"; code=$?; kill -0 "$child" 2>/dev/null || break; done
[ -n "$stopped" ] && exit "$code"
times > "$dir/$i.times"
printf '%s\n%s\n' "$code" "${SLURM_RESTART_COUNT:-0}" > "$dir/$i.exit.partial" && mv "$dir/$i.exit.partial" "$dir/$i.exit"
exit "$code"
)";

class SlurmExecutor : public Executor {
 public:
  SlurmExecutor(SlurmOptions o, fs::path state) : o_(std::move(o)), state_(std::move(state)) {
    fs::create_directories(state_);
    // Batches of an earlier invocation keep their folders: new ones are numbered after them.
    for (const auto& e : fs::directory_iterator(state_)) {
      try {
        batch_ = std::max(batch_, std::stoi(e.path().filename().string()) + 1);
      } catch (const std::exception&) {
      }
    }
  }
  std::string start(const std::vector<std::string>& args, const fs::path& log, int /*keep_fd*/) override {
    queued_.push_back({args, log});
    return "b" + std::to_string(batch_) + "_" + std::to_string(queued_.size() - 1);
  }
  void flush() override {
    if (queued_.empty()) return;
    const fs::path dir = state_ / std::to_string(batch_);
    fs::create_directories(dir);
    write_file_atomic(dir / "task.sh", kTaskScript);
    fs::permissions(dir / "task.sh", fs::perms::owner_all | fs::perms::group_read | fs::perms::group_exec |
                                         fs::perms::others_read | fs::perms::others_exec);
    for (size_t i = 0; i < queued_.size(); ++i) {
      std::string argv;
      for (const auto& a : queued_[i].args) argv += a + '\0';
      write_file_atomic(dir / (std::to_string(i) + ".args"), argv);
      write_file_atomic(dir / (std::to_string(i) + ".log"), fs::absolute(queued_[i].log).string());
    }
    std::vector<std::string> cmd = {"sbatch",
                                    "--parsable",
                                    "--requeue",
                                    "--job-name=hazardforge-campaign",
                                    "--array=0-" + std::to_string(queued_.size() - 1) +
                                        (o_.throttle > 0 ? "%" + std::to_string(o_.throttle) : ""),
                                    "--output=" + (dir / "%a.slurm.out").string(),
                                    "--export=ALL,HF_TASK_DIR=" + dir.string(),
                                    "--cpus-per-task=" + std::to_string(o_.cpus_per_task)};
    if (!o_.partition.empty()) cmd.push_back("--partition=" + o_.partition);
    if (!o_.account.empty()) cmd.push_back("--account=" + o_.account);
    if (!o_.time.empty()) cmd.push_back("--time=" + o_.time);
    if (!o_.mem.empty()) cmd.push_back("--mem=" + o_.mem);
    for (const auto& a : o_.sbatch_args) cmd.push_back(a);
    cmd.push_back((dir / "task.sh").string());
    int code = 0;
    std::string out = capture(cmd, code);
    while (!out.empty() && (out.back() == '\n' || out.back() == '\r')) out.pop_back();
    if (code != 0 || out.empty() || out.find_first_not_of("0123456789;") != std::string::npos)
      throw Error("sbatch refused the campaign's job array (" + dir.string() +
                  "): " + (out.empty() ? "exit " + std::to_string(code) : out));
    const std::string job = out.substr(0, out.find(';'));
    write_file_atomic(dir / "job", job + "\n");
    for (size_t i = 0; i < queued_.size(); ++i) {
      Task t;
      t.id = "b" + std::to_string(batch_) + "_" + std::to_string(i);
      t.slurm = job + "_" + std::to_string(i);
      t.dir = dir;
      t.index = i;
      t.log = queued_[i].log;
      running_[t.id] = t;
    }
    queued_.clear();
    ++batch_;
  }
  TaskEnd wait_any() override {
    flush();
    if (running_.empty()) return {};
    for (;;) {
      if (auto e = ended()) return *e;
      // A task gone from the queue without its exit file was cancelled or lost with its node.
      const std::set<std::string> alive = queue();
      for (auto it = running_.begin(); it != running_.end(); ++it) {
        if (alive.count(it->second.slurm)) continue;
        if (auto e = ended()) return *e;  // it wrote its exit file just before leaving the queue
        TaskEnd te{it->first, 1, 0};
        std::ofstream(it->second.log, std::ios::app)
            << "error: Slurm task " << it->second.slurm
            << " left the queue without an exit status (cancelled, "
            << "or its node was lost and it was not requeued); its Slurm output: "
            << (it->second.dir / (std::to_string(it->second.index) + ".slurm.out")).string() << "\n";
        running_.erase(it);
        return te;
      }
      std::this_thread::sleep_for(std::chrono::duration<double>(o_.poll_s));  // polling the scheduler
    }
  }
  void interrupt_all() override {
    std::set<std::string> jobs;
    for (const auto& [id, t] : running_) jobs.insert(t.slurm.substr(0, t.slurm.find('_')));
    for (const auto& j : jobs) {
      int code = 0;
      capture({"scancel", "--signal=INT", "--full", j}, code);
    }
  }
  std::string holder(const std::string& id) const override {
    auto it = running_.find(id);
    return it == running_.end() ? "" : "slurm " + it->second.slurm;
  }

 private:
  struct Queued {
    std::vector<std::string> args;
    fs::path log;
  };
  struct Task {
    std::string id, slurm;
    fs::path dir, log;
    size_t index = 0;
  };

  std::optional<TaskEnd> ended() {
    for (auto it = running_.begin(); it != running_.end(); ++it) {
      const fs::path exit_file = it->second.dir / (std::to_string(it->second.index) + ".exit");
      std::ifstream in(exit_file);
      int code = 0;
      if (!(in >> code)) continue;
      TaskEnd e{it->first, code, 0};
      std::ifstream times(it->second.dir / (std::to_string(it->second.index) + ".times"));
      std::string a, b, c, d;
      if (times >> a >> b >> c >> d) e.cpu_s = minutes_seconds(c) + minutes_seconds(d);  // the children's
      running_.erase(it);
      return e;
    }
    return std::nullopt;
  }
  std::set<std::string> queue() const {
    std::set<std::string> jobs, alive;
    for (const auto& [id, t] : running_) jobs.insert(t.slurm.substr(0, t.slurm.find('_')));
    std::string list;
    for (const auto& j : jobs) list += (list.empty() ? "" : ",") + j;
    int code = 0;
    const std::string out = capture({"squeue", "-h", "-r", "-o", "%i", "-j", list}, code);
    if (code != 0) {
      // squeue fails for jobs it no longer knows; any other failure (the controller unreachable) must not be
      // read as every task gone: they count as alive until squeue answers.
      if (out.find("Invalid job id") != std::string::npos) return alive;
      for (const auto& [id, t] : running_) alive.insert(t.slurm);
      return alive;
    }
    std::istringstream in(out);
    std::string line;
    while (std::getline(in, line))
      if (!line.empty()) alive.insert(line);
    return alive;
  }

  SlurmOptions o_;
  fs::path state_;
  int batch_ = 0;
  std::vector<Queued> queued_;
  std::map<std::string, Task> running_;
};

}  // namespace

std::unique_ptr<Executor> local_executor() {
  return std::make_unique<LocalExecutor>();
}

std::unique_ptr<Executor> slurm_executor(const SlurmOptions& o, const fs::path& state_dir) {
  int code = 0;
  capture({"sbatch", "--version"}, code);
  if (code != 0)
    throw Error("--executor slurm: sbatch cannot be run (is Slurm's client installed and on PATH?)");
  return std::make_unique<SlurmExecutor>(o, state_dir);
}

bool slurm_job_alive(const std::string& job) {
  int code = 0;
  const std::string out = capture({"squeue", "-h", "-o", "%T", "-j", job}, code);
  return code == 0 && out.find_first_not_of(" \n") != std::string::npos;
}

}  // namespace hf::apps
