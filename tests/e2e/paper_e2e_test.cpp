// The README's main job through the CLI on the real nuScenes scene: harvest appearances, run
// configs/paper.yaml, and check that the generated scenario passed the closed-loop verification and that its
// outputs exist.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <string>

#include "command.hpp"
#include "hazardforge/types.hpp"
#include "test_support.hpp"

namespace hf {
namespace {

namespace fs = std::filesystem;

using test::quote;
using Cmd = test::CommandResult;
using test::read_json_file;
using test::run_command;

TEST(PaperEndToEnd, Scene0916ScenarioPassesVerification) {
  const fs::path shared = test::shared_dir();
  HF_REQUIRE_SHARED(shared / "data/nuscenes/v1.0-mini/scene.json");
  HF_REQUIRE_SHARED(shared / "models/yolov8n/yolov8n_deq_640x384.onnx");
  const fs::path exe = fs::path(HF_BINARY_DIR "/bin/hazardforge");
  ASSERT_TRUE(fs::exists(exe)) << exe;
  const fs::path work = test::binary_dir() / "tests/e2e/paper_run";
  fs::remove_all(work);
  fs::create_directories(work);
  const std::string env = "HAZARDFORGE_SHARED=" + quote(shared) + " ";

  // Real appearances from the same recording (the default car sprite is not recognised by YOLOv8n).
  const fs::path assets = work / "assets";
  const Cmd harvest = run_command(env + quote(exe) + " assets harvest -o " + quote(assets) + " --config " +
                                  quote(test::source_dir() / "configs/harvest_assets.yaml"));
  ASSERT_EQ(harvest.code, 0) << harvest.out;
  ASSERT_TRUE(fs::exists(assets / "assets.yaml")) << harvest.out;

  const fs::path out = work / "run";
  const Cmd paper = run_command(env + "HAZARDFORGE_ASSETS=" + quote(assets) + " " + quote(exe) + " run " +
                                quote(test::source_dir() / "configs/paper.yaml") + " -o " + quote(out));
  ASSERT_EQ(paper.code, 0) << paper.out;

  // The verdict: re-detected, Unsafe while visible, distances measured.
  const Json v = read_json_file(out / "verification.json");
  EXPECT_TRUE(v["passed"].get<bool>()) << v.dump(2);
  EXPECT_TRUE(v["reasons"].empty()) << v.dump(2);
  EXPECT_EQ(v["criteria"]["min_iou"], 0.5);
  EXPECT_EQ(v["criteria"]["min_redetection_rate"], 0.5);
  EXPECT_TRUE(v["criteria"]["require_unsafe"].get<bool>());
  EXPECT_GE(v["visible_frames"].get<int>(), 2);
  EXPECT_GE(v["redetection"]["rate"].get<double>(), 0.5);
  EXPECT_GE(v["redetection"]["mean_iou"].get<double>(), 0.5);
  EXPECT_TRUE(v["unsafe"]["reached"].get<bool>());
  EXPECT_LT(v["ttc"]["achieved_min_ttc_s"].get<double>(), 1.5);
  // The Unsafe verdict comes from the inserted object, not from something else in the scene.
  EXPECT_TRUE(v["criteria"]["require_hazard_critical"].get<bool>());
  EXPECT_GE(v["unsafe"]["hazard_critical_frames"].get<int>(), 1);
  EXPECT_GE(v["distance"]["matched_frames"].get<int>(), 1);
  EXPECT_TRUE(std::isfinite(v["distance"]["median_abs_error_m"].get<double>()));

  // The outputs.
  for (const char* f : {"augmented.mp4", "before_after.mp4", "hazard_spec.json", "trajectory.json",
                        "scenario.xosc", "frames.jsonl", "manifest.json"}) {
    EXPECT_TRUE(fs::exists(out / f)) << f;
    if (fs::exists(out / f)) {
      EXPECT_GT(fs::file_size(out / f), 100u) << f;
    }
  }
  const Json spec = read_json_file(out / "hazard_spec.json");
  EXPECT_EQ(spec["provenance"]["provider"], "offline");
  const Json tr = read_json_file(out / "trajectory.json");
  EXPECT_TRUE(tr["planner"]["feasible"].get<bool>());
  EXPECT_EQ(tr["kind"], spec["kind"]);
  // Planned against the recorded ego track: the ego's planned speed follows the recording (between 5.2 and
  // 6.1 m/s on this stretch), unlike a constant-speed plan.
  ASSERT_GE(tr["ego"].size(), 2u);
  double vmin = kInf, vmax = -kInf;
  for (const Json& e : tr["ego"]) {
    vmin = std::min(vmin, e["speed"].get<double>());
    vmax = std::max(vmax, e["speed"].get<double>());
  }
  EXPECT_GT(vmax - vmin, 0.3) << vmin << " .. " << vmax;

  // The exported scenario is valid ASAM OpenSCENARIO 1.2.
  const Cmd xsd = run_command("xmllint --noout --schema " + quote(shared / "schemas/OpenSCENARIOv1.2.xsd") +
                              " " + quote(out / "scenario.xosc"));
  EXPECT_EQ(xsd.code, 0) << xsd.out << "(xmllint comes with Debian's libxml2-utils)";
}

}  // namespace
}  // namespace hf
