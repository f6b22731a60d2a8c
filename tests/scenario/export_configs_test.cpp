// Every shipped scenario config exports a scenario and road that validate and whose hazard the ego meets.
#include <gtest/gtest.h>
#include <yaml-cpp/yaml.h>

#include <filesystem>
#include <fstream>
#include <iostream>
#include <regex>
#include <set>
#include <string>

#include "command.hpp"
#include "resimulation.hpp"
#include "xml_files.hpp"

namespace hf {
namespace {

namespace fs = std::filesystem;

// The config cut down to what the export needs: the xosc node and, transitively, the nodes it reads from; the
// source stops one frame after the generator's trigger frame.
std::string export_only(const fs::path& config) {
  YAML::Node root = YAML::LoadFile(config.string());
  std::map<std::string, YAML::Node> nodes;
  std::vector<std::string> todo;
  for (const YAML::Node& n : root["nodes"]) {
    nodes[n["id"].as<std::string>()] = n;
    if (n["stage"].as<std::string>() == "xosc") todo.push_back(n["id"].as<std::string>());
  }
  EXPECT_EQ(todo.size(), 1u) << config;
  std::set<std::string> keep;
  while (!todo.empty()) {
    const std::string id = todo.back();
    todo.pop_back();
    if (!keep.insert(id).second) continue;
    auto add = [&](const YAML::Node& v) {
      const std::string ref = v.as<std::string>();
      todo.push_back(ref.substr(0, ref.find('.')));
    };
    for (const auto& in : nodes[id]["inputs"]) {
      if (in.second.IsSequence())
        for (const YAML::Node& v : in.second) add(v);
      else
        add(in.second);
    }
  }
  // Paths in params are relative to the config's folder; the cut config lives elsewhere.
  for (auto& [id, n] : nodes)
    for (auto p : n["params"])
      if (p.second.IsScalar()) {
        const std::string v = p.second.as<std::string>();
        if (!v.empty() && v[0] != '/' && v.find("${") == std::string::npos &&
            fs::exists(config.parent_path() / v))
          p.second = fs::weakly_canonical(config.parent_path() / v).string();
      }
  YAML::Node out;
  out["name"] = root["name"].as<std::string>() + "_export";
  for (const YAML::Node& n : root["nodes"]) {
    if (!keep.count(n["id"].as<std::string>())) continue;
    out["nodes"].push_back(YAML::Clone(n));
  }
  int trigger = -1;
  for (const YAML::Node& n : out["nodes"])
    if (n["stage"].as<std::string>() == "llm_hazard" && n["params"]["trigger_frame"])
      trigger = n["params"]["trigger_frame"].as<int>();
  if (trigger >= 0)
    for (YAML::Node n : out["nodes"])
      if (n["id"].as<std::string>() == "source") n["params"]["max_frames"] = trigger + 1;
  YAML::Emitter e;
  e << out;
  return e.c_str();
}

class ShippedConfig : public ::testing::TestWithParam<std::string> {};

TEST_P(ShippedConfig, ExportsAValidScenarioWhoseHazardTheEgoMeets) {
  const fs::path shared = test::shared_dir();
  HF_REQUIRE_SHARED(test::xosc_schema());
  HF_REQUIRE_SHARED(shared / "models/yolov8n/yolov8n_deq_640x384.onnx");
  const fs::path exe = fs::path(HF_BINARY_DIR "/bin/hazardforge");
  ASSERT_TRUE(fs::exists(exe)) << exe;
  const fs::path dir = test::unique_temp_dir();
  const fs::path config = test::source_dir() / "configs" / (GetParam() + ".yaml");
  const fs::path cut = dir / (GetParam() + ".yaml");
  test::write_text(cut, export_only(config));
  const test::CommandResult r =
      test::run_command("HAZARDFORGE_SHARED=" + test::quote(shared) + " " + test::quote(exe) + " run " +
                        test::quote(cut) + " -o " + test::quote(dir / "run"));
  ASSERT_EQ(r.code, 0) << r.out;
  const fs::path xosc = dir / "run" / "scenario.xosc", xodr = dir / "run" / "scenario.xodr";
  ASSERT_TRUE(fs::exists(xosc)) << r.out;
  const test::Validation vx = test::validate_xml(xosc, test::xosc_schema());
  EXPECT_TRUE(vx.ok()) << vx.output;
  const test::Validation vr = test::validate_xml(xodr, test::xodr_schema());
  EXPECT_TRUE(vr.ok()) << vr.output;
  const test::Validation vc = test::validate_xml(dir / "run" / "hazard_maneuvers.xosc", test::xosc_schema());
  EXPECT_TRUE(vc.ok()) << vc.output;

  const Json traj = test::read_json_file(dir / "run" / "trajectory.json");
  const double plan_min =
      traj["intended_min_ttc_s"].is_number() ? traj["intended_min_ttc_s"].get<double>() : kInf;
  const resim::Result nominal = resim::resimulate(xosc, 1.0);
  const resim::Result slower = resim::resimulate(xosc, 0.8);
  const resim::Result faster = resim::resimulate(xosc, 1.2);
  // The plan's moments, as the FileHeader states them.
  std::ifstream in(xosc);
  const std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  std::smatch planned;
  ASSERT_TRUE(
      std::regex_search(text, planned,
                        std::regex("minimum TTC ([0-9.]+) s at t=([0-9.]+) s; the ego starts the hazard at "
                                   "t=([0-9.]+) s by ([A-Za-z]+)")));
  std::cout << GetParam() << ": " << traj["kind"].get<std::string>() << ", " << planned[4] << " fires at "
            << nominal.trigger_time << " s (planned " << planned[3] << " s), minimum TTC " << nominal.min_ttc
            << " s at " << nominal.min_ttc_time << " s (plan " << plan_min << " s at " << planned[2]
            << " s); ego x0.8: trigger " << slower.trigger_time << " s, min TTC " << slower.min_ttc
            << " s; x1.2: trigger " << faster.trigger_time << " s, min TTC " << faster.min_ttc << " s\n";
  EXPECT_TRUE(nominal.triggered);
  EXPECT_NEAR(nominal.min_ttc, plan_min, 0.3);
  for (const resim::Result* x : {&slower, &faster}) {
    EXPECT_TRUE(x->triggered);
    EXPECT_LT(x->min_ttc, 1.5);
  }
  if (HasFailure())
    std::cout << "kept for inspection: " << dir << "\n";
  else
    fs::remove_all(dir);
}

INSTANTIATE_TEST_SUITE_P(Configs, ShippedConfig,
                         ::testing::Values("paper", "cut_in", "sudden_stop", "pedestrian_crossing",
                                           "cut_in_udacity", "sudden_stop_udacity",
                                           "pedestrian_crossing_udacity"));

}  // namespace
}  // namespace hf
