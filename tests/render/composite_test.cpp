// Compositing: alpha is respected for default and harvested assets, nearer objects occlude, the shadow
// darkens the road, harmonisation moves colours towards the surroundings, and the stage's ports behave.
#include <gtest/gtest.h>

#include <algorithm>
#include <filesystem>
#include <vector>

#include <opencv2/imgcodecs.hpp>

#include "ar_renderer.hpp"
#include "hazardforge/assets/box_geometry.hpp"
#include "hazardforge/testing/stage_runner.hpp"
#include "render_fixtures.hpp"
#include "temp_dir.hpp"

namespace hf::render {
namespace {

namespace fs = std::filesystem;
using hf::test::make_frame;
using hf::test::static_object;
using hf::test::test_camera;

RendererOptions options(bool shadow = false) {
  RendererOptions o;
  o.composite.shadow = shadow;
  o.composite.exposure_s = 0;
  o.ego.mode = EgoMotionMode::kPoses;
  return o;
}

// A harvested-style asset folder: a real-looking picture (textured cuboid with a soft silhouette) with the
// box geometry a harvester writes, so the renderer sees exactly what `asset_harvester` produces.
// `lateral_m` places the car the picture was taken of to the side, so it shows a side too (`view` names it);
// the silhouette then fills the whole projected box.
fs::path make_harvested_folder(const fs::path& dir, double lateral_m = 0.0,
                               const std::string& view = "rear") {
  fs::create_directories(dir);
  const CameraModel cam = test_camera();
  // A car 10 m ahead seen from behind: project its box like the harvester does.
  const BoxCorners c = box_corners(13.0, lateral_m, 0.0, {4.5, 1.85, 1.52});
  const auto pb = project_box(cam, c, 0.5);
  const cv::Rect pic(static_cast<int>(pb->bounds.x) - 1, static_cast<int>(pb->bounds.y) - 1,
                     static_cast<int>(pb->bounds.width) + 3, static_cast<int>(pb->bounds.height) + 3);
  cv::Mat colour = hf::test::textured_image(pic.size(), 3);
  colour.forEach<cv::Vec3b>(
      [](cv::Vec3b& p, const int*) { p = cv::Vec3b(p[0] / 3, p[1] / 3, p[2]); });  // reddish
  cv::Mat alpha(pic.size(), CV_8U, cv::Scalar(0));
  std::vector<cv::Point> poly, hull;
  if (lateral_m == 0.0) {
    for (int k : {2, 3, 7, 6}) poly.emplace_back(cvRound(pb->px[k].x - pic.x), cvRound(pb->px[k].y - pic.y));
  } else {
    for (int k = 0; k < 8; ++k) poly.emplace_back(cvRound(pb->px[k].x - pic.x), cvRound(pb->px[k].y - pic.y));
  }
  cv::convexHull(poly, hull);
  cv::fillConvexPoly(alpha, hull, cv::Scalar(255));
  cv::GaussianBlur(alpha, alpha, cv::Size(), 0.7);
  std::vector<cv::Mat> ch;
  cv::split(colour, ch);
  ch.push_back(alpha);
  cv::Mat bgra;
  cv::merge(ch, bgra);
  AssetIndex idx;
  AssetSpec s;
  s.file = "car_" + view + "_test.png";
  s.object_class = "car";
  s.view = view;
  s.azimuth_deg = camera_azimuth_deg(cam.t_ego_cam, 13.0, lateral_m, 0.0);
  s.size_lwh = {4.5, 1.85, 1.52};
  s.image_size = pic.size();
  s.anchor_px = *cam.project_ego({13.0, 0, 0}) - cv::Point2d(pic.tl());
  for (int k = 0; k < 8; ++k) s.box_corners_px[k] = pb->px[k] - cv::Point2d(pic.tl());
  s.source = "harvested";
  s.instance = "test-instance";
  idx.assets.push_back(s);
  write_png_atomic(dir / s.file, bgra);
  save_asset_index(dir, idx, "test");
  return dir;
}

// Checks the alpha contract on one rendering: outside the ROI and where alpha is 0 nothing changed; where
// alpha is (nearly) 1 nearly everything changed.
void expect_alpha_respected(const cv::Mat& before, const HazardRenderer::Result& r) {
  ASSERT_TRUE(r.composite.drawn);
  const cv::Rect roi = r.composite.roi;
  cv::Mat diff;
  cv::absdiff(before, r.frame.image, diff);
  cv::Mat outside = diff.clone();
  outside(roi).setTo(cv::Scalar::all(0));
  EXPECT_EQ(cv::countNonZero(outside.reshape(1)), 0) << "pixels outside the ROI changed";
  int zero_alpha = 0, zero_changed = 0, opaque = 0, opaque_changed = 0;
  for (int y = 0; y < roi.height; ++y)
    for (int x = 0; x < roi.width; ++x) {
      const int a = r.composite.alpha.at<uint8_t>(y, x);
      const cv::Vec3b d = diff.at<cv::Vec3b>(y + roi.y, x + roi.x);
      const bool changed = d[0] || d[1] || d[2];
      if (a == 0) {
        ++zero_alpha;
        zero_changed += changed;
      } else if (a >= 253) {
        ++opaque;
        opaque_changed += changed;
      }
    }
  EXPECT_GT(zero_alpha, 100);
  EXPECT_EQ(zero_changed, 0) << "pixels with zero alpha changed";
  ASSERT_GT(opaque, 1000);
  EXPECT_GT(opaque_changed, 0.97 * opaque) << opaque_changed << " of " << opaque << " opaque pixels changed";
}

TEST(Composite, DefaultAssetsRespectAlpha) {
  const cv::Mat img = hf::test::textured_image();
  for (const char* cls : {"car", "person", "truck", "bus"}) {
    HazardRenderer r(options(),
                     std::make_shared<const AssetLibrary>(AssetLibrary::load(test::default_asset_dir())));
    auto traj = std::make_shared<const HazardTrajectory>(
        static_object(cls, 18.0, 1.0, 0.7, 0.0, 1.0, 0.0,
                      std::string(cls) == "person" ? cv::Vec3d(0.5, 0.6, 1.7) : cv::Vec3d(4.5, 1.85, 1.52)));
    auto res = r.render(make_frame(0, 0.0, img, test_camera(), cv::Matx44d::eye()), traj, {});
    SCOPED_TRACE(cls);
    EXPECT_NE(res.asset_file.find(test::default_asset_dir().string()), std::string::npos);
    expect_alpha_respected(img, res);
  }
}

TEST(Composite, HarvestedAssetsRespectAlphaAndOverrideDefaults) {
  const hf::test::TempDir tmp;
  const fs::path dir = make_harvested_folder(tmp / "assets");
  const cv::Mat img = hf::test::textured_image();
  auto lib = std::make_shared<const AssetLibrary>(AssetLibrary::load(dir, test::default_asset_dir()));
  HazardRenderer r(options(), lib);
  // A car driving away 14 m ahead: the harvested rear view is used (primary folder), not the default one.
  auto traj = std::make_shared<const HazardTrajectory>(
      static_object("car", 14.0, 0.3, 0.05, 0.0, 1.0, 0.0, cv::Vec3d(4.5, 1.85, 1.52)));
  auto res = r.render(make_frame(0, 0.0, img, test_camera(), cv::Matx44d::eye()), traj, {});
  EXPECT_EQ(fs::path(res.asset_file).filename(), "car_rear_test.png");
  expect_alpha_respected(img, res);
  // A class the folder lacks comes from the default set.
  HazardRenderer r2(options(), lib);
  auto person = std::make_shared<const HazardTrajectory>(
      static_object("person", 12.0, 0.0, 1.57, 0.0, 1.0, 0.0, cv::Vec3d(0.5, 0.6, 1.7)));
  auto res2 = r2.render(make_frame(0, 0.0, img, test_camera(), cv::Matx44d::eye()), person, {});
  EXPECT_NE(res2.asset_file.find(test::default_asset_dir().string()), std::string::npos);
  expect_alpha_respected(img, res2);
}

TEST(Composite, NearerBoxOccludesAndFartherBoxDoesNot) {
  const cv::Mat img = hf::test::textured_image();
  const CameraModel cam = test_camera();
  auto traj = std::make_shared<const HazardTrajectory>(
      static_object("car", 20.0, 0.0, 0.0, 0.0, 1.0, 0.0, cv::Vec3d(4.5, 1.85, 1.52)));
  // The hazard's box without occluders.
  HazardRenderer free_r(options(),
                        std::make_shared<const AssetLibrary>(AssetLibrary::load(test::default_asset_dir())));
  const auto free = free_r.render(make_frame(0, 0.0, img, cam, cv::Matx44d::eye()), traj, {});
  const cv::Rect2f hb = free.hazard.box;
  ASSERT_GT(hb.area(), 1000);
  EXPECT_NEAR(free.hazard.occluded_fraction, 0.0, 1e-9);
  // A detection covering the left half of the hazard, standing on the road 9 m ahead of the camera (its
  // bottom edge lower in the image than the hazard's).
  const double near_bottom = cam.project_ego({1.5 + 9.0, 0, 0})->y;
  const cv::Rect2f near_box(hb.x - 20, static_cast<float>(near_bottom) - 160, hb.width / 2 + 20, 160);
  HazardRenderer r(options(true),
                   std::make_shared<const AssetLibrary>(AssetLibrary::load(test::default_asset_dir())));
  const auto occ = r.render(make_frame(0, 0.0, img, cam, cv::Matx44d::eye()), traj,
                            {{near_box, 0.9f, std::nullopt, "car", 0, 0, -1, std::nullopt}});
  // Every pixel of the nearer object's box is untouched (the hazard and its shadow are behind it).
  const cv::Rect ib = cv::Rect(near_box) & cv::Rect(0, 0, img.cols, img.rows);
  cv::Mat d;
  cv::absdiff(img(ib), occ.frame.image(ib), d);
  EXPECT_EQ(cv::countNonZero(d.reshape(1)), 0);
  // Roughly the covered share of the hazard is reported occluded.
  const double covered = (cv::Rect2f(near_box) & hb).area() / hb.area();
  EXPECT_GT(occ.hazard.occluded_fraction, 0.5 * covered);
  EXPECT_LT(occ.hazard.occluded_fraction, 1.0);
  EXPECT_TRUE(occ.hazard.visible);
  // The same box standing farther away (bottom edge above the hazard's) is drawn over.
  const double far_bottom = cam.project_ego({1.5 + 40.0, 0, 0})->y;
  const cv::Rect2f far_box(hb.x - 20, static_cast<float>(far_bottom) - 160, hb.width / 2 + 20, 160);
  HazardRenderer r3(options(),
                    std::make_shared<const AssetLibrary>(AssetLibrary::load(test::default_asset_dir())));
  const auto behind = r3.render(make_frame(0, 0.0, img, cam, cv::Matx44d::eye()), traj,
                                {{far_box, 0.9f, std::nullopt, "car", 0, 0, -1, std::nullopt}});
  EXPECT_NEAR(behind.hazard.occluded_fraction, 0.0, 1e-9);
}

// A car half out of the picture: the share of its silhouette inside it is reported (measured against the same
// car drawn by a camera whose picture is 800 px wider on the left, which sees all of it), and the box of what
// is drawn ends at the border, inside the projected box.
TEST(Composite, TheShareOfTheSilhouetteInsideThePictureIsReported) {
  const auto lib = std::make_shared<const AssetLibrary>(AssetLibrary::load(test::default_asset_dir()));
  // 12.5 m ahead of the camera the picture's left edge is 800 / 1266 * 12.5 = 7.9 m to the left.
  auto traj = std::make_shared<const HazardTrajectory>(
      static_object("car", 14.0, 7.9, 0.0, 0.0, 1.0, 0.0, cv::Vec3d(4.5, 1.85, 1.52)));
  HazardRenderer cut_r(options(), lib);
  const auto cut = cut_r.render(
      make_frame(0, 0.0, hf::test::textured_image(), test_camera(), cv::Matx44d::eye()), traj, {});
  const CameraModel wide_cam = CameraModel::pinhole(2400, 900, 1266, 1266, 1600, 450, 1.5, 0.0, 1.5);
  HazardRenderer wide_r(options(), lib);
  const auto wide = wide_r.render(
      make_frame(0, 0.0, hf::test::textured_image({2400, 900}), wide_cam, cv::Matx44d::eye()), traj, {});
  ASSERT_TRUE(cut.hazard.visible);
  ASSERT_TRUE(wide.hazard.visible);
  // In the wide picture, columns from 800 on are the narrow picture's.
  const cv::Mat& a = wide.composite.alpha;
  const int split = std::clamp(800 - wide.composite.roi.x, 0, a.cols);
  const double whole = cv::sum(a)[0], inside = cv::sum(a.colRange(split, a.cols))[0];
  ASSERT_GT(whole, 0);
  const double share = inside / whole;
  ASSERT_GT(share, 0.2);  // the case is a partial one
  ASSERT_LT(share, 0.8);
  EXPECT_NEAR(cut.hazard.in_picture_fraction, share, 0.05);
  EXPECT_NEAR(wide.hazard.in_picture_fraction, 1.0, 0.03);
  EXPECT_NEAR(cut.hazard.visible_share(), cut.hazard.in_picture_fraction, 1e-12);  // nothing hides it
  // What is drawn: from the border, within the projected box (give or take the feathered edge's few pixels).
  const cv::Rect2f d = cut.hazard.drawn_box, b = cut.hazard.box;
  ASSERT_GT(d.area(), 0);
  const float edge = 0.03f * b.height;
  EXPECT_EQ(d.x, 0.f);
  EXPECT_GE(d.y, b.y - edge);
  EXPECT_LE(d.x + d.width, b.x + b.width + edge);
  EXPECT_LE(d.y + d.height, b.y + b.height + edge);
  EXPECT_GT(d.area(), 0.5 * b.area());
}

// A picture of a car seen a little from its left (rear and side), drawn straight ahead where the frame sees
// only the rear: the rear is mapped onto the rear face, and the side, which would land beside the box as a
// ghost, is not drawn (clip_to_box). Without the clip it is, so the check can fail; the whole silhouette's
// coverage counts only what is kept, so the car in the middle of the picture is wholly in it.
TEST(Composite, APictureShowingMoreFacesThanTheFrameIsKeptToTheObjectsBox) {
  const hf::test::TempDir tmp;
  const fs::path dir = make_harvested_folder(tmp / "assets", 5.0, "rear_left");
  const auto lib = std::make_shared<const AssetLibrary>(AssetLibrary::load(dir));
  auto traj = std::make_shared<const HazardTrajectory>(
      static_object("car", 14.0, 0.0, 0.0, 0.0, 1.0, 0.0, cv::Vec3d(4.5, 1.85, 1.52)));
  const cv::Mat img = hf::test::textured_image();
  auto beyond_box = [](const HazardRenderer::Result& res) {
    // Alpha sum more than the margin (and the edge's 2 px) outside the projected box, over the alpha sum.
    const cv::Rect2f b = res.hazard.box;
    const float m = static_cast<float>(kClipMargin * b.height) + 4.f;
    const cv::Rect2f grown(b.x - m, b.y - m, b.width + 2 * m, b.height + 2 * m);
    double out = 0, all = 0;
    const cv::Mat& a = res.composite.alpha;
    for (int y = 0; y < a.rows; ++y)
      for (int x = 0; x < a.cols; ++x) {
        const double v = a.at<uint8_t>(y, x);
        all += v;
        if (!grown.contains(cv::Point2f(static_cast<float>(x + res.composite.roi.x) + 0.5f,
                                        static_cast<float>(y + res.composite.roi.y) + 0.5f)))
          out += v;
      }
    return all > 0 ? out / all : 1.0;
  };
  RendererOptions o = options();
  HazardRenderer clipped_r(o, lib);
  const auto clipped = clipped_r.render(make_frame(0, 0.0, img, test_camera(), cv::Matx44d::eye()), traj, {});
  o.composite.clip_to_box = false;
  HazardRenderer free_r(o, lib);
  const auto free = free_r.render(make_frame(0, 0.0, img, test_camera(), cv::Matx44d::eye()), traj, {});
  ASSERT_TRUE(clipped.hazard.visible);
  ASSERT_TRUE(free.hazard.visible);
  ASSERT_EQ(fs::path(clipped.asset_file).filename(), "car_rear_left_test.png");
  EXPECT_GT(beyond_box(free), 0.15) << "the side lands beside the box without the clip";
  EXPECT_LT(beyond_box(clipped), 0.002);
  // The rear is still drawn: the kept silhouette fills most of the box.
  const cv::Rect2f d = clipped.hazard.drawn_box, b = clipped.hazard.box;
  EXPECT_GT((d & b).area(), 0.85 * b.area());
  EXPECT_NEAR(clipped.hazard.in_picture_fraction, 1.0, 0.03);
  EXPECT_NEAR(free.hazard.in_picture_fraction, 1.0, 0.03);
}

// A hazard that takes over a real object (HazardSpec::track_id): the real one leaves the picture — covered by
// the hazard drawn in its place, the rest of its box filled from the surroundings — it occludes nothing, and
// the share of its box left to the fill is reported.
TEST(Composite, ATakenOverObjectIsRemovedAndTheHazardDrawnInItsPlace) {
  const cv::Mat img = hf::test::textured_image();  // grey texture: no saturated blue anywhere
  const CameraModel cam = test_camera();
  HazardTrajectory plan = static_object("car", 20.0, 0.0, 0.0, 0.0, 1.0, 0.0, cv::Vec3d(4.5, 1.85, 1.52));
  auto plain = std::make_shared<const HazardTrajectory>(plan);
  plan.spec.track_id = 3;
  auto taking = std::make_shared<const HazardTrajectory>(plan);
  HazardRenderer probe(options(),
                       std::make_shared<const AssetLibrary>(AssetLibrary::load(test::default_asset_dir())));
  const cv::Rect2f hb = probe.render(make_frame(0, 0.0, img, cam, cv::Matx44d::eye()), plain, {}).hazard.box;
  ASSERT_GT(hb.area(), 1000);
  auto is_blue = [](const cv::Mat& m) {
    cv::Mat mask;
    cv::inRange(m, cv::Scalar(200, 0, 0), cv::Scalar(255, 60, 60), mask);
    return cv::countNonZero(mask);
  };
  auto run = [&](const std::shared_ptr<const HazardTrajectory>& t, const cv::Rect2f& real) {
    cv::Mat frame = img.clone();
    cv::rectangle(frame, cv::Rect(real), cv::Scalar(255, 0, 0),
                  cv::FILLED);  // the real object: saturated blue
    HazardRenderer r(options(),
                     std::make_shared<const AssetLibrary>(AssetLibrary::load(test::default_asset_dir())));
    // As an occluder it stands nearer (bottom edge lower than the hazard's): it would hide a plain hazard.
    return r.render(make_frame(0, 0.0, frame, cam, cv::Matx44d::eye()), t,
                    {{real, 0.9f, std::nullopt, "car", 0, 0, 3, std::nullopt}});
  };
  // The real object where the hazard is drawn, a little taller (its roof shows above the hazard's).
  const cv::Rect2f same(hb.x, hb.y - 12, hb.width, hb.height + 16);
  const auto took = run(taking, same);
  ASSERT_TRUE(took.hazard.taken_over.has_value());
  EXPECT_EQ(took.hazard.taken_over->track_id, 3);
  EXPECT_TRUE(took.hazard.taken_over->seen);
  EXPECT_TRUE(took.hazard.taken_over->box.contains(same.tl()));
  EXPECT_EQ(is_blue(took.frame.image), 0);                      // gone: drawn over or filled
  EXPECT_NEAR(took.hazard.occluded_fraction, 0.0, 1e-9);        // and it hides nothing
  EXPECT_GT(took.hazard.taken_over->uncovered_fraction, 0.05);  // the roof strip and the grown margin
  EXPECT_LT(took.hazard.taken_over->uncovered_fraction, 0.5);
  // A real object twice as wide as the hazard leaves most of its box to the fill.
  const cv::Rect2f wide(hb.x - hb.width / 2, hb.y - 12, 2 * hb.width, hb.height + 16);
  const auto wide_took = run(taking, wide);
  EXPECT_EQ(is_blue(wide_took.frame.image), 0);
  EXPECT_GT(wide_took.hazard.taken_over->uncovered_fraction, 0.5);
  // The hazard keeps to the real object's lane: measured 0.6 m to the left of the plan, it is drawn there.
  {
    cv::Mat frame = img.clone();
    HazardRenderer r(options(),
                     std::make_shared<const AssetLibrary>(AssetLibrary::load(test::default_asset_dir())));
    const auto left = r.render(make_frame(0, 0.0, frame, cam, cv::Matx44d::eye()), taking,
                               {{same, 0.9f, std::nullopt, "car", 0, 0, 3, 0.6}});
    ASSERT_TRUE(left.hazard.taken_over.has_value());
    EXPECT_NEAR(left.hazard.taken_over->lateral_shift_m, 0.6, 1e-9);
    EXPECT_NEAR(left.hazard.lateral_m, 0.6, 1e-9);
    EXPECT_LT(left.hazard.box.x, hb.x - 10);  // left in the image
  }
  // The real one is followed only while the hazard moves as the real one did: once the hazard has braked,
  // a drift of the real one's measured offset no longer moves it (the last correction is held).
  {
    HazardTrajectory brakes = plan;  // 2 m/s until 0.5 s, stopped from 1 s
    brakes.points = {{0.0, 20.0, 0.0, 0.0, 2.0, 0.0},
                     {0.5, 21.0, 0.0, 0.0, 2.0, 0.0},
                     {1.0, 21.5, 0.0, 0.0, 0.0, -4.0},
                     {3.0, 21.5, 0.0, 0.0, 0.0, 0.0}};
    auto braking = std::make_shared<const HazardTrajectory>(brakes);
    HazardRenderer r(options(),
                     std::make_shared<const AssetLibrary>(AssetLibrary::load(test::default_asset_dir())));
    auto at = [&](int index, double t, double real_lateral) {
      return r.render(make_frame(index, t, img.clone(), cam, cv::Matx44d::eye()), braking,
                      {{same, 0.9f, std::nullopt, "car", 0, 0, 3, real_lateral}});
    };
    EXPECT_NEAR(at(0, 0.0, 0.6).hazard.taken_over->lateral_shift_m, 0.6, 1e-9);
    const double moving = at(1, 0.25, 0.9).hazard.taken_over->lateral_shift_m;
    EXPECT_NEAR(moving, 0.7 * 0.6 + 0.3 * 0.9, 1e-9);  // still together: followed (smoothed)
    for (int k = 0; k < 10; ++k) {
      const auto stopped = at(2 + k, 1.2 + 0.1 * k, 1.5);
      ASSERT_TRUE(stopped.hazard.taken_over.has_value());
      EXPECT_NEAR(stopped.hazard.taken_over->lateral_shift_m, moving, 1e-9) << k;
      EXPECT_NEAR(stopped.hazard.lateral_m, moving, 1e-9) << k;
    }
  }
  // After the plan ends (it covers 0-1 s) the hazard stays where it stopped and the real object stays
  // removed; a plain hazard stays where it stopped too.
  {
    cv::Mat frame = img.clone();
    cv::rectangle(frame, cv::Rect(same), cv::Scalar(255, 0, 0), cv::FILLED);
    HazardRenderer r(options(),
                     std::make_shared<const AssetLibrary>(AssetLibrary::load(test::default_asset_dir())));
    r.render(make_frame(0, 0.0, frame, cam, cv::Matx44d::eye()), taking,
             {{same, 0.9f, std::nullopt, "car", 0, 0, 3, std::nullopt}});
    const auto later = r.render(make_frame(3, 2.0, frame, cam, cv::Matx44d::eye()), taking,
                                {{same, 0.9f, std::nullopt, "car", 0, 0, 3, std::nullopt}});
    EXPECT_TRUE(later.hazard.visible);
    EXPECT_TRUE(later.hazard.taken_over.has_value());
    EXPECT_EQ(is_blue(later.frame.image), 0);
    HazardRenderer r2(options(),
                      std::make_shared<const AssetLibrary>(AssetLibrary::load(test::default_asset_dir())));
    r2.render(make_frame(0, 0.0, frame, cam, cv::Matx44d::eye()), plain, {});
    const auto stays = r2.render(make_frame(3, 2.0, frame, cam, cv::Matx44d::eye()), plain, {});
    EXPECT_TRUE(stays.hazard.visible);
    EXPECT_NEAR(stays.hazard.box.x, hb.x, 1.0);
    EXPECT_FALSE(stays.hazard.taken_over.has_value());
  }
  // A track the renderer never sees is not removed, and it says so once.
  {
    HazardRenderer r(options(),
                     std::make_shared<const AssetLibrary>(AssetLibrary::load(test::default_asset_dir())));
    const auto alone = r.render(make_frame(0, 0.0, img, cam, cv::Matx44d::eye()), taking, {});
    EXPECT_FALSE(alone.hazard.taken_over.has_value());
    r.render(make_frame(1, 0.1, img, cam, cv::Matx44d::eye()), taking, {});
    EXPECT_EQ(
        r.take_warnings(),
        std::vector<std::string>{"the hazard takes over track 3, which is not among the renderer's tracked "
                                 "objects (its states or tracks input): the real object is not removed"});
  }
  // Without the takeover the real object stays, in front of the hazard it occludes.
  const auto kept = run(plain, same);
  EXPECT_FALSE(kept.hazard.taken_over.has_value());
  EXPECT_GT(is_blue(kept.frame.image), 0.9 * same.area());
  EXPECT_GT(kept.hazard.occluded_fraction, 0.9);
}

// Past its plan a hazard carries on as it ended (HazardTrajectory::continued_at) and is drawn there; once the
// ego has reached it, it is gone for good.
TEST(Composite, PastItsPlanTheHazardCarriesOnUntilTheEgoReachesIt) {
  const cv::Mat img = hf::test::textured_image();
  const CameraModel cam = test_camera();
  // A person walking to the left at 1.5 m/s, 15 m ahead, planned for 1 s.
  HazardTrajectory walk;
  walk.kind = "test";
  walk.object_class = "person";
  walk.size_lwh = {0.5, 0.6, 1.75};
  walk.anchor_time = 1.0;  // the frame of its last planned point
  walk.points = {{0.0, 15.0, -1.5, CV_PI / 2, 1.5, 0.0}, {1.0, 15.0, 0.0, CV_PI / 2, 1.5, 0.0}};
  auto traj = std::make_shared<const HazardTrajectory>(walk);
  const auto pose = [](double x) { return cv::Matx44d(1, 0, 0, x, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1); };
  HazardRenderer r(options(),
                   std::make_shared<const AssetLibrary>(AssetLibrary::load(test::default_asset_dir())));
  const auto end = r.render(make_frame(0, 1.0, img, cam, pose(0)), traj, {});
  ASSERT_TRUE(end.hazard.visible);
  // Half a second on: 0.75 m further left (further left in the picture), the ego 2 m nearer.
  const auto on = r.render(make_frame(1, 1.5, img, cam, pose(2)), traj, {});
  ASSERT_TRUE(on.hazard.visible);
  EXPECT_NEAR(on.hazard.lateral_m, 0.75, 1e-6);
  EXPECT_NEAR(on.hazard.distance_m, 13.0, 1e-6);
  EXPECT_LT(on.hazard.box.x + on.hazard.box.width / 2, end.hazard.box.x + end.hazard.box.width / 2);
  // The ego's front (3.4 m ahead of its origin) reaches the person's line: no longer drawn, and not again.
  EXPECT_FALSE(r.render(make_frame(2, 2.0, img, cam, pose(11.5)), traj, {}).hazard.visible);
  EXPECT_FALSE(r.render(make_frame(3, 2.1, img, cam, pose(5.0)), traj, {}).hazard.visible);
}

TEST(Composite, ContactShadowDarkensTheRoadBesideTheObject) {
  const cv::Mat img(900, 1600, CV_8UC3, cv::Scalar(120, 120, 120));
  auto traj = std::make_shared<const HazardTrajectory>(
      static_object("car", 12.0, 0.0, 0.0, 0.0, 1.0, 0.0, cv::Vec3d(4.5, 1.85, 1.52)));
  HazardRenderer r(options(true),
                   std::make_shared<const AssetLibrary>(AssetLibrary::load(test::default_asset_dir())));
  const auto res = r.render(make_frame(0, 0.0, img, test_camera(), cv::Matx44d::eye()), traj, {});
  // Just below the rear bumper's ground line, outside the object, the road is darker than before.
  const cv::Point2d below = *test_camera().project_ego({12.0 - 2.25 - 0.05, 0.0, 0.0});
  const int y = static_cast<int>(below.y) + 2, x = static_cast<int>(below.x);
  ASSERT_LT(res.composite.alpha.at<uint8_t>(y - res.composite.roi.y, x - res.composite.roi.x), 3);
  EXPECT_LT(res.frame.image.at<cv::Vec3b>(y, x)[1], 110);
}

TEST(Composite, HarmonisationMovesLightnessTowardsTheSurroundings) {
  // The same car on a dark and on a bright background: with harmonisation its pixels follow the scene.
  auto mean_inside = [](double grey, double luma) {
    RendererOptions o = options();
    o.composite.harmonize_luma = luma;
    o.composite.feather_px = 0;
    HazardRenderer r(o, std::make_shared<const AssetLibrary>(AssetLibrary::load(test::default_asset_dir())));
    const cv::Mat img(900, 1600, CV_8UC3, cv::Scalar(grey, grey, grey));
    auto traj = std::make_shared<const HazardTrajectory>(
        static_object("car", 15.0, 0.0, 0.0, 0.0, 1.0, 0.0, cv::Vec3d(4.5, 1.85, 1.52)));
    const auto res = r.render(make_frame(0, 0.0, img, test_camera(), cv::Matx44d::eye()), traj, {});
    cv::Mat gray;
    cv::cvtColor(res.frame.image(res.composite.roi), gray, cv::COLOR_BGR2GRAY);
    return cv::mean(gray, res.composite.alpha >= 253)[0];
  };
  const double dark0 = mean_inside(30, 0.0), bright0 = mean_inside(220, 0.0);
  EXPECT_NEAR(dark0, bright0, 0.5);  // without harmonisation the object ignores the scene
  const double dark = mean_inside(30, 0.6), bright = mean_inside(220, 0.6);
  EXPECT_LT(dark, dark0 - 5);
  EXPECT_GT(bright, bright0 + 5);
}

TEST(Composite, OnAGrayscaleCameraThePictureIsGreyOnAColourCameraItKeepsItsColour) {
  // The default car (coloured lamps and body) drawn into the same texture seen by a grayscale camera and by a
  // colour one (the texture plus coloured patches). Chroma of a pixel: max(B, G, R) - min(B, G, R).
  auto drawn_chroma = [](const cv::Mat& img) {
    RendererOptions o = options();
    o.composite.feather_px = 0;
    o.composite.grain = false;
    HazardRenderer r(o, std::make_shared<const AssetLibrary>(AssetLibrary::load(test::default_asset_dir())));
    auto traj = std::make_shared<const HazardTrajectory>(
        static_object("car", 12.0, 0.0, 0.0, 0.0, 1.0, 0.0, cv::Vec3d(4.5, 1.85, 1.52)));
    const auto res = r.render(make_frame(0, 0.0, img, test_camera(), cv::Matx44d::eye()), traj, {});
    EXPECT_TRUE(res.composite.drawn);
    std::vector<int> chroma;
    const cv::Mat roi = res.frame.image(res.composite.roi);
    for (int y = 0; y < roi.rows; ++y)
      for (int x = 0; x < roi.cols; ++x)
        if (res.composite.alpha.at<uint8_t>(y, x) >= 253) {
          const auto& p = roi.at<cv::Vec3b>(y, x);
          chroma.push_back(std::max({p[0], p[1], p[2]}) - std::min({p[0], p[1], p[2]}));
        }
    EXPECT_GT(chroma.size(), 1000u);
    std::sort(chroma.begin(), chroma.end());
    return chroma.empty() ? -1 : chroma[chroma.size() * 99 / 100];
  };
  const cv::Mat grey = hf::test::textured_image();
  cv::Mat colour = grey.clone(), patches(9, 16, CV_8UC3);
  cv::randu(patches, cv::Scalar::all(0), cv::Scalar::all(255));
  cv::resize(patches, patches, grey.size(), 0, 0, cv::INTER_NEAREST);
  cv::addWeighted(grey, 0.6, patches, 0.4, 0.0, colour);
  const int on_grey = drawn_chroma(grey), on_colour = drawn_chroma(colour);
  EXPECT_LE(on_grey, 2) << "a grayscale camera shows no colour";
  EXPECT_GE(on_colour, 20) << "a colour camera keeps the picture's colours";
}

TEST(ArRendererStage, PassesFramesThroughUntilTheHazardStartsAndEmitsOneInstancePerFrame) {
  auto runner = hf::testing::StageRunner::create<ArRenderer>("ego_motion: poses\nshadow: false");
  const cv::Mat img = hf::test::textured_image();
  for (int k = 0; k < 6; ++k) {
    Frame f = make_frame(k, k * 0.1, img, test_camera(), planar_pose(k * 1.0, 0, 0));
    f.meta = Json{{"k", k}};
    runner.push("frames", f, f.timestamp);
  }
  // The plan arrives with frame 1 and starts at t = 0.3 s; the sticky port keeps it for later frames.
  runner.push("trajectory", static_object("car", 25.0, 0.0, 0.0, 0.3, 2.0, 0.1, cv::Vec3d(4.5, 1.85, 1.52)),
              0.1);
  runner.run();
  const auto frames = runner.collect<Frame>("frames");
  const auto hazards = runner.collect<HazardInstance>("hazard");
  ASSERT_EQ(frames.size(), 6u);
  ASSERT_EQ(hazards.size(), 6u);
  for (int k = 0; k < 6; ++k) {
    EXPECT_EQ(frames[k].index, k);
    EXPECT_DOUBLE_EQ(frames[k].timestamp, k * 0.1);
    EXPECT_EQ(frames[k].meta["k"], k);
    EXPECT_EQ(hazards[k].frame_index, k);
    if (k < 3) {
      EXPECT_EQ(frames[k].image.data, img.data) << "frame " << k << " should pass through";
      EXPECT_FALSE(hazards[k].visible);
    } else {
      EXPECT_TRUE(hazards[k].visible) << "frame " << k;
      // Anchored at t = 0.1 (ego at x = 1): 25 m ahead there, so 25 - (k - 1) m ahead now.
      EXPECT_NEAR(hazards[k].distance_m, 25.0 - (k - 1), 1e-9);
    }
  }
}

TEST(ArRendererStage, VisibleFramesAndAppearancesOnlyWhereTheHazardIsDrawn) {
  auto runner = hf::testing::StageRunner::create<ArRenderer>("ego_motion: poses");
  const cv::Mat img = hf::test::textured_image();
  for (int k = 0; k < 5; ++k) {
    Frame f = make_frame(k, k * 0.1, img, test_camera(), planar_pose(k * 1.0, 0, 0));
    runner.push("frames", f, f.timestamp);
    // A real car in every frame (painted nowhere: a flat-textured box), measured as a reference on frames 0
    // and 3.
    Detections d;
    d.frame_index = k;
    d.items.push_back(Detection{cv::Rect2f(1200, 480, 160, 120), 2, "car", 0.9f});
    runner.push("detections", d, f.timestamp);
  }
  runner.push("trajectory", static_object("car", 25.0, 0.0, 0.0, 0.25, 2.0, 0.0, cv::Vec3d(4.5, 1.85, 1.52)),
              0.0);
  runner.run();
  const auto hazards = runner.collect<HazardInstance>("hazard");
  const auto visible = runner.collect<Frame>("visible_frames");
  ASSERT_EQ(hazards.size(), 5u);
  std::vector<int64_t> shown;
  for (const auto& f : visible) shown.push_back(f.index);
  EXPECT_EQ(shown, (std::vector<int64_t>{3, 4}));
  for (int k = 0; k < 5; ++k) {
    EXPECT_EQ(hazards[k].appearance.has_value(), hazards[k].visible) << "frame " << k;
    if (hazards[k].appearance) {
      EXPECT_EQ(hazards[k].appearance->label, "car");
      EXPECT_TRUE(std::isfinite(hazards[k].appearance->edge_contrast));
      EXPECT_TRUE(std::isfinite(hazards[k].appearance->sharpness));
      EXPECT_TRUE(std::isfinite(hazards[k].appearance->height_m));
    }
  }
}

// Occluders come from every input, once: the states' objects carry distances, and a tracked or detected
// object that no state stands for (the estimator measures no distance to a car cut by the picture's left and
// bottom edges) still counts.
TEST(ArRendererOccluders, StatesFirstThenWhatNoStateStandsFor) {
  ObjectStates s;
  s.distance_origin_x = 1.5;
  ObjectState a;
  a.track_id = 4;
  a.box = cv::Rect2f(600, 400, 100, 80);
  a.distance_m = 20.0;
  s.objects.push_back(a);
  Tracks t;
  Track same;  // the state's own track
  same.id = 4;
  same.box = cv::Rect2f(900, 400, 100, 80);
  Track cut;  // no state: cut by the left and bottom edges
  cut.id = 7;
  cut.box = cv::Rect2f(0, 500, 400, 400);
  cut.truncated = truncation::kLeft | truncation::kBottom;
  t.items = {same, cut};
  Detections d;
  d.items.push_back(Detection{cv::Rect2f(602, 401, 100, 80), 2, "car", 0.9f});  // the state's object again
  d.items.push_back(Detection{cv::Rect2f(2, 502, 398, 398), 2, "car", 0.9f});   // the cut track again
  d.items.push_back(Detection{cv::Rect2f(1300, 450, 60, 120), 0, "person", 0.8f});  // only detected
  const auto occ = merge_occluders(&s, &t, &d);
  ASSERT_EQ(occ.size(), 3u);
  EXPECT_EQ(occ[0].track_id, 4);
  ASSERT_TRUE(occ[0].distance_m);
  EXPECT_DOUBLE_EQ(*occ[0].distance_m, 21.5);  // from the rear axle: the states' origin added
  EXPECT_EQ(occ[1].track_id, 7);
  EXPECT_EQ(occ[1].truncated, truncation::kLeft | truncation::kBottom);
  EXPECT_FALSE(occ[1].distance_m);
  EXPECT_EQ(occ[2].track_id, -1);
  EXPECT_EQ(occ[2].label, "person");
  EXPECT_TRUE(merge_occluders(nullptr, nullptr, nullptr).empty());
}

// The stage: a car beside the ego, cut by the bottom edge and known only to the detector, hides the hazard
// behind it although the states (which have no distance for it) leave it out.
TEST(ArRendererStage, ADetectedObjectWithoutAStateStillHidesTheHazardBehindIt) {
  const cv::Mat img = hf::test::textured_image();
  const CameraModel cam = test_camera();
  auto run = [&](bool with_detection) {
    auto runner = hf::testing::StageRunner::create<ArRenderer>("ego_motion: poses\nshadow: false");
    Frame f = make_frame(0, 0.0, img, cam, cv::Matx44d::eye());
    runner.push("frames", f, 0.0);
    ObjectStates s;
    s.frame_index = 0;
    runner.push("states", s, 0.0);
    Detections d;
    d.frame_index = 0;
    if (with_detection) {
      // Reaches the picture's bottom edge: it stands on the road nearer than the hazard, whatever its size.
      Detection near{cv::Rect2f(0, 350, 800, 550), 2, "car", 0.9f};
      near.truncated = truncation::kLeft | truncation::kBottom;
      d.items.push_back(near);
    }
    runner.push("detections", d, 0.0);
    runner.push("trajectory",
                static_object("person", 12.0, 1.0, -1.5708, 0.0, 2.0, 0.0, cv::Vec3d(0.5, 0.6, 1.75)), 0.0);
    runner.run();
    const auto hazards = runner.collect<HazardInstance>("hazard");
    EXPECT_EQ(hazards.size(), 1u);
    return hazards.empty() ? HazardInstance{} : hazards.front();
  };
  const HazardInstance free = run(false), hidden = run(true);
  ASSERT_TRUE(free.visible);
  EXPECT_NEAR(free.occluded_fraction, 0.0, 1e-9);
  ASSERT_LT(free.box.x + free.box.width, 800.f) << "the hazard must stand behind the detected box";
  EXPECT_GT(hidden.occluded_fraction, 0.5);
}

TEST(Composite, PictureIsBlurredToTheFramesOwnSharpness) {
  // A defocused frame (Gaussian sigma 2.5): with match_sharpness the inserted car is no sharper than its
  // surroundings; without it, it is much sharper.
  cv::Mat img;
  cv::GaussianBlur(hf::test::textured_image(), img, cv::Size(), 2.5);
  auto traj = std::make_shared<const HazardTrajectory>(
      static_object("car", 12.0, 0.0, 0.3, 0.0, 1.0, 0.0, cv::Vec3d(4.5, 1.85, 1.52)));
  auto ratio = [&](double match) {
    RendererOptions o;
    o.ego.mode = EgoMotionMode::kPoses;
    o.composite.match_sharpness = match;
    o.composite.grain = false;
    o.composite.shadow = false;
    HazardRenderer r(o, std::make_shared<const AssetLibrary>(AssetLibrary::load(test::default_asset_dir())));
    const auto res = r.render(make_frame(0, 0.0, img, test_camera(), cv::Matx44d::eye()), traj, {});
    EXPECT_TRUE(res.hazard.appearance.has_value());
    return res.hazard.appearance ? res.hazard.appearance->sharpness : kNaN;
  };
  const double sharp = ratio(0.0), matched = ratio(1.0);
  EXPECT_GT(sharp, 2.0);
  EXPECT_LT(matched, 1.5) << "unmatched " << sharp;
  EXPECT_LT(matched, 0.6 * sharp);
}

// The final blend equals background x (1 - alpha)(1 - shadow) + colour + grain x alpha to within one grey
// level (the two divisions by 255 round separately), and a pixel gets the same value wherever it lies in the
// row: in the part done 16 pixels at a time or in the rest done one by one.
TEST(Composite, BlendRowIsTheAlphaShadowAndGrainFormulaOnEveryPixel) {
  cv::RNG rng(29);
  const int n = 16 * 3 + 7;
  std::vector<uint8_t> bg(3 * n), colour(4 * n), shadow(n);
  std::vector<int16_t> grain(n);
  for (int x = 0; x < n; ++x) {
    // Transparent, opaque and partial alpha; shadows on some; grain up to +-20 grey levels (1/64 units).
    const int kind = x % 5;
    const int a = kind == 0 ? 0 : kind == 1 ? 255 : rng.uniform(1, 255);
    for (int c = 0; c < 3; ++c) {
      bg[3 * x + c] = static_cast<uint8_t>(rng.uniform(0, 256));
      colour[4 * x + c] = static_cast<uint8_t>(rng.uniform(0, a + 1));  // premultiplied: at most alpha
    }
    colour[4 * x + 3] = static_cast<uint8_t>(a);
    shadow[x] = static_cast<uint8_t>(x % 3 == 0 ? rng.uniform(0, 256) : 0);
    grain[x] = static_cast<int16_t>(rng.uniform(-20 * 64, 20 * 64 + 1));
  }
  for (const bool with_shadow : {false, true}) {
    std::vector<uint8_t> out = bg;
    blend_row(out.data(), colour.data(), with_shadow ? shadow.data() : nullptr, grain.data(), n);
    for (int x = 0; x < n; ++x) {
      const double a = colour[4 * x + 3] / 255.0, sh = with_shadow ? shadow[x] / 255.0 : 0.0;
      for (int c = 0; c < 3; ++c) {
        const double want = std::clamp(bg[3 * x + c] * (1 - a) * (1 - sh) + colour[4 * x + c] +
                                           (a > 0 ? grain[x] / 64.0 * colour[4 * x + 3] / 256.0 : 0.0),
                                       0.0, 255.0);
        EXPECT_NEAR(out[3 * x + c], want, 1.0)
            << "pixel " << x << " channel " << c << " shadow " << with_shadow;
      }
      // Untouched where there is neither picture nor shadow.
      if (colour[4 * x + 3] == 0 && (!with_shadow || shadow[x] == 0)) {
        for (int c = 0; c < 3; ++c) EXPECT_EQ(out[3 * x + c], bg[3 * x + c]);
      }
    }
    // Each pixel alone, as the last of a row of one (the one-by-one path): the same bytes.
    for (int x = 0; x < n; ++x) {
      uint8_t one[3] = {bg[3 * x], bg[3 * x + 1], bg[3 * x + 2]};
      blend_row(one, &colour[4 * x], with_shadow ? &shadow[x] : nullptr, &grain[x], 1);
      for (int c = 0; c < 3; ++c) EXPECT_EQ(one[c], out[3 * x + c]) << "pixel " << x;
    }
  }
}

// The motion blur, in place, equals the mean of the picture's 2^k copies shifted by every sum of the passes'
// shifts (1, 2, 4 px along the motion, rounded), zero where a copy comes from outside — in every direction,
// so the rows and columns are visited in an order that never reads a pixel already averaged.
TEST(Composite, MotionBlurIsTheMeanOfShiftedCopiesInEveryDirection) {
  cv::Mat pic(40, 50, CV_8UC4);
  cv::RNG rng(5);
  rng.fill(pic, cv::RNG::UNIFORM, 0, 256);
  for (const cv::Point2d blur :
       {cv::Point2d(8, 0), cv::Point2d(-8, 0), cv::Point2d(0, 8), cv::Point2d(0, -8), cv::Point2d(6, 6),
        cv::Point2d(-5.7, 5.7), cv::Point2d(3, -7.4), cv::Point2d(-2, -3)}) {
    cv::Mat out = pic.clone();
    std::vector<uint8_t> row;
    const int k = motion_blur(out, blur, row);
    EXPECT_EQ(k, static_cast<int>(std::lround(std::log2(cv::norm(blur))))) << blur;
    std::vector<cv::Point> step;
    for (int i = 0; i < k; ++i) {
      const cv::Point2d d = blur / cv::norm(blur) * std::ldexp(1.0, i);
      step.emplace_back(static_cast<int>(std::lround(d.x)), static_cast<int>(std::lround(d.y)));
    }
    cv::Mat ref(pic.size(), CV_64FC4, cv::Scalar::all(0));
    for (int subset = 0; subset < (1 << k); ++subset) {
      cv::Point s(0, 0);
      for (int i = 0; i < k; ++i)
        if (subset & (1 << i)) s += step[static_cast<size_t>(i)];
      for (int y = 0; y < pic.rows; ++y)
        for (int x = 0; x < pic.cols; ++x) {
          const cv::Point from(x - s.x, y - s.y);
          if (from.inside(cv::Rect(0, 0, pic.cols, pic.rows)))
            ref.at<cv::Vec4d>(y, x) += cv::Vec4d(pic.at<cv::Vec4b>(from));
        }
    }
    ref /= static_cast<double>(1 << k);
    cv::Mat got, diff;
    out.convertTo(got, CV_64FC4);
    cv::absdiff(got, ref, diff);
    double worst = 0;
    cv::minMaxLoc(diff.reshape(1), nullptr, &worst);
    EXPECT_LE(worst, k) << "blur " << blur << ": each pass rounds up by at most half a grey level";
  }
  // Below 1.5 px nothing happens.
  cv::Mat out = pic.clone();
  std::vector<uint8_t> row;
  EXPECT_EQ(motion_blur(out, {1.2, 0.5}, row), 0);
  EXPECT_EQ(cv::norm(out, pic, cv::NORM_INF), 0.0);
}

// A smooth road-grey 1600x900 frame with Gaussian sensor noise of `sigma` per channel.
cv::Mat noisy_road_frame(double sigma, uint64_t seed) {
  cv::Mat base(900, 1600, CV_8UC3), noise(900, 1600, CV_32FC3), img;
  for (int y = 0; y < base.rows; ++y) base.row(y).setTo(cv::Scalar::all(90 + y / 20));
  cv::RNG rng(seed);
  rng.fill(noise, cv::RNG::NORMAL, 0.0, std::max(sigma, 1e-9));
  base.convertTo(img, CV_32FC3);
  img += noise;
  img.convertTo(img, CV_8UC3);
  return img;
}

// A renderer with grain and without shadows, over the default pictures; the default car standing x m ahead.
HazardRenderer grain_renderer() {
  RendererOptions o;
  o.ego.mode = EgoMotionMode::kPoses;
  o.composite.shadow = false;
  return HazardRenderer(o,
                        std::make_shared<const AssetLibrary>(AssetLibrary::load(test::default_asset_dir())));
}
std::shared_ptr<const HazardTrajectory> car_standing_at(double x) {
  return std::make_shared<const HazardTrajectory>(
      static_object("car", x, 0.0, 0.3, 0.0, 1.0, 0.0, cv::Vec3d(4.5, 1.85, 1.52)));
}

TEST(Composite, GrainMatchesTheFramesNoiseAsTheRealismMetricMeasuresIt) {
  // A smooth road-grey frame with sensor noise (Gaussian, per channel, then JPEG): the inserted default car,
  // rendered clean, gets grain until its interior is as noisy as its surroundings by the metric's own
  // estimate (hazardforge/realism noise_ratio ~ 1), and none when the frame has none.
  for (double sigma : {0.0, 2.0, 5.0}) {
    cv::Mat img = noisy_road_frame(sigma, 17);
    // Through JPEG, as recordings come: compression removes part of the noise and leaves the rest correlated.
    std::vector<uint8_t> jpg;
    cv::imencode(".jpg", img, jpg, {cv::IMWRITE_JPEG_QUALITY, 85});
    img = cv::imdecode(jpg, cv::IMREAD_COLOR);
    HazardRenderer r = grain_renderer();
    const auto res =
        r.render(make_frame(0, 0.0, img, test_camera(), cv::Matx44d::eye()), car_standing_at(12.0), {});
    ASSERT_TRUE(res.hazard.appearance.has_value());
    const AppearanceStats& a = *res.hazard.appearance;
    if (sigma > 0) {
      EXPECT_NEAR(a.noise_ratio, 1.0, 0.3) << "frame noise sigma " << sigma << ", object " << a.noise_sigma;
    } else {
      EXPECT_LT(a.noise_sigma, 0.5);
    }
  }
}

TEST(Composite, GrainMatchesTheFramesNoiseWhenTheObjectReachesPastThePicturesBottom) {
  // A car 5 m ahead whose bottom lies below the picture: the noise is read beside it, not under it, so it
  // still gets grain from its first frame on (read under it, there was no road to read and it stayed clean).
  const cv::Mat img = noisy_road_frame(3.0, 23);
  const auto traj = car_standing_at(5.0);
  HazardRenderer r = grain_renderer();
  for (int f = 0; f < 3; ++f) {
    const auto res = r.render(make_frame(f, 0.1 * f, img, test_camera(), cv::Matx44d::eye()), traj, {});
    ASSERT_TRUE(res.hazard.visible);
    ASSERT_GE(res.hazard.box.y + res.hazard.box.height, img.rows - 1.f) << "the car must reach the bottom";
    ASSERT_TRUE(res.hazard.appearance.has_value());
    EXPECT_NEAR(res.hazard.appearance->noise_ratio, 1.0, 0.3) << "frame " << f;
  }
}

TEST(ArRendererStage, RefusesFramesWithoutPosesInPosesMode) {
  auto runner = hf::testing::StageRunner::create<ArRenderer>("ego_motion: poses");
  runner.push("frames", make_frame(4, 0.4, hf::test::textured_image(), test_camera()), 0.4);
  try {
    runner.run();
    FAIL() << "expected an error";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("frame 4"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("T_world_ego"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace hf::render
