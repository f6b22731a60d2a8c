// A single-node Slurm cluster for a test: munged, slurmctld and slurmd started as root on free ports with
// their configuration, state and logs in a temporary folder, stopped when the object goes away. Commands see
// it through SLURM_CONF (set in this process's environment while it lives).
#pragma once

#include <netinet/in.h>
#include <signal.h>
#include <sys/socket.h>
#include <unistd.h>

#include <chrono>
#include <cstdlib>
#include <fstream>
#include <string>
#include <thread>

#include "command.hpp"
#include "temp_dir.hpp"

namespace hf::test {

class SlurmCluster {
 public:
  SlurmCluster() {
    if (geteuid() != 0) {
      error_ = "a Slurm cluster for the tests is started as root";
      return;
    }
    for (const char* b : {"munged", "slurmctld", "slurmd", "sbatch", "squeue", "scontrol"})
      if (run_command(std::string("command -v ") + b).code != 0) {
        error_ = std::string(b) +
                 " is not installed (the README's set-up installs slurmctld slurmd slurm-client munge)";
        return;
      }
    const auto root = dir_.path();
    for (const char* d : {"state", "spool", "log"}) std::filesystem::create_directories(root / d);
    host_ = run_command("hostname -s").out;
    while (!host_.empty() && (host_.back() == '\n' || host_.back() == ' ')) host_.pop_back();
    {
      std::ofstream key(root / "munge.key", std::ios::binary);
      std::ifstream rnd("/dev/urandom", std::ios::binary);
      char buf[1024];
      rnd.read(buf, sizeof buf);
      key.write(buf, sizeof buf);
    }
    std::filesystem::permissions(root / "munge.key", std::filesystem::perms::owner_read);
    const std::string sock = (root / "munge.sock").string();
    auto r = run_command("munged -f --socket=" + quote(sock) + " --key-file=" + quote(root / "munge.key") +
                         " --log-file=" + quote(root / "log/munged.log") + " --pid-file=" +
                         quote(root / "munged.pid") + " --seed-file=" + quote(root / "munged.seed"));
    if (r.code != 0) {
      error_ = "munged: " + r.out;
      return;
    }
    munge_sock_ = sock;
    const int ctl = free_port(), slurmd = free_port();
    conf_ = root / "slurm.conf";
    std::ofstream(conf_)
        << "ClusterName=hftest\nSlurmctldHost=" << host_ << "\nSlurmUser=root\nSlurmdUser=root\n"
        << "AuthType=auth/munge\nCredType=cred/munge\nAuthInfo=socket=" << sock << "\n"
        << "SlurmctldPort=" << ctl << "\nSlurmdPort=" << slurmd << "\n"
        << "StateSaveLocation=" << (root / "state").string() << "\n"
        << "SlurmdSpoolDir=" << (root / "spool").string() << "\n"
        << "SlurmctldPidFile=" << (root / "slurmctld.pid").string() << "\n"
        << "SlurmdPidFile=" << (root / "slurmd.pid").string() << "\n"
        << "SlurmctldLogFile=" << (root / "log/slurmctld.log").string() << "\n"
        << "SlurmdLogFile=" << (root / "log/slurmd.log").string() << "\n"
        << "ProctrackType=proctrack/linuxproc\nTaskPlugin=task/none\n"
        << "JobAcctGatherType=jobacct_gather/none\nAccountingStorageType=accounting_storage/none\n"
        << "SelectType=select/cons_tres\nSelectTypeParameters=CR_CPU\nSchedulerType=sched/backfill\n"
        << "MpiDefault=none\nReturnToService=2\nJobRequeue=1\nMinJobAge=600\nKillWait=10\n"
        << "SchedulerParameters=sched_interval=1\n"
        << "NodeName=" << host_ << " CPUs=" << std::thread::hardware_concurrency() << " State=UNKNOWN\n"
        << "PartitionName=hf Nodes=ALL Default=YES MaxTime=INFINITE State=UP\n";
    setenv("SLURM_CONF", conf_.c_str(), 1);
    r = run_command("slurmctld -f " + quote(conf_) + " && slurmd -f " + quote(conf_));
    if (r.code != 0) {
      error_ = "slurmctld/slurmd: " + r.out;
      return;
    }
    // Up when the node is idle (polling the controller; it answers within seconds).
    for (int i = 0; i < 120; ++i) {
      const auto s = run_command("sinfo -h -o %t");
      if (s.code == 0 && s.out.find("idle") != std::string::npos) {
        ready_ = true;
        return;
      }
      std::this_thread::sleep_for(std::chrono::milliseconds(500));
    }
    error_ = "the node never became idle; slurmd log: " +
             run_command("tail -5 " + quote(root / "log/slurmd.log")).out;
  }
  ~SlurmCluster() {
    run_command(
        "scancel --full --signal=KILL --user=root >/dev/null 2>&1; scontrol shutdown >/dev/null 2>&1");
    for (const char* pid : {"slurmd.pid", "slurmctld.pid"}) {
      std::ifstream in(dir_.path() / pid);
      int p = 0;
      if (in >> p && p > 0) kill(p, SIGTERM);
    }
    if (!munge_sock_.empty())
      run_command("munged --stop --socket=" + quote(munge_sock_) + " >/dev/null 2>&1");
    unsetenv("SLURM_CONF");
  }
  SlurmCluster(const SlurmCluster&) = delete;
  SlurmCluster& operator=(const SlurmCluster&) = delete;

  bool ready() const { return ready_; }
  const std::string& error() const { return error_; }
  const std::filesystem::path& conf() const { return conf_; }
  std::string env() const { return "SLURM_CONF=" + quote(conf_) + " "; }
  const std::filesystem::path& dir() const { return dir_.path(); }

 private:
  static int free_port() {
    const int fd = socket(AF_INET, SOCK_STREAM, 0);
    sockaddr_in a{};
    a.sin_family = AF_INET;
    a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    a.sin_port = 0;
    socklen_t len = sizeof a;
    int port = 0;
    if (bind(fd, reinterpret_cast<sockaddr*>(&a), sizeof a) == 0 &&
        getsockname(fd, reinterpret_cast<sockaddr*>(&a), &len) == 0)
      port = ntohs(a.sin_port);
    close(fd);
    return port;
  }

  TempDir dir_;
  std::string host_, munge_sock_, error_;
  std::filesystem::path conf_;
  bool ready_ = false;
};

}  // namespace hf::test
