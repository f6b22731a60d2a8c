// VideoFileWriter (H.264 through the ffmpeg program, or OpenCV) and the video sinks' encoder params:
// decodable files with the right frames and colours, x264's options string in the stream, clear errors.
#include <gtest/gtest.h>
#include <signal.h>
#include <unistd.h>

#include <fstream>
#include <iostream>
#include <sstream>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <opencv2/videoio.hpp>

#include "annotated_video_sink.hpp"
#include "hazardforge/sink/video_file_writer.hpp"
#include "io_test_util.hpp"
#include "side_by_side_sink.hpp"

namespace hf {
namespace {

namespace fs = std::filesystem;
using sink::VideoFileWriter;
using sink::VideoWriterOptions;
using test::error_of;
using test::TempDir;

bool have_ffmpeg() {
  return !sink::find_program("ffmpeg").empty();
}

// Frame i of a sequence cycling through clearly different flat colours (BGR).
cv::Scalar colour(int i) {
  static const cv::Scalar k[] = {{200, 40, 40}, {40, 200, 40}, {40, 40, 200}, {220, 220, 40}, {30, 30, 30}};
  return k[i % 5];
}

cv::Mat coloured(int i, cv::Size size) {
  cv::Mat m(size, CV_8UC3, colour(i));
  // A white square moving right, so frames differ in structure too.
  cv::rectangle(m, cv::Rect(10 + 8 * i, size.height / 2 - 10, 20, 20), cv::Scalar(255, 255, 255), cv::FILLED);
  return m;
}

// Frames 0..n-1 of the coloured sequence on the runner's `frames` port, 5 per second.
void push_coloured(testing::StageRunner& r, int n, cv::Size size) {
  for (int i = 0; i < n; ++i) {
    Frame f;
    f.index = i;
    f.timestamp = i * 0.2;
    f.image = coloured(i, size);
    r.push("frames", f, f.timestamp);
  }
}

std::string read_all(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  std::ostringstream s;
  s << in.rdbuf();
  return s.str();
}

// The value of `key=` in x264's options string, which libx264 stores in the stream's first SEI.
std::string x264_option(const std::string& bytes, const std::string& key) {
  const size_t opts = bytes.find("options: ");
  if (opts == std::string::npos) return "(no x264 options string)";
  const size_t k = bytes.find(" " + key + "=", opts);
  if (k == std::string::npos) return "(no " + key + ")";
  const size_t v = k + key.size() + 2;
  return bytes.substr(v, bytes.find(' ', v) - v);
}

std::vector<cv::Mat> decode(const fs::path& file, double* fps = nullptr) {
  cv::VideoCapture cap(file.string());
  std::vector<cv::Mat> v;
  if (!cap.isOpened()) return v;
  if (fps) *fps = cap.get(cv::CAP_PROP_FPS);
  for (cv::Mat m; cap.read(m);) v.push_back(m.clone());
  return v;
}

void write_sequence(VideoFileWriter& w, int n, cv::Size size) {
  for (int i = 0; i < n; ++i) w.write(coloured(i, size));
}

TEST(VideoFileWriter, FfmpegH264DecodesToTheFramesWritten) {
  if (!have_ffmpeg()) GTEST_SKIP() << "ffmpeg not installed";
  TempDir dir;
  VideoWriterOptions o;
  o.file = dir / "sub/clip.mp4";
  o.fps = 25;
  o.size = {320, 240};
  std::vector<std::string> warnings;
  VideoFileWriter w;
  w.open(o, [&](const std::string& s) { warnings.push_back(s); });
  EXPECT_TRUE(warnings.empty()) << warnings.front();
  EXPECT_EQ(w.backend(), "ffmpeg");
  EXPECT_EQ(w.codec(), "avc1");
  EXPECT_EQ(w.description(), "avc1 via ffmpeg/libx264 (preset ultrafast, 1 thread, crf 23)");
  write_sequence(w, 15, o.size);
  EXPECT_TRUE(fs::exists(dir / "sub/clip.partial.mp4"));
  EXPECT_FALSE(fs::exists(o.file));
  w.close();
  EXPECT_FALSE(w.is_open());
  EXPECT_FALSE(fs::exists(dir / "sub/clip.partial.mp4"));
  ASSERT_TRUE(fs::exists(o.file));

  double fps = 0;
  const auto back = decode(o.file, &fps);
  ASSERT_EQ(back.size(), 15u);
  EXPECT_NEAR(fps, 25.0, 0.01);
  for (int i = 0; i < 15; ++i) {
    ASSERT_EQ(back[i].size(), o.size);
    // Away from the square the frame is its flat colour, within H.264/4:2:0 rounding.
    const cv::Scalar m = cv::mean(back[i](cv::Rect(200, 20, 100, 60)));
    for (int c = 0; c < 3; ++c) EXPECT_NEAR(m[c], colour(i)[c], 6.0) << "frame " << i << " channel " << c;
    // The square is where frame i drew it.
    EXPECT_GT(cv::mean(back[i](cv::Rect(14 + 8 * i, 114, 12, 12)))[1], 230) << "frame " << i;
  }
}

TEST(VideoFileWriter, ThinColouredLinesKeepTheirColour) {
  // 4:2:0 keeps one colour per 2x2 block: it must be the block's mean, or 1-pixel coloured lines (boxes, text)
  // on odd columns or rows lose their colour.
  if (!have_ffmpeg()) GTEST_SKIP() << "ffmpeg not installed";
  TempDir dir;
  VideoWriterOptions o;
  o.file = dir / "lines.mp4";
  o.fps = 5;
  o.size = {320, 240};
  VideoFileWriter w;
  w.open(o, {});
  cv::Mat f(o.size, CV_8UC3, cv::Scalar(128, 128, 128));
  for (int x = 1; x < f.cols; x += 2) f.col(x).setTo(cv::Scalar(0, 0, 255));  // red on every odd column
  for (int y = 1; y < 60; y += 2) f.row(y).setTo(cv::Scalar(255, 0, 0));     // blue on odd rows at the top
  for (int i = 0; i < 3; ++i) w.write(f);
  w.close();
  const auto back = decode(o.file);
  ASSERT_EQ(back.size(), 3u);
  for (const cv::Rect r : {cv::Rect(40, 120, 200, 80), cv::Rect(40, 10, 200, 40)}) {
    const cv::Scalar want = cv::mean(f(r)), got = cv::mean(back[2](r));
    for (int c = 0; c < 3; ++c) EXPECT_NEAR(got[c], want[c], 12.0) << "channel " << c << " of " << r;
  }
}

TEST(VideoFileWriter, PresetAndThreadsLandInTheStream) {
  if (!have_ffmpeg()) GTEST_SKIP() << "ffmpeg not installed";
  TempDir dir;
  struct Case {
    std::string preset;
    int threads;
    std::string subme, me;
  };
  // x264's preset table: ultrafast subme=0 me=dia, veryfast subme=2 me=hex, medium subme=7 me=hex.
  for (const Case& c :
       {Case{"ultrafast", 1, "0", "0"}, Case{"veryfast", 2, "2", "1"}, Case{"medium", 1, "7", "1"}}) {
    VideoWriterOptions o;
    o.file = dir / (c.preset + ".mp4");
    o.fps = 10;
    o.size = {256, 144};
    o.preset = c.preset;
    o.threads = c.threads;
    o.crf = 30;
    VideoFileWriter w;
    w.open(o);
    write_sequence(w, 5, o.size);
    w.close();
    const std::string bytes = read_all(o.file);
    EXPECT_EQ(x264_option(bytes, "subme"), c.subme) << c.preset;
    EXPECT_EQ(x264_option(bytes, "me"), c.me == "0" ? "dia" : "hex") << c.preset;
    EXPECT_EQ(x264_option(bytes, "threads"), std::to_string(c.threads)) << c.preset;
    EXPECT_EQ(x264_option(bytes, "crf"), "30.0") << c.preset;
    // zerolatency: no macroblock-tree lookahead (x264 then omits rc_lookahead), no B-frames, so nothing is
    // held back until the end of the stream.
    EXPECT_EQ(x264_option(bytes, "mbtree"), "0") << c.preset;
    EXPECT_EQ(x264_option(bytes, "rc_lookahead"), "(no rc_lookahead)") << c.preset;
    EXPECT_EQ(x264_option(bytes, "bframes"), "0") << c.preset;
    EXPECT_EQ(decode(o.file).size(), 5u) << c.preset;
  }
}

volatile sig_atomic_t g_sigints = 0;
void count_sigint(int) {
  g_sigints = g_sigints + 1;
}

// Ctrl-C goes to the terminal's foreground process group. The host handles it by finishing every sink, so the
// encoder must not get it too (it would stop and leave a cut file); it runs in its own process group.
TEST(VideoFileWriter, CtrlCForTheHostDoesNotReachTheEncoder) {
  if (!have_ffmpeg()) GTEST_SKIP() << "ffmpeg not installed";
  // Our own process group, so the signal below reaches only this test process (and children left in it).
  if (setpgid(0, 0) != 0) GTEST_SKIP() << "cannot lead a process group here";
  struct sigaction sa {
  }, old{};
  sa.sa_handler = count_sigint;
  sigemptyset(&sa.sa_mask);
  ASSERT_EQ(sigaction(SIGINT, &sa, &old), 0);
  TempDir dir;
  VideoWriterOptions o;
  o.file = dir / "interrupted.mp4";
  o.size = {320, 240};
  VideoFileWriter w;
  w.open(o);
  write_sequence(w, 5, o.size);
  ASSERT_EQ(kill(0, SIGINT), 0);
  usleep(300 * 1000);
  for (int i = 5; i < 10; ++i) w.write(coloured(i, o.size));
  EXPECT_EQ(error_of([&] { w.close(); }), "");
  sigaction(SIGINT, &old, nullptr);
  EXPECT_EQ(g_sigints, 1);
  EXPECT_EQ(decode(o.file).size(), 10u);
}

TEST(VideoFileWriter, OddSizeIsPaddedToEven) {
  if (!have_ffmpeg()) GTEST_SKIP() << "ffmpeg not installed";
  TempDir dir;
  VideoWriterOptions o;
  o.file = dir / "odd.mp4";
  o.size = {321, 181};
  VideoFileWriter w;
  w.open(o);
  write_sequence(w, 3, o.size);
  w.close();
  const auto back = decode(o.file);
  ASSERT_EQ(back.size(), 3u);
  EXPECT_EQ(back[0].size(), cv::Size(322, 182));
}

TEST(VideoFileWriter, MissingFfmpegFallsBackToOpenCvWithAWarning) {
  TempDir dir;
  VideoWriterOptions o;
  o.file = dir / "fallback.mp4";
  o.fps = 5;
  o.size = {320, 240};
  o.ffmpeg_program = (dir / "no-such-ffmpeg").string();
  std::vector<std::string> warnings;
  VideoFileWriter w;
  w.open(o, [&](const std::string& s) { warnings.push_back(s); });
  ASSERT_EQ(warnings.size(), 1u);
  EXPECT_NE(warnings[0].find("no-such-ffmpeg' not found"), std::string::npos) << warnings[0];
  EXPECT_NE(warnings[0].find("fallback.partial.mp4"), std::string::npos) << warnings[0];
  EXPECT_EQ(w.backend(), "opencv");
  EXPECT_TRUE(w.codec() == "avc1" || w.codec() == "mp4v") << w.codec();
  write_sequence(w, 4, o.size);
  w.close();
  const auto back = decode(o.file);
  ASSERT_EQ(back.size(), 4u);
  const cv::Scalar m = cv::mean(back[2](cv::Rect(200, 20, 100, 60)));
  EXPECT_NEAR(m[2], colour(2)[2], 8.0);
}

TEST(VideoFileWriter, EncoderFailureNamesTheFileExitCodeAndStderr) {
  TempDir dir;
  // A stand-in "ffmpeg" that lists libx264 but fails to encode, as a broken install would.
  const fs::path fake = dir / "fake-ffmpeg";
  {
    std::ofstream s(fake);
    s << "#!/bin/sh\n"
         "case \"$*\" in *-encoders*) echo ' V....D libx264              libx264 H.264'; exit 0;; esac\n"
         "echo 'Unknown encoder settings: broken' >&2\nexit 3\n";
  }
  fs::permissions(fake, fs::perms::owner_all);
  VideoWriterOptions o;
  o.file = dir / "bad.mp4";
  o.size = {640, 480};
  o.ffmpeg_program = fake.string();
  VideoFileWriter w;
  w.open(o);
  EXPECT_EQ(w.backend(), "ffmpeg");
  const std::string err = error_of([&] {
    // The first frames may still fit the pipe before the stand-in exits; the failure shows by close().
    write_sequence(w, 20, o.size);
    w.close();
  });
  std::cout << "encoder failure message: " << err << "\n";  // quoted in docs/sources-and-sinks.md
  EXPECT_NE(err.find("cannot write video '" + (dir / "bad.partial.mp4").string() + "'"), std::string::npos)
      << err;
  EXPECT_NE(err.find(fake.string() + " exited with code 3"), std::string::npos) << err;
  EXPECT_NE(err.find("Unknown encoder settings: broken"), std::string::npos) << err;
  EXPECT_FALSE(fs::exists(o.file));
}

TEST(VideoFileWriter, BadOptionsAreRefusedByName) {
  TempDir dir;
  VideoWriterOptions o;
  o.file = dir / "x.mp4";
  o.size = {64, 64};
  o.preset = "fastest";
  VideoFileWriter w;
  EXPECT_EQ(
      error_of([&] { w.open(o); }),
      "cannot write video '" + (dir / "x.partial.mp4").string() +
          "': preset 'fastest' is not an x264 preset (ultrafast, superfast, veryfast, faster, fast, medium, "
          "slow, slower, veryslow, placebo)");
  o.preset = "ultrafast";
  o.encoder = "gstreamer";
  EXPECT_EQ(error_of([&] { w.open(o); }), "cannot write video '" + (dir / "x.partial.mp4").string() +
                                              "': encoder 'gstreamer' is not one of ffmpeg, opencv");
}

TEST(AnnotatedVideoSink, PresetParamReachesTheEncoder) {
  if (!have_ffmpeg()) GTEST_SKIP() << "ffmpeg not installed";
  auto r = testing::StageRunner::create<sink::AnnotatedVideoSink>(
      "{fps: 5, preset: veryfast, threads: 2, crf: 28}");
  push_coloured(r, 6, {320, 240});
  r.run();
  const fs::path file = r.output_dir() / "annotated.mp4";
  const std::string bytes = read_all(file);
  EXPECT_EQ(x264_option(bytes, "subme"), "2");
  EXPECT_EQ(x264_option(bytes, "threads"), "2");
  EXPECT_EQ(x264_option(bytes, "crf"), "28.0");
  EXPECT_EQ(decode(file).size(), 6u);
}

TEST(AnnotatedVideoSink, ScaleShrinksTheVideoAndKeepsBoxesOnTheirObjects) {
  auto r = testing::StageRunner::create<sink::AnnotatedVideoSink>("{fps: 5, scale: 0.5, png_every: 1}");
  for (int i = 0; i < 3; ++i) {
    Frame f;
    f.index = i;
    f.timestamp = i * 0.2;
    f.image = cv::Mat(cv::Size(640, 360), CV_8UC3, cv::Scalar(90, 90, 90));
    r.push("frames", f, f.timestamp);
    Tracks t;
    t.frame_index = i;
    Track a;
    a.id = 3;
    a.label = "car";
    a.box = cv::Rect2f(200, 180, 120, 90);
    t.items = {a};
    r.push("tracks", t, f.timestamp);
  }
  r.run();
  const auto back = decode(r.output_dir() / "annotated.mp4");
  ASSERT_EQ(back.size(), 3u);
  ASSERT_EQ(back[0].size(), cv::Size(320, 180));
  // The car box (full-size x 200, y 180..270) is drawn in the car colour at half the coordinates.
  const cv::Vec3b edge = back[1].at<cv::Vec3b>(90 + 22, 100);
  EXPECT_GT(edge[0], 150);
  EXPECT_LT(edge[2], 80);
  const cv::Mat png = cv::imread((r.output_dir() / "annotated_frames/frame_000001.png").string());
  ASSERT_EQ(png.size(), cv::Size(320, 180));
  EXPECT_EQ(png.at<cv::Vec3b>(90 + 22, 100), cv::Vec3b(255, 140, 0));
  // Away from the drawing the grey survives.
  EXPECT_NEAR(cv::mean(back[1](cv::Rect(250, 20, 40, 40)))[0], 90, 4);
}

TEST(AnnotatedVideoSink, BadPresetIsAClearParamError) {
  const std::string err =
      error_of([] { testing::StageRunner::create<sink::AnnotatedVideoSink>("{preset: quick}"); });
  EXPECT_NE(err.find("preset"), std::string::npos) << err;
  EXPECT_NE(err.find("quick"), std::string::npos) << err;
  EXPECT_NE(err.find("ultrafast"), std::string::npos) << err;
}

TEST(AnnotatedVideoSink, OpenCvEncoderStillWorks) {
  auto r = testing::StageRunner::create<sink::AnnotatedVideoSink>("{fps: 5, encoder: opencv}");
  push_coloured(r, 4, {320, 240});
  r.run();
  const std::string bytes = read_all(r.output_dir() / "annotated.mp4");
  const std::string codec = dynamic_cast<sink::AnnotatedVideoSink&>(r.stage()).codec_used();
  EXPECT_TRUE(codec == "avc1" || codec == "mp4v") << codec;
  // OpenCV's writer keeps libx264's default preset (medium: subme=7), which is why ffmpeg is the default.
  if (codec == "avc1") {
    EXPECT_EQ(x264_option(bytes, "subme"), "7");
    EXPECT_EQ(x264_option(bytes, "rc_lookahead"), "40");
  }
  EXPECT_EQ(decode(r.output_dir() / "annotated.mp4").size(), 4u);
}

TEST(SideBySideSink, PresetParamReachesTheEncoder) {
  if (!have_ffmpeg()) GTEST_SKIP() << "ffmpeg not installed";
  auto r = testing::StageRunner::create<render::SideBySideSink>(
      "{fps: 4, preset: superfast, threads: 1, scale: 1.0}");
  for (int i = 0; i < 5; ++i) {
    Frame a, b;
    a.index = b.index = i;
    a.timestamp = b.timestamp = i * 0.25;
    a.image = coloured(i, {160, 120});
    b.image = coloured(i + 1, {160, 120});
    r.push("original", a, a.timestamp);
    r.push("augmented", b, b.timestamp);
  }
  r.run();
  const fs::path file = r.output_dir() / "before_after.mp4";
  const std::string bytes = read_all(file);
  EXPECT_EQ(x264_option(bytes, "subme"), "1");  // superfast
  EXPECT_EQ(x264_option(bytes, "threads"), "1");
  double fps = 0;
  const auto back = decode(file, &fps);
  ASSERT_EQ(back.size(), 5u);
  EXPECT_NEAR(fps, 4.0, 0.01);
  ASSERT_EQ(back[0].size(), cv::Size(320, 120));
  // Left half frame i's colour, right half frame i+1's (below the captions).
  for (int i = 0; i < 5; ++i) {
    const cv::Scalar l = cv::mean(back[i](cv::Rect(100, 40, 40, 20)));
    const cv::Scalar rr = cv::mean(back[i](cv::Rect(260, 40, 40, 20)));
    for (int c = 0; c < 3; ++c) {
      EXPECT_NEAR(l[c], colour(i)[c], 8.0) << "frame " << i;
      EXPECT_NEAR(rr[c], colour(i + 1)[c], 8.0) << "frame " << i;
    }
  }
}

}  // namespace
}  // namespace hf
