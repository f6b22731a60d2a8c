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
  auto runner = hf::testing::StageRunner::create<SideBySideSink>("stills: [2]\nscale: 0.5\nstills_scale: 0.5");
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

TEST(SideBySide, RefusesMismatchedPairs) {
  auto runner = hf::testing::StageRunner::create<SideBySideSink>();
  const cv::Mat img = hf::test::textured_image();
  runner.push("original", hf::test::make_frame(0, 0.0, img, hf::test::test_camera()), 0.0);
  runner.push("augmented", hf::test::make_frame(0, 0.0, img(cv::Rect(0, 0, 800, 450)).clone(), hf::test::test_camera()), 0.0);
  try {
    runner.run();
    FAIL() << "expected an error";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("frame 0: original is 1600x900 but augmented is 800x450"), std::string::npos)
        << e.what();
  }
}

}  // namespace
}  // namespace hf::render
