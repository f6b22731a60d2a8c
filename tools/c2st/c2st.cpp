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
  std::string picture;  // the inserted object's picture (realism.json beside realism/): one object
  std::map<std::string, std::map<int64_t, std::vector<std::vector<float>>>> real;  // by class, then track
  std::map<std::pair<std::string, std::string>, std::vector<std::vector<float>>> inserted;  // (class, source)
};

RunCrops read_run(const fs::path& file) {
  RunCrops r;
  r.file = file;
  std::ifstream head(file.parent_path().parent_path() / "realism.json");
  if (head) {
    const Json h = Json::parse(head, nullptr, false);
    if (h.is_object() && h.contains("picture_file") && h["picture_file"].is_string())
      r.picture = fs::path(h["picture_file"].get<std::string>()).filename().string();
  }
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
    std::cout << "class    picture source  runs  pictures  inserted  real  objects  AUC   95 % interval  "
                 "held out  control (real vs real)\n";
    for (const auto& g : groups) {
      std::vector<std::vector<float>> real, ins;
      std::vector<int64_t> real_ids, ins_ids;
      std::vector<std::pair<const std::vector<std::vector<float>>*, int64_t>> objects;  // each real object
      std::map<std::string, int64_t> picture_ids;  // one inserted object per picture drawn
      int n_runs = 0;
      for (size_t ri = 0; ri < runs.size(); ++ri) {
        const auto& r = runs[ri];
        auto it = r.inserted.find(g);
        if (it == r.inserted.end() || it->second.empty()) continue;
        ++n_runs;
        const std::string pic = r.picture.empty() ? r.file.string() : r.picture;
        const int64_t pid = picture_ids.emplace(pic, static_cast<int64_t>(picture_ids.size())).first->second;
        ins.insert(ins.end(), it->second.begin(), it->second.end());
        ins_ids.insert(ins_ids.end(), it->second.size(), pid);
        if (auto rr = r.real.find(g.first); rr != r.real.end())
          for (const auto& [track, crops] : rr->second) {
            const int64_t oid = static_cast<int64_t>(ri) * 1000000 + track;
            real.insert(real.end(), crops.begin(), crops.end());
            real_ids.insert(real_ids.end(), crops.size(), oid);
            objects.push_back({&crops, oid});
          }
      }
      const auto res = hf::realism::c2st(real, ins, 5, seed, 1000, 5, real_ids, ins_ids);
      // The control: real against real, the objects split in two halves of about equal crop counts.
      std::sort(objects.begin(), objects.end(), [](auto& a, auto& b) { return a.first->size() > b.first->size(); });
      std::vector<std::vector<float>> half[2];
      std::vector<int64_t> half_ids[2];
      for (const auto& [crops, oid] : objects) {
        const int k = half[0].size() <= half[1].size() ? 0 : 1;
        half[k].insert(half[k].end(), crops->begin(), crops->end());
        half_ids[k].insert(half_ids[k].end(), crops->size(), oid);
      }
      const auto control = hf::realism::c2st(half[0], half[1], 5, seed, 1000, 5, half_ids[0], half_ids[1]);
      char row[300];
      const std::string ci = std::isfinite(res.auc)
                                 ? "[" + hf::num_text(res.ci_low, 2) + ", " + hf::num_text(res.ci_high, 2) + "]"
                                 : "too few crops";
      std::snprintf(row, sizeof row, "%-8s %-15s %4d  %8zu  %8d  %4d  %7zu  %-4s  %-13s  %-8s  %s\n",
                    g.first.c_str(), g.second.empty() ? "(none)" : g.second.c_str(), n_runs, picture_ids.size(),
                    res.n_inserted, res.n_real, objects.size(), hf::num_text(res.auc, 2).c_str(), ci.c_str(),
                    res.grouped ? "objects" : "crops",
                    std::isfinite(control.auc) ? hf::num_text(control.auc, 2).c_str() : "-");
      std::cout << row;
      Json j = {{"class", g.first}, {"picture_source", g.second}, {"runs", n_runs},
                {"inserted_crops", res.n_inserted}, {"real_crops", res.n_real}, {"classifier", res.classifier}};
      j["auc"] = std::isfinite(res.auc) ? Json(res.auc) : Json();
      if (std::isfinite(res.auc)) j["auc_ci95"] = {res.ci_low, res.ci_high};
      j["real_objects"] = objects.size();
      j["pictures"] = picture_ids.size();
      j["folds_hold_out_objects"] = res.grouped;
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
