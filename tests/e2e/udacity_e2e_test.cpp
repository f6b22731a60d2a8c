// A hazard on the short Udacity highway clip through the CLI: configs/pedestrian_crossing_udacity.yaml (a
// person who left a broken-down car on the shoulder walks into the ego lane, already under way when the 1.52
// s clip starts) must pass the closed-loop verification with the default criteria inside the clip.
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

TEST(UdacityEndToEnd, PersonOnTheHighwayPassesVerificationInsideTheClip) {
  const fs::path shared = test::shared_dir();
  HF_REQUIRE_SHARED(shared / "data/udacity-highway/test_video.mp4");
  HF_REQUIRE_SHARED(shared / "models/yolov8n/yolov8n_deq_640x384.onnx");
  const fs::path exe = fs::path(HF_BINARY_DIR "/bin/hazardforge");
  ASSERT_TRUE(fs::exists(exe)) << exe;
  const fs::path out = test::binary_dir() / "tests/e2e/udacity_run";
  fs::remove_all(out);
  const Cmd r = run_command("HAZARDFORGE_SHARED=" + quote(shared) + " " + quote(exe) + " run " +
                            quote(test::source_dir() / "configs/pedestrian_crossing_udacity.yaml") + " -o " +
                            quote(out));
  ASSERT_EQ(r.code, 0) << r.out;

  // Generated at frame 1 as an explicit edge case: a person on the left shoulder, the walk under way.
  const Json spec = read_json_file(out / "hazard_spec.json");
  EXPECT_EQ(spec["kind"], "pedestrian_crossing");
  EXPECT_EQ(spec["object_class"], "person");
  EXPECT_EQ(spec["provenance"]["frame_index"], 1);
  EXPECT_GT(spec["lateral_offset_m"].get<double>(), 1.75);  // beyond the road edge (leftmost lane)
  EXPECT_GT(spec["under_way_s"].get<double>(), 0.0);
  EXPECT_LE(spec["under_way_s"].get<double>(), 1.0);
  const Json tr = read_json_file(out / "trajectory.json");
  EXPECT_TRUE(tr["planner"]["feasible"].get<bool>());
  // The ego's speed is the video's estimate (nothing states it): within 10 % of the 29.3 m/s the lane dashes'
  // cycle gives (docs/footage-geometry.md).
  EXPECT_NEAR(tr["planner"]["ego_speed_mps"].get<double>(), 29.3, 2.93);
  // In the ego path (|y| < 1.0 + 0.5 + w/2) before the clip ends (1.52 s); in view from the start (below).
  bool in_path = false;
  for (const Json& p : tr["points"])
    in_path |= p["t"].get<double>() < 1.48 && std::abs(p["y"].get<double>()) < 1.5;
  EXPECT_TRUE(in_path);

  // The verdict with the default criteria plus require_hazard_critical.
  const Json v = read_json_file(out / "verification.json");
  EXPECT_TRUE(v["passed"].get<bool>()) << v.dump(2);
  // Already in view when the clip starts: visible in every frame from the trigger (frame 1) on.
  EXPECT_EQ(v["visible_frames"].get<int>(), v["frames"].get<int>() - 1);
  EXPECT_EQ(v["criteria"]["min_iou"], 0.5);
  EXPECT_EQ(v["criteria"]["min_redetection_rate"], 0.5);
  EXPECT_TRUE(v["criteria"]["require_unsafe"].get<bool>());
  EXPECT_TRUE(v["criteria"]["require_hazard_critical"].get<bool>());
  EXPECT_GE(v["redetection"]["rate"].get<double>(), 0.5);
  EXPECT_GE(v["unsafe"]["hazard_critical_frames"].get<int>(), 3);
  EXPECT_LT(v["ttc"]["achieved_min_ttc_s"].get<double>(), 1.5);
  // The person is re-estimated where it was inserted. Near (at most 25 m ahead: 75 px tall in the frame, 37 px
  // in the detector's 640x384 input) the re-assessed tracks read it within 0-6 %; farther out, at 19-28 px in
  // the detector's input, they read it 9-23 % far, in runs of frames with one offset (a track's start). The
  // bounds below are about twice those; the clip-wide median lies between the two groups (0.09-0.11 as the
  // ego's estimated speed moves by a few percent, which moves where the person is planned).
  EXPECT_GE(v["distance"]["matched_frames"].get<int>(), 5);
  EXPECT_LT(v["distance"]["median_rel_error"].get<double>(), 0.15);
  int near = 0;
  std::ifstream frames(out / "frames.jsonl");
  for (std::string line; std::getline(frames, line);) {
    const Json rec = Json::parse(line);
    if (!rec.contains("verifier.records") || !rec["verifier.records"].contains("data")) continue;
    const Json& d = rec["verifier.records"]["data"];
    if (!d.contains("distance_rel_error") || d["distance_rel_error"].is_null()) continue;
    const double intended = d["distance_compared_m"][1].get<double>(), rel = d["distance_rel_error"].get<double>();
    EXPECT_LT(rel, 0.35) << "frame " << d["frame"] << " at " << intended << " m";
    if (intended <= 25.0) {
      ++near;
      EXPECT_LT(rel, 0.1) << "frame " << d["frame"] << " at " << intended << " m";
    }
  }
  EXPECT_GE(near, 5);
}

}  // namespace
}  // namespace hf
