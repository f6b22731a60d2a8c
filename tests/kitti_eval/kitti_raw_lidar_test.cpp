// lidar_ttc on the real KITTI raw clip (2011_09_26, 78 frames): the lead vehicle's lidar range in frame 0 and
// its TTC while the ego closes in on it and after both have stopped.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>

#include "hazardforge/testing/stage_runner.hpp"
#include "lidar_range.hpp"
#include "lidar_ttc_metric.hpp"
#include "test_support.hpp"
#include "velodyne.hpp"

namespace hf {
namespace {

namespace fs = std::filesystem;

const fs::path kRaw = test::shared_data("kitti-raw-2011_09_26");

// The scans, extracted once into the build folder (the marker makes later runs reuse them).
fs::path scans() {
  static const fs::path dir =
      lidar::extract_scans(kRaw / "velodyne_points.tar.xz", test::binary_dir() / "kitti_eval_velodyne");
  return dir;
}

std::string scan_name(int k) {
  char name[32];
  std::snprintf(name, sizeof name, "%010d", k);
  return name;
}

// The lead car in image_02 frame 0, read off the image: rear of a grey estate car centred in the ego lane,
// u 555..700, v 190..310 (bottom = rear tyres on the road).
const cv::Rect2d kLeadFrame0(555, 190, 145, 120);

TEST(KittiRawLidar, LeadRangeInFrameZeroIsPlausible) {
  HF_REQUIRE_SHARED(kRaw / "velodyne_points.tar.xz");
  const auto cal = lidar::read_lidar_calibration(kRaw / "calib_2011_09_26_kitti_tracking_format.txt");
  const auto scan = lidar::read_scan(scans() / (scan_name(0) + ".bin"));
  EXPECT_EQ(scan.size(), 114278u);  // 1828448 bytes / 16
  lidar::RangeOptions o;
  const auto r = lidar::box_ranges(lidar::project_points(scan, cal, o), {kLeadFrame0}, o)[0];
  // Measured: 7.70 m along camera 2's axis from 900+ points on the car's rear, 0.2 m right of the camera.
  EXPECT_NEAR(r.range, 7.70, 0.03);
  EXPECT_GT(r.points, 800);
  EXPECT_NEAR(r.lateral, -0.2, 0.1);
  // Independent check from the image alone: the rear tyres touch the road at row 310, so with the camera 1.65
  // m above a flat road they are f * 1.65 / (310 - c_y) = 8.7 m ahead; the rear bumper overhangs them by
  // roughly 0.8-1 m, which puts it at 7.7-7.9 m.
  const double tyres = cal.P2(1, 1) * 1.65 / (310 - cal.P2(1, 2));
  EXPECT_NEAR(tyres, 8.68, 0.05);
  EXPECT_GT(tyres - r.range, 0.6);
  EXPECT_LT(tyres - r.range, 1.2);
  // Velodyne x is 0.28 m longer: the lidar sits 0.27 m behind camera 0 (Tr_velo_to_cam), camera 2 a few mm
  // ahead of it, and the two axes are not quite parallel.
  o.axis = lidar::RangeAxis::kLidar;
  const auto rx = lidar::box_ranges(lidar::project_points(scan, cal, o), {kLeadFrame0}, o)[0];
  EXPECT_NEAR(rx.range - r.range, 0.28, 0.01);
}

// A box that stays on the lead car's rear in every frame (the car grows around it as the ego closes in).
TEST(KittiRawLidar, TtcIsFiniteWhileClosingAndInfiniteWhenStopped) {
  HF_REQUIRE_SHARED(kRaw / "velodyne_points.tar.xz");
  auto r = testing::StageRunner::create<LidarTtcMetric>(
      "{velodyne_dir: '" + scans().string() + "', calib: '" +
      (kRaw / "calib_2011_09_26_kitti_tracking_format.txt").string() + "', window: 5}");
  for (int k = 0; k < 78; ++k) {
    Frame f;
    f.index = k;
    f.timestamp = 0.1 * k;
    f.source_id = scan_name(k) + ".png";
    Detections d;
    d.frame_index = k;
    Detection lead;
    lead.box = cv::Rect2f(585, 215, 90, 80);
    d.items = {lead};
    r.push("frames", f, f.timestamp);
    r.push("detections", d, f.timestamp);
  }
  r.run();
  const auto risks = r.collect<RiskAssessment>("risk");
  const auto recs = r.collect<Record>("range");
  ASSERT_EQ(risks.size(), 78u);
  std::vector<double> range;
  for (const Record& rec : recs) range.push_back(rec.data.at("lead").at("range_m").get<double>());
  // Measured: 7.70 m at frame 0, 4.23 m from frame 55 on (both cars stand); the range never grows by more
  // than the 1-2 cm of lidar noise.
  EXPECT_NEAR(range[0], 7.70, 0.03);
  EXPECT_NEAR(range[77], 4.23, 0.03);
  for (size_t k = 1; k < 78; ++k) EXPECT_LT(range[k], range[k - 1] + 0.02) << "frame " << k;
  EXPECT_TRUE(std::isnan(risks[0].scene_value));  // one range, no closing speed
  // Closing in at 0.5-1 m/s: TTC between 5 and 15 s (measured 5.3 .. 14.2 s) ...
  for (size_t k = 1; k <= 50; ++k) {
    EXPECT_TRUE(std::isfinite(risks[k].scene_value)) << "frame " << k;
    EXPECT_GT(risks[k].scene_value, 5.0) << "frame " << k;
    EXPECT_LT(risks[k].scene_value, 15.0) << "frame " << k;
  }
  // ... rising while the ego brakes to a stop (12 .. 38 s, frames 51-54) ...
  for (size_t k = 51; k <= 54; ++k) {
    EXPECT_TRUE(std::isfinite(risks[k].scene_value)) << "frame " << k;
    EXPECT_GT(risks[k].scene_value, 10.0) << "frame " << k;
  }
  // ... and infinite once both stand (no closing faster than 0.1 m/s).
  for (size_t k = 55; k < 78; ++k) EXPECT_TRUE(std::isinf(risks[k].scene_value)) << "frame " << k;
  // Always Safe: the lead never comes within 1.5 s.
  for (const auto& a : risks) EXPECT_EQ(a.label, SafetyLabel::kSafe);
  EXPECT_EQ(risks[30].critical_track, 0);
}

}  // namespace
}  // namespace hf
