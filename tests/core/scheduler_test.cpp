// The threaded scheduler: order, timestamps, sparse and sticky streams, failures and interruption.
#include <gtest/gtest.h>

#include <unistd.h>

#include <fstream>

#include "hazardforge/apps/commands.hpp"
#include "hazardforge/core/host.hpp"
#include "test_stages.hpp"
#include "test_support.hpp"

namespace hf::core {
using namespace hf::apps;  // the CLI's frame window
namespace {

// Each test gets its own folder: ctest runs the tests as concurrent processes.
std::filesystem::path test_dir() {
  const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
  return std::filesystem::temp_directory_path() / "hf_sched_test" /
         (std::string(info->name()) + "_" + std::to_string(::getpid()));
}

Graph graph_of(ComponentRegistry& reg, const std::string& yaml) {
  auto dir = test_dir();
  std::filesystem::create_directories(dir);
  auto p = dir / "g.yaml";
  std::ofstream(p) << yaml;
  return build_graph(load_graph_config(p), reg);
}

RunOptions quiet_options(const std::string& name) {
  RunOptions o;
  o.output_dir = test_dir() / name;
  o.quiet = true;
  return o;
}

const char* kChain = R"(name: chain
nodes:
  - id: source
    stage: test_source
    params: {count: 30, fps: 20}
  - id: detector
    stage: test_detector
    inputs: {frames: source.frames}
    params: {throw_at: THROW_AT}
  - id: filter
    stage: test_filter
    inputs: {detections: detector.detections}
    params: {every: 3}
  - id: sink
    stage: test_sink
    inputs: {records: [detector.detections], hint: filter.detections, frames: source.frames}
)";

std::string chain(int throw_at) {
  std::string s = kChain;
  s.replace(s.find("THROW_AT"), 8, std::to_string(throw_at));
  return s;
}

TEST(Scheduler, DeliversEveryFrameInOrderWithFrameTimestamps) {
  hf::test::reset_seen();
  ComponentRegistry reg;
  hf::test::register_test_stages(reg);
  RunResult r = run_graph(graph_of(reg, chain(-1)), reg, quiet_options("order"));
  ASSERT_TRUE(r.ok()) << r.errors.at(0);
  EXPECT_EQ(r.frames, 30);
  std::vector<int64_t> frames;
  for (const auto& s : hf::test::g_seen["sink"])
    if (s.port == "records") {
      frames.push_back(s.frame);
      EXPECT_DOUBLE_EQ(s.timestamp, static_cast<double>(s.frame) / 20.0);
      EXPECT_EQ(s.producer, "detector.detections");
    }
  ASSERT_EQ(frames.size(), 30u);
  for (size_t i = 0; i < frames.size(); ++i) EXPECT_EQ(frames[i], static_cast<int64_t>(i));
  EXPECT_EQ(hf::test::g_finished["sink"], 1);
  // Per-stage timing and inner timings are collected.
  for (const auto& t : r.timings)
    if (t.id == "detector") {
      EXPECT_EQ(t.process_s.size(), 30u);
      EXPECT_EQ(t.inner_s.at("forward").size(), 30u);
    }
  // So is the CPU time of each node's own thread, one value per timed call. (It is not compared call by call
  // with the wall time: on a virtual machine the thread CPU clock and the steady clock are different clock
  // sources, and a call of a few microseconds has been seen with 0.1 ms more CPU than wall time.)
  for (const auto& t : r.timings) {
    ASSERT_EQ(t.process_cpu_s.size(), t.process_s.size()) << t.id;
    for (size_t i = 0; i < t.process_s.size(); ++i) EXPECT_GE(t.process_cpu_s[i], 0.0) << t.id;
  }
}

TEST(Scheduler, TheCpuTimeIsTheNodesOwnThreadsNotTheProcesss) {
  // The detector's work runs on a helper thread while the node's thread waits for it: the call's wall time is
  // that work, the node thread's CPU time is almost none of it. A process-wide CPU clock would count the
  // helper's work (and the other nodes' threads) and fail this.
  hf::test::reset_seen();
  ComponentRegistry reg;
  hf::test::register_test_stages(reg);
  std::string cfg = chain(-1);
  cfg.replace(cfg.find("params: {throw_at: -1}"), 22, "params: {throw_at: -1, helper_work: 3000000}");
  RunResult r = run_graph(graph_of(reg, cfg), reg, quiet_options("own_thread"));
  ASSERT_TRUE(r.ok()) << r.errors.at(0);
  bool seen = false;
  for (const auto& t : r.timings)
    if (t.id == "detector") {
      seen = true;
      ASSERT_EQ(t.process_cpu_s.size(), 30u);
      double wall = 0, cpu = 0;
      for (size_t i = 0; i < t.process_s.size(); ++i) {
        wall += t.process_s[i];
        cpu += t.process_cpu_s[i];
      }
      EXPECT_GT(wall, 0.0);
      EXPECT_LT(cpu, 0.25 * wall) << "node thread CPU " << cpu << " s of " << wall << " s wall";
    }
  EXPECT_TRUE(seen);
}

TEST(Scheduler, StickyInputHoldsTheLatestSparsePacket) {
  hf::test::reset_seen();
  ComponentRegistry reg;
  hf::test::register_test_stages(reg);
  RunResult r = run_graph(graph_of(reg, chain(-1)), reg, quiet_options("sticky"));
  ASSERT_TRUE(r.ok());
  int fresh = 0, held = 0;
  for (const auto& s : hf::test::g_seen["sink"]) {
    if (s.port != "hint") continue;
    if (s.producer == "(held)") ++held;
    else ++fresh;
  }
  EXPECT_EQ(fresh, 10);  // frames 0, 3, ..., 27
  EXPECT_EQ(held, 20);   // every other frame sees the held one
}

TEST(Scheduler, StageFailureNamesNodeStageAndFrameAndSinksStillFinish) {
  hf::test::reset_seen();
  ComponentRegistry reg;
  hf::test::register_test_stages(reg);
  RunResult r = run_graph(graph_of(reg, chain(5)), reg, quiet_options("fail"));
  ASSERT_EQ(r.errors.size(), 1u);
  EXPECT_EQ(r.errors[0], "node 'detector' (stage 'test_detector', built-in): frame 5: synthetic failure");
  EXPECT_EQ(hf::test::g_finished["sink"], 1);
  for (const auto& s : hf::test::g_seen["sink"]) {
    if (s.port == "records") {
      EXPECT_LT(s.frame, 5);
    }
  }
}

TEST(Scheduler, InterruptStopsTheSourceAndFlushesEveryNode) {
  hf::test::reset_seen();
  ComponentRegistry reg;
  hf::test::register_test_stages(reg);
  std::string yaml = chain(-1);
  yaml.replace(yaml.find("count: 30"), 9, "count: 100000");
  std::atomic<bool> stop{false};
  RunOptions o = quiet_options("interrupt");
  o.interrupt = &stop;
  o.on_progress = [&](int64_t done, std::optional<int64_t>) {
    if (done >= 50) stop = true;
  };
  RunResult r = run_graph(graph_of(reg, yaml), reg, o);
  EXPECT_TRUE(r.ok());
  EXPECT_TRUE(r.interrupted);
  EXPECT_GE(r.frames, 50);
  EXPECT_LT(r.frames, 100000);
  EXPECT_EQ(hf::test::g_finished["sink"], 1);
}

TEST(Scheduler, MaxFramesLimitsTheSource) {
  hf::test::reset_seen();
  ComponentRegistry reg;
  hf::test::register_test_stages(reg);
  RunOptions o = quiet_options("max");
  o.max_frames = 7;
  RunResult r = run_graph(graph_of(reg, chain(-1)), reg, o);
  EXPECT_EQ(r.frames, 7);
}

TEST(Scheduler, FrameWindowDropsFramesAtTheSourceAndKeepsTheRecordingsIndexes) {
  hf::test::reset_seen();
  ComponentRegistry reg;
  hf::test::register_test_stages(reg);
  RunOptions o = quiet_options("window");
  o.first_frame = 12;
  o.last_frame = 20;
  RunResult r = run_graph(graph_of(reg, chain(-1)), reg, o);
  ASSERT_TRUE(r.ok()) << r.errors.at(0);
  EXPECT_EQ(r.frames, 9);
  std::vector<int64_t> frames;
  for (const auto& s : hf::test::g_seen["sink"])
    if (s.port == "records") {
      frames.push_back(s.frame);  // the stage's frame_index() is the recording's index, not the stream position
      EXPECT_DOUBLE_EQ(s.timestamp, static_cast<double>(s.frame) / 20.0);
    }
  ASSERT_EQ(frames.size(), 9u);
  for (size_t i = 0; i < frames.size(); ++i) EXPECT_EQ(frames[i], static_cast<int64_t>(12 + i));
  // The filter passes frames whose index is a multiple of 3: 12, 15, 18 — decided on the recording's index.
  int fresh = 0;
  for (const auto& s : hf::test::g_seen["sink"])
    if (s.port == "hint" && s.producer != "(held)") ++fresh;
  EXPECT_EQ(fresh, 3);
  EXPECT_EQ(hf::test::g_finished["sink"], 1);
}

// A window past the recording's end (--frames 40: on 30 frames) is an error naming the window and where the
// recording ends; the stages still finish, so what they wrote stays whole.
TEST(Scheduler, FrameWindowPastTheEndIsAnErrorNamingWhereTheRecordingEnds) {
  hf::test::reset_seen();
  ComponentRegistry reg;
  hf::test::register_test_stages(reg);
  RunOptions o = quiet_options("window_past");
  o.first_frame = 40;  // the source has 30
  RunResult r = run_graph(graph_of(reg, chain(-1)), reg, o);
  ASSERT_FALSE(r.ok());
  ASSERT_EQ(r.errors.size(), 1u);
  EXPECT_NE(r.errors[0].find("frames: the frame window 40: holds no frame of the recording (its frames end at "
                             "index 29)"),
            std::string::npos)
      << r.errors[0];
  EXPECT_EQ(r.frames, 0);
  EXPECT_EQ(hf::test::g_finished["sink"], 1);
  // A window within it is no error.
  o.first_frame = 25;
  o.output_dir = quiet_options("window_end").output_dir;
  EXPECT_TRUE(run_graph(graph_of(reg, chain(-1)), reg, o).ok());
}

TEST(FrameWindow, ParsesBothSidesAndRefusesNonsenseNamingTheText) {
  EXPECT_EQ(parse_frame_window("12:40").first, 12);
  EXPECT_EQ(parse_frame_window("12:40").last, 40);
  EXPECT_EQ(parse_frame_window("12:").last, -1);
  EXPECT_EQ(parse_frame_window(":40").first, 0);
  for (const char* bad : {"12", "a:3", "3:1", "-2:5", "1:2x"}) {
    try {
      parse_frame_window(bad);
      ADD_FAILURE() << bad << " was accepted";
    } catch (const Error& e) {
      EXPECT_NE(std::string(e.what()).find(std::string("--frames '") + bad + "'"), std::string::npos) << e.what();
    }
  }
}

TEST(Scheduler, OpenFailureStopsBeforeAnyFrame) {
  hf::test::reset_seen();
  ComponentRegistry reg;
  hf::test::register_test_stages(reg);
  // throw_at 0 fails on the first frame; an unwritable output folder fails before anything runs.
  RunOptions o = quiet_options("x");
  o.output_dir = "/proc/forbidden/out";
  RunResult r = run_graph(graph_of(reg, chain(-1)), reg, o);
  ASSERT_EQ(r.errors.size(), 1u);
  EXPECT_NE(r.errors[0].find("/proc/forbidden/out: cannot create output folder"), std::string::npos) << r.errors[0];
  EXPECT_EQ(r.frames, 0);
}

TEST(Median, OddAndEven) {
  EXPECT_DOUBLE_EQ(median({3, 1, 2}), 2);
  EXPECT_DOUBLE_EQ(median({4, 1, 3, 2}), 2.5);
  EXPECT_DOUBLE_EQ(median({}), 0);
}

}  // namespace
}  // namespace hf::core
