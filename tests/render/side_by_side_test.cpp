// The side_by_side sink: a playable before/after video with every frame, and stills of the chosen frames.
#include <gtest/gtest.h>

#include <filesystem>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/videoio.hpp>

#include "hazardforge/testing/stage_runner.hpp"
#include "render_fixtures.hpp"
#include "side_by_side_sink.hpp"

namespace hf::render {
namespace {

namespace fs = std::filesystem;

TEST(SideBySide, WritesEveryFrameAndTheRequestedStills) {
  auto runner =
      hf::testing::StageRunner::create<SideBySideSink>("stills: [2]\nscale: 0.5\nstills_scale: 0.5");
  const cv::Mat img = hf::test::textured_image();
  cv::Mat aug = img.clone();
  cv::rectangle(aug, cv::Rect(1000, 300, 300, 300), cv::Scalar(255, 255, 255), cv::FILLED);
  for (int k = 0; k < 5; ++k) {
    runner.push("original", hf::test::make_frame(k, 0.1 * k, img, hf::test::test_camera()), 0.1 * k);
    runner.push("augmented", hf::test::make_frame(k, 0.1 * k, aug, hf::test::test_camera()), 0.1 * k);
  }
  runner.run();
  const auto& sink = dynamic_cast<const SideBySideSink&>(runner.stage());
  const fs::path video = runner.output_dir() / "before_after.mp4";
  ASSERT_TRUE(fs::exists(video));
  EXPECT_FALSE(fs::exists(runner.output_dir() / "before_after.partial.mp4"));
  EXPECT_TRUE(sink.codec() == "avc1" || sink.codec() == "mp4v") << sink.codec();
  cv::VideoCapture cap(video.string());
  ASSERT_TRUE(cap.isOpened());
  EXPECT_EQ(static_cast<int>(cap.get(cv::CAP_PROP_FRAME_WIDTH)), 1600);
  EXPECT_EQ(static_cast<int>(cap.get(cv::CAP_PROP_FRAME_HEIGHT)), 450);
  EXPECT_NEAR(cap.get(cv::CAP_PROP_FPS), 10.0, 0.01);
  int n = 0;
  for (cv::Mat f; cap.read(f);) ++n;
  EXPECT_EQ(n, 5);

  // The still: left half the original, right half the augmented frame (white square at its place).
  const fs::path still = runner.output_dir() / "stills" / "before_after_2.png";
  ASSERT_TRUE(fs::exists(still));
  EXPECT_FALSE(fs::exists(runner.output_dir() / "stills" / "before_after_1.png"));
  const cv::Mat s = cv::imread(still.string());
  ASSERT_EQ(s.size(), cv::Size(1600, 450));
  const cv::Rect sq(800 + 520, 160, 120, 120);  // inside the square, scaled by 0.5, on the right half
  EXPECT_GT(cv::mean(s(sq))[0], 250);
  EXPECT_LT(cv::mean(s(sq - cv::Point(800, 0)))[0], 200);
  // Away from the labels the halves are the frames, scaled.
  cv::Mat small;
  cv::resize(img, small, cv::Size(800, 450), 0, 0, cv::INTER_AREA);
  cv::Mat d;
  cv::absdiff(small(cv::Rect(100, 150, 400, 200)), s(cv::Rect(100, 150, 400, 200)), d);
  EXPECT_EQ(cv::countNonZero(d.reshape(1)), 0);
}

// Per realism metric, the close-ups of the frames whose inserted object is nearest to and farthest from the
// recording's real objects of its class; metrics without real values are left out.
TEST(SideBySide, RealismStillsShowTheBestAndWorstFramePerMetric) {
  auto runner = hf::testing::StageRunner::create<SideBySideSink>("critical_still: false");
  const cv::Mat img = hf::test::textured_image();
  const double halo[] = {2.0, 5.2, 9.0};  // the inserted car's halo in frames 0, 1, 2
  for (int k = 0; k < 3; ++k) {
    cv::Mat aug = img.clone();
    cv::rectangle(aug, cv::Rect(700, 400, 200, 150), cv::Scalar(0, 0, 200 + 20 * k), cv::FILLED);
    runner.push("original", hf::test::make_frame(k, 0.1 * k, img, hf::test::test_camera()), 0.1 * k);
    runner.push("augmented", hf::test::make_frame(k, 0.1 * k, aug, hf::test::test_camera()), 0.1 * k);
    HazardInstance h;
    h.frame_index = k;
    h.visible = true;
    h.object_class = "car";
    h.box = cv::Rect2f(700, 400, 200, 150);
    AppearanceStats in;
    in.label = "car";
    in.halo = halo[k];
    h.appearance = in;
    for (double v : {4.0, 5.0, 6.0, 5.0, 5.5}) {  // the recording's cars
      AppearanceStats r;
      r.label = "car";
      r.halo = v;
      h.references.push_back(r);
    }
    runner.push("hazard", h, 0.1 * k);
  }
  runner.run();
  const fs::path dir = runner.output_dir() / "stills" / "realism";
  const cv::Mat best = cv::imread((dir / "halo_best.png").string()),
                worst = cv::imread((dir / "halo_worst.png").string());
  ASSERT_FALSE(best.empty());
  ASSERT_FALSE(worst.empty());
  // The close-up: twice the box (400 x 300) at 240 px tall per half = 320 x 240, the augmented half on the
  // right with its red square (frame 1 nearest the real halos, frame 2 farthest).
  EXPECT_GE(best.cols, 640);
  EXPECT_EQ(best.rows - 240, worst.rows - 240);  // the same close-up size, a caption strip below
  const cv::Vec3b b = best.at<cv::Vec3b>(120, 320 + 160), w = worst.at<cv::Vec3b>(120, 320 + 160);
  EXPECT_NEAR(b[2], 220, 3);
  EXPECT_NEAR(w[2], 240, 3);
  EXPECT_FALSE(fs::exists(dir / "sharpness_best.png"));  // no real sharpness was measured
  EXPECT_FALSE(fs::exists(runner.output_dir() / "stills" / "critical.png"));
}

TEST(SideBySide, RefusesMismatchedPairs) {
  auto runner = hf::testing::StageRunner::create<SideBySideSink>();
  const cv::Mat img = hf::test::textured_image();
  runner.push("original", hf::test::make_frame(0, 0.0, img, hf::test::test_camera()), 0.0);
  runner.push("augmented",
              hf::test::make_frame(0, 0.0, img(cv::Rect(0, 0, 800, 450)).clone(), hf::test::test_camera()),
              0.0);
  try {
    runner.run();
    FAIL() << "expected an error";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("frame 0: original is 1600x900 but augmented is 800x450"),
              std::string::npos)
        << e.what();
  }
}

}  // namespace
}  // namespace hf::render
