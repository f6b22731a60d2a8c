// Every shipped config validates against the in-tree plugins, and states each fact once: no stated param value
// is written twice across the nodes of one config (a value a subgraph states once and the config instantiates
// twice is stated once).
#include <gtest/gtest.h>

#include <algorithm>
#include <fstream>
#include <map>

#include "hazardforge/apps/campaign.hpp"
#include "hazardforge/core/host.hpp"
#include "hazardforge/yaml_json.hpp"
#include "test_support.hpp"

namespace hf::core {
using namespace hf::apps;  // campaign files
namespace {

namespace fs = std::filesystem;

bool is_campaign(const fs::path& file) {
  return file.stem().string().rfind("campaign", 0) == 0;
}

std::vector<fs::path> shipped_graph_configs() {
  std::vector<fs::path> out;
  for (const auto& e : fs::directory_iterator(hf::test::source_dir() / "configs"))
    if (e.path().extension() == ".yaml" && !is_campaign(e.path())) out.push_back(e.path());
  std::sort(out.begin(), out.end());
  return out;
}

TEST(ShippedConfigs, CampaignsNameRunnableScenarioGraphs) {
  Host host({HF_PLUGIN_DIR});
  host.load_plugins();
  int campaigns = 0;
  for (const auto& e : fs::directory_iterator(hf::test::source_dir() / "configs")) {
    if (e.path().extension() != ".yaml" || !is_campaign(e.path())) continue;
    SCOPED_TRACE(e.path().filename().string());
    ++campaigns;
    try {
      const CampaignSpec spec = load_campaign(e.path().string());
      for (const std::string& k : spec.kinds) EXPECT_NE(host.registry().find(kind::kHazardTemplate, k), nullptr) << k;
      for (const CampaignRecording& r : spec.recordings) {
        const Graph g = load_graph(host, r.config, r.set, nullptr, true, {}, r.set_base);
        EXPECT_NE(g.node("generator"), nullptr) << r.name;
        EXPECT_NE(g.node("verifier"), nullptr) << r.name;
      }
    } catch (const Error& err) {
      ADD_FAILURE() << err.what();
    }
  }
  EXPECT_GE(campaigns, 1);
}

TEST(ShippedConfigs, ValidateAndStateEachFactOnce) {
  Host host({HF_PLUGIN_DIR});
  host.load_plugins();
  const auto configs = shipped_graph_configs();
  ASSERT_GE(configs.size(), 15u);
  for (const fs::path& file : configs) {
    SCOPED_TRACE(file.filename().string());
    // configs/video.yaml states nothing but what the user gives on the command line.
    const std::vector<std::string> set =
        file.stem() == "video" ? std::vector<std::string>{"source.path=clip.mp4"} : std::vector<std::string>{};
    GraphConfig cfg;
    Graph g;
    try {
      g = load_graph(host, file, set, &cfg);
    } catch (const Error& e) {
      ADD_FAILURE() << e.what();
      continue;
    }
    // (param name, value) -> where each stated copy is written.
    std::map<std::pair<std::string, std::string>, std::map<std::string, std::string>> stated;
    const Json& nodes = cfg.doc.value["nodes"];
    for (size_t i = 0; i < nodes.size(); ++i) {
      const Json& n = nodes[i];
      if (!n.contains("params") || !n["params"].is_object()) continue;
      for (auto it = n["params"].begin(); it != n["params"].end(); ++it) {
        const SourceLocation at = cfg.doc.at("/nodes/" + std::to_string(i) + "/params/" + it.key());
        stated[{it.key(), it->dump()}][at.str()] = n["id"].get<std::string>();
      }
    }
    for (const auto& [pv, where] : stated) {
      if (where.size() < 2) continue;
      std::string list;
      for (const auto& [loc, node] : where) list += "\n  node '" + node + "' at " + loc;
      ADD_FAILURE() << "param " << pv.first << " = " << pv.second << " is stated " << where.size() << " times:" << list;
    }
  }
}

TEST(ShippedConfigs, ScenarioConfigsFitInAboutThirtyLines) {
  for (const char* name : {"paper", "cut_in", "sudden_stop", "pedestrian_crossing", "cut_in_udacity",
                           "sudden_stop_udacity", "pedestrian_crossing_udacity", "video"}) {
    std::ifstream in(hf::test::source_dir() / "configs" / (std::string(name) + ".yaml"));
    int lines = 0;
    for (std::string l; std::getline(in, l);)
      if (!l.empty() && l.rfind('#', 0) != 0) ++lines;
    EXPECT_LE(lines, 32) << name << ": " << lines << " lines besides comments";
  }
}

}  // namespace
}  // namespace hf::core
