// The detection replay: what a detector recorded through the jsonl sink's layout comes back exactly, for the
// frames with the same index; a frame without a record, a frame of other footage and a bad record are errors
// that name the file, line and frame.
#include <gtest/gtest.h>

#include <fstream>

#include "detection_replay.hpp"
#include "hazardforge/geometry.hpp"
#include "hazardforge/testing/stage_runner.hpp"
#include "temp_dir.hpp"

namespace hf {
namespace {

Frame frame_at(int64_t index, double t) {
  Frame f;
  f.index = index;
  f.timestamp = t;
  f.image = cv::Mat(48, 64, CV_8UC3, cv::Scalar::all(0));
  return f;
}

Detections detections_of(int64_t index) {
  Detections d;
  d.frame_index = index;
  d.detector = "yolo:yolov8n";
  // Boxes whose floats have no short decimal form: they must come back bit for bit.
  d.items.push_back({cv::Rect2f(10.1f + index, 20.3f, 30.7f / 3, 40.9f / 7), 2, "car", 0.87654321f, -1, 0});
  d.items.push_back({cv::Rect2f(0.f, 1.f / 3, 5.5f, 7.25f), 0, "person", 0.3f, 4, truncation::kLeft});
  return d;
}

void write_record(std::ofstream& out, int64_t index, double t) {
  out << Json{{"frame", index}, {"timestamp", t}, {"det.detections", detections_of(index)}}.dump() << "\n";
}

TEST(DetectionReplay, TheRecordedDetectionsComeBackExactlyForTheSameFrames) {
  test::TempDir dir;
  {
    std::ofstream out(dir / "perception.jsonl");
    for (int64_t i = 3; i < 9; ++i) write_record(out, i, 0.1 * i);
  }
  auto r = testing::StageRunner::create<DetectionReplay>("file: " + (dir / "perception.jsonl").string() +
                                                         "\nrecord: det.detections");
  for (int64_t i = 5; i < 8; ++i) r.push("frames", frame_at(i, 0.1 * i), 0.1 * i);
  r.run();
  const auto got = r.collect<Detections>("detections");
  ASSERT_EQ(got.size(), 3u);
  for (size_t k = 0; k < got.size(); ++k) {
    const Detections want = detections_of(5 + static_cast<int64_t>(k));
    EXPECT_EQ(got[k].frame_index, want.frame_index);
    EXPECT_EQ(got[k].detector, want.detector);
    EXPECT_EQ(got[k].image_size, cv::Size(64, 48));
    ASSERT_EQ(got[k].items.size(), want.items.size());
    for (size_t i = 0; i < want.items.size(); ++i) {
      EXPECT_EQ(got[k].items[i].box, want.items[i].box);  // exact, not near
      EXPECT_EQ(got[k].items[i].score, want.items[i].score);
      EXPECT_EQ(got[k].items[i].class_id, want.items[i].class_id);
      EXPECT_EQ(got[k].items[i].label, want.items[i].label);
      EXPECT_EQ(got[k].items[i].annotation_index, want.items[i].annotation_index);
      EXPECT_EQ(got[k].items[i].truncated, want.items[i].truncated);
    }
  }
}

std::string error_of(const std::string& file, const std::vector<Frame>& frames) {
  try {
    auto r = testing::StageRunner::create<DetectionReplay>("file: " + file + "\nrecord: det.detections");
    for (const Frame& f : frames) r.push("frames", f, f.timestamp);
    r.run();
  } catch (const std::exception& e) {
    return e.what();
  }
  return "";
}

TEST(DetectionReplay, AMissingFrameOtherFootageAndABadRecordAreErrorsNamingWhere) {
  test::TempDir dir;
  const std::string file = (dir / "p.jsonl").string();
  {
    std::ofstream out(file);
    write_record(out, 0, 0.0);
    write_record(out, 1, 0.1);
  }
  EXPECT_NE(error_of(file, {frame_at(2, 0.2)}).find("frame 2: no recorded detections in " + file),
            std::string::npos);
  EXPECT_NE(error_of(file, {frame_at(1, 0.5)}).find("not the frames the detections were made on"),
            std::string::npos);
  {
    std::ofstream out(file, std::ios::app);
    out << R"({"frame": 2, "timestamp": 0.2, "det.detections": {"items": [{"box": [1, 2, 3], "class_id": 2}]}})"
        << "\n";
  }
  const std::string bad = error_of(file, {frame_at(0, 0.0)});
  EXPECT_NE(bad.find(file + ":3: 'det.detections': a detection's 'box' is not [x, y, width, height]"),
            std::string::npos)
      << bad;
  EXPECT_NE(error_of((dir / "none.jsonl").string(), {frame_at(0, 0.0)}).find("cannot read"),
            std::string::npos);
}

}  // namespace
}  // namespace hf
