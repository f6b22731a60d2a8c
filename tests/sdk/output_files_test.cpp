// The output-path policy and the file writers: paths that leave the run folder, symlinks, full disks.
#include <gtest/gtest.h>
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include <csignal>
#include <fstream>

#include "hazardforge/atomic_file.hpp"
#include "hazardforge/error.hpp"
#include "hazardforge/json_text.hpp"
#include "hazardforge/output_path.hpp"
#include "temp_dir.hpp"

namespace fs = std::filesystem;

namespace {

std::string read(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

std::string error_of(const std::function<void()>& f) {
  try {
    f();
  } catch (const hf::Error& e) {
    return e.what();
  }
  return "(no error)";
}

int temp_files_in(const fs::path& dir) {
  int n = 0;
  for (const auto& e : fs::directory_iterator(dir))
    if (e.path().filename().string().find(".tmp.") != std::string::npos) ++n;
  return n;
}

TEST(OutputPath, RelativePathsResolveBelowTheRunFolderAndCreateTheirFolders) {
  hf::test::TempDir t;
  const fs::path run = t / "run";
  fs::create_directories(run);
  EXPECT_EQ(hf::resolve_output_path(run, "a/b/c.json", "x"), run / "a/b/c.json");
  EXPECT_TRUE(fs::is_directory(run / "a/b"));
  EXPECT_EQ(hf::resolve_output_path(run, "stills", "x", true), run / "stills");
  EXPECT_TRUE(fs::is_directory(run / "stills"));
}

TEST(OutputPath, RefusesTheHostsOwnFiles) {
  hf::test::TempDir t;
  const fs::path run = t / "run";
  fs::create_directories(run);
  const std::string w = "node 'sink': param 'file'";
  for (const char* own : {"manifest.json", "./timing.md", "run.log"})
    EXPECT_NE(error_of([&] { hf::resolve_output_path(run, own, w); })
                  .find("is a file the host writes in every run folder"),
              std::string::npos)
        << own;
  EXPECT_EQ(hf::resolve_output_path(run, "records/manifest.json", w), run / "records/manifest.json");
  EXPECT_EQ(hf::resolve_output_path(run, "run.log", w, /*is_dir=*/true), run / "run.log");
}

TEST(OutputPath, RefusesEmptyAbsoluteAndDotDot) {
  hf::test::TempDir t;
  const fs::path run = t / "run";
  fs::create_directories(run);
  const std::string w = "node 'sink': param 'file'";
  EXPECT_EQ(error_of([&] { hf::resolve_output_path(run, "", w); }),
            "node 'sink': param 'file' is empty; it must name a path inside the run folder");
  EXPECT_EQ(
      error_of([&] { hf::resolve_output_path(run, "/etc/passwd", w); }),
      "node 'sink': param 'file' = '/etc/passwd' is an absolute path; output paths must be relative to the "
      "run folder");
  EXPECT_EQ(
      error_of([&] { hf::resolve_output_path(run, "../../../../etc/passwd", w); }),
      "node 'sink': param 'file' = '../../../../etc/passwd' contains '..'; output paths must stay inside "
      "the run folder");
  EXPECT_EQ(
      error_of([&] { hf::resolve_output_path(run, "a/../../b", w); }),
      "node 'sink': param 'file' = 'a/../../b' contains '..'; output paths must stay inside the run folder");
  EXPECT_FALSE(fs::exists(run / "a"));
}

TEST(OutputPath, RefusesASymlinkedFolderLeadingOutside) {
  hf::test::TempDir t;
  const fs::path run = t / "run", outside = t / "outside";
  fs::create_directories(run / "inner");
  fs::create_directories(outside);
  fs::create_directory_symlink(outside, run / "llm");
  fs::create_directory_symlink(run / "inner", run / "alias");
  EXPECT_EQ(error_of([&] { hf::resolve_output_path(run, "llm/sub/calls.jsonl", "the call record"); }),
            "the call record = 'llm/sub/calls.jsonl': " + (run / "llm").string() +
                " is a symlink leading outside the run folder");
  EXPECT_FALSE(fs::exists(outside / "sub"));
  // A symlink that stays inside is followed.
  EXPECT_EQ(hf::resolve_output_path(run, "alias/x.json", "x"), run / "alias/x.json");
}

TEST(OutputPath, SafePathComponent) {
  EXPECT_EQ(hf::safe_path_component("../../../../etc"), "_.._.._.._etc");
  EXPECT_EQ(hf::safe_path_component(".."), "run");
  EXPECT_EQ(hf::safe_path_component(""), "run");
  EXPECT_EQ(hf::safe_path_component("/abs/name"), "_abs_name");
  EXPECT_EQ(hf::safe_path_component("assess_video-2"), "assess_video-2");
}

TEST(AtomicFile, ReplacesTheFileAndNeverWritesThroughASymlink) {
  hf::test::TempDir t;
  const fs::path victim = t / "victim.txt", link = t / "out.json";
  { std::ofstream(victim) << "keep"; }
  fs::create_symlink(victim, link);
  hf::write_file_atomic(link, "new");
  EXPECT_EQ(read(victim), "keep");
  EXPECT_FALSE(fs::is_symlink(link));
  EXPECT_EQ(read(link), "new");
  EXPECT_EQ(temp_files_in(t.path()), 0);
}

TEST(AtomicFile, ClaimRemovesAPlantedSymlink) {
  hf::test::TempDir t;
  const fs::path victim = t / "victim.txt", link = t / "video.partial.mp4";
  { std::ofstream(victim) << "keep"; }
  fs::create_symlink(victim, link);
  hf::claim_output_file(link);
  EXPECT_FALSE(fs::is_symlink(link));
  EXPECT_EQ(fs::file_size(link), 0u);
  EXPECT_EQ(read(victim), "keep");
}

TEST(RecordFile, RefusesASymlinkAndAppendsWholeRecords) {
  hf::test::TempDir t;
  const fs::path victim = t / "victim.txt", link = t / "frames.jsonl";
  { std::ofstream(victim) << "keep"; }
  fs::create_symlink(victim, link);
  EXPECT_EQ(
      error_of([&] { hf::RecordFile f(link, hf::RecordFile::Mode::kTruncate); }),
      link.string() + ": cannot write: it is a symlink (refused: it could point outside the run folder)");
  EXPECT_EQ(read(victim), "keep");
  hf::RecordFile f(t / "a.jsonl", hf::RecordFile::Mode::kTruncate);
  f.write("1\n");
  f.close();
  f.open(t / "a.jsonl", hf::RecordFile::Mode::kAppend);
  f.write("2\n");
  EXPECT_EQ(read(t / "a.jsonl"), "1\n2\n");
}

// A full disk, reproduced with a file-size limit in a child process (EFBIG instead of ENOSPC; the same
// paths).
TEST(RecordFile, AFullDiskCutsNoRecordAndLeavesNoTemporaryFile) {
  hf::test::TempDir t;
  const pid_t pid = fork();
  ASSERT_GE(pid, 0);
  if (pid == 0) {
    std::signal(SIGXFSZ, SIG_IGN);
    rlimit lim{100, 100};
    setrlimit(RLIMIT_FSIZE, &lim);
    int bad = 0;
    hf::RecordFile f(t / "calls.jsonl", hf::RecordFile::Mode::kTruncate);
    f.write(std::string(60, 'a') + "\n");
    const std::string e1 = error_of([&] { f.write(std::string(60, 'b') + "\n"); });
    if (e1 != (t / "calls.jsonl").string() + ": cannot write: File too large") bad |= 1;
    f.close();
    if (fs::file_size(t / "calls.jsonl") != 61) bad |= 2;
    const std::string e2 =
        error_of([&] { hf::write_file_atomic(t / "manifest.json", std::string(500, 'x')); });
    if (e2 != (t / "manifest.json").string() + ": cannot write: File too large") bad |= 4;
    if (temp_files_in(t.path()) != 0 || fs::exists(t / "manifest.json")) bad |= 8;
    _exit(bad);
  }
  int status = 0;
  waitpid(pid, &status, 0);
  ASSERT_TRUE(WIFEXITED(status));
  EXPECT_EQ(WEXITSTATUS(status), 0) << "bits: 1 message, 2 cut record, 4 atomic message, 8 temp file left";
}

TEST(RecordFile, DevFullIsReportedWithItsCause) {
  if (!fs::exists("/dev/full")) GTEST_SKIP() << "no /dev/full";
  hf::RecordFile f("/dev/full", hf::RecordFile::Mode::kAppend);
  EXPECT_EQ(error_of([&] { f.write("x\n"); }), "/dev/full: cannot write: No space left on device");
}

TEST(JsonText, ReplacesInvalidUtf8InsteadOfThrowing) {
  const nlohmann::json j = {{"error", std::string("bad \xff byte")}};
  EXPECT_EQ(hf::json_text(j), "{\"error\":\"bad \xEF\xBF\xBD byte\"}");
}

}  // namespace
