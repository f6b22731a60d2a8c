// The jsonl and annotated_video sinks driven by StageRunner with synthetic packets.
#include <gtest/gtest.h>

#include <cstdio>
#include <fstream>
#include <sstream>

#include <opencv2/imgproc.hpp>
#include <opencv2/videoio.hpp>

#include "annotated_video_sink.hpp"
#include "io_test_util.hpp"
#include "jsonl_sink.hpp"
#include "overlay.hpp"

namespace hf {
namespace {

namespace fs = std::filesystem;
using sink::AnnotatedVideoSink;
using sink::JsonlSink;
using test::error_of;

std::vector<std::string> lines_of(const fs::path& file) {
  std::ifstream in(file);
  std::vector<std::string> v;
  for (std::string l; std::getline(in, l);) v.push_back(l);
  return v;
}

std::vector<std::string> cells(const std::string& line) {
  std::vector<std::string> v;
  std::string cur;
  bool quoted = false;
  for (char c : line) {
    if (c == '"') {
      quoted = !quoted;
      continue;
    }
    if (c == ',' && !quoted) {
      v.push_back(cur);
      cur.clear();
    } else {
      cur += c;
    }
  }
  v.push_back(cur);
  return v;
}

ObjectStates states(int64_t frame, double t) {
  ObjectStates s;
  s.frame_index = frame;
  s.timestamp = t;
  ObjectState a;
  a.track_id = 7;
  a.label = "car";
  a.score = 0.5f;
  a.box = cv::Rect2f(100, 120, 50, 40);
  a.distance_m = 20.0 - frame;
  a.lateral_m = -0.5;
  a.velocity_rel = cv::Vec2d(-4.0, 0.25);
  a.speed_mps = 10.0;
  a.heading_rad = 0.0;
  a.in_path = true;
  ObjectState b;
  b.track_id = 9;
  b.label = "person, walking";  // needs CSV quoting
  b.distance_m = kInf;
  s.objects = {a, b};
  return s;
}

RiskAssessment risk(const std::string& metric, int64_t frame, double v7, double scene, bool unsafe) {
  RiskAssessment r;
  r.frame_index = frame;
  r.metric = metric;
  r.stage = metric;
  r.unit = "s";
  r.objects = {{7, v7, true}, {9, kInf, false}};
  r.scene_value = scene;
  r.critical_track = std::isfinite(scene) ? 7 : -1;
  r.label = unsafe ? SafetyLabel::kUnsafe : SafetyLabel::kSafe;
  return r;
}

TEST(JsonlSink, LinesKeyedByProducerAndCsvTables) {
  auto r = testing::StageRunner::create<JsonlSink>();
  for (int f = 0; f < 3; ++f) {
    const double t = f * 0.04;
    r.push("records", states(f, t), t, "estimator");
    r.push("records", risk("ttc", f, f == 1 ? kInf : 5.0 - f, f == 1 ? kInf : 5.0 - f, false), t, "ttc.risk");
    if (f == 2) r.push("records", risk("drac", f, 3.5, 3.5, true), t, "drac.risk");  // appears late
    r.push("records", Record{"note", {{"k", f}}}, t, "eval");
  }
  r.run();
  const fs::path out = r.output_dir();
  const auto lines = lines_of(out / "frames.jsonl");
  ASSERT_EQ(lines.size(), 3u);
  const Json j0 = Json::parse(lines[0]), j1 = Json::parse(lines[1]), j2 = Json::parse(lines[2]);
  EXPECT_EQ(j0["frame"], 0);
  EXPECT_DOUBLE_EQ(j2["timestamp"].get<double>(), 0.08);
  EXPECT_EQ(j0["estimator"]["objects"][0]["track_id"], 7);
  EXPECT_DOUBLE_EQ(j0["estimator"]["objects"][0]["distance_m"].get<double>(), 20.0);
  EXPECT_TRUE(j0["estimator"]["objects"][1]["distance_m"].is_null()) << "infinity -> null";
  EXPECT_DOUBLE_EQ(j0["ttc.risk"]["scene_value"].get<double>(), 5.0);
  EXPECT_TRUE(j1["ttc.risk"]["scene_value"].is_null());
  EXPECT_EQ(j2["drac.risk"]["label"], "Unsafe");
  EXPECT_FALSE(j1.contains("drac.risk"));
  EXPECT_EQ(j1["eval"]["data"]["k"], 1);

  const auto obj = lines_of(out / "objects.csv");
  ASSERT_EQ(obj.size(), 1u + 6u);
  // Metric columns in order of appearance; drac appeared at frame 2, so the table was rewritten with the
  // wider header and its earlier cells left empty.
  EXPECT_EQ(obj[0],
            "frame,timestamp,states,track_id,label,score,box_x,box_y,box_w,box_h,distance_m,lateral_m,vx_mps,"
            "vy_mps,"
            "speed_mps,heading_rad,in_path,ttc,drac");
  auto c = cells(obj[1]);
  ASSERT_EQ(c.size(), 19u);
  EXPECT_EQ(c[0], "0");
  EXPECT_EQ(c[2], "estimator");
  EXPECT_EQ(c[3], "7");
  EXPECT_EQ(c[4], "car");
  EXPECT_EQ(c[6], "100");
  EXPECT_EQ(c[10], "20");
  EXPECT_EQ(c[12], "-4");
  EXPECT_EQ(c[13], "0.25");
  EXPECT_EQ(c[16], "1");
  EXPECT_EQ(c[17], "5");  // ttc of track 7
  EXPECT_EQ(c[18], "");   // no drac on frame 0
  c = cells(obj[2]);
  EXPECT_EQ(c[4], "person, walking");
  EXPECT_EQ(c[10], "");  // infinite distance -> empty
  EXPECT_EQ(c[17], "");
  c = cells(obj[3]);  // frame 1, track 7: ttc infinite
  EXPECT_EQ(c[0], "1");
  EXPECT_EQ(c[17], "");
  c = cells(obj[5]);  // frame 2, track 7
  EXPECT_EQ(c[17], "3");
  EXPECT_EQ(c[18], "3.5");

  const auto sc = lines_of(out / "scenes.csv");
  ASSERT_EQ(sc.size(), 4u);
  EXPECT_EQ(sc[0], "frame,timestamp,ttc,ttc_label,ttc_critical_track,drac,drac_label,drac_critical_track");
  EXPECT_EQ(sc[1], "0,0,5,Safe,7,,,");
  EXPECT_EQ(sc[2], "1,0.04,,Safe,,,,");
  EXPECT_EQ(sc[3], "2,0.08,3,Safe,7,3.5,Unsafe,7");
  // Nothing temporary is left behind.
  for (const auto& e : fs::directory_iterator(out))
    EXPECT_EQ(e.path().extension() == ".tmp", false) << e.path();
}

TEST(JsonlSink, LinesAreOnDiskBeforeFinish) {
  auto r = testing::StageRunner::create<JsonlSink>("{file: sub/run.jsonl, csv: false}");
  r.push("records", risk("ttc", 0, 2.0, 2.0, false), 0.0, "ttc");
  r.push("records", risk("ttc", 1, 1.0, 1.0, true), 0.1, "ttc");
  r.run(/*finish=*/false);
  // As after a crash: finish() never ran, every completed line is already in the file.
  const auto lines = lines_of(r.output_dir() / "sub/run.jsonl");
  ASSERT_EQ(lines.size(), 2u);
  EXPECT_EQ(Json::parse(lines[1])["ttc"]["label"], "Unsafe");
  EXPECT_FALSE(fs::exists(r.output_dir() / "objects.csv"));
}

TEST(JsonlSink, SameProducerTwiceKeepsBothPackets) {
  auto r = testing::StageRunner::create<JsonlSink>("{csv: false}");
  r.push("records", risk("ttc", 0, 2.0, 2.0, false), 0.0, "ttc");
  r.push("records", risk("ttc", 0, 1.0, 1.0, true), 0.0, "ttc");
  r.run();
  const auto lines = lines_of(r.output_dir() / "frames.jsonl");
  ASSERT_EQ(lines.size(), 1u);
  const Json j = Json::parse(lines[0]);
  EXPECT_EQ(j["ttc"]["label"], "Safe");
  EXPECT_EQ(j["ttc#2"]["label"], "Unsafe");
}

// ---- annotated video
// ------------------------------------------------------------------------------------------

Frame grey_frame(int64_t i, double t, cv::Size size) {
  Frame f;
  f.index = i;
  f.timestamp = t;
  f.image = cv::Mat(size, CV_8UC3, cv::Scalar(90, 90, 90));
  return f;
}

Tracks tracks(int64_t i) {
  Tracks t;
  t.frame_index = i;
  Track a;
  a.id = 3;
  a.label = "car";
  a.box = cv::Rect2f(200.f + 5.f * static_cast<float>(i), 180, 120, 90);
  t.items = {a};
  return t;
}

std::string run_cmd(const std::string& cmd) {
  std::string out;
  if (FILE* p = popen(cmd.c_str(), "r")) {
    char buf[256];
    while (fgets(buf, sizeof buf, p)) out += buf;
    pclose(p);
  }
  return out;
}

TEST(AnnotatedVideoSink, WritesPlayableMp4WithBanners) {
  const cv::Size size(640, 360);
  auto r = testing::StageRunner::create<AnnotatedVideoSink>("{png_every: 5}");
  for (int i = 0; i < 20; ++i) {
    const double t = i / 25.0;
    r.push("frames", grey_frame(i, t, size), t);
    r.push("tracks", tracks(i), t);
    ObjectStates s = states(i, t);
    s.objects.resize(1);
    s.objects[0].track_id = 3;
    r.push("states", s, t);
    RiskAssessment ttc = risk("ttc", i, i >= 10 ? 1.0 : 3.0, i >= 10 ? 1.0 : 3.0, i >= 10);
    ttc.objects[0].track_id = 3;
    r.push("risk", ttc, t, "ttc");
  }
  r.run();
  const fs::path file = r.output_dir() / "annotated.mp4";
  ASSERT_TRUE(fs::exists(file));
  EXPECT_FALSE(fs::exists(r.output_dir() / "annotated.partial.mp4"));
  const std::string codec = dynamic_cast<AnnotatedVideoSink&>(r.stage()).codec_used();
  EXPECT_TRUE(codec == "avc1" || codec == "mp4v") << codec;

  cv::VideoCapture cap(file.string());
  ASSERT_TRUE(cap.isOpened());
  EXPECT_NEAR(cap.get(cv::CAP_PROP_FPS), 25.0, 0.01);
  std::vector<cv::Mat> back;
  for (cv::Mat m; cap.read(m);) back.push_back(m.clone());
  ASSERT_EQ(back.size(), 20u);
  EXPECT_EQ(back[0].size(), size);
  // The banner (top left) is green while Safe and red once Unsafe.
  const cv::Scalar safe = cv::mean(back[5](cv::Rect(10, 4, 6, 8)));
  const cv::Scalar unsafe = cv::mean(back[15](cv::Rect(10, 4, 6, 8)));
  EXPECT_GT(safe[1], 100);
  EXPECT_LT(safe[2], 60);
  EXPECT_GT(unsafe[2], 150);
  EXPECT_LT(unsafe[1], 60);
  // The track box edge is drawn in the car colour (BGR 255,140,0) where the grey frame had 90,90,90.
  const cv::Vec3b edge = back[0].at<cv::Vec3b>(180 + 45, 200);
  EXPECT_GT(edge[0], 180);
  EXPECT_LT(edge[2], 60);

  // Every 5th frame as PNG.
  for (int i : {0, 5, 10, 15}) {
    char name[32];
    std::snprintf(name, sizeof name, "frame_%06d.png", i);
    EXPECT_TRUE(fs::exists(r.output_dir() / "annotated_frames" / name)) << name;
  }
  EXPECT_FALSE(fs::exists(r.output_dir() / "annotated_frames/frame_000001.png"));

  // An independent decoder agrees (Debian's ffprobe, when installed).
  if (run_cmd("command -v ffprobe").empty()) GTEST_SKIP() << "ffprobe not installed";
  const std::string probe = run_cmd(
      "ffprobe -v error -select_streams v:0 -count_frames -show_entries "
      "stream=codec_name,width,height,nb_read_frames -of default=nw=1 '" +
      file.string() + "'");
  EXPECT_NE(probe.find("width=640"), std::string::npos) << probe;
  EXPECT_NE(probe.find("height=360"), std::string::npos) << probe;
  EXPECT_NE(probe.find("nb_read_frames=20"), std::string::npos) << probe;
  EXPECT_NE(probe.find(codec == "avc1" ? "codec_name=h264" : "codec_name=mpeg4"), std::string::npos) << probe;
}

TEST(AnnotatedVideoSink, FpsOverrideShortStreamAndSizeChange) {
  const cv::Size size(320, 240);
  {
    auto r = testing::StageRunner::create<AnnotatedVideoSink>("{fps: 12, file: out/clip.mp4, codec: mp4v}");
    for (int i = 0; i < 3; ++i) r.push("frames", grey_frame(i, i * 0.5, size), i * 0.5);
    r.run();
    cv::VideoCapture cap((r.output_dir() / "out/clip.mp4").string());
    ASSERT_TRUE(cap.isOpened());
    EXPECT_NEAR(cap.get(cv::CAP_PROP_FPS), 12.0, 0.01);
    EXPECT_EQ(dynamic_cast<AnnotatedVideoSink&>(r.stage()).codec_used(), "mp4v");
    int n = 0;
    for (cv::Mat m; cap.read(m);) ++n;
    EXPECT_EQ(n, 3);
  }
  {
    // Fewer frames than the rate probe: the rate still comes from their timestamps (0.5 s apart -> 2 fps).
    auto r = testing::StageRunner::create<AnnotatedVideoSink>();
    for (int i = 0; i < 3; ++i) r.push("frames", grey_frame(i, i * 0.5, size), i * 0.5);
    r.run();
    cv::VideoCapture cap((r.output_dir() / "annotated.mp4").string());
    EXPECT_NEAR(cap.get(cv::CAP_PROP_FPS), 2.0, 0.01);
  }
  {
    auto r = testing::StageRunner::create<AnnotatedVideoSink>("{fps: 10}");
    r.push("frames", grey_frame(0, 0.0, size), 0.0);
    r.push("frames", grey_frame(1, 0.1, {160, 120}), 0.1);
    EXPECT_EQ(error_of([&] { r.run(); }), "annotated video: frame 1 is 160x120 but the video is 320x240");
  }
}

TEST(Overlay, ValueText) {
  EXPECT_EQ(sink::format_value(1.234, "s"), "1.23 s");
  EXPECT_EQ(sink::format_value(kInf, "s"), "inf");
  EXPECT_EQ(sink::csv_number(kInf), "");
  EXPECT_EQ(sink::csv_number(0.1), "0.1");
  EXPECT_EQ(sink::csv_escape("a\"b"), "\"a\"\"b\"");
}

}  // namespace
}  // namespace hf
