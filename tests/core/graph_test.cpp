// Graph loading and validation: every invalid graph in tests/data/invalid_graphs against its .expected text,
// plus overrides, ${VAR} expansion, output renames and dot output on valid graphs.
#include <gtest/gtest.h>
#include <unistd.h>

#include <cstdlib>
#include <fstream>
#include <sstream>

#include "hazardforge/core/graph.hpp"
#include "test_stages.hpp"
#include "temp_dir.hpp"
#include "test_support.hpp"

namespace hf::core {
namespace {

std::string slurp(const std::filesystem::path& p) {
  std::ifstream in(p);
  std::stringstream ss;
  ss << in.rdbuf();
  std::string s = ss.str();
  while (!s.empty() && s.back() == '\n') s.pop_back();
  return s;
}

class GraphFiles : public ::testing::TestWithParam<std::string> {};

TEST_P(GraphFiles, ReportsExactlyTheExpectedDiagnostics) {
  // Paths in messages are as given, so run from the source tree with a relative path.
  std::filesystem::current_path(hf::test::source_dir());
  const std::string rel = "tests/data/invalid_graphs/" + GetParam() + ".yaml";
  ComponentRegistry reg;
  hf::test::register_test_stages(reg);
  std::string got;
  try {
    GraphConfig cfg = load_graph_config(rel);
    build_graph(cfg, reg);
  } catch (const Error& e) {
    got = e.what();
  }
  const auto expected_file = hf::test::test_data("invalid_graphs/" + GetParam() + ".expected");
  if (std::getenv("HF_UPDATE_EXPECTED")) std::ofstream(expected_file) << got << "\n";
  EXPECT_EQ(got, slurp(expected_file));
}

std::vector<std::string> invalid_graph_names() {
  std::vector<std::string> names;
  for (const auto& e : std::filesystem::directory_iterator(hf::test::test_data("invalid_graphs")))
    if (e.path().extension() == ".yaml") names.push_back(e.path().stem().string());
  std::sort(names.begin(), names.end());
  return names;
}

INSTANTIATE_TEST_SUITE_P(Invalid, GraphFiles, ::testing::ValuesIn(invalid_graph_names()),
                         [](const auto& info) { return info.param; });

std::filesystem::path write_temp(const std::string& name, const std::string& text) {
  static const hf::test::TempDir dir;  // this process's, for the test's lifetime
  auto p = dir / name;
  std::ofstream(p) << text;
  return p;
}

const char* kValid = R"(name: valid
plugin_paths: [plugins_here]
nodes:
  - id: source
    stage: test_source
    params: {count: 5}
  - id: detector
    stage: test_detector
    inputs: {frames: source.frames}
    params: {conf_threshold: 0.3}
    outputs: {detections: boxes}
  - id: sink
    stage: test_sink
    inputs: {records: [boxes, source.frames], frames: source.frames}
)";

TEST(Graph, ValidGraphInTopologicalOrderWithDefaults) {
  ComponentRegistry reg;
  hf::test::register_test_stages(reg);
  auto file = write_temp("valid.yaml", kValid);
  GraphConfig cfg = load_graph_config(file);
  EXPECT_EQ(cfg.plugin_paths.at(0), file.parent_path() / "plugins_here");
  Graph g = build_graph(cfg, reg);
  ASSERT_EQ(g.nodes.size(), 3u);
  EXPECT_EQ(g.nodes[0].id, "source");
  EXPECT_EQ(g.nodes[2].id, "sink");
  EXPECT_DOUBLE_EQ(g.node("detector")->params["conf_threshold"].get<double>(), 0.3);
  EXPECT_EQ(g.node("detector")->params["mode"], "fast");  // default filled in
  EXPECT_EQ(g.producers.at("boxes").first, "detector");
  const std::string dot = g.to_dot();
  EXPECT_NE(dot.find("\"detector\" -> \"sink\" [label=\"detections → records\\nDetections v1\"]"), std::string::npos) << dot;
}

TEST(Graph, OverridesAndEnvironmentExpansion) {
  ComponentRegistry reg;
  hf::test::register_test_stages(reg);
  setenv("HF_TEST_COUNT_MODE", "accurate", 1);
  auto file = write_temp("env.yaml", R"(name: env
nodes:
  - id: source
    stage: test_source
  - id: detector
    stage: test_detector
    inputs: {frames: source.frames}
    params: {mode: "${HF_TEST_COUNT_MODE}"}
)");
  GraphConfig cfg = load_graph_config(file, {"source.count=7", "detector.conf_threshold=0.9"});
  Graph g = build_graph(cfg, reg);
  EXPECT_EQ(g.node("source")->params["count"], 7);
  EXPECT_EQ(g.node("detector")->params["mode"], "accurate");
  EXPECT_DOUBLE_EQ(g.node("detector")->params["conf_threshold"].get<double>(), 0.9);
}

// A command line has no comments: a value with ' #' or a line break in it is kept whole, not cut there.
TEST(Graph, OverrideValuesWithAHashOrALineBreakAreKeptWhole) {
  auto file = write_temp("hash.yaml", R"(name: hash
nodes:
  - id: source
    stage: test_source
)");
  GraphConfig cfg = load_graph_config(
      file, {"scene.environment=Main St #5, downtown with sidewalks", "scene.note=#3", "scene.lines=one\ntwo",
             "scene.plain=downtown", "scene.count=3", "scene.quoted=\"a # b\""});
  const Json& scene = cfg.doc.value["scene"];
  EXPECT_EQ(scene["environment"], "Main St #5, downtown with sidewalks");
  EXPECT_EQ(scene["note"], "#3");
  EXPECT_EQ(scene["lines"], "one\ntwo");
  EXPECT_EQ(scene["plain"], "downtown");
  EXPECT_EQ(scene["count"], 3);
  EXPECT_EQ(scene["quoted"], "a # b");  // a YAML-quoted string is YAML's
}

TEST(Graph, BadOverridesAndUndefinedVariablesAreReportedTogether) {
  auto file = write_temp("bad_env.yaml", R"(name: env
nodes:
  - id: source
    stage: test_source
    params: {count: "${HF_TEST_SURELY_UNDEFINED}"}
)");
  try {
    load_graph_config(file, {"sorce.count=3", "nodot"});
    FAIL();
  } catch (const DiagnosticError& e) {
    ASSERT_EQ(e.diagnostics().size(), 3u) << e.what();
    EXPECT_EQ(e.diagnostics()[0].str(), "--set sorce.count=3: error: no node 'sorce'; did you mean 'source'?");
    EXPECT_EQ(e.diagnostics()[1].str(), "--set nodot: error: expected --set node.param=value");
    EXPECT_EQ(e.diagnostics()[2].str(), file.string() + ":5:21: error: undefined variable ${HF_TEST_SURELY_UNDEFINED}");
  }
}

TEST(Graph, OverrideOutOfRangePointsAtTheCommandLine) {
  ComponentRegistry reg;
  hf::test::register_test_stages(reg);
  auto file = write_temp("valid2.yaml", kValid);
  GraphConfig cfg = load_graph_config(file, {"detector.conf_threshold=3"});
  try {
    build_graph(cfg, reg);
    FAIL();
  } catch (const DiagnosticError& e) {
    EXPECT_EQ(std::string(e.what()),
              "--set detector.conf_threshold=3: error: node 'detector': stage 'test_detector': parameter "
              "'conf_threshold' = 3 is out of range [0, 1]");
  }
}

TEST(Graph, MissingConfigFile) {
  try {
    load_graph_config("/nonexistent/graph.yaml");
    FAIL();
  } catch (const Error& e) {
    EXPECT_EQ(std::string(e.what()), "/nonexistent/graph.yaml: error: config file not found");
  }
}

TEST(Graph, AmbiguousStageNameAsksForKind) {
  ComponentRegistry reg;
  hf::test::register_test_stages(reg);
  std::string why;
  EXPECT_NE(reg.find("test_detector", true, &why), nullptr);
  EXPECT_NE(reg.find("detector/test_detector", true, &why), nullptr);
  EXPECT_EQ(reg.find("sink/test_detector", true, &why), nullptr);
}

}  // namespace
}  // namespace hf::core

namespace hf::core {
namespace {

// A second detector with other params, to swap in.
class OtherDetector : public hf::test::TestDetector {
 public:
  static ComponentInfo describe() {
    ComponentInfo i = base_info("other_detector", "another detector");
    i.params = {ParamSpec::number("gain", 1.0)};
    return i;
  }
  void open(StageContext&) override {}
};

TEST(Graph, StageSwapDropsParamsTheNewStageDoesNotDeclare) {
  ComponentRegistry reg;
  hf::test::register_test_stages(reg);
  reg.add<OtherDetector>();
  auto file = write_temp("swap.yaml", R"(name: swap
nodes:
  - id: source
    stage: test_source
  - id: detector
    stage: test_detector
    inputs: {frames: source.frames}
    params: {conf_threshold: 0.3, mode: accurate}
)");
  GraphConfig cfg = load_graph_config(file, {"detector.stage=other_detector", "detector.gain=2"});
  Graph g = build_graph(cfg, reg);
  ASSERT_EQ(g.warnings.size(), 2u);
  EXPECT_EQ(g.warnings[0].str(), file.string() +
                                     ":8:14: warning: node 'detector': parameter 'conf_threshold' dropped: stage "
                                     "'other_detector' (set on the command line) does not declare it");
  EXPECT_DOUBLE_EQ(g.node("detector")->params["gain"].get<double>(), 2.0);
  // Without a stage swap the same param is an error, as always.
  GraphConfig plain = load_graph_config(file, {"detector.gain=2"});
  EXPECT_THROW(build_graph(plain, reg), DiagnosticError);
}

}  // namespace
}  // namespace hf::core

namespace hf::core {
namespace {

// A chain source -> detector -> n filters -> sink, written as a config file.
std::filesystem::path chain_config(int n, bool close_cycle) {
  std::ostringstream os;
  os << "nodes:\n  - {id: src, stage: test_source}\n"
     << "  - {id: f0, stage: test_filter, inputs: {detections: "
     << (close_cycle ? "f" + std::to_string(n - 1) : "det")
     << ".detections}}\n  - {id: det, stage: test_detector, inputs: {frames: src.frames}}\n";
  for (int i = 1; i < n; ++i)
    os << "  - {id: f" << i << ", stage: test_filter, inputs: {detections: f" << i - 1 << ".detections}}\n";
  os << "  - {id: out, stage: test_sink, inputs: {records: [f" << n - 1 << ".detections]}}\n";
  return write_temp("chain_" + std::to_string(n) + (close_cycle ? "_cycle" : "") + "_" +
                        std::to_string(::getpid()) + ".yaml",
                    os.str());
}

// Validation is near-linear: 20,000 nodes validate in well under a second of work (a quadratic lookup made
// 16,000 take 85 s) and the depth-first search does not recurse once per node.
// HF_GRAPH_SCALE_NODES=80000 measures a bigger chain (docs/reliability.md); the default keeps the test fast.
// ---- scene block ---------------------------------------------------------------------------------------------------

std::string build_error(const std::filesystem::path& file, const std::vector<std::string>& overrides = {}) {
  ComponentRegistry reg;
  hf::test::register_test_stages(reg);
  try {
    build_graph(load_graph_config(file, overrides), reg);
  } catch (const Error& e) {
    return e.what();
  }
  return {};
}

TEST(SceneBlock, FillsBoundParamsAndTheCommandLineCanChangeIt) {
  const hf::test::TempDir tmp;
  const std::filesystem::path dir = tmp.path();
  const auto file = dir / "scene.yaml";
  std::ofstream(file) << R"(name: scene
scene:
  road: {lanes_left: 3, driving_side: left}
nodes:
  - id: source
    stage: test_source
  - id: detector
    stage: test_detector
    inputs: {frames: source.frames}
)";
  ComponentRegistry reg;
  hf::test::register_test_stages(reg);
  Graph g = build_graph(load_graph_config(file), reg);
  EXPECT_EQ(g.node("detector")->params["lanes"], 3);
  EXPECT_EQ(g.scene["road"]["driving_side"], "left");
  EXPECT_EQ(g.resolved()["scene"]["road"]["lanes_left"], 3);
  Graph g2 = build_graph(load_graph_config(file, {"scene.road.lanes_left=2"}), reg);
  EXPECT_EQ(g2.node("detector")->params["lanes"], 2);
  // A --set on the node itself wins over the scene, with a warning.
  Graph g3 = build_graph(load_graph_config(file, {"detector.lanes=4"}), reg);
  EXPECT_EQ(g3.node("detector")->params["lanes"], 4);
  ASSERT_EQ(g3.warnings.size(), 1u);
  EXPECT_NE(g3.warnings[0].message.find("overrides scene.road.lanes_left"), std::string::npos);
  // Out of the bound param's range: the message points at the scene line.
  const std::string e = build_error(file, {"scene.road.lanes_left=9"});
  EXPECT_NE(e.find("--set scene.road.lanes_left=9"), std::string::npos) << e;
  EXPECT_NE(e.find("'lanes'"), std::string::npos) << e;
}

TEST(Graph, RelativePathsFromTheCommandLineAreRelativeToWhereItWasTyped) {
  const hf::test::TempDir tmp;
  const std::filesystem::path dir = tmp.path() / "configs";
  std::filesystem::create_directories(dir);
  const auto file = dir / "paths.yaml";
  std::ofstream(file) << R"(name: paths
scene:
  assets: {dir: ../assets}
nodes:
  - id: source
    stage: test_source
  - id: detector
    stage: test_detector
    inputs: {frames: source.frames}
    params: {weights: models/w.onnx}
)";
  ComponentRegistry reg;
  hf::test::register_test_stages(reg);
  // Written in the file: left relative, the stage resolves it against the config's folder (Params::get_path).
  Graph g = build_graph(load_graph_config(file), reg);
  EXPECT_EQ(g.node("detector")->params["weights"], "models/w.onnx");
  EXPECT_EQ(g.node("detector")->params["assets"], "../assets");
  EXPECT_EQ(g.dir, std::filesystem::absolute(dir));
  // Typed on the command line: relative to the folder it was typed in (or the one a campaign names).
  const std::filesystem::path typed_in = tmp.path() / "elsewhere";
  Graph g2 = build_graph(
      load_graph_config(file,
                        {"detector.weights=m/x.onnx", "scene.assets.dir=../mine", "detector.mode=accurate"},
                        typed_in),
      reg);
  EXPECT_EQ(g2.node("detector")->params["weights"], (typed_in / "m/x.onnx").lexically_normal().string());
  EXPECT_EQ(g2.node("detector")->params["assets"], (tmp.path() / "mine").lexically_normal().string());
  EXPECT_EQ(g2.node("detector")->params["mode"], "accurate");  // not a path: untouched
  Graph g3 = build_graph(load_graph_config(file, {"detector.weights=/abs/w.onnx", "detector.assets=a"}), reg);
  EXPECT_EQ(g3.node("detector")->params["weights"], "/abs/w.onnx");
  EXPECT_EQ(g3.node("detector")->params["assets"],
            (std::filesystem::current_path() / "a").lexically_normal().string());
}

TEST(SceneBlock, AFactStatedTwiceAndUnknownKeysAreErrors) {
  const hf::test::TempDir tmp;
  const std::filesystem::path dir = tmp.path();
  const auto file = dir / "twice.yaml";
  std::ofstream(file) << R"(name: twice
scene:
  road: {lanes_left: 3, lane_widht_m: 3.2}
  camra: {}
nodes:
  - id: source
    stage: test_source
  - id: detector
    stage: test_detector
    inputs: {frames: source.frames}
    params: {lanes: 3}
)";
  const std::string e = build_error(file);
  const std::string f = file.string();
  EXPECT_NE(e.find(f + ":3:25: error: unknown key 'scene.road.lane_widht_m'; did you mean 'lane_width_m'?"),
            std::string::npos) << e;
  EXPECT_NE(e.find(f + ":4:3: error: unknown scene section 'camra'; did you mean 'camera'?"), std::string::npos) << e;
  EXPECT_NE(e.find(f + ":11:14: error: node 'detector': parameter 'lanes' restates scene.road.lanes_left (" + f +
                   ":3:22); state it once, in the scene block"),
            std::string::npos) << e;
}

// ---- include: subgraphs ------------------------------------------------------------------------------------------

TEST(Include, ASubgraphWrittenOnceIsInstantiatedTwice) {
  const hf::test::TempDir tmp;
  const std::filesystem::path dir = tmp.path();
  std::filesystem::create_directories(dir / "sub");
  std::ofstream(dir / "sub" / "detect.yaml") << R"(description: a detector and a filter on one frame stream
inputs: {frames: the frames to look at}
nodes:
  - id: detector
    stage: test_detector
    inputs: {frames: $frames}
    params: {mode: accurate}
  - id: filter
    stage: test_filter
    inputs: {detections: detector.detections}
)";
  const auto file = dir / "main.yaml";
  std::ofstream(file) << R"(name: twice
nodes:
  - id: source
    stage: test_source
  - include: sub/detect.yaml
    inputs: {frames: source.frames}
  - include: sub/detect.yaml
    prefix: re_
    inputs: {frames: source.frames}
    params: {detector: {conf_threshold: 0.9}}
  - id: sink
    stage: test_sink
    inputs: {records: [filter.detections, re_filter.detections]}
)";
  ComponentRegistry reg;
  hf::test::register_test_stages(reg);
  Graph g = build_graph(load_graph_config(file, {"re_detector.mode=fast"}), reg);
  ASSERT_EQ(g.nodes.size(), 6u);
  EXPECT_EQ(g.node("detector")->params["mode"], "accurate");
  EXPECT_DOUBLE_EQ(g.node("detector")->params["conf_threshold"].get<double>(), 0.25);
  EXPECT_DOUBLE_EQ(g.node("re_detector")->params["conf_threshold"].get<double>(), 0.9);
  EXPECT_EQ(g.node("re_detector")->params["mode"], "fast");
  EXPECT_EQ(g.node("re_filter")->inputs.at("detections").at(0), "re_detector.detections");
  EXPECT_EQ(g.node("re_detector")->inputs.at("frames").at(0), "source.frames");
  // Errors inside a subgraph point into the subgraph file.
  std::ofstream(dir / "sub" / "bad.yaml") << R"(inputs: {frames: frames}
nodes:
  - id: detector
    stage: test_detector
    inputs: {frames: $frames}
    params: {conf_threshold: 7}
  - id: filter
    stage: test_filter
    inputs: {detections: source.detections}
)";
  std::ofstream(dir / "bad_main.yaml") << R"(name: bad
nodes:
  - id: source
    stage: test_source
  - include: sub/bad.yaml
    prefix: b_
  - include: sub/nothere.yaml
)";
  const std::string e = build_error(dir / "bad_main.yaml");
  const std::string sub = (dir / "sub" / "bad.yaml").string();
  EXPECT_NE(e.find("include of 'bad.yaml': input 'frames' is not bound"), std::string::npos) << e;
  EXPECT_NE(e.find(sub + ":9:26: error: stream 'source.detections' is not produced inside subgraph 'bad.yaml'"),
            std::string::npos) << e;
  EXPECT_NE(e.find("subgraph file '" + (dir / "sub" / "nothere.yaml").string() + "' not found"), std::string::npos) << e;
}

TEST(Include, ASubgraphIncludingItselfIsRefused) {
  const hf::test::TempDir tmp;
  const std::filesystem::path dir = tmp.path();
  std::ofstream(dir / "loop.yaml") << "nodes:\n  - include: loop.yaml\n";
  std::ofstream(dir / "main.yaml") << "name: m\nnodes:\n  - include: loop.yaml\n";
  EXPECT_NE(build_error(dir / "main.yaml").find("includes itself"), std::string::npos) << build_error(dir / "main.yaml");
}

TEST(GraphScale, TwentyThousandNodeChainValidates) {
  ComponentRegistry reg;
  hf::test::register_test_stages(reg);
  const char* env = std::getenv("HF_GRAPH_SCALE_NODES");
  const int n = env ? std::atoi(env) : 20000;
  const auto file = chain_config(n, false);
  Graph g = build_graph(load_graph_config(file), reg);
  ASSERT_EQ(g.nodes.size(), static_cast<size_t>(n) + 3);
  EXPECT_EQ(g.nodes.front().id, "src");
  EXPECT_EQ(g.nodes.back().id, "out");
  std::filesystem::remove(file);
}

TEST(GraphScale, ACycleThroughTwentyThousandNodesIsReportedOnce) {
  ComponentRegistry reg;
  hf::test::register_test_stages(reg);
  const auto file = chain_config(20000, true);
  std::string got;
  try {
    build_graph(load_graph_config(file), reg);
  } catch (const Error& e) {
    got = e.what();
  }
  EXPECT_NE(got.find("error: the graph has a cycle: 'f0' -> 'f19999' -> 'f19998' -> "), std::string::npos)
      << got.substr(0, 300);
  EXPECT_EQ(got.find("\n"), std::string::npos) << "one diagnostic";
  std::filesystem::remove(file);
}

}  // namespace
}  // namespace hf::core
