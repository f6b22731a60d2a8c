// Testing systems with a real scenario, end to end through the CLI: a verified hazard on the Udacity highway
// clip, tested with both built-in chains, the reference external client (C++), the Python skeleton client and
// a client that crashes; the report, its JUnit XML read by python3-junitparser; the scenario exported as
// KITTI tracking and COCO, read back by independent readers and by the project's own KITTI source.
#include <gtest/gtest.h>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <map>
#include <string>

#include "command.hpp"
#include "hazardforge/types.hpp"
#include "temp_dir.hpp"
#include "test_support.hpp"

namespace hf {
namespace {

namespace fs = std::filesystem;
using test::quote;
using test::read_json_file;
using test::run_command;

const fs::path kExe = fs::path(HF_BINARY_DIR "/bin/hazardforge");

class SystemEndToEnd : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    shared_ = new fs::path(test::shared_dir());
    dir_ = new test::TempDir();
    const auto r = run_command("HAZARDFORGE_SHARED=" + quote(*shared_) + " " + quote(kExe) + " run " +
                               quote(test::source_dir() / "configs/pedestrian_crossing_udacity.yaml") +
                               " -o " + quote(run_dir()) + " -q");
    run_ok_ = r.code == 0;
    run_out_ = new std::string(r.out);
  }
  static void TearDownTestSuite() {
    delete dir_;
    delete shared_;
    delete run_out_;
  }
  static fs::path run_dir() { return dir_->path() / "run"; }
  static std::string env() { return "HAZARDFORGE_SHARED=" + quote(*shared_) + " "; }
  void SetUp() override {
    HF_REQUIRE_SHARED(*shared_ / "data/udacity-highway/test_video.mp4");
    ASSERT_TRUE(run_ok_) << *run_out_;
    ASSERT_TRUE(read_json_file(run_dir() / "verification.json")["passed"].get<bool>());
  }
  static inline fs::path* shared_ = nullptr;
  static inline test::TempDir* dir_ = nullptr;
  static inline bool run_ok_ = false;
  static inline std::string* run_out_ = nullptr;
};

// The renderer's drawn box per frame (from the run's frames.jsonl), where the hazard shows.
std::map<int64_t, Json> drawn_boxes(const fs::path& run) {
  std::map<int64_t, Json> out;
  std::ifstream in(run / "frames.jsonl");
  std::string line;
  while (std::getline(in, line)) {
    const Json j = Json::parse(line);
    if (!j.contains("renderer.hazard")) continue;
    const Json& h = j["renderer.hazard"];
    if (h.value("visible", false) && h.contains("drawn_box")) out[j["frame"].get<int64_t>()] = h["drawn_box"];
  }
  return out;
}

TEST_F(SystemEndToEnd, SystemsAreTestedSideBySideAndBadOnesAreNamedWithoutLosingTheOthers) {
  const fs::path t = dir_->path();
  std::ofstream(t / "python.yaml") << "description: the Python skeleton client\ninputs: {frames: frames}\n"
                                      "nodes:\n  - id: system\n    stage: external_program\n"
                                      "    inputs: {frames: $frames}\n    params: {command: [python3, "
                                   << quote(test::source_dir() / "docs/examples/sut/sut_client.py") << "]}\n";
  std::ofstream(t / "crash.py")
      << "import json, sys\nsys.stdin.readline()\nfor n, line in enumerate(sys.stdin):\n"
         "    if n == 3: raise SystemExit(7)\n"
         "    print(json.dumps({'frame': json.loads(line)['frame']}), flush=True)\n";
  std::ofstream(t / "crash.yaml")
      << "description: a client that exits at its 4th frame\ninputs: {frames: frames}\n"
         "nodes:\n  - id: system\n    stage: external_program\n"
         "    inputs: {frames: $frames}\n    params: {command: [python3, crash.py]}\n";
  const fs::path out = t / "test";
  const auto r = run_command(
      env() + quote(kExe) + " test " + quote(test::source_dir() / "configs/sut/paper.yaml") + " " +
      quote(test::source_dir() / "configs/sut/filtered.yaml") + " " +
      quote(test::source_dir() / "configs/sut/reference_client.yaml") + " " + quote(t / "python.yaml") + " " +
      quote(t / "crash.yaml") + " --scenarios " + quote(run_dir()) + " -o " + quote(out) + " -j 2");
  EXPECT_EQ(r.code, 3) << r.out;  // a system's error makes the command fail; the others' results are kept
  const Json rep = read_json_file(out / "report.json");
  ASSERT_EQ(rep["systems"].size(), 5u);
  std::map<std::string, Json> by;
  for (const Json& s : rep["systems"]) by[s["name"]] = s["scenarios"][0];
  for (const char* n : {"paper", "filtered", "reference_client"}) {
    ASSERT_TRUE(by.count(n)) << n;
    EXPECT_NE(by[n]["verdict"], "error") << n << ": " << by[n].dump(2);
    // Every built-in and the reference client see the person the verification re-detected.
    EXPECT_TRUE(by[n]["detection"]["detected"].get<bool>()) << n << ": " << by[n]["detection"].dump();
    EXPECT_EQ(by[n]["answered_frames"], by[n]["frames"]) << n;
  }
  // The skeleton never warns: it fails the hazard case and passes the control.
  EXPECT_EQ(by["python"]["verdict"], "failed");
  EXPECT_EQ(by["python"]["control"]["verdict"], "passed");
  EXPECT_FALSE(by["python"]["detection"]["detected"].get<bool>());
  // The crash: one error naming the scenario, the frame and the exit code.
  EXPECT_EQ(by["crash"]["verdict"], "error");
  const std::string err = by["crash"]["error"];
  EXPECT_NE(err.find("scenario run"), std::string::npos) << err;
  EXPECT_NE(err.find("exited"), std::string::npos) << err;
  EXPECT_NE(err.find("exit code 7"), std::string::npos) << err;
  EXPECT_NE(err.find("frame "), std::string::npos) << err;

  // The JUnit XML as a CI server reads it (Debian's python3-junitparser).
  const auto j = run_command("/usr/bin/python3 " + quote(test::source_dir() / "tests/system/check_junit.py") +
                             " " + quote(out / "junit.xml"));
  ASSERT_EQ(j.code, 0) << j.out;
  const Json ju = Json::parse(j.out);
  ASSERT_EQ(ju["suites"].size(), 5u);
  for (const Json& s : ju["suites"]) {
    if (s["name"] == "crash") {
      EXPECT_EQ(s["errors"], 1);
      EXPECT_EQ(s["tests"], 1);
    } else {
      EXPECT_EQ(s["tests"], 2) << s.dump();
    }
    if (s["name"] == "python") {
      EXPECT_EQ(s["failures"], 1);
    }
  }
  EXPECT_TRUE(fs::exists(out / "report.html"));
}

TEST_F(SystemEndToEnd, ExportsReadBackWithTheRenderersDrawnBoxes) {
  const fs::path t = dir_->path();
  const auto drawn = drawn_boxes(run_dir());
  ASSERT_FALSE(drawn.empty());
  // KITTI tracking, read by an independent reader (tests/system/read_kitti_tracking.py).
  ASSERT_EQ(run_command(quote(kExe) + " export " + quote(run_dir()) + " --format kitti-tracking -o " +
                        quote(t / "kitti"))
                .code,
            0);
  const auto k = run_command("python3 " + quote(test::source_dir() / "tests/system/read_kitti_tracking.py") +
                             " " + quote(t / "kitti"));
  ASSERT_EQ(k.code, 0) << k.out;
  const Json kj = Json::parse(k.out);
  // Label frames are positions in the package; the package's frames are the run's.
  const Json pkg_first = Json::parse([&] {
    std::ifstream in(run_dir() / "scenario/frames.jsonl");
    std::string l;
    std::getline(in, l);
    return l;
  }());
  const int64_t first = pkg_first["frame"].get<int64_t>();
  const double last_col = pkg_first["camera"]["width"].get<double>() - 1;
  const double last_row = pkg_first["camera"]["height"].get<double>() - 1;
  size_t compared = 0;
  for (const auto& [frame, box] : drawn) {
    const std::string key = std::to_string(frame - first);
    ASSERT_TRUE(kj["boxes"]["0000"].contains(key)) << "no label in frame " << frame;
    const Json& b = kj["boxes"]["0000"][key]["0"];  // the inserted object is track 0
    EXPECT_NEAR(b[0].get<double>(), box[0].get<double>(), 1e-3);
    EXPECT_NEAR(b[1].get<double>(), box[1].get<double>(), 1e-3);
    // KITTI's boxes are in 0-based pixel coordinates: right and bottom end at the last column and row.
    EXPECT_NEAR(b[2].get<double>(), std::min(box[0].get<double>() + box[2].get<double>(), last_col), 1e-3);
    EXPECT_NEAR(b[3].get<double>(), std::min(box[1].get<double>() + box[3].get<double>(), last_row), 1e-3);
    ++compared;
  }
  EXPECT_EQ(compared, drawn.size());

  // COCO, read by an independent reader (tests/system/read_coco.py).
  ASSERT_EQ(
      run_command(quote(kExe) + " export " + quote(run_dir()) + " --format coco -o " + quote(t / "coco"))
          .code,
      0);
  const auto c = run_command("python3 " + quote(test::source_dir() / "tests/system/read_coco.py") + " " +
                             quote(t / "coco"));
  ASSERT_EQ(c.code, 0) << c.out;
  const Json cj = Json::parse(c.out);
  EXPECT_EQ(cj["annotations"].get<size_t>(), drawn.size());
  for (const auto& [frame, box] : drawn) {
    char name[32];
    std::snprintf(name, sizeof name, "0000_%06lld.jpg", static_cast<long long>(frame - first));
    ASSERT_TRUE(cj["boxes"].contains(name)) << name;
    const Json& b = cj["boxes"][name][0];
    for (int i = 0; i < 4; ++i) EXPECT_NEAR(b[i].get<double>(), box[i].get<double>(), 1e-3);
    EXPECT_EQ(b[4], 1);  // COCO's person
  }

  // The project's own KITTI source reads the export as a tracking dataset, its labels as annotations.
  std::ofstream(t / "kitti_read.yaml")
      << "name: kitti_read\nnodes:\n  - id: source\n    stage: kitti\n    params: {root: "
      << quote(t / "kitti") << ", sequence: \"0000\", image_width: 1280, image_height: 720}\n"
      << "  - id: detector\n    stage: detector/ground_truth\n    inputs: {frames: source.frames}\n"
      << "  - id: records\n    stage: jsonl\n    inputs: {records: [detector.detections]}\n";
  const auto kr = run_command(env() + quote(kExe) + " run " + quote(t / "kitti_read.yaml") + " -o " +
                              quote(t / "kitti_read") + " -q");
  ASSERT_EQ(kr.code, 0) << kr.out;
  std::ifstream in(t / "kitti_read/frames.jsonl");
  std::string line;
  size_t frames = 0, with_person = 0;
  while (std::getline(in, line)) {
    ++frames;
    const Json rec = Json::parse(line);
    for (const Json& d : rec["detector.detections"]["items"]) with_person += d["label"] == "person";
  }
  EXPECT_EQ(frames, kj["frames"].get<size_t>());
  EXPECT_EQ(with_person, drawn.size());
}

}  // namespace
}  // namespace hf
