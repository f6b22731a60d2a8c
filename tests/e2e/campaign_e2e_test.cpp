// A campaign through the CLI on the real nuScenes scene: interrupted (here: stopped after one attempt) and run
// again, it keeps every finished attempt untouched, runs only what is left, reads back an attempt that ended
// unrecorded and re-runs one that never finished; index.json lists each attempt once.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>
#include <string>

#include "command.hpp"
#include "hazardforge/types.hpp"
#include "temp_dir.hpp"
#include "test_support.hpp"

namespace hf {
namespace {

namespace fs = std::filesystem;

// A campaign file over nuScenes scene-0916 through configs/paper.yaml with the default appearance set (no
// harvest needed): its name, kinds and budget line, and the recording's extra overrides.
void write_nuscenes_campaign(const fs::path& file, const std::string& head, const std::string& extra_set) {
  std::ofstream(file) << head << "recordings:\n  - name: nus\n    config: "
                      << (test::source_dir() / "configs/paper.yaml").string()
                      << "\n    set: [scene.assets.dir=" << extra_set << "]\n";
}

// The CLI with the shared data's location.
std::string hazardforge(const fs::path& shared) {
  return "HAZARDFORGE_SHARED=" + test::quote(shared) + " " + test::quote(HF_BINARY_DIR "/bin/hazardforge");
}

TEST(CampaignEndToEnd, ResumingLosesNothingAndRepeatsNothing) {
  const fs::path shared = test::shared_dir();
  HF_REQUIRE_SHARED(shared / "data/nuscenes/v1.0-mini/scene.json");
  HF_REQUIRE_SHARED(shared / "models/yolov8n/yolov8n_deq_640x384.onnx");
  test::TempDir dir;
  // Two pairs with one attempt each.
  write_nuscenes_campaign(dir / "c.yaml",
                          "name: resume\nkinds: [sudden_stop, pedestrian_crossing]\nbudget: {attempts: 1, cpu_s: 600}\n",
                          "");
  const fs::path out = dir / "out";
  const std::string cmd = hazardforge(shared) + " campaign " +
                          test::quote(dir / "c.yaml") + " -o " + test::quote(out) + " -q";

  const auto first = test::run_command(cmd + " --max-attempts 1");
  ASSERT_EQ(first.code, 0) << first.out;
  EXPECT_NE(first.out.find("stopped after 1 attempts"), std::string::npos) << first.out;
  const fs::path a = out / "attempts/nus/sudden_stop";
  ASSERT_EQ(std::distance(fs::directory_iterator(a), fs::directory_iterator{}), 1) << first.out;
  const fs::path a1 = fs::directory_iterator(a)->path();
  ASSERT_TRUE(fs::exists(a1 / "attempt.json")) << first.out;
  const std::string a1_record = test::read_file(a1 / "attempt.json"), a1_manifest = test::read_file(a1 / "manifest.json");
  const auto scout_time = fs::last_write_time(out / "recordings/nus/scout/scout.jsonl");
  EXPECT_FALSE(fs::exists(out / "attempts/nus/pedestrian_crossing"));
  // The scouting pass also cut the recording's own road users out (the footage harvester ran on it); when it
  // kept any, the attempts draw with them.
  const std::string scout_manifest = test::read_file(out / "recordings/nus/scout/manifest.json");
  EXPECT_NE(scout_manifest.find("campaign_footage_harvest"), std::string::npos);
  EXPECT_EQ(fs::exists(out / "recordings/nus/scout/appearances/assets.yaml"),
            a1_manifest.find("renderer.footage_assets_dir=") != std::string::npos)
      << a1_manifest;

  // Again: the sudden stop is kept as it was (not run again), the pedestrian crossing runs; the scouting run too
  // is kept.
  const auto second = test::run_command(cmd);
  ASSERT_EQ(second.code, 0) << second.out;
  EXPECT_EQ(test::read_file(a1 / "attempt.json"), a1_record);
  EXPECT_EQ(test::read_file(a1 / "manifest.json"), a1_manifest);
  EXPECT_EQ(fs::last_write_time(out / "recordings/nus/scout/scout.jsonl"), scout_time);
  EXPECT_EQ(second.out.find("sudden_stop #1"), std::string::npos) << second.out;
  EXPECT_NE(second.out.find("pedestrian_crossing #1"), std::string::npos) << second.out;
  Json index = test::read_json_file(out / "index.json");
  ASSERT_EQ(index["attempts"].size(), 2u) << index.dump(2);
  EXPECT_TRUE(index["complete"].get<bool>());
  for (const Json& e : index["attempts"]) {
    EXPECT_TRUE(e.contains("reasons"));
    EXPECT_TRUE(e["window"].contains("trigger_frame"));
    EXPECT_TRUE(fs::exists(out / e["folder"].get<std::string>() / "manifest.json"));
    if (e["passed"].get<bool>()) {
      EXPECT_TRUE(fs::exists(out / e["scenario"].get<std::string>() / "augmented.mp4"));
      EXPECT_TRUE(fs::exists(out / e["scenario"].get<std::string>() / "scenario.xosc"));
      EXPECT_GT(e["hazard_critical_frames"].get<int>(), 0);
    } else {
      EXPECT_FALSE(e["reasons"].empty()) << e.dump(2);
    }
  }
  EXPECT_TRUE(fs::exists(out / "index.html"));
  EXPECT_TRUE(fs::exists(out / "summary.md"));

  // An attempt whose run ended although its campaign was killed before recording it (no attempt.json, a
  // finished manifest) is read back from its own folder, not run again.
  const fs::path b = fs::directory_iterator(out / "attempts/nus/pedestrian_crossing")->path();
  const Json b_record = test::read_json_file(b / "attempt.json");
  fs::remove(b / "attempt.json");
  const auto read_back = test::run_command(cmd);
  ASSERT_EQ(read_back.code, 0) << read_back.out;
  EXPECT_EQ(read_back.out.find("pedestrian_crossing #1"), std::string::npos) << read_back.out;
  const Json b_again = test::read_json_file(b / "attempt.json");
  EXPECT_TRUE(b_again.value("read_back", false));
  EXPECT_EQ(b_again["outcome"], b_record["outcome"]);
  EXPECT_EQ(b_again["passed"], b_record["passed"]);
  EXPECT_EQ(b_again["reasons"], b_record["reasons"]);
  EXPECT_EQ(test::read_json_file(out / "index.json")["attempts"].size(), 2u);

  // An attempt that never finished (no attempt.json, its manifest still running: the process was killed) is
  // run again; nothing else is.
  fs::remove(b / "attempt.json");
  Json m = test::read_json_file(b / "manifest.json");
  m["status"] = "running";
  m.erase("outputs");
  std::ofstream(b / "manifest.json") << m.dump(2);
  const auto third = test::run_command(cmd);
  ASSERT_EQ(third.code, 0) << third.out;
  EXPECT_NE(third.out.find("pedestrian_crossing #1"), std::string::npos) << third.out;
  EXPECT_EQ(third.out.find("sudden_stop #1"), std::string::npos) << third.out;
  EXPECT_TRUE(fs::exists(b / "attempt.json"));
  EXPECT_FALSE(test::read_json_file(b / "attempt.json").value("read_back", false));
  EXPECT_EQ(test::read_file(a1 / "attempt.json"), a1_record);
  EXPECT_EQ(test::read_json_file(out / "index.json")["attempts"].size(), 2u);

  // A different campaign file is refused for this folder: results of two campaigns never mix.
  std::ofstream(dir / "c.yaml", std::ios::app) << "description: changed\n";
  const auto fourth = test::run_command(cmd);
  EXPECT_EQ(fourth.code, 1);
  EXPECT_NE(fourth.out.find("holds a campaign of a different campaign file"), std::string::npos) << fourth.out;
}

// A hazard kind from a plugin the project does not build into its plugin folder: the campaign generates it
// (the offline planner asks the kind's own template for a plan), plans, renders and verifies it, with no line of
// the prompt, the planner or the campaign changed for it.
// A graph that cannot start (here an asset folder without its index) fails the same way at every window: the
// pair stops after its first attempt, which says why, instead of spending its budget.
TEST(CampaignEndToEnd, AGraphThatDoesNotStartEndsThePairAtOnce) {
  const fs::path shared = test::shared_dir();
  HF_REQUIRE_SHARED(shared / "data/nuscenes/v1.0-mini/scene.json");
  test::TempDir dir;
  fs::create_directories(dir / "no_assets");
  write_nuscenes_campaign(dir / "c.yaml", "name: broken\nkinds: [sudden_stop]\nbudget: {attempts: 4, cpu_s: 600}\n",
                          (dir / "no_assets").string());
  const fs::path out = dir / "out";
  const auto r = test::run_command(hazardforge(shared) + " campaign " + test::quote(dir / "c.yaml") + " -o " +
                                   test::quote(out) + " -q");
  ASSERT_EQ(r.code, 0) << r.out;
  const Json index = Json::parse(test::read_file(out / "index.json"));
  ASSERT_EQ(index["attempts"].size(), 1u) << index.dump(2);
  const Json& a = index["attempts"][0];
  EXPECT_EQ(a["failed_to_start"], true);
  EXPECT_EQ(a["outcome"], "no hazard");
  const std::string summary = test::read_file(out / "summary.md");
  EXPECT_NE(summary.find("the attempt's graph does not start: node 'generator': open: "), std::string::npos)
      << summary;
  EXPECT_NE(summary.find("asset index not found"), std::string::npos) << summary;
}

// An attempt whose run ends before it makes its folder (here a `hazardforge` beside the campaign's executable that
// fails every `run` into an attempt folder, as a broken install would) is recorded in a folder of its own with its
// log, and ends its pair, instead of ending the campaign.
TEST(CampaignEndToEnd, AnAttemptThatNeverStartsIsRecordedAndTheCampaignGoesOn) {
  const fs::path shared = test::shared_dir();
  HF_REQUIRE_SHARED(shared / "data/nuscenes/v1.0-mini/scene.json");
  HF_REQUIRE_SHARED(shared / "models/yolov8n/yolov8n_deq_640x384.onnx");
  test::TempDir dir;
  const fs::path bin = dir / "bin";
  fs::create_directories(bin);
  fs::copy_file(HF_BINARY_DIR "/bin/hazardforge", bin / "hazardforge-campaign");
  std::ofstream(bin / "hazardforge") << "#!/bin/sh\ncase \"$*\" in *attempts*) echo \"error: cannot load the plugins\" >&2; "
                                        "exit 1;; esac\nexec " << test::quote(HF_BINARY_DIR "/bin/hazardforge")
                                     << " \"$@\"\n";
  fs::permissions(bin / "hazardforge", fs::perms::owner_all);
  write_nuscenes_campaign(dir / "c.yaml", "name: broken\nkinds: [sudden_stop]\nbudget: {attempts: 3, cpu_s: 600}\n", "");
  const fs::path out = dir / "out";
  const auto r = test::run_command("HAZARDFORGE_SHARED=" + test::quote(shared) + " " +
                                   test::quote(bin / "hazardforge-campaign") + " --plugin-path " +
                                   test::quote(HF_BINARY_DIR "/lib/hazardforge/plugins") + " campaign " +
                                   test::quote(dir / "c.yaml") + " -o " + test::quote(out) + " -q");
  ASSERT_EQ(r.code, 0) << r.out;
  const Json index = Json::parse(test::read_file(out / "index.json"));
  ASSERT_EQ(index["attempts"].size(), 1u) << index.dump(2);
  const Json& a = index["attempts"][0];
  EXPECT_EQ(a["failed_to_start"], true);
  const fs::path folder = out / a["folder"].get<std::string>();
  EXPECT_TRUE(fs::exists(folder / "attempt.json"));
  EXPECT_NE(test::read_file(folder / "run.log").find("cannot load the plugins"), std::string::npos);
  const std::string summary = test::read_file(out / "summary.md");
  EXPECT_NE(summary.find("the attempt's run did not start: cannot load the plugins"), std::string::npos)
      << summary;
}

TEST(CampaignEndToEnd, AThirdPartyHazardKindIsGeneratedAndVerified) {
  const fs::path shared = test::shared_dir();
  HF_REQUIRE_SHARED(shared / "data/nuscenes/v1.0-mini/scene.json");
  HF_REQUIRE_SHARED(shared / "models/yolov8n/yolov8n_deq_640x384.onnx");
  test::TempDir dir;
  // Scene-0916 as a two-way road: the lane beside the ego carries oncoming traffic.
  write_nuscenes_campaign(dir / "c.yaml",
                          "name: third_party\nkinds: [oncoming_overtaker]\nbudget: {attempts: 4, cpu_s: 300}\n",
                          ", scene.road.lanes_right=1, scene.road.oncoming_lanes=1");
  const fs::path out = dir / "out";
  const auto r = test::run_command(hazardforge(shared) +
                                   " --plugin-path " + test::quote(ONCOMING_OVERTAKER_DIR) + " campaign " +
                                   test::quote(dir / "c.yaml") + " -o " + test::quote(out) + " -q");
  ASSERT_EQ(r.code, 0) << r.out;
  const Json index = test::read_json_file(out / "index.json");
  EXPECT_EQ(index["summary"]["verified_pairs"], 1) << r.out;
  EXPECT_EQ(index["summary"]["spurious_passes"], 0);
  const fs::path scenario = out / "scenarios/nus/oncoming_overtaker";
  const Json spec = test::read_json_file(scenario / "hazard_spec.json");
  EXPECT_EQ(spec["kind"], "oncoming_overtaker");
  EXPECT_EQ(spec["provenance"]["provider"], "offline");
  const Json v = test::read_json_file(scenario / "verification.json");
  EXPECT_TRUE(v["passed"].get<bool>());
  EXPECT_GT(v["unsafe"]["attributed_frames"].get<int>(), 0);
  EXPECT_TRUE(fs::exists(scenario / "scenario.xosc"));
}

// Recordings found by recordings_from on the real data: a video file pattern and a nuScenes dataroot. What
// cannot be used — a pattern matching nothing, a file that does not decode — is reported and left out, the
// rest is scouted; `campaign status` reads it back from the folder alone.
TEST(CampaignEndToEnd, RecordingsFoundInPatternsAndADatasetAndWhatCannotBeReadIsLeftOut) {
  const fs::path shared = test::shared_dir();
  HF_REQUIRE_SHARED(shared / "data/udacity-highway/test_video.mp4");
  HF_REQUIRE_SHARED(shared / "data/nuscenes/v1.0-mini/scene.json");
  HF_REQUIRE_SHARED(shared / "models/yolov8n/yolov8n_deq_640x384.onnx");
  test::TempDir dir;
  std::ofstream(dir / "broken.mp4") << std::string(4096, '\x5a');  // not a video
  std::ofstream(dir / "c.yaml")
      << "name: found\nkinds: [sudden_stop]\nbudget: {attempts: 1, cpu_s: 600}\nrecordings_from:\n"
      << "  - videos: [" << (shared / "data/udacity-highway/*.mp4").string() << ", "
      << (dir / "*.mp4").string() << ", " << (dir / "none/*.mp4").string() << "]\n"
      << "    config: " << (test::source_dir() / "configs/video.yaml").string() << "\n"
      << "  - nuscenes: " << (shared / "data/nuscenes").string() << "\n    scenes: [\"scene-09*\"]\n"
      << "    config: " << (test::source_dir() / "configs/pedestrian_crossing.yaml").string() << "\n";
  const fs::path out = dir / "out";
  const auto r = test::run_command(hazardforge(shared) + " campaign " + test::quote(dir / "c.yaml") + " -o " +
                                   test::quote(out) + " --max-attempts 0");
  ASSERT_EQ(r.code, 0) << r.out;
  EXPECT_NE(r.out.find("c.yaml:5: " + (dir / "none/*.mp4").string() + ": matches nothing"), std::string::npos)
      << r.out;
  const Json index = test::read_json_file(out / "index.json");
  std::map<std::string, Json> recs;
  for (const Json& rec : index["recordings"]) recs[rec["name"].get<std::string>()] = rec;
  ASSERT_TRUE(recs.count("test_video")) << index["recordings"].dump();
  EXPECT_FALSE(recs["test_video"]["windows"].empty());  // scouted: it has candidate windows
  // The nuScenes scene's driving side from the camera files' log names (the shared tables have no log.json).
  ASSERT_TRUE(recs.count("scene-0916"));
  EXPECT_FALSE(recs["scene-0916"]["windows"].empty());
  const Json set = recs["scene-0916"]["set"];
  EXPECT_NE(std::find(set.begin(), set.end(), Json("scene.road.driving_side=left")), set.end()) << set.dump();
  std::map<std::string, std::string> skipped;
  for (const Json& k : index["skipped"])
    skipped[k["what"].get<std::string>()] = k["reason"].get<std::string>();
  ASSERT_EQ(skipped.size(), 2u) << index["skipped"].dump();
  EXPECT_NE(skipped["broken"].find("not a video OpenCV/FFmpeg can decode"), std::string::npos)
      << skipped["broken"];

  const auto st = test::run_command(hazardforge(shared) + " campaign status " + test::quote(out) + " --json");
  ASSERT_EQ(st.code, 0) << st.out;
  const Json status = Json::parse(st.out);
  EXPECT_EQ(status["skipped"].size(), 2u);
  EXPECT_TRUE(status["attempts"].empty());
  EXPECT_FALSE(status["complete"].get<bool>());
  const auto text = test::run_command(hazardforge(shared) + " campaign status " + test::quote(out));
  EXPECT_NE(text.out.find("left out: broken: its scouting run failed"), std::string::npos) << text.out;
  EXPECT_EQ(test::run_command(hazardforge(shared) + " campaign status " + test::quote(dir.path())).code, 1);
}

}  // namespace
}  // namespace hf
