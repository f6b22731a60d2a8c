// hazardforge test: a system under test run over verified scenarios, scored against their labels
// (docs/testing-a-system.md).
#pragma once

#include <atomic>
#include <filesystem>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include "hazardforge/core/host.hpp"
#include "hazardforge/scenario_package.hpp"

namespace hf::apps {

struct SystemTestOptions {
  std::vector<std::string> systems;    // SUT files
  std::vector<std::string> scenarios;  // campaign folders, run folders or package folders
  std::string output_dir;
  int jobs = 1;
  double critical_ttc_s = 1.5;  // the hazard is critical once its true TTC falls below this
  double min_lead_s = 0.0;      // a pass needs a warning this long before that moment
  double match_iou = 0.5;       // a detection is the hazard at this IoU with its label box
  std::vector<std::string> plugin_paths;
  const std::atomic<bool>* interrupt = nullptr;
};

// The pass rule of a test.
struct PassRule {
  double critical_ttc_s = 1.5;
  double min_lead_s = 0.0;
  double match_iou = 0.5;
};

// Reads system/responses.jsonl (the system_responses sink's SystemResponse lines); throws hf::Error naming the file and line.
std::vector<SystemResponse> read_responses(const std::filesystem::path& file);

// What one system did in one scenario (the JSON of report.json's scenario entries).
Json score_scenario(const scenario::Package& pkg, const std::vector<SystemResponse>& augmented,
                    const std::vector<SystemResponse>& control, const PassRule& rule);

int cmd_test(core::Host& host, const SystemTestOptions& o);

}  // namespace hf::apps
