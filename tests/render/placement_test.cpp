// Placement geometry: projection of world points, 1/distance scaling, views, and anchoring under known ego
// poses.
#include <gtest/gtest.h>

#include <set>

#include <cmath>
#include <iostream>

#include "ar_renderer.hpp"
#include "ego_motion.hpp"
#include "hazardforge/assets/box_geometry.hpp"
#include "render_fixtures.hpp"

#include <opencv2/imgcodecs.hpp>

namespace hf::render {
namespace {

using hf::test::make_frame;
using hf::test::static_object;
using hf::test::test_camera;

std::shared_ptr<const AssetLibrary> default_assets() {
  return std::make_shared<const AssetLibrary>(
      AssetLibrary::load(std::filesystem::path(share_dir()) / "assets"));
}

// Plain compositing (no shadow, harmonisation, feathering or blur) so drawn pixels are exactly the object's.
RendererOptions plain_options() {
  RendererOptions o;
  o.composite.shadow = false;
  o.composite.harmonize_luma = 0;
  o.composite.harmonize_chroma = 0;
  o.composite.feather_px = 0;
  o.composite.exposure_s = 0;
  o.ego.mode = EgoMotionMode::kPoses;
  return o;
}

// Rows in which the output differs from the input.
std::pair<int, int> changed_rows(const cv::Mat& a, const cv::Mat& b) {
  cv::Mat diff;
  cv::absdiff(a, b, diff);
  cv::Mat g;
  cv::cvtColor(diff, g, cv::COLOR_BGR2GRAY);
  int top = -1, bottom = -1;
  for (int y = 0; y < g.rows; ++y)
    if (cv::countNonZero(g.row(y)) > 0) {
      if (top < 0) top = y;
      bottom = y;
    }
  return {top, bottom};
}

// Sub-pixel height of an outline: per row, the strongest coverage; summed over rows.
double outline_height(const cv::Mat& alpha) {
  cv::Mat alpha32;
  alpha.convertTo(alpha32, CV_32F, alpha.depth() == CV_8U ? 1.0 / 255 : 1.0);
  double h = 0;
  for (int y = 0; y < alpha32.rows; ++y) {
    double mx = 0;
    cv::minMaxLoc(alpha32.row(y), nullptr, &mx);
    h += std::min(mx, 1.0);
  }
  return h;
}

TEST(Placement, WorldPointProjectsToTheExpectedPixel) {
  // Anchor pose and current pose in the world; the object's ground point is given in the anchor frame.
  const cv::Matx44d anchor_pose = planar_pose(100.0, 50.0, 0.3);
  const cv::Matx44d cur_pose = planar_pose(104.0, 51.5, 0.35);
  const CameraModel cam = test_camera();
  HazardRenderer r(plain_options(), default_assets());
  auto traj = std::make_shared<const HazardTrajectory>(
      static_object("car", 22.0, 2.0, 0.0, 0.0, 2.0, 0.0, cv::Vec3d(0.01, 0.01, 0.01)));
  const cv::Mat img(900, 1600, CV_8UC3, cv::Scalar(90, 90, 90));
  r.render(make_frame(0, 0.0, img, cam, anchor_pose), traj, {});
  auto res = r.render(make_frame(1, 1.0, img, cam, cur_pose), traj, {});

  // By hand: world point, then into the current ego frame, then the level pinhole camera at (1.5, 0, 1.5).
  const double ca = std::cos(0.3), sa = std::sin(0.3);
  const double wx = 100.0 + ca * 22.0 - sa * 2.0, wy = 50.0 + sa * 22.0 + ca * 2.0;
  const double cc = std::cos(0.35), sc = std::sin(0.35);
  const double ex = cc * (wx - 104.0) + sc * (wy - 51.5), ey = -sc * (wx - 104.0) + cc * (wy - 51.5);
  const double Z = ex - 1.5, X = -ey, Y = 1.5;
  const cv::Point2d expected(800 + 1266 * X / Z, 450 + 1266 * Y / Z);

  EXPECT_NEAR(res.hazard.distance_m, ex, 1e-9);
  EXPECT_NEAR(res.hazard.lateral_m, ey, 1e-9);
  // The 1 cm box's bottom centre is the ground point.
  const cv::Rect2f& b = res.hazard.box;
  EXPECT_NEAR(b.x + b.width / 2, expected.x, 0.2);
  EXPECT_NEAR(b.y + b.height, expected.y, 0.2);
  EXPECT_LT(b.height, 1.0f);
}

TEST(Placement, PixelHeightScalesExactlyWithInverseDistance) {
  const CameraModel cam = test_camera();
  const cv::Mat img(900, 1600, CV_8UC3, cv::Scalar(90, 90, 90));
  std::vector<double> depth, height;
  for (double rear_depth : {6.0, 9.0, 12.0, 18.0, 24.0}) {
    HazardRenderer r(plain_options(), default_assets());
    // A car straight ahead driving away from the camera: its rear face is parallel to the image plane.
    const double x = cam.t_ego_cam[0] + rear_depth + 2.25;
    auto traj = std::make_shared<const HazardTrajectory>(
        static_object("car", x, 0.0, 0.0, 0.0, 1.0, 0.0, cv::Vec3d(4.5, 1.85, 1.52)));
    auto res = r.render(make_frame(0, 0.0, img, cam, cv::Matx44d::eye()), traj, {});
    ASSERT_TRUE(res.hazard.visible);
    // The rear view, in whichever colour the hazard drew (car_rear.png, car_white_rear.png, ...).
    EXPECT_TRUE(res.asset_file.size() >= 8 &&
                res.asset_file.compare(res.asset_file.size() - 8, 8, "rear.png") == 0)
        << res.asset_file;
    auto [top, bottom] = changed_rows(img, res.frame.image);
    ASSERT_GE(top, 0);
    depth.push_back(rear_depth);
    height.push_back(outline_height(res.composite.alpha));
  }
  // The silhouette's share of the rear face's height in the picture: the roof sits behind the rear face, so
  // the outline is a little lower than the box.
  cv::Mat pic = cv::imread((std::filesystem::path(share_dir()) / "assets" / "car_rear.png").string(),
                           cv::IMREAD_UNCHANGED);
  ASSERT_FALSE(pic.empty());
  std::vector<cv::Mat> ch;
  cv::split(pic, ch);
  cv::Mat pic_alpha;
  ch[3].convertTo(pic_alpha, CV_32F, 1.0 / 255);
  const AssetSpec spec = [] {
    for (const auto& s : load_asset_index(std::filesystem::path(share_dir()) / "assets").assets)
      if (s.file == "car_rear.png") return s;
    return AssetSpec{};
  }();
  const double face_px = spec.box_corners_px[2].y - spec.box_corners_px[6].y;  // rear bottom - rear top
  const double share = outline_height(pic_alpha) / face_px;
  EXPECT_GT(share, 0.85);
  EXPECT_LE(share, 1.01);
  for (size_t i = 0; i < depth.size(); ++i) {
    // h = f * (share * H) / Z: the drawn outline is the real height's projection, to 1 % (bilinear resampling
    // and the pyramid level blur the outline's edge rows a little; the picture, rendered from 8 m, shows the
    // roof behind the rear face from a slightly different angle than the frame at each distance: 0.4-0.5 %).
    const double expected = 1266 * 1.52 * share / depth[i];
    std::cout << "rear face at " << depth[i] << " m: drawn height " << height[i] << " px, f*H/Z " << expected
              << " px\n";
    EXPECT_NEAR(height[i], expected, std::max(0.3, 0.01 * expected)) << "depth " << depth[i];
  }
  // So h * Z is the same constant at every distance.
  for (size_t i = 1; i < depth.size(); ++i)
    EXPECT_NEAR(height[i] * depth[i] / (height[0] * depth[0]), 1.0, 0.005) << "depth " << depth[i];
}

// The default set's car comes in several colours: one hazard keeps its colour through every frame, the same
// hazard drawn again gets the same one, and different hazards get different ones.
TEST(Placement, EachDefaultCarHazardKeepsOneOfTheColours) {
  const CameraModel cam = test_camera();
  const cv::Mat img(900, 1600, CV_8UC3, cv::Scalar(90, 90, 90));
  auto colour_of = [](const std::string& file) {
    const std::string name = std::filesystem::path(file).filename().string();
    for (const char* c : {"white", "grey"})
      if (name.rfind(std::string("car_") + c + "_", 0) == 0) return std::string(c);
    return std::string("silver");
  };
  std::set<std::string> seen;
  for (int k = 0; k < 12; ++k) {
    const double x = 12.0 + 1.7 * k;
    auto traj = std::make_shared<const HazardTrajectory>(
        static_object("car", x, 0.4, 0.0, 0.0, 1.0, 0.0, cv::Vec3d(4.5, 1.85, 1.52)));
    HazardRenderer r(plain_options(), default_assets()), again(plain_options(), default_assets());
    std::string first;
    for (int f = 0; f < 2; ++f) {  // the same hazard in a later frame
      const auto res = r.render(make_frame(f, 0.3 * f, img, cam, cv::Matx44d::eye()), traj, {});
      ASSERT_TRUE(res.hazard.visible) << "hazard " << k << " frame " << f;
      if (f == 0) first = colour_of(res.asset_file);
      EXPECT_EQ(colour_of(res.asset_file), first) << res.asset_file;
    }
    EXPECT_EQ(colour_of(again.render(make_frame(0, 0.0, img, cam, cv::Matx44d::eye()), traj, {}).asset_file),
              first);
    seen.insert(first);
  }
  EXPECT_EQ(seen.size(), 3u);
}

TEST(Placement, ViewFollowsHeadingRelativeToTheCamera) {
  const cv::Vec3d cam(1.5, 0, 1.5);
  EXPECT_EQ(view_for_azimuth(camera_azimuth_deg(cam, 20, 0, 0.0)), "rear");          // driving away
  EXPECT_EQ(view_for_azimuth(camera_azimuth_deg(cam, 20, 0, CV_PI)), "front");       // oncoming
  EXPECT_EQ(view_for_azimuth(camera_azimuth_deg(cam, 20, 0, CV_PI / 2)), "left");    // crossing to the left
  EXPECT_EQ(view_for_azimuth(camera_azimuth_deg(cam, 20, 0, -CV_PI / 2)), "right");  // crossing to the right
  EXPECT_EQ(view_for_azimuth(camera_azimuth_deg(cam, 20, 0, CV_PI / 4)), "rear_left");
  EXPECT_EQ(view_for_azimuth(camera_azimuth_deg(cam, 20, 0, -3 * CV_PI / 4)), "front_right");
  // A car ahead-left seen from the camera sees its right side partly: bearing matters, not only heading.
  EXPECT_EQ(view_for_azimuth(camera_azimuth_deg(cam, 11.5, 10, 0.0)), "rear_right");
  EXPECT_EQ(visible_faces(180.0).size(), 1u);
  EXPECT_EQ(visible_faces(135.0).size(), 2u);
  EXPECT_EQ(visible_corners(135.0), (std::vector<int>{0, 2, 3, 4, 6, 7}));
}

TEST(Placement, AnchoredObjectStaysFixedInTheWorldUnderKnownEgoPoses) {
  const CameraModel cam = test_camera();
  const cv::Mat img = hf::test::textured_image();
  HazardRenderer r(plain_options(), default_assets());
  // Object anchored at the frame at t = 0.3 s, standing 25 m ahead and 1 m right of the ego there.
  auto traj = std::make_shared<const HazardTrajectory>(
      static_object("car", 25.0, -1.0, 0.2, 0.3, 2.0, 0.3, cv::Vec3d(4.5, 1.85, 1.52)));
  const double v = 8.0, yaw_rate = 0.1, dt = 0.1;
  std::optional<cv::Vec3d> world_ref;
  cv::Matx44d anchor_pose;
  for (int k = 0; k < 15; ++k) {
    const double t = k * dt, yaw = yaw_rate * t;
    // Constant speed and yaw rate: the exact circular arc.
    const double R = v / yaw_rate;
    const cv::Matx44d pose = planar_pose(R * std::sin(yaw), R * (1 - std::cos(yaw)), yaw);
    if (k == 3) anchor_pose = pose;
    auto res = r.render(make_frame(k, t, img, cam, pose), traj, {});
    if (k < 3) {
      // Before the hazard starts the frame passes through untouched.
      EXPECT_FALSE(res.hazard.visible);
      EXPECT_EQ(res.frame.image.data, img.data);
      continue;
    }
    ASSERT_TRUE(res.hazard.visible) << "frame " << k;
    // The object's centre, taken back to the world with this frame's pose, is the same point every frame.
    const cv::Vec4d c_w = pose * cv::Vec4d(res.hazard.distance_m, res.hazard.lateral_m, 0, 1);
    const cv::Vec4d expect_w = anchor_pose * cv::Vec4d(25.0, -1.0, 0, 1);
    EXPECT_NEAR(c_w[0], expect_w[0], 1e-9);
    EXPECT_NEAR(c_w[1], expect_w[1], 1e-9);
    // The HazardInstance box is the projection of the box's corners in this frame (computed independently).
    const cv::Matx44d cur_from_anchor = invert_rigid(pose) * anchor_pose;
    const double yaw_rel = 0.2 + yaw_of(cur_from_anchor);
    const cv::Vec4d cc = cur_from_anchor * cv::Vec4d(25.0, -1.0, 0, 1);
    double x0 = 1e9, y0 = 1e9, x1 = -1e9, y1 = -1e9;
    for (double sl : {-1.0, 1.0})
      for (double sw : {-1.0, 1.0})
        for (double z : {0.0, 1.52}) {
          const double px = cc[0] + std::cos(yaw_rel) * sl * 2.25 - std::sin(yaw_rel) * sw * 0.925;
          const double py = cc[1] + std::sin(yaw_rel) * sl * 2.25 + std::cos(yaw_rel) * sw * 0.925;
          const double Z = px - 1.5;
          const double u = 800 + 1266 * (-py) / Z, vv = 450 + 1266 * (1.5 - z) / Z;
          x0 = std::min(x0, u);
          x1 = std::max(x1, u);
          y0 = std::min(y0, vv);
          y1 = std::max(y1, vv);
        }
    x0 = std::max(x0, 0.0);
    y0 = std::max(y0, 0.0);
    x1 = std::min(x1, 1600.0);
    y1 = std::min(y1, 900.0);
    EXPECT_NEAR(res.hazard.box.x, x0, 1e-3) << "frame " << k;
    EXPECT_NEAR(res.hazard.box.y, y0, 1e-3);
    EXPECT_NEAR(res.hazard.box.x + res.hazard.box.width, x1, 1e-3);
    EXPECT_NEAR(res.hazard.box.y + res.hazard.box.height, y1, 1e-3);
    if (!world_ref) world_ref = cv::Vec3d(c_w[0], c_w[1], 0);
  }
  // The ego drove ~1.1 m closer per... 8 m/s over 1.1 s: the object is ~8.8 m nearer at the end.
  ASSERT_TRUE(world_ref);
}

TEST(Placement, IntendedTtcFollowsTheGuideProtocol) {
  // Ego at 10 m/s (poses 1 m apart at 10 Hz), a stopped car 30 m ahead in the lane.
  const CameraModel cam = test_camera();
  const cv::Mat img(900, 1600, CV_8UC3, cv::Scalar(90, 90, 90));
  HazardRenderer r(plain_options(), default_assets());
  auto traj = std::make_shared<const HazardTrajectory>(
      static_object("car", 30.0, 0.0, 0.0, 0.0, 1.0, 0.0, cv::Vec3d(4.5, 1.85, 1.52)));
  HazardRenderer::Result res;
  for (int k = 0; k < 3; ++k)
    res = r.render(make_frame(k, k * 0.1, img, cam, planar_pose(k * 1.0, 0, 0)), traj, {});
  // Frame 2: distance 28 m, gap = 28 - 3.4 - 2.25, closing 10 m/s.
  EXPECT_NEAR(res.hazard.distance_m, 28.0, 1e-9);
  EXPECT_NEAR(res.hazard.intended_ttc_s, (28.0 - 3.4 - 2.25) / 10.0, 1e-9);
}

TEST(Placement, IntendedTtcUsesTheCorridorAlongTheTurningEgo) {
  // Ego at 10 m/s on a 50 m left curve (poses 1 m apart along the arc at 10 Hz; the yaw rate comes from
  // them), a stopped car in the ego's lane 30 m along the curve from the anchor frame.
  const double R = 50.0;
  const CameraModel cam = test_camera();
  const cv::Mat img(900, 1600, CV_8UC3, cv::Scalar(90, 90, 90));
  auto traj = std::make_shared<const HazardTrajectory>(
      static_object("car", R * std::sin(30.0 / R), R * (1 - std::cos(30.0 / R)), 30.0 / R, 0.0, 1.0, 0.0,
                    cv::Vec3d(4.5, 1.85, 1.52)));
  auto render = [&](bool follow_path) {
    RendererOptions o = plain_options();
    o.corridor.follow_path = follow_path;
    HazardRenderer r(o, default_assets());
    HazardRenderer::Result res;
    for (int k = 0; k < 3; ++k)
      res = r.render(make_frame(k, k * 0.1, img, cam,
                                planar_pose(R * std::sin(k / R), R * (1 - std::cos(k / R)), k / R)),
                     traj, {});
    return res;
  };
  // Frame 2: the car is 28 m along the curve, 7.6 m left of the ego's x axis.
  const HazardRenderer::Result along = render(true), straight = render(false);
  EXPECT_NEAR(along.hazard.distance_m, R * std::sin(28.0 / R), 1e-9);
  EXPECT_NEAR(along.hazard.lateral_m, R * (1 - std::cos(28.0 / R)), 1e-9);
  EXPECT_NEAR(along.hazard.intended_ttc_s, (R * std::sin(28.0 / R) - 3.4 - 2.25) / 10.0, 0.01);
  EXPECT_EQ(straight.hazard.intended_ttc_s, kInf);
}

}  // namespace
}  // namespace hf::render
