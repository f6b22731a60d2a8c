// Chessboard calibration on the Udacity camera_cal photos, the YAML round trip, and the committed
// calibration.
#include <gtest/gtest.h>

#include <fstream>
#include <sstream>

#include <opencv2/calib3d.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "camera_setup.hpp"
#include "hazardforge/apps/calibration.hpp"
#include "io_test_util.hpp"
#include "test_support.hpp"

namespace hf {
namespace {

using test::error_of;
using test::TempDir;

CalibrationResult udacity() {
  static const CalibrationResult r = [] {
    std::ostringstream log;
    return calibrate_chessboard(test::shared_data("udacity-highway/camera_cal"), cv::Size(9, 6), 1.0, &log);
  }();
  return r;
}

TEST(Calibration, UdacityHighwayChessboards) {
  HF_REQUIRE_SHARED(test::shared_data("udacity-highway/camera_cal"));
  const CalibrationResult r = udacity();
  EXPECT_EQ(r.image_width, 1280);
  EXPECT_EQ(r.image_height, 720);
  EXPECT_LT(r.rms_px, 1.0);
  EXPECT_GT(r.rms_px, 0.0);
  // A dash camera at 1280x720: fx of ~1150 px is a ~58 deg horizontal FOV.
  EXPECT_GT(r.fx, 900);
  EXPECT_LT(r.fx, 1400);
  EXPECT_NEAR(r.fy / r.fx, 1.0, 0.02);
  EXPECT_NEAR(r.cx, 640, 40);
  EXPECT_NEAR(r.cy, 360, 40);
  ASSERT_EQ(r.distortion.size(), 5u);
  EXPECT_LT(r.distortion[0], 0.0) << "wide-angle dash cameras show barrel distortion";
  EXPECT_EQ(r.images_used.size() + r.images_rejected.size(), 20u);
  EXPECT_GE(r.images_used.size(), 15u);
  // The two 1281x721 photos cannot join a 1280x720 calibration.
  std::vector<std::string> rejected;
  for (const auto& x : r.images_rejected) rejected.push_back(x.file + ": " + x.reason);
  EXPECT_NE(
      std::find(rejected.begin(), rejected.end(), "calibration15.jpg: size 1281x721 differs from 1280x720"),
      rejected.end());
  EXPECT_NE(
      std::find(rejected.begin(), rejected.end(), "calibration7.jpg: size 1281x721 differs from 1280x720"),
      rejected.end());
}

TEST(Calibration, CommittedFileMatchesAFreshCalibration) {
  HF_REQUIRE_SHARED(test::shared_data("udacity-highway/camera_cal"));
  const auto committed = test::source_dir() / "share/calibration/udacity_highway.yaml";
  ASSERT_TRUE(std::filesystem::exists(committed));
  const CalibrationResult c = read_calibration(committed), r = udacity();
  EXPECT_NEAR(c.fx, r.fx, 1e-6 * r.fx);
  EXPECT_NEAR(c.fy, r.fy, 1e-6 * r.fy);
  EXPECT_NEAR(c.cx, r.cx, 1e-6 * r.cx);
  EXPECT_NEAR(c.cy, r.cy, 1e-6 * r.cy);
  ASSERT_EQ(c.distortion.size(), r.distortion.size());
  for (size_t i = 0; i < r.distortion.size(); ++i) EXPECT_NEAR(c.distortion[i], r.distortion[i], 1e-6);
  EXPECT_EQ(c.images_used, r.images_used);
}

TEST(Calibration, SyntheticBoardRecoversKnownIntrinsics) {
  // Render a 7x5-inner-corner board with a known camera from several poses; calibration must find that
  // camera.
  TempDir dir;
  const cv::Size inner(7, 5), img(800, 600);
  const double sq = 30;  // px per square on the flat board image
  cv::Mat board((inner.height + 3) * static_cast<int>(sq), (inner.width + 3) * static_cast<int>(sq), CV_8UC1,
                cv::Scalar(255));
  for (int y = 0; y < inner.height + 1; ++y)
    for (int x = 0; x < inner.width + 1; ++x)
      if ((x + y) % 2 == 0)
        cv::rectangle(board,
                      cv::Rect(static_cast<int>((x + 1) * sq), static_cast<int>((y + 1) * sq),
                               static_cast<int>(sq), static_cast<int>(sq)),
                      cv::Scalar(0), cv::FILLED);
  const cv::Matx33d K(700, 0, 400, 0, 700, 300, 0, 0, 1);
  int n = 0;
  for (double ax : {-0.35, 0.0, 0.35})
    for (double ay : {-0.3, 0.3}) {
      // Homography of the board plane (board pixels scaled to metres) seen under rotation (ax, ay).
      cv::Matx33d R;
      cv::Rodrigues(cv::Vec3d(ax, ay, 0.1 * n), R);
      const double s = 0.002;  // m per board pixel
      // Board centre on the optical axis 1.2 m away, board rotated about its centre.
      const cv::Vec3d tt = R * cv::Vec3d(-board.cols * s / 2, -board.rows * s / 2, 0) + cv::Vec3d(0, 0, 1.2);
      cv::Matx33d H = K * cv::Matx33d(R(0, 0) * s, R(0, 1) * s, tt[0], R(1, 0) * s, R(1, 1) * s, tt[1],
                                      R(2, 0) * s, R(2, 1) * s, tt[2]);
      cv::Mat view;
      cv::warpPerspective(board, view, cv::Mat(H), img, cv::INTER_LINEAR, cv::BORDER_CONSTANT,
                          cv::Scalar(255));
      cv::imwrite((dir / ("view" + std::to_string(n++) + ".png")).string(), view);
    }
  cv::imwrite((dir / "blank.png").string(), cv::Mat(img, CV_8UC1, cv::Scalar(128)));
  std::ofstream(dir / "readme.txt") << "not an image";
  const CalibrationResult r = calibrate_chessboard(dir.path(), inner, 1.0);
  EXPECT_EQ(r.images_used.size(), 6u);
  ASSERT_EQ(r.images_rejected.size(), 1u);
  EXPECT_EQ(r.images_rejected[0].file, "blank.png");
  EXPECT_EQ(r.images_rejected[0].reason, "no 7x5 chessboard found");
  EXPECT_LT(r.rms_px, 0.3);
  EXPECT_NEAR(r.fx, 700, 10);
  EXPECT_NEAR(r.fy, 700, 10);
  EXPECT_NEAR(r.cx, 400, 10);
  EXPECT_NEAR(r.cy, 300, 10);
}

TEST(Calibration, YamlRoundTripAndSourceReader) {
  TempDir dir;
  CalibrationResult c;
  c.image_width = 1280;
  c.image_height = 720;
  c.fx = 1156.94;
  c.fy = 1152.13;
  c.cx = 665.95;
  c.cy = 388.79;
  c.distortion = {-0.2376, -0.0854, -0.00079, -0.000116, 0.1057};
  c.rms_px = 0.4;
  c.board_cols = 9;
  c.board_rows = 6;
  c.images_used = {"a.jpg", "b.jpg"};
  c.images_rejected = {{"c.jpg", "no 9x6 chessboard found"}};
  const auto file = dir / "cal.yaml";
  write_calibration(c, file);
  // No temporary file is left behind.
  EXPECT_EQ(std::distance(std::filesystem::directory_iterator(dir.path()), {}), 1);
  const CalibrationResult r = read_calibration(file);
  EXPECT_EQ(r.image_width, 1280);
  EXPECT_DOUBLE_EQ(r.fx, c.fx);
  EXPECT_DOUBLE_EQ(r.cy, c.cy);
  EXPECT_EQ(r.distortion, c.distortion);
  EXPECT_EQ(r.images_used, c.images_used);
  ASSERT_EQ(r.images_rejected.size(), 1u);
  EXPECT_EQ(r.images_rejected[0].reason, "no 9x6 chessboard found");
  // The sources read the same file with the SDK's reader.
  const CalibrationFile s = read_calibration_file(file);
  EXPECT_DOUBLE_EQ(s.fx, c.fx);
  EXPECT_DOUBLE_EQ(s.cx, c.cx);
  EXPECT_EQ(s.distortion, c.distortion);
  EXPECT_EQ(s.width, 1280);

  std::ofstream(dir / "bad.yaml") << "image_width: 1280\nimage_height: 720\nfx: abc\nfy: 1\ncx: 1\ncy: 1\n";
  EXPECT_EQ(error_of([&] { read_calibration(dir / "bad.yaml"); }),
            (dir / "bad.yaml").string() + ":3: error: calibration field 'fx' is not a number");
  EXPECT_EQ(error_of([&] { read_calibration_file(dir / "bad.yaml"); }),
            (dir / "bad.yaml").string() + ":3: error: calibration field 'fx' is not a number");
  std::ofstream(dir / "short.yaml") << "image_width: 1280\nimage_height: 720\nfx: 1\n";
  EXPECT_EQ(error_of([&] { read_calibration(dir / "short.yaml"); }),
            (dir / "short.yaml").string() + ": error: calibration field 'fy' is missing");
  EXPECT_EQ(error_of([&] {
              calibrate_chessboard(dir / "nothing", {9, 6});
            }),
            "calibration folder '" + (dir / "nothing").string() + "' does not exist");
  EXPECT_EQ(error_of([&] {
              calibrate_chessboard(dir.path(), {9, 6});
            }),
            "calibration folder '" + dir.path().string() +
                "': only 0 of 0 images show a 9x6 chessboard; at least 3 are needed");
}

}  // namespace
}  // namespace hf
