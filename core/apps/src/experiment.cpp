// `hazardforge experiment`: a base config under a list or matrix of overrides, each run in its own folder
// (a child process, up to --jobs at once), complete runs skipped, one comparison report across them.
#include <csignal>
#include <fstream>
#include <iomanip>
#include <iostream>
#include <map>
#include <sstream>

#include "hazardforge/apps/child_process.hpp"
#include "hazardforge/apps/commands.hpp"
#include "hazardforge/json_text.hpp"

namespace hf::apps {

using namespace hf::core;  // the host's public interface

namespace {

struct PlannedRun {
  std::string id;
  Json labels = Json::object();  // axis -> value label
  std::vector<std::string> overrides;
};

std::vector<PlannedRun> plan_runs(const YamlDocument& doc) {
  const Json& spec = doc.value;
  std::vector<Diagnostic> diags;
  auto bad = [&](const std::string& ptr, const std::string& msg) {
    diags.push_back({Diagnostic::Severity::kError, doc.at(ptr), msg});
  };
  auto overrides_of = [&](const Json& v, const std::string& ptr) {
    std::vector<std::string> o;
    if (v.is_string()) o.push_back(v.get<std::string>());
    else if (v.is_array())
      for (size_t i = 0; i < v.size(); ++i)
        if (v[i].is_string()) o.push_back(v[i].get<std::string>());
        else bad(ptr + "/" + std::to_string(i), "an override is a string 'node.param=value'");
    else bad(ptr, "expected an override 'node.param=value' or a list of them");
    return o;
  };
  std::vector<PlannedRun> runs{PlannedRun{}};
  if (spec.contains("matrix")) {
    if (!spec["matrix"].is_object()) bad("/matrix", "'matrix' maps axis -> {label: overrides}");
    else
      for (auto axis = spec["matrix"].begin(); axis != spec["matrix"].end(); ++axis) {
        if (!axis->is_object() || axis->empty()) {
          bad("/matrix/" + axis.key(), "axis '" + axis.key() + "' maps labels to overrides");
          continue;
        }
        std::vector<PlannedRun> next;
        for (const PlannedRun& r : runs)
          for (auto val = axis->begin(); val != axis->end(); ++val) {
            PlannedRun n = r;
            n.labels[axis.key()] = val.key();
            for (auto& s : overrides_of(*val, "/matrix/" + axis.key() + "/" + val.key())) n.overrides.push_back(s);
            n.id += (n.id.empty() ? "" : "__") + val.key();
            next.push_back(std::move(n));
          }
        runs = std::move(next);
      }
  }
  if (spec.contains("runs")) {
    if (!spec.contains("matrix")) runs.clear();
    const Json& list = spec["runs"];
    if (!list.is_array()) bad("/runs", "'runs' is a list of {name, set}");
    else
      for (size_t i = 0; i < list.size(); ++i) {
        const std::string p = "/runs/" + std::to_string(i);
        if (!list[i].is_object() || !list[i].contains("name") || !list[i]["name"].is_string()) {
          bad(p, "a run needs a 'name'");
          continue;
        }
        PlannedRun r;
        r.id = list[i]["name"].get<std::string>();
        r.labels["run"] = r.id;
        if (list[i].contains("set")) r.overrides = overrides_of(list[i]["set"], p + "/set");
        runs.push_back(std::move(r));
      }
  }
  if (runs.size() == 1 && runs[0].id.empty()) runs[0].id = "base";
  std::map<std::string, int> seen;
  for (const auto& r : runs)
    if (++seen[r.id] == 2) bad("", "two runs are both named '" + r.id + "'");
  if (!diags.empty()) throw DiagnosticError(std::move(diags));
  return runs;
}

std::string run_status(const std::filesystem::path& dir) {
  std::ifstream in(dir / "manifest.json");
  if (!in) return "";
  try {
    Json m = Json::parse(in);
    return m.value("status", "");
  } catch (const std::exception&) {
    return "";
  }
}

std::filesystem::path log_while_running(const std::filesystem::path& dir, const std::string& id) {
  return dir / (id + ".run.log");
}

// Flattens the comparable numbers of a run: manifest facts plus any report.json "summary" rows it wrote.
Json collect_results(const std::filesystem::path& dir) {
  Json out = Json::object();
  std::ifstream mi(dir / "manifest.json");
  if (mi) {
    try {
      Json m = Json::parse(mi);
      out["status"] = m.value("status", "");
      out["frames"] = m.value("frames", 0);
      out["wall_seconds"] = m.value("wall_seconds", 0.0);
    } catch (const std::exception&) {
      out["status"] = "unreadable manifest";
    }
  }
  std::error_code ec;
  for (const auto& e : std::filesystem::recursive_directory_iterator(dir, ec)) {
    if (e.path().filename() != "report.json") continue;
    std::ifstream in(e.path());
    try {
      Json r = Json::parse(in);
      if (r.contains("summary")) out["summary"] = r["summary"];
    } catch (const std::exception&) {
    }
  }
  return out;
}

}  // namespace

int cmd_experiment(Host& /*host*/, const ExperimentOptions& o) {
  YamlDocument doc;
  std::vector<PlannedRun> runs;
  std::filesystem::path base;
  std::string name;
  try {
    doc = load_yaml_file(o.spec);
    if (!doc.value.is_object() || !doc.value.contains("base") || !doc.value["base"].is_string())
      throw DiagnosticError({{Diagnostic::Severity::kError, doc.at(""), "an experiment needs 'base: CONFIG.yaml'"}});
    base = expand_vars(doc.value["base"].get<std::string>());
    if (base.is_relative()) base = std::filesystem::absolute(o.spec).parent_path() / base;
    base = base.lexically_normal();
    if (!std::filesystem::exists(base))
      throw DiagnosticError({{Diagnostic::Severity::kError, doc.at("/base"), "base config " + base.string() + " not found"}});
    name = doc.value.value("name", std::filesystem::path(o.spec).stem().string());
    runs = plan_runs(doc);
  } catch (const Error& e) {
    std::cerr << e.what() << "\n";
    return 1;
  }
  const std::filesystem::path dir = o.output_dir.empty() ? std::filesystem::path("runs") / name : std::filesystem::path(o.output_dir);
  std::filesystem::create_directories(dir);
  int jobs = o.jobs;
  if (doc.value.contains("jobs") && doc.value["jobs"].is_number_integer() && o.jobs == 1)
    jobs = std::max(1, doc.value["jobs"].get<int>());
  const std::string exe = (executable_dir() / "hazardforge").string();

  std::map<pid_t, size_t> running;
  std::vector<int> codes(runs.size(), 0);
  size_t next = 0, skipped = 0;
  auto reap_one = [&] {
    const ChildExit ex = wait_any_child();
    if (ex.pid <= 0) return;
    const size_t i = running.at(ex.pid);
    running.erase(ex.pid);
    codes[i] = ex.exit_code;
    std::error_code ec;
    std::filesystem::rename(log_while_running(dir, runs[i].id), dir / runs[i].id / "run.log", ec);
    std::cerr << "experiment: " << runs[i].id << (codes[i] == 0 ? " completed" : " FAILED (exit " + std::to_string(codes[i]) + ", see " + (dir / runs[i].id / "run.log").string() + ")") << "\n";
  };
  while (next < runs.size() || !running.empty()) {
    if (o.interrupt && o.interrupt->load()) {
      for (auto& [pid, i] : running) kill(pid, SIGINT);
      while (!running.empty()) reap_one();
      std::cerr << "experiment interrupted; completed runs are kept and will be skipped next time\n";
      return 130;
    }
    if (next < runs.size() && running.size() < static_cast<size_t>(jobs)) {
      const PlannedRun& r = runs[next];
      const auto rdir = dir / r.id;
      if (!o.force && run_status(rdir) == "completed") {
        std::cerr << "experiment: " << r.id << " already complete, skipped\n";
        ++skipped;
        ++next;
        continue;
      }
      std::vector<std::string> args = {exe};
      for (const auto& p : o.plugin_paths) args.insert(args.end(), {"--plugin-path", p});
      // A run not completed (or forced) is re-run from scratch; its folder belongs to the new run.
      args.insert(args.end(), {"run", base.string(), "-o", rdir.string(), "-q", "--overwrite", "--set-base",
                               std::filesystem::absolute(o.spec).parent_path().string()});
      for (const auto& s : r.overrides) args.insert(args.end(), {"--set", s});
      // The log stays beside the run folder while the run owns that folder, and moves into it afterwards.
      running[spawn_logged(args, log_while_running(dir, r.id))] = next;
      std::cerr << "experiment: started " << r.id << "\n";
      ++next;
      continue;
    }
    reap_one();
  }

  Json cmp = {{"name", name}, {"base", base.string()}, {"runs", Json::array()}};
  std::ostringstream md;
  md << "# Experiment: " << name << "\n\nBase config `" << base.string() << "`, " << runs.size() << " runs.\n\n";
  md << "| run | overrides | status | frames | seconds |\n|---|---|---|---:|---:|\n";
  int failed = 0;
  for (size_t i = 0; i < runs.size(); ++i) {
    Json res = collect_results(dir / runs[i].id);
    Json row = {{"id", runs[i].id}, {"labels", runs[i].labels}, {"overrides", runs[i].overrides}, {"results", res}};
    cmp["runs"].push_back(row);
    std::string ov;
    for (const auto& s : runs[i].overrides) ov += (ov.empty() ? "`" : "<br>`") + s + "`";
    md << "| " << runs[i].id << " | " << ov << " | " << res.value("status", "missing") << " | " << res.value("frames", 0)
       << " | " << std::fixed << std::setprecision(1) << res.value("wall_seconds", 0.0) << " |\n";
    if (res.value("status", "") != "completed") ++failed;
  }
  // Evaluation summaries side by side: one table with a row per (run, summary row).
  std::vector<std::string> cols;
  for (const auto& r : cmp["runs"])
    if (r["results"].contains("summary") && r["results"]["summary"].is_array())
      for (const auto& row : r["results"]["summary"])
        for (auto it = row.begin(); it != row.end(); ++it)
          if (std::find(cols.begin(), cols.end(), it.key()) == cols.end()) cols.push_back(it.key());
  if (!cols.empty()) {
    md << "\n## Evaluation summaries\n\n| run |";
    for (const auto& c : cols) md << " " << c << " |";
    md << "\n|---|";
    for (size_t i = 0; i < cols.size(); ++i) md << "---|";
    md << "\n";
    for (const auto& r : cmp["runs"]) {
      if (!r["results"].contains("summary")) continue;
      for (const auto& row : r["results"]["summary"]) {
        md << "| " << r["id"].get<std::string>() << " |";
        for (const auto& c : cols) {
          if (!row.contains(c) || row[c].is_null()) md << " |";
          else if (row[c].is_number_float()) md << " " << std::setprecision(3) << row[c].get<double>() << " |";
          else
            md << " " << (row[c].is_string() ? row[c].get<std::string>() : hf::json_text(row[c])) << " |";
        }
        md << "\n";
      }
    }
  }
  write_file_atomic(dir / "comparison.json", hf::json_text(cmp, 2));
  write_file_atomic(dir / "comparison.md", md.str());
  std::cout << md.str();
  std::cerr << "experiment: " << runs.size() - failed << "/" << runs.size() << " runs complete (" << skipped
            << " skipped as already complete) -> " << (dir / "comparison.md").string() << "\n";
  return failed == 0 ? 0 : 1;
}

}  // namespace hf::apps
