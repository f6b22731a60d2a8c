// Appearances cut from the footage itself (hazardforge/assets/footage_harvest.hpp) on synthetic frames: a
// known object on a known textured background, so the silhouette, the view and the metric size have true
// values to meet.
#include <gtest/gtest.h>

#include <filesystem>

#include <opencv2/imgproc.hpp>

#include "ar_renderer.hpp"
#include "hazardforge/assets/box_geometry.hpp"
#include "hazardforge/assets/footage_harvest.hpp"
#include "render_fixtures.hpp"
#include "temp_dir.hpp"

namespace hf::render {
namespace {

namespace fs = std::filesystem;
using hf::test::test_camera;

constexpr double kCarH = 1.5, kCarW = 1.8;

double iou(const cv::Mat& a, const cv::Mat& b) {
  return cv::countNonZero(a & b) / std::max(1.0, static_cast<double>(cv::countNonZero(a | b)));
}

// Paints a car seen from behind whose rear face is `gap` m ahead of the camera and `lateral` m to the left: a
// body over the lower 60 % of the face's rectangle and a narrower cabin above, in `colour` with a texture as
// strong as the background's. Returns the painted silhouette (full-image mask).
cv::Mat paint_car_rear(cv::Mat& img, const CameraModel& cam, double gap, double lateral, cv::Scalar colour,
                       unsigned seed) {
  const double x = cam.t_ego_cam[0] + gap;
  const cv::Point2d bl = *cam.project_ego({x, lateral + kCarW / 2, 0.0});
  const cv::Point2d tr = *cam.project_ego({x, lateral - kCarW / 2, kCarH});
  const double w = tr.x - bl.x, h = bl.y - tr.y;
  cv::Mat mask(img.size(), CV_8U, cv::Scalar(0));
  const double body_top = bl.y - 0.6 * h;
  cv::rectangle(mask, cv::Point2d(bl.x, body_top), cv::Point2d(tr.x, bl.y), cv::Scalar(255), cv::FILLED);
  std::vector<cv::Point> cabin{cv::Point2d(bl.x + 0.05 * w, body_top), cv::Point2d(tr.x - 0.05 * w, body_top),
                               cv::Point2d(tr.x - 0.17 * w, tr.y), cv::Point2d(bl.x + 0.17 * w, tr.y)};
  cv::fillConvexPoly(mask, cabin, cv::Scalar(255));
  cv::Mat tex = hf::test::noise_texture(img.size(), seed, 40.0), tex3, car;
  cv::cvtColor(tex, tex3, cv::COLOR_GRAY2BGR);
  cv::Mat base(img.size(), CV_8UC3, colour);
  cv::addWeighted(base, 1.0, tex3, 0.6, -0.6 * 128, car);
  car.copyTo(img, mask);
  return mask;
}

cv::Rect2f bounds(const cv::Mat& mask) { return cv::Rect2f(cv::boundingRect(mask)); }

TEST(FootageHarvest, TheCutFromABoxAloneFindsAKnownCarsSilhouette) {
  const CameraModel cam = test_camera();
  cv::Mat img = hf::test::textured_image();
  const cv::Mat truth = paint_car_rear(img, cam, 12.0, 0.3, cv::Scalar(40, 40, 150), 3);
  const cv::Rect2f box = bounds(truth);
  const auto cut = cut_from_box(img, box, /*person=*/false, 4);
  ASSERT_TRUE(cut.has_value());
  cv::Mat full(img.size(), CV_8U, cv::Scalar(0));
  cut->mask.copyTo(full(cut->crop));
  // The cabin's corners are background inside the box: the cut must find them, not fill the box.
  cv::Mat box_mask(img.size(), CV_8U, cv::Scalar(0));
  cv::rectangle(box_mask, cv::Rect(box), cv::Scalar(255), cv::FILLED);
  EXPECT_GT(iou(full, truth), 0.9);
  EXPECT_GT(iou(full, truth), iou(box_mask, truth) + 0.03);
  EXPECT_GT(cut->box_iou, 0.9);
}

TEST(FootageHarvest, APersonsSilhouetteTooFromItsBox) {
  cv::Mat img = hf::test::textured_image({640, 480}, 9);
  cv::Mat truth(img.size(), CV_8U, cv::Scalar(0));
  cv::ellipse(truth, cv::Point(320, 170), cv::Size(14, 17), 0, 0, 360, cv::Scalar(255), cv::FILLED);  // head
  cv::rectangle(truth, cv::Rect(298, 186, 44, 90), cv::Scalar(255), cv::FILLED);                     // torso
  cv::rectangle(truth, cv::Rect(302, 276, 14, 84), cv::Scalar(255), cv::FILLED);                     // legs
  cv::rectangle(truth, cv::Rect(324, 276, 14, 84), cv::Scalar(255), cv::FILLED);
  img.setTo(cv::Scalar(160, 60, 30), truth);
  const auto cut = cut_from_box(img, bounds(truth), /*person=*/true, 4);
  ASSERT_TRUE(cut.has_value());
  cv::Mat full(img.size(), CV_8U, cv::Scalar(0));
  cut->mask.copyTo(full(cut->crop));
  EXPECT_GT(iou(full, truth), 0.85);
  // A person fills less of its box than a car: beside the head and between the legs is background.
  const double truth_fill = cv::countNonZero(truth) / static_cast<double>(cv::boundingRect(truth).area());
  EXPECT_NEAR(cut->fill, truth_fill, 0.08);
  EXPECT_LT(cut->fill, 0.9);
}

TEST(FootageHarvest, TheViewComesFromTheMotionAndWhatCannotBeToldIsSaid) {
  FootageHarvestOptions opt;
  FootageObject o;
  o.distance_m = 15.0;
  o.lateral_m = 3.5;
  o.speed_mps = 10.0;
  o.heading_rad = deg_to_rad(8.0);
  EXPECT_DOUBLE_EQ(*view_heading(o, false, opt).yaw, 0.0);  // along the road, the ego's way
  o.heading_rad = deg_to_rad(-172.0);
  EXPECT_NEAR(*view_heading(o, false, opt).yaw, kPi, 1e-9);  // oncoming
  o.heading_rad = deg_to_rad(90.0);
  EXPECT_NEAR(*view_heading(o, false, opt).yaw, deg_to_rad(90.0), 1e-9);  // crossing: kept as measured
  o.speed_mps = 0.2;
  const ViewHeading parked = view_heading(o, false, opt);
  EXPECT_FALSE(parked.yaw.has_value());
  EXPECT_NE(parked.why.find("which way it faces is unknown"), std::string::npos);
  o.lateral_m = 0.5;  // standing in the ego's lane: queued traffic
  EXPECT_DOUBLE_EQ(*view_heading(o, false, opt).yaw, 0.0);
  EXPECT_FALSE(view_heading(o, true, opt).yaw.has_value());  // a standing person: unknown
}

// A car driving ahead over eight frames, a blurred one beside it and one cut by the picture's border: only the
// first is kept, once its track is old enough and two of its cuts agree, as a rear view of its measured size.
TEST(FootageHarvest, KeepsAWholeSharpStableCarWithItsViewAndSize) {
  const CameraModel cam = test_camera();
  ClassPriors sizes;
  sizes.set("car", ClassSize{1.52, 1.85, 4.5});
  FootageHarvest harvest(FootageHarvestOptions{}, sizes);
  for (int i = 0; i < 8; ++i) {
    cv::Mat img = hf::test::textured_image({1600, 900}, 7);
    const double gap = 12.0 - 0.2 * i;
    const cv::Mat car = paint_car_rear(img, cam, gap, 0.3, cv::Scalar(40, 40, 150), 3);
    const cv::Mat blurred = paint_car_rear(img, cam, 14.0, 4.0, cv::Scalar(150, 60, 40), 4);
    const cv::Rect blur_box = cv::boundingRect(blurred);
    cv::GaussianBlur(img(blur_box), img(blur_box), cv::Size(), 5.0);
    const cv::Mat edge = paint_car_rear(img, cam, 10.0, -6.2, cv::Scalar(60, 140, 60), 5);
    auto object = [&](int64_t id, const cv::Mat& m, double g, double lat) {
      FootageObject o;
      o.track_id = id;
      o.label = "car";
      o.box = bounds(m);
      o.score = 0.9f;
      o.hits = i + 1;
      o.distance_m = cam.t_ego_cam[0] + g;
      o.lateral_m = lat;
      o.speed_mps = 9.0;
      o.heading_rad = 0.01;
      return o;
    };
    const Frame f = hf::test::make_frame(i, 0.1 * i, img, cam);
    harvest.offer(f, {object(1, car, gap, 0.3), object(2, blurred, 14.0, 4.0), object(3, edge, 10.0, -6.2)});
  }
  const std::vector<FootageCut> cuts = harvest.cuts();
  ASSERT_EQ(cuts.size(), 1u) << harvest.summary();
  const FootageCut& c = cuts[0];
  EXPECT_EQ(c.track_id, 1);
  EXPECT_EQ(c.spec.view, "rear");
  EXPECT_EQ(c.spec.source, "footage");
  EXPECT_EQ(c.spec.instance, "track 1");
  EXPECT_NEAR(c.spec.size_lwh[2], kCarH, 0.1 * kCarH);  // from the box's height and the range
  EXPECT_NEAR(c.spec.size_lwh[1], kCarW, 0.1 * kCarW);  // head-on: from its width too
  EXPECT_EQ(c.bgra.type(), CV_8UC4);
  EXPECT_NE(c.why.find("rear view"), std::string::npos) << c.why;
  const auto& r = harvest.rejections();
  EXPECT_GT(r.count("blurred") ? r.at("blurred") : 0, 0) << harvest.summary();
  EXPECT_GT(r.count("cut by the picture's border") ? r.at("cut by the picture's border") : 0, 0)
      << harvest.summary();
  EXPECT_GT(r.count("its track too young") ? r.at("its track too young") : 0, 0) << harvest.summary();

  // Written as an asset folder the library reads back, the box's corners framing the picture's object.
  const hf::test::TempDir tmp;
  const fs::path dir = tmp.path() / "appearances";
  ASSERT_EQ(harvest.save(dir), 1);
  const AssetIndex idx = load_asset_index(dir);
  ASSERT_EQ(idx.assets.size(), 1u);
  double x0 = 1e9, x1 = -1e9;
  for (const auto& p : idx.assets[0].box_corners_px) {
    x0 = std::min(x0, p.x);
    x1 = std::max(x1, p.x);
  }
  EXPECT_NEAR(x0, 1.0, 2.0);
  EXPECT_NEAR(x1, idx.assets[0].image_size.width - 1.0, 2.0);
}

// A track whose measured direction of travel flips between its cuts (velocity noise read as the car going the
// other way) gives no appearance: its view would be a guess.
TEST(FootageHarvest, ATrackWhoseDirectionFlipsIsNotKept) {
  const CameraModel cam = test_camera();
  FootageHarvest harvest(FootageHarvestOptions{}, ClassPriors{});
  for (int i = 0; i < 10; ++i) {
    cv::Mat img = hf::test::textured_image({1600, 900}, 7);
    const cv::Mat car = paint_car_rear(img, cam, 12.0, 3.0, cv::Scalar(40, 40, 150), 3);
    FootageObject o;
    o.track_id = 4;
    o.label = "car";
    o.box = bounds(car);
    o.score = 0.9f;
    o.hits = i + 1;
    o.distance_m = cam.t_ego_cam[0] + 12.0;
    o.lateral_m = 3.0;
    o.speed_mps = 5.0;
    o.heading_rad = (i / 2) % 2 == 0 ? 0.0 : kPi;  // cut every second frame: each cut the other way
    harvest.offer(hf::test::make_frame(i, 0.1 * i, img, cam), {o});
  }
  EXPECT_TRUE(harvest.cuts().empty()) << harvest.summary();
  EXPECT_GT(harvest.rejections().count("its direction of travel changed between two cuts"), 0u)
      << harvest.summary();
}

}  // namespace
}  // namespace hf::render
