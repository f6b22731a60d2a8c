// Hostile and careless use of `hazardforge run`: output paths, run-folder ownership, invalid UTF-8, the
// manifest.
#include <fcntl.h>
#include <gtest/gtest.h>
#include <sys/stat.h>
#include <sys/inotify.h>
#include <sys/wait.h>
#include <unistd.h>

#include <csignal>
#include <fstream>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/videoio.hpp>
#include <sstream>

#include "command.hpp"
#include "hazardforge/types.hpp"
#include "temp_dir.hpp"
#include "test_support.hpp"

namespace fs = std::filesystem;

namespace {

using hf::test::quote;

// Three small synthetic frames and a graph image_sequence -> jsonl whose sink file is `file`.
struct Scene {
  hf::test::TempDir dir;
  fs::path config = dir / "graph.yaml";
  fs::path run = dir / "run";
  explicit Scene(const std::string& file = "frames.jsonl", const std::string& name = "hardening") {
    fs::create_directories(dir / "images");
    for (int i = 0; i < 3; ++i)
      cv::imwrite((dir / ("images/" + std::to_string(i) + ".png")).string(),
                  cv::Mat(48, 64, CV_8UC3, cv::Scalar(40 * i, 80, 120)));
    std::ofstream(config)
        << "name: \"" << name << "\"\nnodes:\n"
        << "  - id: source\n    stage: image_sequence\n    params: {path: images, hfov_deg: 60}\n"
        << "  - id: sink\n    stage: jsonl\n    inputs: {records: [source.frames]}\n"
        << "    params: {file: \"" << file << "\", csv: false}\n";
  }
  hf::test::CommandResult run_cli(const std::string& extra = "", const std::string& cwd = "") const {
    std::string cmd = std::string(HF_EXE) + " run -q " + quote(config) + " " + extra;
    if (cwd.empty()) cmd += " -o " + quote(run);
    return hf::test::run_command((cwd.empty() ? "" : "cd " + quote(cwd) + " && ") + cmd);
  }
  hf::Json manifest() const { return hf::test::read_json_file(run / "manifest.json"); }
};

// Starts `hazardforge run -q CONFIG -o RUN --resume` of the scene as a child process; its pid (-1: no fork).
pid_t start_resumed_run(const Scene& s) {
  const std::string config = s.config.string(), run = s.run.string();
  const pid_t pid = fork();
  if (pid == 0) {
    execl(HF_EXE, HF_EXE, "run", "-q", config.c_str(), "-o", run.c_str(), "--resume",
          static_cast<char*>(nullptr));
    _exit(127);
  }
  return pid;
}

// Every file below `root`, relative; used to show that nothing appeared outside the run folder.
std::vector<std::string> files_below(const fs::path& root) {
  std::vector<std::string> v;
  for (const auto& e : fs::recursive_directory_iterator(root))
    v.push_back(fs::relative(e.path(), root).string());
  std::sort(v.begin(), v.end());
  return v;
}

bool has(const std::string& text, const std::string& part) {
  return text.find(part) != std::string::npos;
}

TEST(Hardening, SinkFileWithDotDotIsRefusedAndTheManifestSaysFailed) {
  Scene s("../escaped.jsonl");
  const auto before = files_below(s.dir.path());
  const auto c = s.run_cli();
  EXPECT_EQ(c.code, 1) << c.out;
  const std::string msg =
      "node 'sink': param 'file' = '../escaped.jsonl' contains '..'; output paths must stay inside the run "
      "folder";
  EXPECT_TRUE(has(c.out, msg)) << c.out;
  EXPECT_FALSE(fs::exists(s.dir / "escaped.jsonl"));
  const hf::Json m = s.manifest();
  EXPECT_EQ(m["status"], "failed");
  ASSERT_EQ(m["errors"].size(), 1u);
  EXPECT_TRUE(has(m["errors"][0].get<std::string>(), msg)) << m["errors"];
  for (const auto& f : files_below(s.dir.path()))
    EXPECT_TRUE(f.rfind("run", 0) == 0 || std::find(before.begin(), before.end(), f) != before.end()) << f;
}

TEST(Hardening, SinkFileWithAnAbsolutePathIsRefused) {
  hf::test::TempDir victim;
  Scene s((victim / "passwd").string());
  { std::ofstream(victim / "passwd") << "root:x:0:0\n"; }
  const auto c = s.run_cli();
  EXPECT_EQ(c.code, 1) << c.out;
  EXPECT_TRUE(has(c.out, "node 'sink': param 'file' = '" + (victim / "passwd").string() +
                             "' is an absolute path; output paths must be relative to the run folder"))
      << c.out;
  std::ifstream in(victim / "passwd");
  std::string line;
  std::getline(in, line);
  EXPECT_EQ(line, "root:x:0:0");
  EXPECT_EQ(s.manifest()["status"], "failed");
}

TEST(Hardening, ConfigNameCannotPlaceTheDefaultRunFolderOutsideRuns) {
  Scene s("frames.jsonl", "../../../escaped");
  fs::create_directories(s.dir / "cwd/a/b");
  const fs::path cwd = s.dir / "cwd/a/b";
  const auto c = s.run_cli("", cwd.string());
  EXPECT_EQ(c.code, 0) << c.out;
  std::vector<std::string> runs;
  for (const auto& e : fs::directory_iterator(cwd / "runs")) runs.push_back(e.path().filename().string());
  ASSERT_EQ(runs.size(), 1u);
  EXPECT_EQ(runs[0].rfind("_.._.._escaped-", 0), 0u) << runs[0];
  EXPECT_TRUE(fs::exists(cwd / "runs" / runs[0] / "frames.jsonl"));
  EXPECT_FALSE(fs::exists(s.dir / "cwd/escaped-"));
  for (const auto& f : files_below(s.dir / "cwd")) EXPECT_EQ(f.rfind("a", 0), 0u) << f;
}

TEST(Hardening, ASecondRunIntoTheSameFolderIsRefused) {
  Scene s;
  ASSERT_EQ(s.run_cli().code, 0);
  const std::string first = hf::test::read_json_file(s.run / "manifest.json")["started_at"];
  const auto c = s.run_cli("--set source.max_frames=1");
  EXPECT_EQ(c.code, 1) << c.out;
  EXPECT_EQ(c.out,
            "error: " + s.run.string() +
                ": the output folder already holds a run (status 'completed'); use --resume to run the "
                "same config into it again or --overwrite to clear it first\n");
  EXPECT_EQ(s.manifest()["status"], "completed");
  EXPECT_EQ(s.manifest()["started_at"], first);
}

TEST(Hardening, ANonEmptyFolderWithoutARunIsRefused) {
  Scene s;
  fs::create_directories(s.run);
  { std::ofstream(s.run / "notes.txt") << "mine"; }
  const auto c = s.run_cli("--overwrite");
  EXPECT_EQ(c.code, 1) << c.out;
  EXPECT_EQ(c.out, "error: " + s.run.string() +
                       ": the output folder is not empty and holds no run (no manifest.json); a run folder "
                       "belongs to one run: choose a new or empty folder\n");
  EXPECT_TRUE(fs::exists(s.run / "notes.txt"));
}

TEST(Hardening, ResumeNeedsTheSameConfig) {
  Scene s;
  ASSERT_EQ(s.run_cli().code, 0);
  const auto bad = s.run_cli("--resume --set source.max_frames=1");
  EXPECT_EQ(bad.code, 1) << bad.out;
  EXPECT_EQ(bad.out, "error: " + s.run.string() +
                         ": --resume needs the same config, but the earlier run's config differs at "
                         "'/nodes/0/params/max_frames'; use --overwrite or a new folder\n");
  const auto ok = s.run_cli("--resume");
  EXPECT_EQ(ok.code, 0) << ok.out;
  EXPECT_EQ(s.manifest()["status"], "completed");
}

TEST(Hardening, ResumeDoesNotWriteThroughSymlinksPlantedInTheRunFolder) {
  Scene s("sub/frames.jsonl");
  ASSERT_EQ(s.run_cli().code, 0);
  hf::test::TempDir outside;
  fs::remove_all(s.run / "sub");
  fs::create_directory_symlink(outside.path(), s.run / "sub");
  const auto c = s.run_cli("--resume");
  EXPECT_EQ(c.code, 1) << c.out;
  EXPECT_TRUE(has(c.out, "node 'sink': param 'file' = 'sub/frames.jsonl': " + (s.run / "sub").string() +
                             " is a symlink leading outside the run folder"))
      << c.out;
  EXPECT_TRUE(fs::is_empty(outside.path()));
  EXPECT_EQ(s.manifest()["status"], "failed");
}

TEST(Hardening, ResumeRefusesASymlinkPlantedAtARecordFile) {
  Scene s;
  ASSERT_EQ(s.run_cli().code, 0);
  hf::test::TempDir outside;
  { std::ofstream(outside / "victim") << "keep"; }
  fs::remove(s.run / "frames.jsonl");
  fs::create_symlink(outside / "victim", s.run / "frames.jsonl");
  const auto c = s.run_cli("--resume");
  EXPECT_EQ(c.code, 1) << c.out;
  EXPECT_TRUE(
      has(c.out, (s.run / "frames.jsonl").string() +
                     ": cannot write: it is a symlink (refused: it could point outside the run folder)"))
      << c.out;
  std::ifstream in(outside / "victim");
  std::string text;
  std::getline(in, text);
  EXPECT_EQ(text, "keep");
  EXPECT_EQ(s.manifest()["status"], "failed");
}

TEST(Hardening, InvalidUtf8InAnErrorEndsInTheManifestNotInAnException) {
  Scene s;
  // An override whose value is not UTF-8 and makes the source fail: the error text carries the byte.
  const auto c = s.run_cli("--set 'source.pattern=\xff*.png'");
  EXPECT_EQ(c.code, 1) << c.out;
  EXPECT_TRUE(has(c.out, "has no file matching '\xff*.png'")) << c.out;
  EXPECT_FALSE(has(c.out, "type_error")) << c.out;
  const hf::Json m = s.manifest();
  EXPECT_EQ(m["status"], "failed");
  ASSERT_EQ(m["errors"].size(), 1u);
  EXPECT_TRUE(has(m["errors"][0].get<std::string>(), "has no file matching '\xEF\xBF\xBD*.png'"))
      << m["errors"];
}

}  // namespace

namespace {

TEST(Hardening, ValidateDoesNotLoadLibrariesNamedOnlyByTheConfig) {
  Scene s;
  const fs::path lib_dir = fs::path(HF_FIXTURE_DIR) / "fixture_good_a";
  std::ofstream(s.config)
      << "plugin_paths: [" << lib_dir.string() << "]\nnodes:\n"
      << "  - id: source\n    stage: image_sequence\n    params: {path: images, hfov_deg: 60}\n"
      << "  - id: det\n    stage: dup_detector\n    inputs: {frames: source.frames}\n";
  const auto plain = hf::test::run_command(std::string(HF_EXE) + " validate " + quote(s.config));
  EXPECT_EQ(plain.code, 1) << plain.out;
  EXPECT_TRUE(
      has(plain.out, s.config.string() +
                         ": warning: plugin_paths not loaded (loading runs the libraries' code); pass "
                         "--load-config-plugins to load them\n"))
      << plain.out;
  EXPECT_TRUE(has(plain.out, "'dup_detector'")) << plain.out;
  const auto asked =
      hf::test::run_command(std::string(HF_EXE) + " validate --load-config-plugins " + quote(s.config));
  EXPECT_FALSE(has(asked.out, "warning: plugin_paths not loaded")) << asked.out;
  EXPECT_FALSE(has(asked.out, "'dup_detector'")) << asked.out;
}

TEST(Hardening, CredentialsInArgumentsAreRedactedFromTheManifest) {
  Scene s;
  const auto c = s.run_cli("--set 'sink.file=http://alice:s3cret@h/x.jsonl?token=t0k'");
  EXPECT_EQ(c.code, 0) << c.out;
  std::ifstream in(s.run / "manifest.json");
  const std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  EXPECT_EQ(text.find("s3cret"), std::string::npos);
  EXPECT_EQ(text.find("t0k"), std::string::npos);
  EXPECT_NE(text.find("http://***@h/x.jsonl?***"), std::string::npos);
}

}  // namespace

namespace {

// experiment re-runs a run that did not complete into its own folder (--overwrite) and keeps each run's log.
TEST(Hardening, ExperimentRerunsAnIncompleteRunIntoItsFolder) {
  Scene s;
  const fs::path spec = s.dir / "exp.yaml", out = s.dir / "exp";
  std::ofstream(spec) << "name: exp\nbase: graph.yaml\nruns:\n  - name: one\n    set: [source.max_frames=1]\n"
                      << "  - name: two\n    set: [source.max_frames=2]\n";
  const std::string cmd = std::string(HF_EXE) + " experiment " + quote(spec) + " -o " + quote(out);
  const auto first = hf::test::run_command(cmd);
  ASSERT_EQ(first.code, 0) << first.out;
  for (const char* id : {"one", "two"}) {
    EXPECT_TRUE(fs::exists(out / id / "run.log")) << id;
    EXPECT_EQ(hf::test::read_json_file(out / id / "manifest.json")["status"], "completed") << id;
  }
  // A run left failed (e.g. by an earlier crash) is run again into the same folder.
  hf::Json m = hf::test::read_json_file(out / "two" / "manifest.json");
  m["status"] = "failed";
  std::ofstream(out / "two" / "manifest.json") << m.dump();
  const auto second = hf::test::run_command(cmd);
  ASSERT_EQ(second.code, 0) << second.out;
  EXPECT_TRUE(has(second.out, "experiment: one already complete, skipped")) << second.out;
  EXPECT_EQ(hf::test::read_json_file(out / "two" / "manifest.json")["status"], "completed");
  EXPECT_EQ(hf::test::read_json_file(out / "two" / "manifest.json")["frames"], 2);
  EXPECT_TRUE(fs::exists(out / "two" / "run.log"));
}

}  // namespace

namespace {

// A cut video: fails by default; with allow_partial the run ends "incomplete", says how many frames, exit 0.
TEST(Hardening, ACutVideoFailsOrEndsIncomplete) {
  hf::test::TempDir dir;
  const fs::path video = dir / "clip.avi", run = dir / "run";
  {
    cv::VideoWriter w(video.string(), cv::VideoWriter::fourcc('M', 'J', 'P', 'G'), 25.0, {160, 120});
    ASSERT_TRUE(w.isOpened());
    for (int k = 0; k < 38; ++k) w.write(cv::Mat(120, 160, CV_8UC3, cv::Scalar::all(6 * k)));
  }
  fs::resize_file(video, fs::file_size(video) * 4 / 10);
  const fs::path config = dir / "graph.yaml";
  std::ofstream(config)
      << "nodes:\n  - id: source\n    stage: video\n    params: {path: clip.avi, hfov_deg: 60}\n"
      << "  - id: sink\n    stage: jsonl\n    inputs: {records: [source.frames]}\n"
      << "    params: {csv: false}\n";
  const std::string exe = std::string(HF_EXE) + " run -q " + quote(config);
  const auto strict = hf::test::run_command(exe + " -o " + quote(run));
  EXPECT_EQ(strict.code, 1) << strict.out;
  EXPECT_TRUE(has(strict.out, "of the 38 frames its container declares")) << strict.out;
  EXPECT_EQ(hf::test::read_json_file(run / "manifest.json")["status"], "failed");
  const auto partial =
      hf::test::run_command(exe + " -o " + quote(run) + " --overwrite --set source.allow_partial=true");
  EXPECT_EQ(partial.code, 0) << partial.out;
  EXPECT_TRUE(has(partial.out, "warning: incomplete: node 'source': video file '")) << partial.out;
  const hf::Json m = hf::test::read_json_file(run / "manifest.json");
  EXPECT_EQ(m["status"], "incomplete");
  ASSERT_EQ(m["incomplete"].size(), 1u);
  EXPECT_TRUE(has(m["incomplete"][0].get<std::string>(), "of the 38 frames its container declares")) << m;
  EXPECT_LT(m["frames"].get<int>(), 37);
}

}  // namespace

namespace {

// A disk that fills up during the run, stood in for by a file-size limit (EFBIG where a full disk gives
// ENOSPC; the same write path): the run fails naming file and frame, the JSON lines file ends in a whole
// line, no temporary file is left and the manifest says failed.
TEST(Hardening, AFullDiskFailsTheRunWithWholeLinesAndNoTemporaries) {
  Scene s;
  for (int i = 3; i < 150; ++i)
    cv::imwrite((s.dir / ("images/" + std::to_string(i) + ".png")).string(), cv::Mat(48, 64, CV_8UC3));
  // dash counts ulimit -f in 512-byte blocks: 40 = 20 KB, more than the manifest, less than 150 lines.
  // Nothing is estimated from the (blank) footage, so the first file that outgrows the limit is the sink's.
  const auto c =
      hf::test::run_command("trap '' XFSZ; ulimit -f 40; " + std::string(HF_EXE) + " run -q " +
                            quote(s.config) + " -o " + quote(s.run) + " --set source.self_calibrate=false");
  EXPECT_EQ(c.code, 1) << c.out;
  EXPECT_TRUE(has(c.out, (s.run / "frames.jsonl").string() + ": cannot write: File too large (frame "))
      << c.out;
  EXPECT_EQ(s.manifest()["status"], "failed");
  std::ifstream in(s.run / "frames.jsonl", std::ios::binary);
  const std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  ASSERT_FALSE(text.empty());
  EXPECT_EQ(text.back(), '\n');
  std::istringstream lines(text);
  for (std::string line; std::getline(lines, line);) EXPECT_TRUE(hf::Json::accept(line)) << line;
  for (const auto& f : files_below(s.run)) EXPECT_EQ(f.find(".tmp."), std::string::npos) << f;
}

}  // namespace

namespace {

// Ten anchors of ten aliases each ("billion laughs"): 10^10 values once every alias is copied. The shell
// caps the address space, so a conversion that copies them fails fast instead of taking the machine's memory.
std::string laughs() {
  std::string y = "  a: &a [lol, lol, lol, lol, lol, lol, lol, lol, lol, lol]\n";
  for (char c = 'b'; c <= 'j'; ++c) {
    y += std::string("  ") + c + ": &" + c + " [";
    for (int i = 0; i < 10; ++i) y += std::string(i ? ", " : "") + "*" + static_cast<char>(c - 1);
    y += "]\n";
  }
  return y;
}

const std::string kMemoryCap = "ulimit -v 3000000; ";

TEST(Hardening, YamlAliasesExpandingWithoutLimitAreRefusedNamingFileAndLine) {
  Scene s;
  { std::ofstream(s.config, std::ios::app) << "unused:\n" << laughs(); }
  for (const std::string& cmd : {std::string("validate"), std::string("run -q -o ") + quote(s.run)}) {
    const auto c = hf::test::run_command(kMemoryCap + HF_EXE + " " + cmd + " " + quote(s.config));
    EXPECT_EQ(c.code, 1) << cmd << "\n" << c.out;
    EXPECT_TRUE(has(c.out, s.config.string() + ":")) << c.out;
    EXPECT_TRUE(has(c.out, "YAML aliases expand to more than")) << c.out;
    EXPECT_FALSE(has(c.out, "bad_alloc")) << c.out;
  }
  EXPECT_FALSE(fs::exists(s.run));
}

TEST(Hardening, YamlAliasesInASetValueAreBoundedToo) {
  Scene s;
  std::string value = "[";
  const std::string bomb = laughs();
  // The same anchors as one flow sequence: "[&a [lol, ...], &b [*a, ...], ...]".
  std::istringstream lines(bomb);
  bool first = true;
  for (std::string line; std::getline(lines, line);) {
    value += (first ? "" : ", ") + line.substr(line.find('&'));
    first = false;
  }
  value += "]";
  const auto c = hf::test::run_command(kMemoryCap + HF_EXE + " validate " + quote(s.config) +
                                       " --set 'sink.file=" + value + "'");
  EXPECT_EQ(c.code, 1) << c.out;
  EXPECT_TRUE(has(c.out, "--set sink.file=")) << c.out;
  EXPECT_TRUE(has(c.out, "YAML aliases expand to more than")) << c.out;
}

TEST(Hardening, AnIncludeOfAnEndlessFileIsRefusedNamingIt) {
  Scene s;
  { std::ofstream(s.config, std::ios::app) << "  - include: /dev/zero\n"; }
  const auto c = hf::test::run_command(kMemoryCap + HF_EXE + " validate " + quote(s.config));
  EXPECT_EQ(c.code, 1) << c.out;
  EXPECT_TRUE(has(c.out, "/dev/zero: error: larger than")) << c.out;
}

// f0 includes f1 twice, f1 includes f2 twice, ...: 2^16 copies of f16 if every include were expanded.
TEST(Hardening, AnIncludeDiamondIsBounded) {
  Scene s;
  for (int i = 0; i < 16; ++i)
    std::ofstream(s.dir / ("f" + std::to_string(i) + ".yaml"))
        << "nodes:\n  - include: f" << i + 1 << ".yaml\n    prefix: l_\n  - include: f" << i + 1
        << ".yaml\n    prefix: r_\n";
  std::ofstream(s.dir / "f16.yaml") << "nodes:\n  - id: s\n    stage: image_sequence\n"
                                    << "    params: {path: images, hfov_deg: 60}\n";
  { std::ofstream(s.config, std::ios::app) << "  - include: f0.yaml\n"; }
  const auto c = hf::test::run_command(kMemoryCap + HF_EXE + " validate " + quote(s.config));
  EXPECT_EQ(c.code, 1) << c.out;
  EXPECT_TRUE(has(c.out, "subgraph includes")) << c.out;
  EXPECT_TRUE(has(c.out, (s.dir / "f").string())) << c.out;
}

}  // namespace

namespace {

// A folder that is not a run of ours, though it has a manifest.json (a web app's): --overwrite leaves it
// alone.
TEST(Hardening, OverwriteRefusesAFolderWhoseManifestIsNotARunManifest) {
  Scene s;
  fs::create_directories(s.run / "icons");
  { std::ofstream(s.run / "manifest.json") << R"({"name": "app", "start_url": "/", "status": "x"})"; }
  { std::ofstream(s.run / "index.html") << "<html></html>"; }
  { std::ofstream(s.run / "icons" / "a.png") << "png"; }
  const auto c = s.run_cli("--overwrite");
  EXPECT_EQ(c.code, 1) << c.out;
  EXPECT_TRUE(has(c.out, (s.run / "manifest.json").string() + ": not a HazardForge run manifest")) << c.out;
  EXPECT_EQ(files_below(s.run),
            (std::vector<std::string>{"icons", "icons/a.png", "index.html", "manifest.json"}));
}

// --overwrite removes what the earlier run wrote and keeps what the user put into its folder since.
TEST(Hardening, OverwriteRemovesOnlyTheEarlierRunsFiles) {
  Scene s("sub/frames.jsonl");
  ASSERT_EQ(s.run_cli().code, 0);
  { std::ofstream(s.run / "notes.txt") << "mine"; }
  { std::ofstream(s.run / "sub" / "mine.txt") << "mine too"; }
  const auto c = s.run_cli("--overwrite --set sink.file=other.jsonl --set source.max_frames=2");
  EXPECT_EQ(c.code, 0) << c.out;
  EXPECT_FALSE(fs::exists(s.run / "sub" / "frames.jsonl"));
  EXPECT_TRUE(fs::exists(s.run / "notes.txt"));
  EXPECT_TRUE(fs::exists(s.run / "sub" / "mine.txt"));
  EXPECT_EQ(s.manifest()["frames"], 2);
  EXPECT_EQ(s.manifest()["status"], "completed");
  // The user's files stay theirs on the next --overwrite too; the run's own go.
  const auto again = s.run_cli("--overwrite");
  EXPECT_EQ(again.code, 0) << again.out;
  EXPECT_FALSE(fs::exists(s.run / "other.jsonl"));
  EXPECT_TRUE(fs::exists(s.run / "notes.txt"));
  EXPECT_TRUE(fs::exists(s.run / "sub" / "mine.txt"));
  EXPECT_TRUE(fs::exists(s.run / "sub" / "frames.jsonl"));
}

}  // namespace

namespace {

// A secret's variable is never expanded into a config, where it would reach the manifest and an LLM prompt.
TEST(Hardening, VariablesNamingSecretsAreNotExpandedIntoTheConfig) {
  Scene s("${HF_TEST_API_KEY}.jsonl");
  const auto c = hf::test::run_command("HF_TEST_API_KEY=sk-live-0123 " + std::string(HF_EXE) + " run -q " +
                                       quote(s.config) + " -o " + quote(s.run));
  EXPECT_EQ(c.code, 1) << c.out;
  EXPECT_TRUE(has(c.out, s.config.string() + ":9:")) << c.out;
  EXPECT_TRUE(has(c.out, "${HF_TEST_API_KEY} is not expanded")) << c.out;
  EXPECT_FALSE(has(c.out, "sk-live-0123")) << c.out;
  EXPECT_FALSE(fs::exists(s.run / "sk-live-0123.jsonl"));
}

}  // namespace

namespace {

// SIGTERM (a service manager, `timeout`, `kill`) stops a run as Ctrl-C does: what was written is kept and
// the manifest ends "interrupted". The run is held at its sink's file, a FIFO the test opens, while the
// signal arrives.
TEST(Hardening, SigtermEndsARunInterruptedLikeCtrlC) {
  Scene s;
  ASSERT_EQ(s.run_cli().code, 0);
  fs::remove(s.run / "frames.jsonl");
  ASSERT_EQ(mkfifo((s.run / "frames.jsonl").c_str(), 0600), 0);
  const pid_t pid = start_resumed_run(s);
  ASSERT_GT(pid, 0);
  // Opening the FIFO returns once the run's sink has opened it for writing: the run is under way.
  const int fd = ::open((s.run / "frames.jsonl").c_str(), O_RDONLY);
  ASSERT_GE(fd, 0);
  ASSERT_EQ(kill(pid, SIGTERM), 0);
  char buf[4096];
  while (::read(fd, buf, sizeof buf) > 0) {
  }
  ::close(fd);
  int st = 0;
  ASSERT_EQ(waitpid(pid, &st, 0), pid);
  ASSERT_TRUE(WIFEXITED(st)) << "ended by signal " << WTERMSIG(st);
  EXPECT_EQ(WEXITSTATUS(st), 130);
  EXPECT_EQ(s.manifest()["status"], "interrupted");
}

// A run into a folder another run is still writing into (--resume or --overwrite) is refused: two writers
// would mix their files and the second's manifest would describe neither. The first run is held in its sink's
// open of a FIFO no one reads yet; the test knows it is under way when its manifest ("running") is renamed into
// place (inotify), and lets it finish afterwards.
TEST(Hardening, ASecondRunIntoAFolderStillBeingWrittenIsRefused) {
  Scene s;
  ASSERT_EQ(s.run_cli().code, 0);
  fs::remove(s.run / "frames.jsonl");
  ASSERT_EQ(mkfifo((s.run / "frames.jsonl").c_str(), 0600), 0);
  const int in = inotify_init1(IN_CLOEXEC);
  ASSERT_GE(in, 0);
  ASSERT_GE(inotify_add_watch(in, s.run.c_str(), IN_MOVED_TO), 0);
  const std::string run = s.run.string();
  const pid_t pid = start_resumed_run(s);
  ASSERT_GT(pid, 0);
  for (bool started = false; !started;) {  // until the first run's manifest is renamed into place
    alignas(inotify_event) char buf[4096];
    const ssize_t n = ::read(in, buf, sizeof buf);
    ASSERT_GT(n, 0);
    for (ssize_t at = 0; at < n;) {
      const auto* ev = reinterpret_cast<const inotify_event*>(buf + at);
      if (ev->len > 0 && std::string(ev->name) == "manifest.json") started = true;
      at += static_cast<ssize_t>(sizeof(inotify_event) + ev->len);
    }
  }
  ::close(in);
  EXPECT_EQ(s.manifest()["status"], "running");
  for (const char* use : {"--resume", "--overwrite"}) {
    const auto second = s.run_cli(use);
    EXPECT_EQ(second.code, 1) << use << ": " << second.out;
    EXPECT_TRUE(has(second.out, run + ": another run is still writing into this folder")) << second.out;
  }
  const int fd = ::open((s.run / "frames.jsonl").c_str(), O_RDONLY);  // lets the first run go on
  ASSERT_GE(fd, 0);
  char buf[4096];
  while (::read(fd, buf, sizeof buf) > 0) {
  }
  ::close(fd);
  int st = 0;
  ASSERT_EQ(waitpid(pid, &st, 0), pid);
  ASSERT_TRUE(WIFEXITED(st));
  EXPECT_EQ(WEXITSTATUS(st), 0);
  EXPECT_EQ(s.manifest()["status"], "completed");  // the first run's, untouched by the refused ones
  EXPECT_TRUE(fs::is_fifo(s.run / "frames.jsonl"));  // --overwrite removed nothing
}

// `eval` on a graph without an evaluation sink is refused before it runs: no run folder whose manifest says
// "completed" behind a failing command.
TEST(Hardening, EvalOfAGraphWithoutAnEvaluationSinkIsRefusedBeforeItRuns) {
  Scene s;
  const auto c = hf::test::run_command(std::string(HF_EXE) + " eval " + quote(s.config) + " -o " + quote(s.run));
  EXPECT_EQ(c.code, 1) << c.out;
  EXPECT_TRUE(has(c.out, s.config.string() + ": the graph has no evaluation sink (stage 'evaluation')")) << c.out;
  EXPECT_FALSE(fs::exists(s.run));
}

TEST(Hardening, AFifoAsSourceOrConfigIsRefusedInsteadOfBlockingForever) {
  hf::test::TempDir dir;
  const fs::path fifo = dir / "clip.mp4", run = dir / "run";
  ASSERT_EQ(mkfifo(fifo.c_str(), 0600), 0);
  const fs::path config = dir / "graph.yaml";
  std::ofstream(config)
      << "nodes:\n  - id: source\n    stage: video\n    params: {path: clip.mp4, hfov_deg: 60}\n"
      << "  - id: sink\n    stage: jsonl\n    inputs: {records: [source.frames]}\n";
  // Without the check the open blocks until a writer comes; `timeout` turns that into exit 124.
  const auto r = hf::test::run_command("timeout -s KILL 60 " + std::string(HF_EXE) + " run -q " + quote(config) +
                                       " -o " + quote(run));
  EXPECT_EQ(r.code, 1) << r.out;
  EXPECT_TRUE(has(r.out, "is a FIFO or socket, not a video file")) << r.out;
  EXPECT_EQ(hf::test::read_json_file(run / "manifest.json")["status"], "failed");
  // A config (or an include) that is a FIFO.
  const fs::path fifo_config = dir / "fifo.yaml";
  ASSERT_EQ(mkfifo(fifo_config.c_str(), 0600), 0);
  const auto v = hf::test::run_command("timeout -s KILL 60 " + std::string(HF_EXE) + " validate " +
                                       quote(fifo_config));
  EXPECT_NE(v.code, 0);
  EXPECT_NE(v.code, 137) << "blocked on the FIFO";
  EXPECT_TRUE(has(v.out, "a FIFO or socket, not a file")) << v.out;
}

}  // namespace
