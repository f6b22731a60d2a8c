// Matting and colour decontamination on a synthetic picture with a known alpha and known colours.
#include <gtest/gtest.h>

#include <cmath>

#include <opencv2/imgproc.hpp>

#include "hazardforge/error.hpp"
#include "hazardforge/realism/matting.hpp"

namespace hf::realism {
namespace {

struct Scene {
  cv::Mat image, alpha, fg, bg;  // image = alpha fg + (1 - alpha) bg
};

// A disc of uniform colour with a soft edge (alpha falls linearly over 6 px) on a striped, textured background.
Scene soft_disc() {
  const cv::Size size(120, 100);
  Scene s;
  s.fg = cv::Mat(size, CV_8UC3, cv::Scalar(40, 90, 200));
  s.bg = cv::Mat(size, CV_8UC3);
  cv::RNG rng(11);
  for (int y = 0; y < size.height; ++y)
    for (int x = 0; x < size.width; ++x) {
      const int v = (x / 8) % 2 ? 200 : 150;
      s.bg.at<cv::Vec3b>(y, x) = cv::Vec3b(cv::saturate_cast<uint8_t>(v + rng.gaussian(3)),
                                           cv::saturate_cast<uint8_t>(v - 20 + rng.gaussian(3)), 90);
    }
  s.alpha = cv::Mat(size, CV_8U);
  for (int y = 0; y < size.height; ++y)
    for (int x = 0; x < size.width; ++x) {
      const double r = std::hypot(x - 60.0, y - 50.0);
      s.alpha.at<uint8_t>(y, x) = cv::saturate_cast<uint8_t>(255.0 * std::clamp((33.0 - r) / 6.0, 0.0, 1.0));
    }
  cv::Mat a3, f, b;
  cv::Mat af;
  s.alpha.convertTo(af, CV_32F, 1.0 / 255);
  cv::merge(std::vector<cv::Mat>{af, af, af}, a3);
  s.fg.convertTo(f, CV_32FC3);
  s.bg.convertTo(b, CV_32FC3);
  cv::Mat img = f.mul(a3) + b.mul(cv::Scalar::all(1.0) - a3);
  img.convertTo(s.image, CV_8UC3);
  return s;
}

TEST(RealismMatting, TrimapFromAHardMask) {
  cv::Mat m(50, 50, CV_8U, cv::Scalar(0));
  cv::rectangle(m, cv::Rect(15, 15, 20, 20), cv::Scalar(255), cv::FILLED);
  const cv::Mat t = trimap_from_mask(m, 2);
  EXPECT_EQ(t.at<uint8_t>(25, 25), kTrimapForeground);
  EXPECT_EQ(t.at<uint8_t>(15, 25), kTrimapUnknown);  // on the edge
  EXPECT_EQ(t.at<uint8_t>(13, 25), kTrimapUnknown);  // 2 px outside
  EXPECT_EQ(t.at<uint8_t>(5, 5), kTrimapBackground);
}

TEST(RealismMatting, InformationFlowRecoversAKnownSoftEdge) {
  const Scene s = soft_disc();
  // Unknown: everything that is neither fully opaque nor fully transparent, plus 2 px either side.
  cv::Mat hard = s.alpha >= 128;
  cv::Mat tri(s.alpha.size(), CV_8U, cv::Scalar(kTrimapUnknown));
  cv::Mat fg_sure, bg_sure;
  cv::erode(s.alpha == 255, fg_sure, cv::Mat(), cv::Point(-1, -1), 2);
  cv::erode(s.alpha == 0, bg_sure, cv::Mat(), cv::Point(-1, -1), 2);
  tri.setTo(kTrimapForeground, fg_sure);
  tri.setTo(kTrimapBackground, bg_sure);
  const cv::Mat a = matte(s.image, tri);
  ASSERT_EQ(a.type(), CV_8U);
  cv::Mat err;
  cv::absdiff(a, s.alpha, err);
  const cv::Mat unknown = tri == kTrimapUnknown;
  const double mae = cv::mean(err, unknown)[0] / 255.0;
  // The hard mask (what grabCut gives) is ~0.2 off on a 6 px ramp; the matte must be much closer.
  cv::Mat herr;
  cv::absdiff(hard, s.alpha, herr);
  const double hard_mae = cv::mean(herr, unknown)[0] / 255.0;
  EXPECT_LT(mae, 0.08) << "hard mask error " << hard_mae;
  EXPECT_LT(mae, 0.5 * hard_mae);
  EXPECT_EQ(a.at<uint8_t>(50, 60), 255);  // definite pixels kept
  EXPECT_EQ(a.at<uint8_t>(2, 2), 0);
}

TEST(RealismMatting, DecontaminationRemovesTheOldBackgroundFromTheEdge) {
  const Scene s = soft_disc();
  const cv::Mat F = decontaminate(s.image, s.alpha, 4.0);
  const cv::Mat edge = (s.alpha > 64) & (s.alpha < 250);
  cv::Mat before, after;
  cv::absdiff(s.image, s.fg, before);
  cv::absdiff(F, s.fg, after);
  auto grey_mean = [&](const cv::Mat& d) {
    const cv::Scalar m = cv::mean(d, edge);
    return (m[0] + m[1] + m[2]) / 3;
  };
  EXPECT_LT(grey_mean(after), 12.0) << "raw edge colour error " << grey_mean(before);
  EXPECT_LT(grey_mean(after), 0.3 * grey_mean(before));
  // Opaque pixels keep their colour exactly.
  EXPECT_EQ(F.at<cv::Vec3b>(50, 60), s.image.at<cv::Vec3b>(50, 60));
}

TEST(RealismMatting, RefusesMismatchedOrOneSidedTrimaps) {
  const Scene s = soft_disc();
  EXPECT_THROW(matte(s.image, cv::Mat(10, 10, CV_8U, cv::Scalar(128))), Error);
  EXPECT_THROW(matte(s.image, cv::Mat(s.image.size(), CV_8U, cv::Scalar(kTrimapUnknown))), Error);
}

}  // namespace
}  // namespace hf::realism
