// The external_program stage against small programs the tests write: one that follows the protocol (paths and
// raw frames), and ones that crash, hang, print garbage or answer for another frame, each stopped with one
// error naming the frame. And risk_response, a graph's risk read as a warning.
#include <gtest/gtest.h>

#include <fstream>

#include "external_program_stage.hpp"
#include "hazardforge/error.hpp"
#include "hazardforge/testing/stage_runner.hpp"
#include "risk_response_stage.hpp"
#include "temp_dir.hpp"

namespace hf {
namespace {

namespace fs = std::filesystem;

// A client in Python: answers per frame as `body` says (a Python expression of `msg`, the frame line).
fs::path write_client(const test::TempDir& dir, const std::string& name, const std::string& per_frame) {
  const fs::path p = dir / name;
  std::ofstream(p) << "import json, sys\n"
                      "inp = sys.stdin.buffer\n"
                      "hello = json.loads(inp.readline())\n"
                      "assert hello['type'] == 'hello' and hello['protocol'] == 1\n"
                      "for line in inp:\n"
                      "    msg = json.loads(line)\n"
                      "    if msg.get('encoding') == 'bgr8':\n"
                      "        data = inp.read(msg['bytes'])\n"
                      "        assert len(data) == msg['bytes'] == msg['width'] * msg['height'] * 3\n"
                      "        msg['first_pixel'] = list(data[:3])\n"
                   << per_frame << "\n"
                   << "    sys.stdout.flush()\n";
  return p;
}

Frame frame(int64_t index) {
  Frame f;
  f.index = index;
  f.timestamp = 0.1 * static_cast<double>(index);
  f.camera = CameraModel::pinhole(64, 48, 50, 50, 32, 24);
  f.image = cv::Mat(48, 64, CV_8UC3, cv::Scalar(7, 8, 9));
  f.ego.speed_mps = 10.0;
  return f;
}

testing::StageRunner runner(const fs::path& client, const std::string& extra = "") {
  return testing::StageRunner::create<system::ExternalProgramStage>(
      "command: [python3, '" + client.string() + "']\nframe_timeout_s: 2\nstartup_timeout_s: 5\n" + extra);
}

std::string error_of(testing::StageRunner& r) {
  try {
    r.run();
  } catch (const Error& e) {
    return e.what();
  }
  return "";
}

TEST(ExternalProgram, AnswersPerFrameWithPathsAndWithRawBytes) {
  test::TempDir dir;
  const fs::path client = write_client(
      dir, "good.py",
      "    warn = msg['frame'] >= 2\n"
      "    print(json.dumps({'frame': msg['frame'], 'ttc_s': 3.0 - msg['frame'], 'warning': warn,\n"
      "        'brake': msg['frame'] >= 3, 'detections': [{'box': [1, 2, 10, 12], 'label': 'car', 'score': "
      "0.8,\n"
      "        'seen': msg.get('image', str(msg.get('first_pixel')))}]}))");
  for (const std::string mode : {"path", "raw"}) {
    auto r = runner(client, "frames: " + mode);
    for (int i = 0; i < 4; ++i) r.push("frames", frame(i), 0.1 * i);
    r.run();
    const auto resp = r.collect<SystemResponse>("response");
    ASSERT_EQ(resp.size(), 4u) << mode;
    EXPECT_FALSE(resp[1].warning);
    EXPECT_TRUE(resp[2].warning);
    EXPECT_TRUE(resp[3].brake);
    EXPECT_DOUBLE_EQ(*resp[1].ttc_s, 2.0);
    ASSERT_EQ(resp[0].detections.size(), 1u);
    EXPECT_EQ(resp[0].detections[0].box, cv::Rect2f(1, 2, 10, 12));
    EXPECT_EQ(r.collect<Detections>("detections").size(), 4u);
    if (mode == "path") {  // frames without a picture file of their own are written for the program
      EXPECT_TRUE(fs::exists(r.output_dir() / "system/frames/000003.png"));
    }
  }
}

TEST(ExternalProgram, CrashHangGarbageAndWrongFrameEachStopWithTheFrameNamed) {
  test::TempDir dir;
  struct Case {
    const char* name;
    const char* body;
    const char* expect;
  } cases[] = {
      {"crash.py",
       "    import os\n    os.abort() if msg['frame'] == 2 else None\n"
       "    print(json.dumps({'frame': msg['frame']}))",
       "exited without answering (killed by signal 6"},
      {"hang.py",
       "    import time\n    time.sleep(600) if msg['frame'] == 2 else None\n"
       "    print(json.dumps({'frame': msg['frame']}))",
       "did not answer within 2"},
      {"garbage.py",
       "    print('loading model...' if msg['frame'] == 2 else json.dumps({'frame': msg['frame']}))",
       "answered 'loading model...', which is not a JSON line"},
      {"wrong.py", "    print(json.dumps({'frame': msg['frame'] + (1 if msg['frame'] == 2 else 0)}))",
       "answered for frame 3 instead"},
      {"badbox.py", "    print(json.dumps({'frame': msg['frame'], 'detections': [{'box': [1, 2, -3, 4]}]}))",
       "detections[0]: 'box' has no width or height"},
  };
  for (const Case& c : cases) {
    auto r = runner(write_client(dir, c.name, c.body));
    for (int i = 0; i < 4; ++i) r.push("frames", frame(i), 0.1 * i);
    const std::string err = error_of(r);
    EXPECT_NE(err.find(c.expect), std::string::npos) << c.name << ": " << err;
    if (std::string(c.name) != "badbox.py") {
      EXPECT_NE(err.find("frame 2"), std::string::npos) << c.name << ": " << err;
    }
  }
}

TEST(ExternalProgram, AProgramThatCannotStartIsNamed) {
  auto r = testing::StageRunner::create<system::ExternalProgramStage>("command: [no-such-program-hf]");
  r.push("frames", frame(0), 0.0);
  const std::string err = error_of(r);
  EXPECT_NE(err.find("cannot start 'no-such-program-hf'"), std::string::npos) << err;
}

TEST(RiskResponse, WarnsWhenTheMetricSaysUnsafeAndBrakesBelowItsThreshold) {
  auto r = testing::StageRunner::create<system::RiskResponseStage>("brake_below_s: 1.0");
  for (int i = 0; i < 3; ++i) {
    Detections d;
    d.frame_index = i;
    d.items.push_back(Detection{cv::Rect2f(1, 1, 5, 5), 2, "car", 0.9f});
    RiskAssessment ra;
    ra.frame_index = i;
    ra.metric = "ttc";
    ra.threshold = 1.5;
    ra.scene_value = 2.0 - 0.6 * i;  // 2.0, 1.4, 0.8
    ra.objects.push_back(ObjectRisk{1, ra.scene_value, true});
    ra.label = ra.scene_value < 1.5 ? SafetyLabel::kUnsafe : SafetyLabel::kSafe;
    r.push("detections", d, 0.1 * i);
    r.push("risk", ra, 0.1 * i);
  }
  r.run();
  const auto resp = r.collect<SystemResponse>("response");
  ASSERT_EQ(resp.size(), 3u);
  EXPECT_FALSE(resp[0].warning);
  EXPECT_TRUE(resp[1].warning);
  EXPECT_FALSE(resp[1].brake);
  EXPECT_TRUE(resp[2].brake);
  EXPECT_NEAR(*resp[2].ttc_s, 0.8, 1e-12);
  EXPECT_EQ(resp[0].detections.size(), 1u);
}

}  // namespace
}  // namespace hf
