// The realism two-sample classifier test on synthetic crops: objects drawn from one distribution are not told
// apart (AUC near 0.5), flat untextured boxes pasted on the same backgrounds are (AUC near 1).
#include <gtest/gtest.h>

#include <opencv2/imgproc.hpp>

#include "hazardforge/realism/c2st.hpp"
#include "realism_fixtures.hpp"

namespace hf::realism {
namespace {

// A picture of 200x160 with one object in the middle: textured like its background (a "real" one), or a flat
// box of one colour with a hard edge (a toy insertion). `tint` >= 0 fixes the object's colour (one object seen
// many times), else each is drawn at random.
std::vector<float> object_features(cv::RNG& rng, bool flat, int tint = -1) {
  cv::Mat img = texture({200, 160}, static_cast<unsigned>(rng.next()), 25.0, 1.5);
  const int w = rng.uniform(50, 90), h = rng.uniform(40, 70);
  const cv::Rect box(100 - w / 2, 80 - h / 2, w, h);
  if (flat) {
    img(box).setTo(cv::Scalar(rng.uniform(60, 200), rng.uniform(60, 200), rng.uniform(60, 200)));
  } else {
    cv::Mat obj = texture(box.size(), static_cast<unsigned>(rng.next()), 25.0, 1.5);
    cv::RNG colour(tint >= 0 ? static_cast<uint64_t>(tint) + 1000 : rng.next());
    cv::Mat shade(box.size(), CV_8UC3,
                  cv::Scalar(colour.uniform(-60, 60), colour.uniform(-60, 60), colour.uniform(-60, 60)));
    cv::add(obj, shade, obj);
    obj.copyTo(img(box));
  }
  return crop_features(img, cv::Rect2f(box));
}

TEST(C2st, RocAucCountsPairsAndTies) {
  EXPECT_DOUBLE_EQ(roc_auc({0.1, 0.2, 0.8, 0.9}, {0, 0, 1, 1}), 1.0);
  EXPECT_DOUBLE_EQ(roc_auc({0.9, 0.8, 0.2, 0.1}, {0, 0, 1, 1}), 0.0);
  EXPECT_DOUBLE_EQ(roc_auc({0.5, 0.5, 0.5, 0.5}, {0, 1, 0, 1}), 0.5);
  EXPECT_DOUBLE_EQ(roc_auc({0.1, 0.6, 0.4, 0.9}, {0, 0, 1, 1}), 0.75);
}

TEST(C2st, ObjectsFromOneDistributionAreNotToldApart) {
  cv::RNG rng(11);
  std::vector<std::vector<float>> a, b;
  for (int i = 0; i < 60; ++i) a.push_back(object_features(rng, false));
  for (int i = 0; i < 60; ++i) b.push_back(object_features(rng, false));
  const C2stResult r = c2st(a, b);
  EXPECT_EQ(r.n_real, 60);
  EXPECT_EQ(r.folds, 5);
  EXPECT_LT(std::abs(r.auc - 0.5), 0.15) << r.auc;
  EXPECT_LE(r.ci_low, 0.5);
  EXPECT_GE(r.ci_high, 0.5);
}

TEST(C2st, FlatBoxesAreToldApartFromTexturedObjects) {
  cv::RNG rng(12);
  std::vector<std::vector<float>> real, toy;
  for (int i = 0; i < 40; ++i) real.push_back(object_features(rng, false));
  for (int i = 0; i < 40; ++i) toy.push_back(object_features(rng, true));
  const C2stResult r = c2st(real, toy);
  EXPECT_GT(r.auc, 0.9);
  EXPECT_GT(r.ci_low, 0.75);
}

// With object ids the folds hold out whole objects (as many folds as the smaller sample has objects, at most
// five); a sample of a single object can only be held out crop by crop, and the result says so.
TEST(C2st, FoldsHoldOutWholeObjectsWhenBothSamplesHaveSeveral) {
  cv::RNG rng(14);
  std::vector<std::vector<float>> a, b;
  std::vector<int64_t> ia, ib;
  for (int o = 0; o < 6; ++o)
    for (int k = 0; k < 10; ++k) {
      a.push_back(object_features(rng, false, o));
      ia.push_back(o);
    }
  for (int o = 0; o < 3; ++o)
    for (int k = 0; k < 10; ++k) {
      b.push_back(object_features(rng, true));
      ib.push_back(o);
    }
  const C2stResult grouped = c2st(a, b, 5, 1, 1000, 5, ia, ib);
  EXPECT_TRUE(grouped.grouped);
  EXPECT_EQ(grouped.folds, 3);
  EXPECT_GT(grouped.auc, 0.9);  // flat boxes stay flat boxes on objects the classifier never saw
  const C2stResult single = c2st(a, b, 5, 1, 1000, 5, ia, std::vector<int64_t>(b.size(), 0));
  EXPECT_FALSE(single.grouped);
  EXPECT_EQ(single.folds, 5);
}

TEST(C2st, TooFewCropsGiveNoAuc) {
  cv::RNG rng(13);
  std::vector<std::vector<float>> a, b;
  for (int i = 0; i < 10; ++i) a.push_back(object_features(rng, false));
  for (int i = 0; i < 3; ++i) b.push_back(object_features(rng, false));
  EXPECT_TRUE(std::isnan(c2st(a, b).auc));
  EXPECT_TRUE(crop_features(cv::Mat(100, 100, CV_8UC3, cv::Scalar::all(9)), cv::Rect2f(10, 10, 5, 5)).empty());
  EXPECT_EQ(object_features(rng, false).size(), crop_feature_names().size());
}

}  // namespace
}  // namespace hf::realism
