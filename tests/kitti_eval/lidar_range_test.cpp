// lidar_ttc on synthetic point clouds and a synthetic camera: range of a known box (closest-points median,
// ground removed, stray points and box edges rejected), range axes, and TTC under a constant closing speed.
#include <gtest/gtest.h>

#include <cmath>
#include <fstream>

#include <unistd.h>

#include "hazardforge/testing/stage_runner.hpp"
#include "lidar_range.hpp"
#include "lidar_ttc_metric.hpp"
#include "velodyne.hpp"

namespace hf {
namespace {

namespace fs = std::filesystem;
using lidar::RangeOptions;

constexpr double kF = 700, kCx = 600, kCy = 180;

// Velodyne axes (x forward, y left, z up) -> camera axes (x right, y down, z forward) with camera z =
// velodyne x + dz; P2 without an offset, R0_rect = I.
lidar::LidarCalibration synthetic_calibration(double dz = 0.0) {
  lidar::LidarCalibration c;
  c.P2 = cv::Matx34d(kF, 0, kCx, 0, 0, kF, kCy, 0, 0, 0, 1, 0);
  c.R0_rect = cv::Matx33d::eye();
  c.Tr_velo_to_cam = cv::Matx34d(0, -1, 0, 0, 0, 0, -1, 0, 1, 0, 0, dz);
  return c;
}

void write_calibration(const fs::path& file, double dz = 0.0) {
  std::ofstream out(file);
  out << "P0: 1 0 0 0 0 1 0 0 0 0 1 0\n"
      << "P2: " << kF << " 0 " << kCx << " 0 0 " << kF << " " << kCy << " 0 0 0 1 0\n"
      << "R0_rect: 1 0 0 0 1 0 0 0 1\n"
      << "Tr_velo_to_cam: 0 -1 0 0 0 0 -1 0 1 0 0 " << dz << "\n";
}

void write_scan(const fs::path& file, const std::vector<cv::Vec4f>& pts) {
  std::ofstream out(file, std::ios::binary);
  out.write(reinterpret_cast<const char*>(pts.data()), static_cast<std::streamsize>(pts.size() * 16));
}

// The rear face of a car: 30 points at ranges 10 + i/64 m (exact in float), |y| <= 0.8, z in [-1.2, 0.2].
std::vector<cv::Vec4f> car_face(float x0 = 10.0f, float step = 1.0f / 64.0f, float y0 = 0.0f) {
  std::vector<cv::Vec4f> pts;
  for (int i = 0; i < 30; ++i) {
    const float y = y0 - 0.8f + 1.6f * static_cast<float>(i % 6) / 5.0f;
    const float z = -1.2f + 1.4f * static_cast<float>(i / 6) / 4.0f;
    pts.push_back({x0 + step * static_cast<float>(i), y, z, 0.5f});
  }
  return pts;
}

// Image box of a face at range x spanning y in [y0-0.8, y0+0.8], z in [z_low, 0.2].
cv::Rect2d face_box(double x, double y0 = 0.0, double z_low = -1.2) {
  const double u0 = kCx - kF * (y0 + 0.8) / x, u1 = kCx - kF * (y0 - 0.8) / x;
  const double v0 = kCy - kF * 0.2 / x, v1 = kCy - kF * z_low / x;
  // 8 % margin so the shrunk box (10 %) still holds the face.
  return {u0 - 0.08 * (u1 - u0), v0 - 0.08 * (v1 - v0), 1.16 * (u1 - u0), 1.16 * (v1 - v0)};
}

double range_of(const std::vector<cv::Vec4f>& scan, const cv::Rect2d& box, const RangeOptions& o,
                const lidar::LidarCalibration& cal = synthetic_calibration()) {
  const auto pts = lidar::project_points(scan, cal, o);
  return lidar::box_ranges(pts, {box}, o)[0].range;
}

TEST(LidarRange, MedianOfTheClosestPoints) {
  RangeOptions o;
  o.k_closest = 10;
  const auto r =
      lidar::box_ranges(lidar::project_points(car_face(), synthetic_calibration(), o), {face_box(10)}, o);
  ASSERT_EQ(r.size(), 1u);
  EXPECT_EQ(r[0].points, 30);
  // The 10 closest are 10 + 0/64 ... 10 + 9/64: median (10 + 4/64 + 10 + 5/64) / 2.
  EXPECT_DOUBLE_EQ(r[0].range, 10.0 + 4.5 / 64.0);
  EXPECT_DOUBLE_EQ(r[0].nearest, 10.0);
  EXPECT_NEAR(r[0].lateral, 0.0, 1e-6);
  o.k_closest = 30;  // all points: median of 0/64 ... 29/64
  EXPECT_DOUBLE_EQ(range_of(car_face(), face_box(10), o), 10.0 + 14.5 / 64.0);
  o.statistic = lidar::RangeStatistic::kPercentile;
  o.percentile = 0;
  EXPECT_DOUBLE_EQ(range_of(car_face(), face_box(10), o), 10.0);
  o.percentile = 50;
  EXPECT_DOUBLE_EQ(range_of(car_face(), face_box(10), o), 10.0 + 14.5 / 64.0);
  // Fewer points than min_points: no range.
  o.min_points = 31;
  EXPECT_TRUE(std::isnan(range_of(car_face(), face_box(10), o)));
}

TEST(LidarRange, GroundPointsAreRemoved) {
  // Road points 8 m ahead (closer than the car) inside a box reaching down to the road.
  std::vector<cv::Vec4f> scan = car_face();
  for (float y : {-0.3f, -0.1f, 0.1f, 0.3f}) scan.push_back({8.0f, y, -1.7f, 0.1f});
  const cv::Rect2d box = face_box(10, 0.0, -2.6);  // rows down to z = -2.6 at 10 m: the road at 8 m is inside
  RangeOptions o;
  o.k_closest = 10;
  EXPECT_DOUBLE_EQ(range_of(scan, box, o), 10.0 + 4.5 / 64.0);  // ground_z -1.5 drops z = -1.7
  o.ground_z = -10;  // nothing dropped: the road points are the closest four
  EXPECT_DOUBLE_EQ(range_of(scan, box, o), 10.0 + 0.5 / 64.0);
}

TEST(LidarRange, StrayPointsAndBoxEdgesAreRejected) {
  RangeOptions o;
  o.k_closest = 10;
  // Two stray returns 3 m ahead inside the box: the median of the 10 closest is the 3rd/4th car point.
  std::vector<cv::Vec4f> scan = car_face();
  scan.push_back({3.0f, 0.0f, -0.3f, 0.1f});
  scan.push_back({3.0f, 0.1f, -0.3f, 0.1f});
  // Background seen through the windows, 30 m away: far, so not among the closest.
  for (int i = 0; i < 20; ++i) scan.push_back({30.0f, -0.5f + 0.05f * static_cast<float>(i), 0.0f, 0.1f});
  EXPECT_DOUBLE_EQ(range_of(scan, face_box(10), o), 10.0 + 2.5 / 64.0);
  // A neighbour 5 m ahead seen just inside the box's left edge (u = box.x + 1 px).
  const cv::Rect2d box = face_box(10);
  const float y_edge = static_cast<float>((kCx - (box.x + 1.0)) * 5.0 / kF);
  std::vector<cv::Vec4f> edge = car_face();
  for (int i = 0; i < 6; ++i) edge.push_back({5.0f, y_edge, -0.1f * static_cast<float>(i), 0.1f});
  EXPECT_DOUBLE_EQ(range_of(edge, box, o), 10.0 + 4.5 / 64.0);  // shrink 10 %: the edge points are out
  o.box_shrink = 0.0;
  EXPECT_DOUBLE_EQ(range_of(edge, box, o), 5.0);  // without shrink the neighbour's 6 points are the median
}

TEST(LidarRange, PointsInTwoBoxesBelongToNeither) {
  RangeOptions o;
  o.k_closest = 30;
  const auto pts = lidar::project_points(car_face(), synthetic_calibration(), o);
  const cv::Rect2d box = face_box(10);
  // A second box over the left half of the face: the shared points are dropped from both.
  const cv::Rect2d left(box.x - 50, box.y, box.width / 2 + 50, box.height);
  const auto r = lidar::box_ranges(pts, {box, left}, o);
  EXPECT_EQ(r[0].points + r[1].points, 15);  // 30 points, 15 of them (|y| side) shared
  EXPECT_EQ(r[1].points, 0);
}

TEST(LidarRange, CameraDepthOrLidarX) {
  RangeOptions o;
  o.k_closest = 1;
  const auto cal = synthetic_calibration(-0.27);  // camera 0.27 m ahead of the lidar
  EXPECT_NEAR(range_of(car_face(), face_box(9.73), o, cal), 10.0 - 0.27, 1e-9);
  o.axis = lidar::RangeAxis::kLidar;
  EXPECT_NEAR(range_of(car_face(), face_box(9.73), o, cal), 10.0, 1e-9);
  // Camera 2's offset from the rectified camera 0 comes from P2's last column.
  lidar::LidarCalibration c = synthetic_calibration();
  c.P2(0, 3) = kF * 0.06;
  c.P2(2, 3) = 0.003;
  c.P2(0, 3) += kCx * 0.003;
  EXPECT_NEAR(c.rect_to_cam2()[0], 0.06, 1e-12);
  EXPECT_NEAR(c.rect_to_cam2()[2], 0.003, 1e-12);
}

TEST(LidarTtc, ConstantVelocityModel) {
  // 2 m/s closing from 20 m, 10 Hz.
  std::vector<std::pair<double, double>> h;
  for (int k = 0; k < 6; ++k) h.push_back({0.1 * k, 20.0 - 0.2 * k});
  for (int w : {2, 3, 5}) {
    const auto r = lidar::constant_velocity_ttc(h, w, 0.1);
    EXPECT_NEAR(r.closing, 2.0, 1e-9) << w;
    EXPECT_NEAR(r.ttc, 19.0 / 2.0, 1e-9) << w;
  }
  // Two frames: TTC = d_t dt / (d_{t-1} - d_t).
  EXPECT_NEAR(lidar::constant_velocity_ttc({{0.0, 8.0}, {0.1, 7.9}}, 2, 0.1).ttc, 7.9 * 0.1 / 0.1, 1e-9);
  // Receding or slower than min_closing: infinite; one sample: unknown.
  EXPECT_TRUE(std::isinf(lidar::constant_velocity_ttc({{0.0, 8.0}, {0.1, 8.1}}, 2, 0.1).ttc));
  EXPECT_TRUE(std::isinf(lidar::constant_velocity_ttc({{0.0, 8.0}, {0.1, 7.995}}, 2, 0.1).ttc));
  EXPECT_TRUE(std::isnan(lidar::constant_velocity_ttc({{0.0, 8.0}}, 2, 0.1).ttc));
}

// The stage on six synthetic frames: a lead car closing at 2 m/s and a car in the next lane.
struct StageFixture {
  fs::path dir;
  std::vector<double> lead_x;
  StageFixture() {
    dir = fs::temp_directory_path() / ("hf_lidar_ttc_" + std::to_string(::getpid()));
    fs::create_directories(dir / "scans");
    write_calibration(dir / "calib.txt");
    for (int k = 0; k < 6; ++k) {
      const float x = 20.0f - 0.2f * static_cast<float>(k);
      lead_x.push_back(x);
      std::vector<cv::Vec4f> scan = car_face(x, 0.0f);                      // a flat rear face at x
      for (const auto& p : car_face(12.0f, 0.0f, 4.0f)) scan.push_back(p);  // parked, 4 m to the left
      char name[32];
      std::snprintf(name, sizeof name, "%06d.bin", k);
      write_scan(dir / "scans" / name, scan);
    }
  }
  ~StageFixture() { fs::remove_all(dir); }
  Frame frame(int k) const {
    Frame f;
    f.index = k;
    f.timestamp = 0.1 * k;
    char name[32];
    std::snprintf(name, sizeof name, "%06d.png", k);
    f.source_id = name;
    return f;
  }
  std::string params(const std::string& extra = "") const {
    return "{velodyne_dir: '" + (dir / "scans").string() + "', calib: '" + (dir / "calib.txt").string() +
           "'" + extra + "}";
  }
};

TEST(LidarTtcStage, TracksGiveTheLeadsTtcUnderConstantClosing) {
  StageFixture fx;
  auto r = testing::StageRunner::create<LidarTtcMetric>(fx.params());
  for (int k = 0; k < 6; ++k) {
    ObjectStates s;
    s.frame_index = k;
    ObjectState lead, side;
    lead.track_id = 7;
    lead.box = cv::Rect2f(face_box(fx.lead_x[static_cast<size_t>(k)]));
    side.track_id = 9;
    side.box = cv::Rect2f(face_box(12.0, 4.0));
    s.objects = {side, lead};
    r.push("frames", fx.frame(k), 0.1 * k);
    r.push("states", s, 0.1 * k);
  }
  r.run();
  const auto risks = r.collect<RiskAssessment>("risk");
  const auto recs = r.collect<Record>("range");
  ASSERT_EQ(risks.size(), 6u);
  ASSERT_EQ(recs.size(), 6u);
  EXPECT_TRUE(std::isnan(risks[0].scene_value));  // one range: no closing speed yet
  EXPECT_EQ(risks[0].critical_track, 7);
  for (size_t k = 1; k < 6; ++k) {
    EXPECT_EQ(risks[k].critical_track, 7);
    EXPECT_NEAR(risks[k].scene_value, fx.lead_x[k] / 2.0, 1e-4) << k;  // d / 2 m/s
    ASSERT_EQ(risks[k].objects.size(), 2u);
    EXPECT_FALSE(risks[k].objects[0].in_path);           // 4 m to the left
    EXPECT_TRUE(std::isinf(risks[k].objects[0].value));  // parked relative to the camera
    EXPECT_TRUE(risks[k].objects[1].in_path);
    EXPECT_EQ(risks[k].label, SafetyLabel::kSafe);
  }
  EXPECT_NEAR(recs[3].data.at("lead").at("range_m").get<double>(), fx.lead_x[3], 1e-6);
  EXPECT_EQ(recs[3].data.at("lead").at("points").get<int>(), 30);
  EXPECT_EQ(recs[3].data.at("boxes")[0].at("in_lane"), false);
  EXPECT_NEAR(recs[3].data.at("boxes")[0].at("lateral_m").get<double>(), 4.0, 1e-6);
  EXPECT_EQ(recs[0].data.at("scan"), "000000.bin");
}

TEST(LidarTtcStage, DetectionsGiveTheLeadsTtcAndUnsafeBelowThreshold) {
  StageFixture fx;
  auto r = testing::StageRunner::create<LidarTtcMetric>(fx.params(", threshold: 9.8, window: 3"));
  for (int k = 0; k < 6; ++k) {
    Detections d;
    d.frame_index = k;
    Detection lead;
    lead.box = cv::Rect2f(face_box(fx.lead_x[static_cast<size_t>(k)]));
    d.items = {lead};
    r.push("frames", fx.frame(k), 0.1 * k);
    r.push("detections", d, 0.1 * k);
  }
  r.run();
  const auto risks = r.collect<RiskAssessment>("risk");
  ASSERT_EQ(risks.size(), 6u);
  EXPECT_NEAR(risks[1].scene_value, 9.9, 1e-4);
  EXPECT_EQ(risks[1].label, SafetyLabel::kSafe);
  EXPECT_NEAR(risks[2].scene_value, 9.8, 1e-4);
  EXPECT_NEAR(risks[5].scene_value, 9.5, 1e-4);
  EXPECT_EQ(risks[5].label, SafetyLabel::kUnsafe);
  EXPECT_EQ(risks[5].critical_track, 0);  // detection index
}

TEST(LidarTtcStage, MessagesNameTheFrameAndTheMissingPiece) {
  StageFixture fx;
  {
    auto r = testing::StageRunner::create<LidarTtcMetric>(fx.params());
    Frame f = fx.frame(0);
    f.source_id = "000042.png";
    r.push("frames", f, 0.0);
    r.push("states", ObjectStates{}, 0.0);
    try {
      r.run();
      FAIL() << "no error";
    } catch (const Error& e) {
      EXPECT_NE(std::string(e.what()).find("frame 0 (000042.png): no Velodyne scan in '" +
                                           (fx.dir / "scans").string() + "'"),
                std::string::npos)
          << e.what();
    }
  }
  {
    auto r = testing::StageRunner::create<LidarTtcMetric>(fx.params());
    r.push("frames", fx.frame(0), 0.0);
    r.push("states", ObjectStates{}, 0.0);
    r.push("detections", Detections{}, 0.0);
    try {
      r.run();
      FAIL() << "no error";
    } catch (const Error& e) {
      EXPECT_NE(std::string(e.what()).find("both 'states' and 'detections' carry boxes"), std::string::npos);
    }
  }
  {
    std::ofstream(fx.dir / "bad_calib.txt")
        << "P2: 700 0 600 0 0 700 180 0 0 0 1 0\nR0_rect: 1 0 0 0 1 0 0 0\n";
    try {
      lidar::read_lidar_calibration(fx.dir / "bad_calib.txt");
      FAIL() << "no error";
    } catch (const Error& e) {
      EXPECT_EQ(std::string(e.what()),
                (fx.dir / "bad_calib.txt").string() + ":2: error: R0_rect needs 9 numbers, got 8");
    }
  }
  {
    std::ofstream(fx.dir / "scans" / "000009.bin") << "12345";
    try {
      lidar::read_scan(fx.dir / "scans" / "000009.bin");
      FAIL() << "no error";
    } catch (const Error& e) {
      EXPECT_NE(std::string(e.what()).find("has 5 bytes, not a multiple of 16"), std::string::npos);
    }
  }
}

}  // namespace
}  // namespace hf
