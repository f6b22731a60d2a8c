// hf_c2st: the realism two-sample classifier test pooled over runs and campaigns. Reads every
// realism/crops.jsonl below the folders given (written by the realism_test sink) and, per object class and
// picture source (footage, harvested, generated), tests the inserted crops against the real crops of the same
// runs (hazardforge/realism/c2st.hpp), and, as the control, the real objects against each other (split in two
// by object): a test that tells real objects apart measures identity as much as realism.
//
//   build/bin/hf_c2st runs/campaign_a runs/campaign_b [--json pooled.json]
#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <map>
#include <set>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>

#include "hazardforge/number_text.hpp"
#include "hazardforge/realism/c2st.hpp"

namespace fs = std::filesystem;
using Json = nlohmann::json;

namespace {

struct RunCrops {
  fs::path file;
  std::map<std::string, std::map<int64_t, std::vector<std::vector<float>>>> real;  // by class, then track
  std::map<std::pair<std::string, std::string>, std::vector<std::vector<float>>> inserted;  // (class, source)
};

RunCrops read_run(const fs::path& file) {
  RunCrops r;
  r.file = file;
  std::ifstream in(file);
  std::string line;
  int n = 0;
  while (std::getline(in, line)) {
    ++n;
    if (line.empty()) continue;
    Json j;
    try {
      j = Json::parse(line);
    } catch (const Json::exception& e) {
      throw std::runtime_error(file.string() + ":" + std::to_string(n) + ": not JSON: " + e.what());
    }
    if (!j.contains("set") || !j.contains("class") || !j.contains("features") || !j["features"].is_array())
      throw std::runtime_error(file.string() + ":" + std::to_string(n) + ": needs set, class and features");
    std::vector<float> f = j["features"].get<std::vector<float>>();
    if (j["set"] == "real")
      r.real[j["class"].get<std::string>()][j.value("track", int64_t{-1})].push_back(std::move(f));
    else
      r.inserted[{j["class"].get<std::string>(), j.value("source", std::string())}].push_back(std::move(f));
  }
  return r;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"hf_c2st: realism C2ST pooled over runs (their realism/crops.jsonl)"};
  std::vector<std::string> dirs;
  std::string json_out;
  unsigned seed = 1;
  app.add_option("folders", dirs, "run or campaign folders (searched recursively)")->required();
  app.add_option("--json", json_out, "also write the results as JSON");
  app.add_option("--seed", seed, "the folds' and bootstrap's seed");
  CLI11_PARSE(app, argc, argv);
  try {
    std::vector<RunCrops> runs;
    for (const auto& d : dirs) {
      if (!fs::exists(d)) throw std::runtime_error(d + ": no such folder");
      for (const auto& e : fs::recursive_directory_iterator(d))
        if (e.path().filename() == "crops.jsonl" && e.path().parent_path().filename() == "realism")
          runs.push_back(read_run(e.path()));
    }
    if (runs.empty()) throw std::runtime_error("no realism/crops.jsonl below the folders given");
    std::set<std::pair<std::string, std::string>> groups;
    for (const auto& r : runs)
      for (const auto& [k, v] : r.inserted) groups.insert(k);
    Json out = Json::array();
    std::cout << "class    picture source  runs  inserted  real  objects  AUC   95 % interval  control (real vs real)\n";
    for (const auto& g : groups) {
      std::vector<std::vector<float>> real, ins;
      std::vector<const std::vector<std::vector<float>>*> objects;  // each real object's crops
      int n_runs = 0;
      for (const auto& r : runs) {
        auto it = r.inserted.find(g);
        if (it == r.inserted.end() || it->second.empty()) continue;
        ++n_runs;
        ins.insert(ins.end(), it->second.begin(), it->second.end());
        if (auto rr = r.real.find(g.first); rr != r.real.end())
          for (const auto& [track, crops] : rr->second) {
            real.insert(real.end(), crops.begin(), crops.end());
            objects.push_back(&crops);
          }
      }
      const auto res = hf::realism::c2st(real, ins, 5, seed);
      // The control: real against real, the objects split in two halves of about equal crop counts.
      std::sort(objects.begin(), objects.end(), [](auto* a, auto* b) { return a->size() > b->size(); });
      std::vector<std::vector<float>> half[2];
      for (const auto* o : objects) {
        auto& h = half[0].size() <= half[1].size() ? half[0] : half[1];
        h.insert(h.end(), o->begin(), o->end());
      }
      const auto control = hf::realism::c2st(half[0], half[1], 5, seed);
      char row[300];
      const std::string ci = std::isfinite(res.auc)
                                 ? "[" + hf::num_text(res.ci_low, 2) + ", " + hf::num_text(res.ci_high, 2) + "]"
                                 : "too few crops";
      std::snprintf(row, sizeof row, "%-8s %-15s %4d  %8d  %4d  %7zu  %-4s  %-13s  %s\n", g.first.c_str(),
                    g.second.empty() ? "(none)" : g.second.c_str(), n_runs, res.n_inserted, res.n_real,
                    objects.size(), hf::num_text(res.auc, 2).c_str(), ci.c_str(),
                    std::isfinite(control.auc) ? hf::num_text(control.auc, 2).c_str() : "-");
      std::cout << row;
      Json j = {{"class", g.first}, {"picture_source", g.second}, {"runs", n_runs},
                {"inserted_crops", res.n_inserted}, {"real_crops", res.n_real}, {"classifier", res.classifier}};
      j["auc"] = std::isfinite(res.auc) ? Json(res.auc) : Json();
      if (std::isfinite(res.auc)) j["auc_ci95"] = {res.ci_low, res.ci_high};
      j["real_objects"] = objects.size();
      j["control_auc"] = std::isfinite(control.auc) ? Json(control.auc) : Json();
      out.push_back(j);
    }
    if (!json_out.empty()) std::ofstream(json_out) << out.dump(2) << "\n";
  } catch (const std::exception& e) {
    std::cerr << "hf_c2st: error: " << e.what() << "\n";
    return 1;
  }
  return 0;
}
