// The kitti source on the real KITTI raw frames and tracking labels, checked against hand computations.
#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <map>

#include "io_test_util.hpp"
#include "kitti_files.hpp"
#include "kitti_source.hpp"
#include "test_support.hpp"

namespace hf {
namespace {

namespace fs = std::filesystem;
using source::KittiSource;
using test::error_of;
using test::run_source;
using test::TempDir;

const fs::path kRaw = test::shared_data("kitti-raw-2011_09_26");
const fs::path kTracking = test::shared_data("kitti-tracking");

std::string raw_params() {
  return "{layout: raw, images: '" + (kRaw / "2011_09_26/image_02/data").string() + "', calib: '" +
         (kRaw / "calib_2011_09_26_kitti_tracking_format.txt").string() + "'}";
}

TEST(KittiSource, RawFolder78FramesWithP2) {
  HF_REQUIRE_SHARED(kRaw);
  testing::StageRunner r;
  auto frames = run_source<KittiSource>(raw_params(), &r);
  ASSERT_EQ(frames.size(), 78u);
  EXPECT_EQ(*dynamic_cast<SourceStage&>(r.stage()).frame_count(), 78);
  EXPECT_EQ(frames[0].image.size(), cv::Size(1242, 375));
  EXPECT_DOUBLE_EQ(frames[0].camera.fx, 721.5377);
  EXPECT_DOUBLE_EQ(frames[0].camera.fy, 721.5377);
  EXPECT_DOUBLE_EQ(frames[0].camera.cx, 609.5593);
  EXPECT_DOUBLE_EQ(frames[0].camera.cy, 172.854);
  EXPECT_DOUBLE_EQ(frames[0].camera.height_above_ground(), 1.65);
  EXPECT_NEAR(frames[0].camera.pitch(), 0.0, 1e-12);
  EXPECT_NEAR(frames[77].timestamp, 7.7, 1e-9);
  EXPECT_EQ(frames[77].source_id, "0000000077.png");
  EXPECT_FALSE(frames[0].annotations);
}

TEST(KittiSource, TrackingLabelsWithoutImages) {
  HF_REQUIRE_SHARED(kTracking);
  auto frames = run_source<KittiSource>("{root: '" + kTracking.string() +
                                        "', sequence: '0000', images_required: false}");
  // label_02/0000.txt runs over frames 0..153; no image_02/0000 images exist here.
  ASSERT_EQ(frames.size(), 154u);
  EXPECT_EQ(frames[0].image.size(), cv::Size(1242, 375));
  EXPECT_EQ(cv::countNonZero(frames[0].image.reshape(1)), 0);
  EXPECT_NEAR(frames[153].timestamp, 15.3, 1e-9);
  EXPECT_EQ(frames[0].meta["has_image"], false);
  EXPECT_DOUBLE_EQ(frames[0].camera.fx, 721.5377);

  ASSERT_TRUE(frames[1].annotations);
  const Annotations& a = *frames[1].annotations;
  EXPECT_EQ(a.objects.size(), 3u);  // DontCare dropped
  ASSERT_TRUE(a.ego_velocity_ego);
  EXPECT_EQ(*a.ego_velocity_ego, cv::Vec3d(0, 0, 0));
  const AnnotatedObject& van = a.objects[0];
  EXPECT_EQ(van.instance_id, "0");
  EXPECT_EQ(van.category, "Van");
  EXPECT_EQ(van.label, "car");
  // By hand, frame 1, track 0: location (-4.650955, 1.766774, 13.581085), h 2.0, in rectified camera-0
  // coordinates (bottom centre). Camera 2 sits t = K^-1 P2[:,3] from camera 0; ego = (z, -x, h_cam - y).
  const double tx = (44.85728 - 609.5593 * 2.745884e-3) / 721.5377;
  const double ty = (0.2163791 - 172.854 * 2.745884e-3) / 721.5377;
  const double tz = 2.745884e-3;
  EXPECT_NEAR(van.center_ego[0], 13.581085 + tz, 1e-9);
  EXPECT_NEAR(van.center_ego[1], -(-4.650955 + tx), 1e-9);
  EXPECT_NEAR(van.center_ego[2], 1.65 - (1.766774 - 1.0 + ty), 1e-9);
  EXPECT_NEAR(van.size_lwh[0], 4.433886, 1e-12);
  EXPECT_NEAR(van.size_lwh[1], 1.823255, 1e-12);
  EXPECT_NEAR(van.size_lwh[2], 2.0, 1e-12);
  // rotation_y = -2.121565: yaw_ego = -(ry + pi/2).
  EXPECT_NEAR(van.yaw_ego, -(-2.121565 + CV_PI / 2), 1e-9);
  ASSERT_TRUE(van.box2d);
  EXPECT_NEAR(van.box2d->x, 294.898777, 1e-9);
  EXPECT_NEAR(van.box2d->width, 452.199718 - 294.898777, 1e-9);
  EXPECT_EQ(van.occlusion, 0.0);
  // Relative velocity: central difference of frames 0 and 2 of track 0, 0.2 s apart.
  ASSERT_TRUE(van.velocity_ego);
  EXPECT_NEAR((*van.velocity_ego)[0], (13.751675 - 13.410495) / 0.2, 1e-9);
  EXPECT_NEAR((*van.velocity_ego)[1], -(-4.749625 - -4.552284) / 0.2, 1e-9);
  // Frame 0 has no previous label: one-sided difference to frame 1.
  const AnnotatedObject& van0 = frames[0].annotations->objects[0];
  ASSERT_TRUE(van0.velocity_ego);
  EXPECT_NEAR((*van0.velocity_ego)[0], (13.581085 - 13.410495) / 0.1, 1e-9);
  // Every labelled class is mapped.
  std::map<std::string, std::string> seen;
  for (const Frame& f : frames)
    for (const auto& o : f.annotations->objects) seen[o.category] = o.label;
  EXPECT_EQ(seen.size(), 4u);
  EXPECT_EQ(seen["Car"], "car");
  EXPECT_EQ(seen["Cyclist"], "bicycle");
  EXPECT_EQ(seen["Pedestrian"], "person");
  // Occlusion states 0 / 1 / 2 / 3 (fully visible, partly, largely occluded, unknown) as hidden shares; the
  // sequence's labels hold 395 / 125 / 185 / 6 of them (awk over label_02/0000.txt, DontCare left out).
  std::map<double, int> hidden;
  for (const Frame& f : frames)
    for (const auto& o : f.annotations->objects) ++hidden[o.occlusion];
  EXPECT_EQ(hidden, (std::map<double, int>{{0.0, 395}, {0.4, 125}, {0.8, 185}, {1.0, 6}}));
}

TEST(KittiSource, EgoSpeedParamShiftsAbsoluteVelocitiesOnly) {
  HF_REQUIRE_SHARED(kTracking);
  auto frames = run_source<KittiSource>(
      "{root: '" + kTracking.string() +
      "', sequence: '0000', images_required: false, ego_speed_mps: 5, max_frames: 3}");
  ASSERT_EQ(frames.size(), 3u);
  ASSERT_TRUE(frames[1].ego.speed_mps);
  EXPECT_DOUBLE_EQ(*frames[1].ego.speed_mps, 5.0);
  const Annotations& a = *frames[1].annotations;
  const cv::Vec3d rel = *a.objects[0].velocity_ego - *a.ego_velocity_ego;
  EXPECT_NEAR(rel[0], (13.751675 - 13.410495) / 0.2, 1e-9);
  EXPECT_NEAR((*a.objects[0].velocity_ego)[0], 5.0 + (13.751675 - 13.410495) / 0.2, 1e-9);
}

TEST(KittiSource, TrackingSequenceWithSparseImages) {
  HF_REQUIRE_SHARED(kTracking);
  auto frames = run_source<KittiSource>("{root: '" + kTracking.string() + "', sequence: '0001'}");
  // Only frames 10, 15 and 20 of sequence 0001 have images.
  ASSERT_EQ(frames.size(), 3u);
  EXPECT_EQ(frames[0].origin.dataset_frame, 10);
  EXPECT_EQ(frames[2].origin.dataset_frame, 20);
  EXPECT_NEAR(frames[1].timestamp, 0.5, 1e-12);
  EXPECT_EQ(frames[0].source_id, "000010.png");
  EXPECT_GT(cv::countNonZero(frames[0].image.reshape(1)), 0);
  EXPECT_EQ(frames[0].annotations->objects.size(), 9u);
  EXPECT_EQ(frames[0].image.cols, frames[0].camera.width);
  // No images for sequence 0000: a clear message that points at images_required.
  const fs::path img0 = kTracking / "training/image_02/0000";
  EXPECT_EQ(
      error_of([&] { run_source<KittiSource>("{root: '" + kTracking.string() + "', sequence: '0000'}"); }),
      "KITTI image folder '" + img0.string() +
          "' does not exist (images_required: false iterates over the label frames)");
}

TEST(KittiSource, BadFilesNameFileAndLine) {
  HF_REQUIRE_SHARED(kRaw);
  TempDir dir;
  std::ofstream(dir / "calib.txt") << "P0: 1 0 0 0 0 1 0 0 0 0 1 0\nP2: 7 0 6 0 0 7 1\n";
  EXPECT_EQ(error_of([&] { source::kitti::read_calibration(dir / "calib.txt"); }),
            (dir / "calib.txt").string() + ":2: error: P2 needs 12 numbers");
  std::ofstream(dir / "nop2.txt") << "P0: 1 0 0 0 0 1 0 0 0 0 1 0\n";
  EXPECT_EQ(error_of([&] {
              run_source<KittiSource>("{layout: raw, images: '" +
                                      (kRaw / "2011_09_26/image_02/data").string() + "', calib: '" +
                                      (dir / "nop2.txt").string() + "'}");
            }),
            "KITTI calibration '" + (dir / "nop2.txt").string() + "' has no P2 (or P_rect_02) line");
  std::ofstream(dir / "labels.txt")
      << "0 0 Car 0 0 -1.7 296.7 161.7 455.2 292.3 2.0 1.8 4.4 -4.5 1.8 13.4 -2.1\n"
      << "1 0 Car 0 0 -1.7 296.7 161.7 455.2 292.3 2.0 1.8 4.4 -4.5 1.8 x13.4 -2.1\n";
  EXPECT_EQ(error_of([&] { source::kitti::read_labels(dir / "labels.txt"); }),
            (dir / "labels.txt").string() + ":2: error: field 'z' is not a finite decimal number: 'x13.4'");
  std::ofstream(dir / "short.txt") << "0 0 Car 0 0\n";
  EXPECT_EQ(error_of([&] {
              run_source<KittiSource>("{layout: raw, images: '" +
                                      (kRaw / "2011_09_26/image_02/data").string() + "', calib: '" +
                                      (kRaw / "calib_2011_09_26_kitti_tracking_format.txt").string() +
                                      "', labels: '" + (dir / "short.txt").string() + "'}");
            }),
            (dir / "short.txt").string() +
                ":1: error: expected 17 fields (frame track_id type ... rotation_y), got 5");
  EXPECT_EQ(error_of([&] {
              run_source<KittiSource>("{layout: raw, calib: '" + (dir / "calib.txt").string() + "'}");
            }),
            "kitti source: layout 'raw' needs the 'images' folder");
}

// Values std::stod would take but no KITTI tool writes, and frame numbers that would size arrays.
TEST(KittiSource, LabelAndCalibrationFieldsMustBeFiniteDecimals) {
  TempDir dir;
  const std::string good = "0 0 Car 0 0 -1.7 296.7 161.7 455.2 292.3 2.0 1.8 4.4 -4.5 1.8 13.4 -2.1\n";
  auto label_error = [&](const std::string& second_line) {
    std::ofstream(dir / "l.txt") << good << second_line << "\n";
    return error_of([&] { source::kitti::read_labels(dir / "l.txt"); });
  };
  const std::string at = (dir / "l.txt").string() + ":2: error: ";
  EXPECT_EQ(label_error("1 0 Car 0 0 nan 296.7 161.7 455.2 292.3 2.0 1.8 4.4 -4.5 1.8 13.4 -2.1"),
            at + "field 'alpha' is not a finite decimal number: 'nan'");
  EXPECT_EQ(label_error("1 0 Car 0 0 -1.7 0x10 161.7 455.2 292.3 2.0 1.8 4.4 -4.5 1.8 13.4 -2.1"),
            at + "field 'x1' is not a finite decimal number: '0x10'");
  EXPECT_EQ(label_error("1 0 Car 0 0 -1.7 296.7 161.7 455.2 292.3 inf 1.8 4.4 -4.5 1.8 13.4 -2.1"),
            at + "field 'h' is not a finite decimal number: 'inf'");
  EXPECT_EQ(label_error("2000000000 0 Car 0 0 -1.7 296.7 161.7 455.2 292.3 2.0 1.8 4.4 -4.5 1.8 13.4 -2.1"),
            at + "field 'frame' = 2000000000 is not an integer in [0, 1000000]");
  EXPECT_EQ(label_error("1.5 0 Car 0 0 -1.7 296.7 161.7 455.2 292.3 2.0 1.8 4.4 -4.5 1.8 13.4 -2.1"),
            at + "field 'frame' = 1.5 is not an integer in [0, 1000000]");
  EXPECT_EQ(label_error("-1 0 Car 0 0 -1.7 296.7 161.7 455.2 292.3 2.0 1.8 4.4 -4.5 1.8 13.4 -2.1"),
            at + "field 'frame' = -1 is not an integer in [0, 1000000]");
  // Found by fuzz_kitti_files: an occlusion state too large for an int was converted unchecked.
  EXPECT_EQ(label_error("1 0 Car 0 6e21 -1.7 296.7 161.7 455.2 292.3 2.0 1.8 4.4 -4.5 1.8 13.4 -2.1"),
            at + "field 'occluded' = 6e21 is not an integer in [-1, 3]");
  std::ofstream(dir / "c.txt") << "P2: 7.2e+02 0 6e2 0 0 721 1.7e2 0 0 0 1 nan\n";
  EXPECT_EQ(error_of([&] { source::kitti::read_calibration(dir / "c.txt"); }),
            (dir / "c.txt").string() + ":1: error: P2 value 12 is not a finite decimal number: 'nan'");
  std::ofstream(dir / "ok.txt") << "P2: 7.2e+02 0 6e2 0 0 721 1.7e2 0 0 0 1 0\n";
  EXPECT_DOUBLE_EQ(source::kitti::read_calibration(dir / "ok.txt").fx(), 720.0);
}

}  // namespace
}  // namespace hf
