// The hazardforge executable end to end: plugins, inspect, validate, run on the real video, manifest.
#include <gtest/gtest.h>
#include <sys/wait.h>
#include <unistd.h>

#include <csignal>

#include <array>
#include <atomic>
#include <cstdio>
#include <fstream>

#include "command.hpp"
#include "hazardforge/apps/commands.hpp"
#include "hazardforge/types.hpp"
#include "temp_dir.hpp"
#include "test_support.hpp"

namespace {

using Cmd = hf::test::CommandResult;

Cmd run(const std::string& args) {
  return hf::test::run_command(std::string(HF_EXE) + " " + args);
}

TEST(Cli, HelpOnEveryCommand) {
  for (const char* sub :
       {"run", "validate", "plugins", "inspect", "graph", "bench", "eval", "experiment", "calibrate"}) {
    Cmd c = run(std::string(sub) + " --help");
    EXPECT_EQ(c.code, 0) << sub;
    EXPECT_NE(c.out.find("Usage"), std::string::npos) << sub << ": " << c.out;
  }
}

TEST(Cli, PluginsListsInTreePluginsWithPaths) {
  Cmd c = run("plugins");
  EXPECT_EQ(c.code, 0) << c.out;
  for (const char* s : {"source/video", "detector/yolo", "tracker/centroid", "sink/jsonl"})
    EXPECT_NE(c.out.find(s), std::string::npos) << s << "\n" << c.out;
  EXPECT_NE(c.out.find(hf::test::plugin_dir().string()), std::string::npos);
}

TEST(Cli, InspectDocumentsPortsAndParams) {
  Cmd c = run("inspect yolo");
  EXPECT_EQ(c.code, 0) << c.out;
  for (const char* s : {"detector/yolo", "inputs:", "frames", "Frame v2", "outputs:", "detections",
                        "params:", "conf_threshold"})
    EXPECT_NE(c.out.find(s), std::string::npos) << s << "\n" << c.out;
  Cmd bad = run("inspect yoloo");
  EXPECT_EQ(bad.code, 1);
  EXPECT_NE(bad.out.find("error: unknown component 'yoloo'; did you mean 'yolo'?"), std::string::npos)
      << bad.out;
}

TEST(Cli, ValidateReportsEveryErrorAndFails) {
  std::filesystem::current_path(hf::test::source_dir());
  Cmd c = run("validate tests/data/cli/bad_video_graph.yaml");
  EXPECT_EQ(c.code, 1);
  std::ifstream in(hf::test::test_data("cli/bad_video_graph.expected"));
  std::string expected((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  EXPECT_EQ(c.out, expected);
}

TEST(Cli, RunWritesPlayableVideoJsonlAndManifest) {
  HF_REQUIRE_SHARED(hf::test::shared_data("udacity-highway/test_video.mp4"));
  std::filesystem::current_path(hf::test::source_dir());
  const hf::test::TempDir tmp;
  const auto out = tmp / "run";
  Cmd c = run("run configs/examples/video_to_jsonl.yaml -o " + out.string());
  ASSERT_EQ(c.code, 0) << c.out;
  std::ifstream mf(out / "manifest.json");
  ASSERT_TRUE(mf);
  hf::Json m = hf::Json::parse(mf);
  EXPECT_EQ(m["status"], "completed");
  EXPECT_EQ(m["frames"], 38);
  EXPECT_FALSE(m["plugins"].empty());
  EXPECT_FALSE(m["resolved_graph"]["nodes"].empty());
  EXPECT_FALSE(m["started_at"].get<std::string>().empty());
  EXPECT_FALSE(m["ended_at"].get<std::string>().empty());
  std::ifstream jl(out / "frames.jsonl");
  int lines = 0;
  for (std::string l; std::getline(jl, l);) ++lines;
  EXPECT_EQ(lines, 38);
  EXPECT_TRUE(std::filesystem::exists(out / "timing.md"));
}

// A path typed in --set is relative to the folder the command is typed in (or --set-base), not to the
// config's.
TEST(Cli, RelativeSetPathsAreRelativeToWhereTheCommandIsTyped) {
  std::filesystem::current_path(hf::test::source_dir());
  const auto out = std::filesystem::temp_directory_path() / ("hf_cli_set_base_" + std::to_string(::getpid()));
  for (const std::string& base : {std::string(), std::string("/nonexistent/base")}) {
    std::filesystem::remove_all(out);
    Cmd c = run("run configs/examples/video_to_jsonl.yaml -o " + out.string() +
                " --set source.path=no_such/clip.mp4" + (base.empty() ? "" : " --set-base " + base));
    EXPECT_NE(c.code, 0);
    const std::string expected =
        ((base.empty() ? hf::test::source_dir() : std::filesystem::path(base)) / "no_such/clip.mp4").string();
    EXPECT_NE(c.out.find("'" + expected + "' does not exist"), std::string::npos) << c.out;
  }
  std::filesystem::remove_all(out);
}

TEST(Cli, GraphDot) {
  std::filesystem::current_path(hf::test::source_dir());
  Cmd c = run("graph configs/examples/video_to_jsonl.yaml --dot");
  EXPECT_EQ(c.code, 0) << c.out;
  EXPECT_EQ(c.out.rfind("digraph", 0), 0u) << c.out;
}

}  // namespace

namespace {

TEST(Cli, CtrlCKeepsWhatWasWrittenAndMarksTheManifest) {
  HF_REQUIRE_SHARED(hf::test::shared_data("udacity-highway/test_video.mp4"));
  std::filesystem::current_path(hf::test::source_dir());
  const hf::test::TempDir tmp;
  const auto out = tmp / "run";
  const pid_t pid = fork();
  ASSERT_GE(pid, 0);
  if (pid == 0) {
    const std::string o = out.string();
    execl(HF_EXE, HF_EXE, "run", "configs/assess_video.yaml", "-o", o.c_str(), "-q",
          static_cast<char*>(nullptr));
    _exit(127);
  }
  // Wait until a few frames are on disk, then press Ctrl-C.
  for (int i = 0; i < 600; ++i) {
    std::ifstream jl(out / "frames.jsonl");
    int lines = 0;
    for (std::string l; std::getline(jl, l);) ++lines;
    if (lines >= 3) break;
    usleep(100 * 1000);
  }
  kill(pid, SIGINT);
  int st = 0;
  waitpid(pid, &st, 0);
  ASSERT_TRUE(WIFEXITED(st));
  EXPECT_EQ(WEXITSTATUS(st), 130);
  std::ifstream mf(out / "manifest.json");
  hf::Json m = hf::Json::parse(mf);
  EXPECT_EQ(m["status"], "interrupted");
  const int frames = m["frames"].get<int>();
  EXPECT_GE(frames, 3);
  EXPECT_LT(frames, 38);
  std::ifstream jl(out / "frames.jsonl");
  int lines = 0;
  for (std::string l; std::getline(jl, l);) {
    EXPECT_TRUE(hf::Json::accept(l)) << "a truncated line was left behind: " << l;
    ++lines;
  }
  EXPECT_EQ(lines, frames);
  // The annotated video was finalised: it opens and holds every processed frame.
  EXPECT_TRUE(std::filesystem::exists(out / "assessed.mp4"));
}

}  // namespace

namespace {

// docs/stages.md is generated from the stages' own declarations; regenerate it with
//   build/bin/hazardforge inspect --all --markdown > docs/stages.md
// Every registered component must have its section there.
TEST(Cli, GeneratedStageReferenceCoversEveryComponent) {
  Cmd c = run("plugins --json");
  ASSERT_EQ(c.code, 0) << c.out;
  const hf::Json j = hf::Json::parse(c.out);
  std::ifstream in(hf::test::source_dir() / "docs" / "stages.md");
  std::string doc((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  int n = 0;
  for (const auto& p : j["plugins"])
    for (const auto& comp : p["components"]) {
      const std::string kn = comp.get<std::string>();
      const std::string name = kn.substr(kn.find('/') + 1), kind = kn.substr(0, kn.find('/'));
      EXPECT_NE(doc.find("### `" + name + "` (" + kind + ")"), std::string::npos)
          << kn << " is missing from docs/stages.md: regenerate it with "
          << "`build/bin/hazardforge inspect --all --markdown > docs/stages.md`";
      ++n;
    }
  EXPECT_GE(n, 25);
  // And it is exactly what the code declares today.
  Cmd gen = run("inspect --all --markdown");
  ASSERT_EQ(gen.code, 0) << gen.out;
  EXPECT_TRUE(gen.out == doc) << "docs/stages.md differs from the stages' declarations: regenerate it with "
                              << "`build/bin/hazardforge inspect --all --markdown > docs/stages.md`";
}

}  // namespace

namespace {

// What a signal does to a process that installed the CLI's handlers: "flag" when it set the stop flag and the
// process went on, "killed by N" when it ended the process.
std::string after_signals(std::initializer_list<int> signals) {
  const pid_t pid = fork();
  if (pid == 0) {
    static std::atomic<bool> flag{false};
    hf::apps::install_stop_signals(&flag);
    for (int sig : signals) raise(sig);
    _exit(flag.load() ? 0 : 3);
  }
  int st = 0;
  waitpid(pid, &st, 0);
  if (WIFSIGNALED(st)) return "killed by " + std::to_string(WTERMSIG(st));
  return WEXITSTATUS(st) == 0 ? "flag" : "exit " + std::to_string(WEXITSTATUS(st));
}

// SIGTERM stops a command as Ctrl-C does; a run stopped by SIGTERM still finishes (and writes its manifest)
// when its parent command forwards a Ctrl-C as SIGINT; the same signal twice ends the process at once.
TEST(Cli, SigtermStopsLikeCtrlCAndAForwardedCtrlCDoesNotCutTheRunShort) {
  EXPECT_EQ(after_signals({SIGTERM}), "flag");
  EXPECT_EQ(after_signals({SIGINT}), "flag");
  EXPECT_EQ(after_signals({SIGTERM, SIGINT}), "flag");
  EXPECT_EQ(after_signals({SIGINT, SIGTERM}), "flag");
  EXPECT_EQ(after_signals({SIGTERM, SIGTERM}), "killed by " + std::to_string(SIGTERM));
  EXPECT_EQ(after_signals({SIGINT, SIGINT}), "killed by " + std::to_string(SIGINT));
}

}  // namespace
