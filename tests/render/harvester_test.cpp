// The asset harvester on synthetic annotated frames: which objects are kept, the cut-out mask, the index it
// writes, and rendering with what it harvested.
#include <gtest/gtest.h>

#include <filesystem>

#include <unistd.h>

#include <opencv2/imgcodecs.hpp>

#include "ar_renderer.hpp"
#include "asset_harvester.hpp"
#include "hazardforge/assets/box_geometry.hpp"
#include "hazardforge/testing/stage_runner.hpp"
#include "render_fixtures.hpp"
#include "temp_dir.hpp"

namespace hf::render {
namespace {

namespace fs = std::filesystem;
using hf::test::test_camera;

AnnotatedObject object(const std::string& id, const std::string& label, cv::Vec3d centre, double yaw,
                       cv::Vec3d size, int points) {
  AnnotatedObject o;
  o.instance_id = id;
  o.label = label;
  o.category = label.empty() ? "movable_object.barrier" : "vehicle." + label;
  o.center_ego = centre;
  o.yaw_ego = yaw;
  o.size_lwh = size;
  o.num_points = points;
  return o;
}

BoxCorners corners_of(const AnnotatedObject& o) {
  return box_corners(o.center_ego[0], o.center_ego[1], o.yaw_ego, o.size_lwh,
                     o.center_ego[2] - o.size_lwh[2] / 2);
}

// Paints the faces of the box the camera sees in shades of `colour` with some texture; returns their mask.
cv::Mat paint_box(cv::Mat& img, const CameraModel& cam, const AnnotatedObject& o, cv::Scalar colour) {
  const BoxCorners c = corners_of(o);
  cv::Mat mask(img.size(), CV_8U, cv::Scalar(0));
  const cv::Vec3d centre = (c[0] + c[2]) * 0.5;
  double shade = 1.0;
  for (Face f : {Face::kFront, Face::kRear, Face::kLeft, Face::kRight}) {
    const auto idx = face_corners(f);
    const cv::Vec3d fc = (c[idx[0]] + c[idx[1]]) * 0.5;
    cv::Vec3d n = fc - centre;
    n[2] = 0;
    if (n.dot(cam.t_ego_cam - fc) <= 0) continue;
    std::vector<cv::Point> poly;
    for (int k : idx) poly.push_back(*cam.project_ego(c[k]));
    cv::fillConvexPoly(img, poly, colour * shade);
    cv::fillConvexPoly(mask, poly, cv::Scalar(255));
    shade *= 0.75;
  }
  cv::Mat tex = hf::test::noise_texture(img.size(), 5, 24.0), tex3;
  cv::cvtColor(tex, tex3, cv::COLOR_GRAY2BGR);
  cv::Mat textured;
  cv::addWeighted(img, 1.0, tex3, 0.5, -64, textured);
  textured.copyTo(img, mask);
  return mask;
}

struct Scene {
  Frame frame;
  cv::Mat mask_a;  // where object A really is
};

Scene make_scene(int64_t index, double a_x) {
  const CameraModel cam = test_camera();
  Scene s;
  cv::Mat img = hf::test::textured_image({1600, 900}, 9);
  auto ann = std::make_shared<Annotations>();
  const auto A = object("inst-a", "car", {a_x, 1.0, 0.76}, 0.4, {4.5, 1.85, 1.52}, 300);
  ann->objects.push_back(A);
  if (index == 0) {
    const auto E =
        object("inst-e", "car", {24.0, 1.3, 0.76}, 0.4, {4.5, 1.85, 1.52}, 300);            // hidden behind A
    const auto D = object("inst-d", "car", {16.0, -5.0, 0.76}, 0.0, {4.5, 1.85, 1.52}, 3);  // too few points
    paint_box(img, cam, E, cv::Scalar(200, 80, 40));
    paint_box(img, cam, D, cv::Scalar(40, 200, 40));
    ann->objects.push_back(E);
    ann->objects.push_back(D);
    ann->objects.push_back(object("inst-c", "truck", {7.0, 6.0, 1.5}, 0.0, {8.0, 2.5, 3.0}, 900));  // clipped
    ann->objects.push_back(
        object("inst-b", "person", {60.0, 0.0, 0.85}, 0.0, {0.5, 0.6, 1.7}, 40));               // too far
    ann->objects.push_back(object("inst-f", "", {10.0, -3.0, 0.5}, 0.0, {0.5, 2.0, 1.0}, 50));  // not wanted
  }
  s.mask_a = paint_box(img, cam, A, cv::Scalar(40, 40, 210));
  s.frame = hf::test::make_frame(index, index * 0.5, img, cam);
  s.frame.annotations = ann;
  s.frame.source_id = "synthetic-" + std::to_string(index);
  return s;
}

TEST(AssetHarvester, KeepsOnlyWellVisibleObjectsAndCutsThemOut) {
  const hf::test::TempDir tmp;
  const fs::path out = tmp / "assets";
  auto runner = hf::testing::StageRunner::create<AssetHarvester>("out_dir: " + out.string());
  const Scene s0 = make_scene(0, 14.0), s1 = make_scene(1, 20.0);
  runner.push("frames", s0.frame, s0.frame.timestamp);
  runner.push("frames", s1.frame, s1.frame.timestamp);
  runner.run();
  const auto& h = dynamic_cast<const AssetHarvester&>(runner.stage());
  const auto& rej = h.rejections();
  EXPECT_EQ(rej.at("overlapped by a nearer object"), 1);
  EXPECT_EQ(rej.at("too few lidar/radar points"), 1);
  EXPECT_EQ(rej.at("clipped by the image border"), 1);
  EXPECT_EQ(rej.at("too far"), 1);

  // One picture: object A from behind, from the frame where it was largest.
  const AssetIndex idx = load_asset_index(out);
  ASSERT_EQ(idx.assets.size(), 1u);
  const AssetSpec& a = idx.assets[0];
  EXPECT_EQ(a.object_class, "car");
  EXPECT_EQ(a.source, "harvested");
  EXPECT_EQ(a.instance, "inst-a");
  const CameraModel cam = test_camera();
  const double az = camera_azimuth_deg(cam.t_ego_cam, 14.0, 1.0, 0.4);
  EXPECT_NEAR(a.azimuth_deg, az, 0.05);
  EXPECT_EQ(a.view, "rear");
  EXPECT_NE(a.file.find("_f0.png"), std::string::npos) << a.file;

  // The stored corners are the projected box in the picture's pixels.
  const auto pb = project_box(cam, corners_of(s0.frame.annotations->objects[0]), 0.5);
  ASSERT_TRUE(pb);
  const cv::Point2d origin = pb->px[0] - a.box_corners_px[0];
  for (int k = 0; k < 8; ++k) EXPECT_NEAR(cv::norm(pb->px[k] - a.box_corners_px[k] - origin), 0.0, 0.01);
  EXPECT_NEAR(origin.x, std::floor(pb->bounds.x) - 1, 0.01);  // assets.yaml keeps 2 decimals

  // The cut-out matches the painted object: intersection over union of the masks.
  const cv::Mat pic = cv::imread((out / a.file).string(), cv::IMREAD_UNCHANGED);
  ASSERT_EQ(pic.type(), CV_8UC4);
  std::vector<cv::Mat> ch;
  cv::split(pic, ch);
  const cv::Rect r(cv::Point(cvRound(origin.x), cvRound(origin.y)), pic.size());
  const cv::Mat truth = s0.mask_a(r) > 0, cut = ch[3] > 127;
  const double iou = cv::countNonZero(truth & cut) / static_cast<double>(cv::countNonZero(truth | cut));
  EXPECT_GT(iou, 0.9);
}

TEST(AssetHarvester, HarvestedAssetsCompositeWithCorrectAlpha) {
  const hf::test::TempDir tmp;
  const fs::path out = tmp / "assets";
  auto runner = hf::testing::StageRunner::create<AssetHarvester>("out_dir: " + out.string());
  const Scene s0 = make_scene(0, 14.0);
  runner.push("frames", s0.frame, 0.0);
  runner.run();
  RendererOptions o;
  o.composite.shadow = false;
  o.composite.exposure_s = 0;
  o.ego.mode = EgoMotionMode::kPoses;
  HazardRenderer r(
      o, std::make_shared<const AssetLibrary>(AssetLibrary::load(out, fs::path(share_dir()) / "assets")));
  auto traj = std::make_shared<const HazardTrajectory>(
      hf::test::static_object("car", 16.0, -0.5, 0.1, 0.0, 1.0, 0.0, cv::Vec3d(4.5, 1.85, 1.52)));
  const cv::Mat img = hf::test::textured_image();
  const auto res = r.render(hf::test::make_frame(0, 0.0, img, test_camera(), cv::Matx44d::eye()), traj, {});
  ASSERT_TRUE(res.composite.drawn);
  EXPECT_EQ(fs::path(res.asset_file).parent_path(), out);
  cv::Mat diff;
  cv::absdiff(img, res.frame.image, diff);
  cv::Mat changed;
  cv::cvtColor(diff, changed, cv::COLOR_BGR2GRAY);
  changed = changed > 0;
  const cv::Rect roi = res.composite.roi;
  const cv::Mat a = res.composite.alpha;
  cv::Mat outside = changed.clone();
  outside(roi).setTo(0);
  EXPECT_EQ(cv::countNonZero(outside), 0);
  EXPECT_EQ(cv::countNonZero(changed(roi) & (a == 0)), 0);
  const int opaque = cv::countNonZero(a >= 253);
  ASSERT_GT(opaque, 1000);
  EXPECT_GT(cv::countNonZero(changed(roi) & (a >= 253)), 0.97 * opaque);
}

TEST(AssetHarvester, RefusesACutWhoseMaskDisagreesWithTheAnnotationsBox) {
  // The annotation says a 1.85 m wide car; the picture holds one 0.8 m wide in its place (an annotation that
  // does not fit what the camera saw): the cut spans half the projected box and is refused.
  const CameraModel cam = test_camera();
  cv::Mat img = hf::test::textured_image({1600, 900}, 9);
  auto ann = std::make_shared<Annotations>();
  ann->objects.push_back(object("inst-w", "car", {14.0, 1.0, 0.76}, 0.0, {4.5, 1.85, 1.52}, 300));
  paint_box(img, cam, object("inst-w", "car", {14.0, 1.0, 0.76}, 0.0, {4.5, 0.8, 1.52}, 300),
            cv::Scalar(40, 40, 210));
  Frame f = hf::test::make_frame(0, 0.0, img, cam);
  f.annotations = ann;
  const hf::test::TempDir tmp;
  const fs::path out = tmp / "assets";
  auto runner = hf::testing::StageRunner::create<AssetHarvester>("out_dir: " + out.string());
  runner.push("frames", f, 0.0);
  runner.run();
  const auto& h = dynamic_cast<const AssetHarvester&>(runner.stage());
  ASSERT_EQ(h.rejections().count("mask disagrees with the projected box"), 1u);
  EXPECT_EQ(h.rejections().at("mask disagrees with the projected box"), 1);
  EXPECT_TRUE(load_asset_index(out).assets.empty());
}

TEST(AssetHarvester, StreamWithoutAnnotationsIsAnError) {
  const hf::test::TempDir tmp;
  auto runner = hf::testing::StageRunner::create<AssetHarvester>("out_dir: " + (tmp / "assets").string());
  runner.push("frames", hf::test::make_frame(0, 0.0, hf::test::textured_image(), test_camera()), 0.0);
  try {
    runner.run();
    FAIL() << "expected an error";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("none of the 1 frames carried annotations"), std::string::npos)
        << e.what();
  }
}

}  // namespace
}  // namespace hf::render
