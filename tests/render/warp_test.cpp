// The compositor's BGRA perspective warp against OpenCV's on pictures and homographies of known geometry.
#include <gtest/gtest.h>

#include <random>

#include <opencv2/imgproc.hpp>

#include "warp.hpp"

namespace hf::render {
namespace {

// A premultiplied BGRA picture with texture at every scale and a transparent border.
cv::Mat picture(cv::Size size, unsigned seed) {
  cv::Mat bgra(size, CV_8UC4);
  cv::RNG rng(seed);
  rng.fill(bgra, cv::RNG::UNIFORM, 0, 256);
  cv::GaussianBlur(bgra, bgra, cv::Size(), 1.2);
  cv::rectangle(bgra, cv::Rect(0, 0, size.width, size.height), cv::Scalar::all(0), 3);
  return bgra;
}

// Magnified, shrunk, rotated, foreshortened, partly outside the destination, and destinations whose width is
// not a multiple of the kernel's eight pixels; into a view of a larger buffer (row stride != width) from a
// view of a larger picture.
TEST(WarpBgra, MatchesOpenCvWithinOneGreyLevel) {
  const cv::Mat big = picture({460, 300}, 7);
  const cv::Mat src = big(cv::Rect(20, 15, 407, 250));
  const std::vector<cv::Point2f> from = {{0, 0}, {407, 0}, {407, 250}, {0, 250}};
  const std::vector<std::pair<std::vector<cv::Point2f>, cv::Size>> cases = {
      {{{10, 30}, {720, 0}, {735, 520}, {0, 490}}, {735, 524}},     // magnified with perspective (a car 8 m ahead)
      {{{5, 4}, {105, 8}, {102, 70}, {3, 66}}, {111, 77}},          // shrunk (a car 60 m ahead)
      {{{100, -40}, {420, 60}, {330, 330}, {10, 230}}, {401, 301}},  // rotated, partly above the top
      {{{-80, 10}, {300, 40}, {310, 180}, {-60, 200}}, {257, 193}},  // partly left of the destination
      {{{0, 0}, {407, 0}, {407, 250}, {0, 250}}, {407, 250}},        // identity
  };
  for (size_t i = 0; i < cases.size(); ++i) {
    const cv::Matx33d H = cv::Matx33d(cv::getPerspectiveTransform(from, cases[i].first));
    const cv::Size size = cases[i].second;
    cv::Mat want(size, CV_8UC4);
    cv::warpPerspective(src, want, cv::Mat(H), size, cv::INTER_LINEAR, cv::BORDER_CONSTANT, cv::Scalar::all(0));
    cv::Mat buffer(size.height + 6, size.width + 13, CV_8UC4, cv::Scalar::all(77));
    cv::Mat got = buffer(cv::Rect(5, 3, size.width, size.height));
    warp_bgra(src, got, H);
    cv::Mat diff;
    cv::absdiff(want, got, diff);
    double worst = 0;
    cv::minMaxLoc(diff.reshape(1), nullptr, &worst);
    EXPECT_LE(worst, 1.0) << "case " << i;
    EXPECT_LT(cv::mean(diff.reshape(1))[0], 0.01) << "case " << i;
    // Nothing outside the view is touched.
    cv::Mat around = buffer.clone();
    around(cv::Rect(5, 3, size.width, size.height)).setTo(cv::Scalar::all(77));
    EXPECT_EQ(cv::countNonZero(around.reshape(1) != 77), 0) << "case " << i;
  }
  SUCCEED() << (warp_bgra_accelerated() ? "own AVX2 kernel" : "OpenCV's warp (no AVX2 here)");
}

// A homography that maps the picture behind the camera for part of the destination (w <= 0 there) and one
// that sends everything far off: transparent where OpenCV is, no crash.
TEST(WarpBgra, DegenerateMapsStayTransparent) {
  const cv::Mat src = picture({64, 48}, 3);
  const cv::Matx33d behind(1, 0, 0, 0, 1, 0, 0.02, 0, -0.5);  // w crosses 0 at x = 25
  cv::Mat a(40, 60, CV_8UC4), b(40, 60, CV_8UC4);
  cv::warpPerspective(src, a, cv::Mat(behind), a.size(), cv::INTER_LINEAR, cv::BORDER_CONSTANT, cv::Scalar::all(0));
  warp_bgra(src, b, behind);
  cv::Mat diff;
  cv::absdiff(a, b, diff);
  EXPECT_LE(cv::countNonZero(diff.reshape(1) > 1), static_cast<int>(diff.total() * 4 / 100));
  const cv::Matx33d far(1, 0, 1e7, 0, 1, 1e7, 0, 0, 1);
  warp_bgra(src, b, far);
  EXPECT_EQ(cv::countNonZero(b.reshape(1)), 0);
}

}  // namespace
}  // namespace hf::render
