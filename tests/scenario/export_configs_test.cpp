// Every shipped scenario config exports a scenario and road that validate and whose hazard the ego meets.
#include <gtest/gtest.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <regex>
#include <set>
#include <string>

#include "command.hpp"
#include "hazardforge/core/graph.hpp"
#include "resimulation.hpp"
#include "xml_files.hpp"

namespace hf {
namespace {

namespace fs = std::filesystem;

// The config (subgraphs expanded by the host's loader) cut down to what the export needs: the xosc node and,
// transitively, the nodes it reads from, over the whole recording (the generator's horizon follows the clip's end).
std::string export_only(const fs::path& config) {
  Json root = core::load_graph_config(config).doc.value;
  std::map<std::string, Json> nodes;
  std::vector<std::string> todo;
  for (const Json& n : root["nodes"]) {
    nodes[n["id"].get<std::string>()] = n;
    if (n["stage"] == "xosc") todo.push_back(n["id"].get<std::string>());
  }
  EXPECT_EQ(todo.size(), 1u) << config;
  std::set<std::string> keep;
  while (!todo.empty()) {
    const std::string id = todo.back();
    todo.pop_back();
    if (!keep.insert(id).second) continue;
    auto add = [&](const Json& v) {
      const std::string ref = v.get<std::string>();
      todo.push_back(ref.substr(0, ref.find('.')));
    };
    for (const auto& in : nodes[id]["inputs"].items()) {
      if (in.value().is_array())
        for (const Json& v : in.value()) add(v);
      else
        add(in.value());
    }
  }
  // Paths are relative to the config's folder; the cut config lives elsewhere.
  auto absolute = [&](Json& v) {
    if (!v.is_string()) return;
    const std::string s = v.get<std::string>();
    if (!s.empty() && s[0] != '/' && s.find("${") == std::string::npos && fs::exists(config.parent_path() / s))
      v = fs::weakly_canonical(config.parent_path() / s).string();
  };
  Json out = {{"name", root["name"].get<std::string>() + "_export"}, {"nodes", Json::array()}};
  if (root.contains("scene")) {
    out["scene"] = root["scene"];
    for (auto& sec : out["scene"].items())
      if (sec.value().is_object())
        for (auto& kv : sec.value().items()) absolute(kv.value());
  }
  for (const Json& n : root["nodes"]) {
    if (!keep.count(n["id"].get<std::string>())) continue;
    Json c = n;
    if (c.contains("params"))
      for (auto& kv : c["params"].items()) absolute(kv.value());
    out["nodes"].push_back(c);
  }
  return out.dump(2);
}

class ShippedConfig : public ::testing::TestWithParam<std::string> {};

TEST_P(ShippedConfig, ExportsAValidScenarioWhoseHazardTheEgoMeets) {
  const fs::path shared = test::shared_dir();
  HF_REQUIRE_SHARED(test::xosc_schema());
  HF_REQUIRE_SHARED(shared / "models/yolov8n/yolov8n_deq_640x384.onnx");
  const fs::path exe = fs::path(HF_BINARY_DIR "/bin/hazardforge");
  ASSERT_TRUE(fs::exists(exe)) << exe;
  // The configs name their harvested assets as ${HAZARDFORGE_ASSETS:-...}; cutting them expands it here.
  ::setenv("HAZARDFORGE_ASSETS", HF_TEST_ASSETS_DIR, 1);
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
  // At least as critical as planned (within 0.3 s): the story goes on after the plan's end, so a person who
  // stopped in the lane is met later still, closer than the plan's last moment.
  EXPECT_LE(nominal.min_ttc, plan_min + 0.3);
  EXPECT_LT(nominal.min_ttc, 1.5);
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
