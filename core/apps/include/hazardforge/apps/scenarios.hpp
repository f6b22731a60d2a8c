// The scenarios a test or an export takes: a campaign's verified attempts, run folders, or scenario packages.
#pragma once

#include <filesystem>
#include <string>
#include <vector>

#include "hazardforge/scenario_package.hpp"

namespace hf::apps {

struct Scenario {
  std::string id;  // its folder relative to the campaign (or its folder's name), unique
  std::filesystem::path run_dir;
  scenario::Package pkg;
  std::string recording;
};

// Every scenario under `roots`: a campaign folder (index.json) gives its verified attempts that have a
// package (others are reported on stderr and skipped), a run or package folder itself. Throws hf::Error
// naming a root that is none of these, or a package that cannot be read.
std::vector<Scenario> find_scenarios(const std::vector<std::string>& roots);

// A JSON file's content; throws hf::Error naming the file.
nlohmann::json read_json_file(const std::filesystem::path& p);
// The same, or null when the file is missing or not JSON (a campaign folder's files while tasks write them).
nlohmann::json read_json_or_null(const std::filesystem::path& p);

}  // namespace hf::apps
