// Finding the scenarios of campaigns, run folders and packages.
#include "hazardforge/apps/scenarios.hpp"

#include <fstream>
#include <iostream>
#include <set>

#include "hazardforge/error.hpp"

namespace hf::apps {

namespace fs = std::filesystem;

Json read_json_file(const fs::path& p) {
  std::ifstream in(p);
  if (!in) throw Error("'" + p.string() + "' cannot be read");
  try {
    return Json::parse(in);
  } catch (const nlohmann::json::exception& e) {
    throw Error("'" + p.string() + "' is not JSON: " + e.what());
  }
}

Json read_json_or_null(const fs::path& p) {
  std::ifstream in(p);
  if (!in) return nullptr;
  try {
    return Json::parse(in);
  } catch (const std::exception&) {
    return nullptr;
  }
}

// The scenarios of a campaign (its verified attempts), of a run folder or of a package folder.
std::vector<Scenario> find_scenarios(const std::vector<std::string>& roots) {
  std::vector<Scenario> out;
  std::set<std::string> ids;
  auto add = [&](const fs::path& run, std::string id, std::string recording) {
    Scenario s;
    s.pkg = scenario::read_package(run);
    s.run_dir = run;
    s.recording = std::move(recording);
    if (s.recording.empty()) s.recording = s.pkg.header.origin.scene;
    std::string base = id;
    for (int n = 2; ids.count(id); ++n) id = base + "-" + std::to_string(n);
    ids.insert(id);
    s.id = std::move(id);
    out.push_back(std::move(s));
  };
  for (const std::string& r : roots) {
    const fs::path root = fs::absolute(r);
    if (fs::is_regular_file(root / "index.json")) {
      const Json index = read_json_file(root / "index.json");
      if (!index.contains("attempts") || !index["attempts"].is_array())
        throw Error("'" + (root / "index.json").string() +
                    "' has no list 'attempts': not a campaign's index");
      size_t found = 0;
      for (const Json& a : index["attempts"]) {
        if (!a.value("passed", false)) continue;
        const fs::path run = root / a.value("folder", "");
        if (!scenario::find_package(run)) {
          std::cerr << "test: " << run.string()
                    << " is verified but has no scenario package (a run from before "
                    << "the scenario_package sink); skipped\n";
          continue;
        }
        add(run, a.value("folder", ""), a.value("recording", ""));
        ++found;
      }
      if (!found) std::cerr << "test: campaign '" << root.string() << "' has no verified scenario to test\n";
    } else if (scenario::find_package(root)) {
      add(root, root.filename().string(), "");
    } else {
      throw Error("'" + r +
                  "' is neither a campaign folder (index.json), a run folder (scenario/) nor a "
                  "scenario package (scenario.json)");
    }
  }
  return out;
}

}  // namespace hf::apps
