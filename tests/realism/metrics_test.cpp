// Realism metrics on synthetic composites whose halo, blur, noise, colour and size are known.
#include <gtest/gtest.h>

#include <cmath>
#include <vector>

#include <opencv2/imgproc.hpp>

#include "hazardforge/error.hpp"
#include "hazardforge/realism/compare.hpp"
#include "hazardforge/realism/metrics.hpp"
#include "realism_fixtures.hpp"

namespace hf::realism {
namespace {

// An ellipse-shaped object mask (0/255) over the whole picture.
cv::Mat ellipse_mask(cv::Size size, cv::Point c, cv::Size axes) {
  cv::Mat m(size, CV_8U, cv::Scalar(0));
  cv::ellipse(m, c, axes, 0, 0, 360, cv::Scalar(255), cv::FILLED);
  return m;
}

cv::Mat paste(const cv::Mat& bg, const cv::Mat& obj, const cv::Mat& mask) {
  cv::Mat out = bg.clone();
  obj.copyTo(out, mask);
  return out;
}

cv::Mat add_noise(const cv::Mat& bgr, double sigma, unsigned seed) {
  cv::Mat n(bgr.size(), CV_32FC3), f;
  cv::RNG rng(seed);
  rng.fill(n, cv::RNG::NORMAL, 0.0, sigma);
  bgr.convertTo(f, CV_32FC3);
  f += n;
  cv::Mat out;
  f.convertTo(out, CV_8UC3);
  return out;
}

AppearanceStats measure_all(const cv::Mat& img, const cv::Mat& mask, const CameraModel* cam = nullptr) {
  const cv::Rect b = cv::boundingRect(mask);
  return measure(img, mask(b), b.tl(), cv::Rect2f(b), "car", cam);
}

const cv::Size kSize(320, 240);
const cv::Point kCentre(160, 120);
const cv::Size kAxes(60, 40);

TEST(RealismMetrics, HaloOfAKnownFringeStandsOutOfTheBackgroundsTexture) {
  const cv::Mat bg = texture(kSize, 1, 6.0);
  const cv::Mat obj = texture(kSize, 2, 6.0) * 0.5;  // a darker textured object
  const cv::Mat mask = ellipse_mask(kSize, kCentre, kAxes);
  const cv::Mat clean = paste(bg, obj, mask);
  // A 2 px light fringe just outside the silhouette: the cut-out's old background.
  cv::Mat fringe = ellipse_mask(kSize, kCentre, kAxes + cv::Size(2, 2)) & ~mask;
  cv::Mat haloed = clean.clone();
  haloed.setTo(cv::Scalar(230, 230, 230), fringe);
  const AppearanceStats a = measure_all(clean, mask), b = measure_all(haloed, mask);
  ASSERT_TRUE(std::isfinite(a.halo));
  ASSERT_TRUE(std::isfinite(b.halo));
  EXPECT_LT(a.halo, 3.0);          // texture of contrast 6 grey levels: about 2 L* units at most
  EXPECT_GT(b.halo, a.halo + 15);  // the fringe is ~40 L* brighter than the background
  // The object is ~25 L* darker than the background: the edge contrast says so, with or without the fringe.
  EXPECT_NEAR(a.edge_contrast, 26.0, 6.0);
}

TEST(RealismMetrics, SharpnessFallsWithTheObjectsBlur) {
  const cv::Mat bg = texture(kSize, 3, 20.0, 1.0);
  const cv::Mat obj = texture(kSize, 4, 20.0, 1.0);
  const cv::Mat mask = ellipse_mask(kSize, kCentre, kAxes);
  cv::Mat blurred;
  cv::GaussianBlur(obj, blurred, cv::Size(), 2.0);
  const AppearanceStats same = measure_all(paste(bg, obj, mask), mask);
  const AppearanceStats soft = measure_all(paste(bg, blurred, mask), mask);
  EXPECT_NEAR(same.sharpness, 1.0, 0.3);  // same texture statistics inside and out
  EXPECT_LT(soft.sharpness, 0.1);
}

// The Laplacian is taken at the masked pixels only: the same variance as cv::Laplacian (3x3, reflected border)
// over the whole picture followed by cv::meanStdDev under the mask, for 8-bit, float and 16-bit pictures,
// masks that touch every border, a full (empty) mask and pictures one pixel wide or high.
TEST(RealismMetrics, LaplacianVarianceUnderAMaskIsTheWholePicturesLaplacianMasked) {
  cv::RNG rng(17);
  // 2101 x 5: rows longer than the 8-bit path's 2000-pixel chunks; its last case is a 0/255 checkerboard,
  // whose every Laplacian is +-1020 (the largest square sums a chunk can hold).
  const std::vector<cv::Size> sizes = {{97, 61}, {1, 40}, {40, 1}, {2101, 5}, {2101, 5}};
  for (size_t k = 0; k < sizes.size(); ++k) {
    const cv::Size size = sizes[k];
    cv::Mat g8(size, CV_8U);
    rng.fill(g8, cv::RNG::UNIFORM, 0, 256);
    if (k + 1 == sizes.size())
      for (int y = 0; y < size.height; ++y)
        for (int x = 0; x < size.width; ++x) g8.at<uint8_t>(y, x) = (x + y) % 2 ? 255 : 0;
    cv::Mat mask(size, CV_8U);
    rng.fill(mask, cv::RNG::UNIFORM, 0, 3);  // about a third of the pixels left out, runs of both
    mask = mask > 0;
    cv::Mat g16, g32;
    g8.convertTo(g16, CV_16U, 97);
    g8.convertTo(g32, CV_32F, 0.37, -5.0);
    for (const cv::Mat& g : {g8, g16, g32})
      for (const cv::Mat& m : {mask, cv::Mat()}) {
        cv::Mat g64, lap;
        g.convertTo(g64, CV_64F);
        cv::Laplacian(g64, lap, CV_64F, 1);
        cv::Scalar mean, sd;
        cv::meanStdDev(lap, mean, sd, m);
        const double want = sd[0] * sd[0];
        EXPECT_NEAR(laplacian_variance(g, m), want, 1e-5 * want)
            << size << " depth " << g.depth() << (m.empty() ? " whole picture" : " masked");
      }
  }
  // Fewer than 16 masked pixels: no estimate.
  cv::Mat g(20, 20, CV_8U, cv::Scalar(9)), few(20, 20, CV_8U, cv::Scalar(0));
  few(cv::Rect(0, 0, 3, 5)).setTo(255);
  EXPECT_TRUE(std::isnan(laplacian_variance(g, few)));
  EXPECT_THROW(laplacian_variance(g, cv::Mat(10, 10, CV_8U, cv::Scalar(255))), hf::Error);
}

TEST(RealismMetrics, BlurToMatchFindsAKnownBlurFromAnyStartingPoint) {
  const cv::Mat sharp = texture(kSize, 7, 20.0, 0.7);
  cv::Mat grey, soft;
  cv::cvtColor(sharp, grey, cv::COLOR_BGR2GRAY);
  const cv::Mat mask = ellipse_mask(kSize, kCentre, kAxes);
  const std::vector<double> sigmas = {0.5, 0.8, 1.1, 1.5, 2.0, 2.6};
  for (double known : {0.8, 1.5, 2.0}) {
    cv::GaussianBlur(grey, soft, cv::Size(), known);
    const double target = laplacian_variance(soft, mask);
    // The frame is as soft as the picture blurred by `known`: that sigma, whichever sigma the search starts
    // at.
    EXPECT_DOUBLE_EQ(blur_to_match(grey, mask, target), known);
    for (double hint : {0.0, 0.5, 1.1, 2.6, 9.0})
      EXPECT_DOUBLE_EQ(blur_to_match(grey, mask, target, hint), known);
  }
  // Already softer than the frame: never sharpened; softer than the largest sigma reaches: the largest.
  EXPECT_DOUBLE_EQ(blur_to_match(grey, mask, 10 * laplacian_variance(grey, mask), 1.5), 0.0);
  EXPECT_DOUBLE_EQ(blur_to_match(grey, mask, 1e-6, 0.5), sigmas.back());
}

TEST(RealismMetrics, NoiseEstimateRecoversAKnownSigmaAndItsRatio) {
  // A smooth ramp (the kernel cancels planar shading) with noise of sigma 4.
  cv::Mat ramp(kSize, CV_8U);
  for (int y = 0; y < ramp.rows; ++y)
    for (int x = 0; x < ramp.cols; ++x) ramp.at<uint8_t>(y, x) = static_cast<uint8_t>(60 + x / 3 + y / 4);
  cv::Mat bgr;
  cv::cvtColor(ramp, bgr, cv::COLOR_GRAY2BGR);
  const cv::Mat noisy = add_noise(bgr, 4.0, 5);
  // Independent noise of sigma 4 per channel is sigma 4 |(0.114, 0.587, 0.299)| in the grey picture.
  const double grey_sigma = 4.0 * std::sqrt(0.114 * 0.114 + 0.587 * 0.587 + 0.299 * 0.299);
  cv::Mat grey;
  cv::cvtColor(noisy, grey, cv::COLOR_BGR2GRAY);
  EXPECT_NEAR(noise_sigma(grey), grey_sigma, 0.1 * grey_sigma);
  cv::cvtColor(bgr, grey, cv::COLOR_BGR2GRAY);
  EXPECT_LT(noise_sigma(grey), 0.6);

  // A clean object pasted into a noisy frame has a small noise ratio; the same object with the frame's noise ~1.
  const cv::Mat mask = ellipse_mask(kSize, kCentre, kAxes);
  const cv::Mat flat(kSize, CV_8UC3, cv::Scalar(90, 100, 110));
  const AppearanceStats clean = measure_all(paste(noisy, flat, mask), mask);
  const AppearanceStats grained = measure_all(paste(noisy, add_noise(flat, 4.0, 6), mask), mask);
  EXPECT_LT(clean.noise_ratio, 0.3);
  EXPECT_NEAR(grained.noise_ratio, 1.0, 0.25);
  EXPECT_NEAR(grained.noise_sigma, grey_sigma, 0.15 * grey_sigma);
}

TEST(RealismMetrics, NoiseOverPooledPatchesIsTheFlattestHalfOfAllTheirPixels) {
  // Four strips of a noisy ramp read together give the whole picture's sigma; a textured strip among them is
  // left out with the less flat half of the pooled pixels, so it raises the estimate far less than it would
  // alone.
  cv::Mat ramp(kSize, CV_8U);
  for (int y = 0; y < ramp.rows; ++y)
    for (int x = 0; x < ramp.cols; ++x) ramp.at<uint8_t>(y, x) = static_cast<uint8_t>(60 + x / 3 + y / 4);
  cv::Mat bgr, grey;
  cv::cvtColor(ramp, bgr, cv::COLOR_GRAY2BGR);
  cv::cvtColor(add_noise(bgr, 4.0, 7), grey, cv::COLOR_BGR2GRAY);
  const double whole = noise_sigma(grey);
  const int w = 12;
  std::vector<cv::Mat> strips = {
      grey(cv::Rect(0, 0, grey.cols, w)), grey(cv::Rect(0, grey.rows - w, grey.cols, w)),
      grey(cv::Rect(0, w, w, grey.rows - 2 * w)), grey(cv::Rect(grey.cols - w, w, w, grey.rows - 2 * w))};
  EXPECT_NEAR(noise_sigma(strips), whole, 0.1 * whole);
  cv::Mat textured = strips[0].clone();
  cv::Mat tex(textured.size(), CV_8U);
  cv::RNG rng(9);
  rng.fill(tex, cv::RNG::UNIFORM, 0, 60);
  textured += tex;
  const double alone = noise_sigma(textured);
  strips[0] = textured;
  EXPECT_GT(alone, 2 * whole);
  EXPECT_LT(noise_sigma(strips), 0.5 * (whole + alone));
  EXPECT_TRUE(std::isnan(noise_sigma(std::vector<cv::Mat>{})));
  EXPECT_THROW(noise_sigma(std::vector<cv::Mat>{bgr}), hf::Error);
}

TEST(RealismMetrics, LabStatisticsFollowAKnownColourShift) {
  const cv::Mat bg = texture(kSize, 7, 10.0);
  const cv::Mat mask = ellipse_mask(kSize, kCentre, kAxes);
  const cv::Scalar colour(60, 90, 170);  // BGR, a reddish object
  const AppearanceStats a = measure_all(paste(bg, cv::Mat(kSize, CV_8UC3, colour), mask), mask);
  cv::Mat one(1, 1, CV_32FC3, colour / 255.0), lab;
  cv::cvtColor(one, lab, cv::COLOR_BGR2Lab);
  const cv::Vec3f want = lab.at<cv::Vec3f>(0, 0);
  for (int k = 0; k < 3; ++k) EXPECT_NEAR(a.lab_mean[k], want[k], 0.5) << "channel " << k;
  EXPECT_LT(a.lab_std[0], 0.5);
  // The same object 20 grey levels brighter: L* moves by what the conversion says, a* b* barely.
  const AppearanceStats b =
      measure_all(paste(bg, cv::Mat(kSize, CV_8UC3, colour + cv::Scalar::all(20)), mask), mask);
  cv::Mat one2(1, 1, CV_32FC3, (colour + cv::Scalar::all(20)) / 255.0), lab2;
  cv::cvtColor(one2, lab2, cv::COLOR_BGR2Lab);
  EXPECT_NEAR(b.lab_mean[0] - a.lab_mean[0], lab2.at<cv::Vec3f>(0, 0)[0] - want[0], 0.5);
  EXPECT_GT(b.lab_mean[0] - a.lab_mean[0], 5.0);
}

TEST(RealismMetrics, SizeAtTheRoadDistanceOfTheBoxBottom) {
  // Level camera 1.5 m above a flat road, f = 1266 px: a box whose bottom is 63.3 px below the horizon stands
  // 30 m from the camera; 63.3 px tall there is 1.5 m.
  const CameraModel cam = CameraModel::pinhole(1600, 900, 1266, 1266, 800, 450, 1.5, 0.0, 1.5);
  cv::Mat img(900, 1600, CV_8UC3, cv::Scalar(128, 128, 128));
  const cv::Rect2f box(780, 450.0f, 84.4f, 63.3f);
  cv::Mat mask(cv::Size(84, 63), CV_8U, cv::Scalar(255));
  const AppearanceStats s = measure(img, mask, cv::Point(780, 450), box, "car", &cam);
  EXPECT_NEAR(s.ground_depth_m, 30.0, 0.05);
  EXPECT_NEAR(s.height_m, 1.5, 0.01);
  EXPECT_NEAR(s.width_m, 2.0, 0.01);
  EXPECT_NEAR(s.aspect, 84.4 / 63.3, 1e-4);
  // A box touching the picture's bottom has no road point: no size.
  const AppearanceStats t = measure(img, mask, cv::Point(780, 837), cv::Rect2f(780, 837, 84, 63), "car", &cam);
  EXPECT_TRUE(std::isnan(t.height_m));
}

TEST(RealismMetrics, GrabCutSilhouetteOfARealObjectFromItsBox) {
  const cv::Mat bg = texture(kSize, 9, 8.0);
  const cv::Mat mask = ellipse_mask(kSize, kCentre, kAxes);
  const cv::Mat img = paste(bg, cv::Mat(kSize, CV_8UC3, cv::Scalar(40, 40, 160)), mask);
  cv::Rect crop;
  const cv::Mat m = object_mask(img, cv::Rect2f(cv::boundingRect(mask)), &crop);
  ASSERT_FALSE(m.empty());
  ASSERT_EQ(m.size(), crop.size());
  const cv::Mat truth = mask(crop);
  const double inter = cv::countNonZero(m & truth), uni = cv::countNonZero(m | truth);
  EXPECT_GT(inter / uni, 0.9);
  EXPECT_TRUE(object_mask(img, cv::Rect2f(10, 10, 4, 4), &crop).empty());  // too small
}

TEST(RealismCompare, InsertedMedianAgainstTheRealSpread) {
  std::vector<AppearanceStats> real, inserted;
  for (int i = 0; i < 10; ++i) {
    AppearanceStats s;
    s.label = "car";
    s.halo = i;         // 0..9: p10 0.9, p90 8.1
    s.sharpness = 1.0;  // all equal
    real.push_back(s);
  }
  for (double h : {20.0, 21.0, 22.0}) {
    AppearanceStats s;
    s.label = "car";
    s.halo = h;
    s.sharpness = 1.0;
    inserted.push_back(s);
  }
  const Json j = compare(inserted, real);
  EXPECT_EQ(j["halo"]["real"]["n"], 10);
  EXPECT_NEAR(j["halo"]["real"]["p10"].get<double>(), 0.9, 1e-9);
  EXPECT_NEAR(j["halo"]["real"]["p90"].get<double>(), 8.1, 1e-9);
  EXPECT_EQ(j["halo"]["inserted"]["median"], 21.0);
  EXPECT_EQ(j["halo"]["within"], false);
  EXPECT_EQ(j["halo"]["rank"], 1.0);
  EXPECT_EQ(j["sharpness"]["within"], true);
  EXPECT_EQ(j["sharpness"]["rank"], 0.5);
  EXPECT_TRUE(j["noise_ratio"]["within"].is_null());  // measured on neither side
  EXPECT_EQ(j["outside"], Json::array({"halo"}));
}

TEST(RealismCompare, ReferencesAreTheSameClassThenItsGroup) {
  std::vector<AppearanceStats> real(4);
  real[0].label = "car";
  real[1].label = "truck";
  real[2].label = "person";
  real[3].label = "bus";
  std::vector<std::string> used;
  EXPECT_EQ(references_for("car", real, 1, &used).size(), 1u);
  EXPECT_EQ(used, std::vector<std::string>{"car"});
  EXPECT_EQ(references_for("car", real, 3, &used).size(), 3u);
  EXPECT_EQ(used, (std::vector<std::string>{"car", "truck", "bus"}));
  EXPECT_EQ(references_for("person", real, 3, &used).size(), 1u);
}

}  // namespace
}  // namespace hf::realism
