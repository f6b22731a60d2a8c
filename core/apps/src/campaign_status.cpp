// `hazardforge campaign status DIR`: a campaign folder's state from its files alone.
#include <fcntl.h>
#include <sys/file.h>
#include <unistd.h>

#include <algorithm>
#include <fstream>
#include <iostream>
#include <map>

#include <nlohmann/json.hpp>

#include "hazardforge/apps/campaign.hpp"
#include "hazardforge/apps/executor.hpp"
#include "hazardforge/apps/scenarios.hpp"
#include "hazardforge/json_text.hpp"

namespace hf::apps {

namespace fs = std::filesystem;
using Json = nlohmann::json;

namespace {

// An attempt's lock without its attempt.json: still running (a local process holds the lock, or its Slurm
// task is queued or running), or stopped half-way (the campaign runs it again when it runs again).
std::string unfinished_state(const fs::path& lock) {
  const int fd = ::open(lock.c_str(), O_RDONLY | O_CLOEXEC);
  if (fd < 0) return "stopped";
  std::string state = "stopped";
  if (flock(fd, LOCK_SH | LOCK_NB) != 0) {
    state = "running";
  } else {
    char holder[64] = {};
    if (::read(fd, holder, sizeof holder - 1) > 0 && std::string(holder).rfind("slurm ", 0) == 0) {
      std::string job(holder + 6);
      job.erase(job.find_last_not_of(" \n") + 1);
      if (slurm_job_alive(job)) state = "queued or running (Slurm " + job + ")";
    }
    flock(fd, LOCK_UN);
  }
  ::close(fd);
  return state;
}

}  // namespace

int cmd_campaign_status(const fs::path& dir, bool as_json) {
  const Json index = read_json_or_null(dir / "index.json");
  if (!fs::exists(dir / "campaign.json")) {
    std::cerr << "error: " << dir.string() << " is not a campaign folder (no campaign.json)\n";
    return 1;
  }
  Json st = {{"folder", fs::absolute(dir).lexically_normal().string()},
             {"name", index.is_object() ? index.value("name", "") : ""},
             {"complete", index.is_object() && index.value("complete", false)},
             {"skipped", index.is_object() ? index.value("skipped", Json::array()) : Json::array()}};
  std::map<std::string, int> outcomes;
  Json failed = Json::array(), unfinished = Json::array();
  std::map<std::pair<std::string, std::string>, bool> pair_verified;
  std::error_code ec;
  // attempts/<recording>/<kind>/<attempt>/attempt.json, and <attempt>.lock while one runs.
  for (const auto& rec : fs::directory_iterator(dir / "attempts", ec)) {
    if (!rec.is_directory()) continue;
    for (const auto& kind : fs::directory_iterator(rec.path(), ec)) {
      if (!kind.is_directory()) continue;
      const auto key = std::make_pair(rec.path().filename().string(), kind.path().filename().string());
      pair_verified.emplace(key, false);
      std::vector<fs::path> entries;
      for (const auto& e : fs::directory_iterator(kind.path(), ec)) entries.push_back(e.path());
      std::sort(entries.begin(), entries.end());
      for (const fs::path& e : entries) {
        if (e.extension() == ".lock") {
          const fs::path attempt = e.parent_path() / e.stem();
          if (fs::exists(attempt / "attempt.json")) continue;
          const std::string state = unfinished_state(e);
          ++outcomes[state.rfind("stopped", 0) == 0   ? "stopped"
                     : state.rfind("running", 0) == 0 ? "running"
                                                      : "queued"];
          const fs::path log =
              fs::exists(attempt / "run.log") ? attempt / "run.log" : fs::path(attempt.string() + ".log");
          unfinished.push_back({{"attempt", fs::relative(attempt, dir).string()},
                                {"state", state},
                                {"log", fs::relative(log, dir).string()}});
          continue;
        }
        if (!fs::is_directory(e)) continue;
        const Json a = read_json_or_null(e / "attempt.json");
        if (!a.is_object()) continue;
        const std::string outcome = a.value("outcome", "failed");
        ++outcomes[outcome];
        if (a.value("passed", false)) pair_verified[key] = true;
        if (outcome == "failed" || a.value("exit_code", 0) != 0) {
          std::string reason;
          for (const Json& r : a.value("reasons", Json::array()))
            if (r.is_string()) reason += (reason.empty() ? "" : "; ") + r.get<std::string>();
          failed.push_back({{"attempt", fs::relative(e, dir).string()},
                            {"exit_code", a.value("exit_code", 0)},
                            {"reason", reason},
                            {"log", fs::relative(e / "run.log", dir).string()}});
        }
      }
    }
  }
  int verified_pairs = 0;
  for (const auto& [k, v] : pair_verified) verified_pairs += v ? 1 : 0;
  const int pairs = index.is_object() ? index["summary"].value("pairs", 0) : 0;
  st["pairs"] = {{"total", std::max(pairs, static_cast<int>(pair_verified.size()))},
                 {"verified", verified_pairs},
                 {"with_attempts", pair_verified.size()}};
  st["attempts"] = outcomes;
  st["failed"] = failed;
  st["unfinished"] = unfinished;
  // Slurm: tasks submitted (N.args) without an exit status (N.exit) yet.
  int arrays = 0, tasks = 0, ended = 0;
  for (const auto& batch : fs::directory_iterator(dir / "slurm", ec)) {
    if (!batch.is_directory()) continue;
    ++arrays;
    for (const auto& f : fs::directory_iterator(batch.path(), ec)) {
      if (f.path().extension() == ".args") ++tasks;
      if (f.path().extension() == ".exit") ++ended;
    }
  }
  if (arrays > 0) st["slurm"] = {{"arrays", arrays}, {"tasks", tasks}, {"ended", ended}};
  if (as_json) {
    std::cout << json_text(st, 2) << "\n";
    return 0;
  }
  std::cout << "campaign " << st["name"].get<std::string>() << " in " << st["folder"].get<std::string>()
            << ": " << (st["complete"].get<bool>() ? "complete" : "not complete") << "\n";
  std::cout << "pairs: " << verified_pairs << " of " << st["pairs"]["total"].get<int>() << " verified ("
            << pair_verified.size() << " with attempts)\n";
  std::cout << "attempts:";
  int n = 0;
  for (const auto& [k, v] : outcomes) std::cout << (n++ ? ", " : " ") << v << " " << k;
  std::cout << (outcomes.empty() ? " none" : "") << "\n";
  if (arrays > 0)
    std::cout << "slurm: " << arrays << " job arrays, " << tasks << " tasks, " << ended
              << " with an exit status\n";
  for (const Json& k : st["skipped"])
    std::cout << "left out: " << k.value("what", "") << ": " << k.value("reason", "") << "\n";
  for (const Json& u : unfinished)
    std::cout << u["state"].get<std::string>() << ": " << u["attempt"].get<std::string>() << " (log "
              << u["log"].get<std::string>() << ")\n";
  for (const Json& f : failed)
    std::cout << "failed: " << f["attempt"].get<std::string>() << " (exit " << f["exit_code"].get<int>()
              << ", log " << f["log"].get<std::string>() << ")"
              << (f["reason"].get<std::string>().empty() ? "" : ": ") << f["reason"].get<std::string>()
              << "\n";
  return 0;
}

}  // namespace hf::apps
