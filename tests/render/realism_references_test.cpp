// The renderer's real references for the realism comparison: the recording's detected road users and the
// dataset's annotated ones, each measured once, and only where the picture shows the object itself.
#include <gtest/gtest.h>

#include <filesystem>

#include "ar_renderer.hpp"
#include "hazardforge/geometry.hpp"
#include "render_fixtures.hpp"

namespace hf::render {
namespace {

using hf::test::make_frame;
using hf::test::test_camera;

AnnotatedObject annotated(const std::string& label, double x, double y, double yaw, cv::Vec3d lwh,
                          double occlusion = 0.1) {
  AnnotatedObject o;
  o.label = label;
  o.category = label;
  o.center_ego = {x, y, lwh[2] / 2};
  o.size_lwh = lwh;
  o.yaw_ego = yaw;
  o.num_points = 40;
  o.occlusion = occlusion;
  return o;
}

// A textured grey scene with a saturated, textured rectangle painted at `r` (an object's outline).
void paint(cv::Mat& img, const cv::Rect& r, const cv::Scalar& colour) {
  cv::Mat tex = hf::test::noise_texture(r.size(), 3, 30.0), bgr;
  cv::cvtColor(tex, bgr, cv::COLOR_GRAY2BGR);
  cv::Mat patch(r.size(), CV_8UC3, colour);
  cv::addWeighted(patch, 0.8, bgr, 0.4, -40, patch);
  patch.copyTo(img(r));
}

HazardRenderer renderer(bool annotations = true) {
  RendererOptions o;
  o.ego.mode = EgoMotionMode::kPoses;
  o.composite.shadow = false;
  o.scene_light = false;
  o.realism.annotations = annotations;
  o.realism.references = 3;
  return HazardRenderer(o, std::make_shared<const AssetLibrary>(
                               AssetLibrary::load(std::filesystem::path(share_dir()) / "assets")));
}

std::vector<AppearanceStats> references_of(HazardRenderer& r, const Frame& f,
                                           const std::vector<OccluderCandidate>& detections) {
  return r.render(f, nullptr, detections).hazard.references;
}

TEST(RealismReferences, AnnotatedObjectsAreMeasuredWithTheirOutlineAsBox) {
  const CameraModel cam = test_camera();
  // An oblique car 14 m ahead: its 3D box's picture is wider than the car's outline, which is painted as
  // the middle 70 % of that width.
  const AnnotatedObject car = annotated("car", 15.5, 1.0, 0.6, {4.5, 1.85, 1.5});
  const cv::Rect2d projected = *annotation_image_box(cam, car);
  const cv::Rect outline(static_cast<int>(projected.x + 0.15 * projected.width), static_cast<int>(projected.y),
                         static_cast<int>(0.7 * projected.width), static_cast<int>(projected.height));
  cv::Mat img = hf::test::textured_image();
  paint(img, outline, {40, 40, 220});
  Frame f = make_frame(0, 0.0, img, cam, cv::Matx44d::eye());
  auto ann = std::make_shared<Annotations>();
  ann->objects = {car};
  f.annotations = ann;

  HazardRenderer r = renderer();
  const auto refs = references_of(r, f, {});
  ASSERT_EQ(refs.size(), 1u);
  EXPECT_EQ(refs[0].source, "annotation");
  EXPECT_EQ(refs[0].label, "car");
  // Size and aspect are read from the outline grabCut finds, not from the wider projected box.
  EXPECT_NEAR(refs[0].box.width, outline.width, 0.1 * outline.width) << "projected " << projected.width;
  EXPECT_NEAR(refs[0].box.height, outline.height, 0.1 * outline.height);
  EXPECT_NEAR(refs[0].aspect, double(outline.width) / outline.height, 0.15);
  EXPECT_GT(refs[0].edge_contrast, 5.0);

  // With the option off, nothing is measured.
  HazardRenderer off = renderer(false);
  EXPECT_TRUE(references_of(off, f, {}).empty());
}

TEST(RealismReferences, HiddenOrAlreadyDetectedObjectsAreNotMeasuredFromTheAnnotations) {
  const CameraModel cam = test_camera();
  cv::Mat img = hf::test::textured_image();
  const AnnotatedObject front = annotated("car", 13.0, 0.0, 0.0, {4.5, 1.85, 1.5});
  // Straight behind it, a van mostly hidden by it in this picture (the dataset's own hint says visible).
  const AnnotatedObject behind = annotated("car", 20.0, 0.4, 0.0, {5.0, 2.0, 2.2});
  // To the left, a car the dataset flags as half hidden.
  const AnnotatedObject flagged = annotated("car", 14.0, 5.0, 0.0, {4.5, 1.85, 1.5}, 0.5);
  // To the right, a person with no lidar or radar return.
  AnnotatedObject unseen = annotated("person", 10.0, -3.5, 0.0, {0.6, 0.6, 1.75});
  unseen.num_points = 0;
  for (const AnnotatedObject* o : {&behind, &front, &flagged, static_cast<const AnnotatedObject*>(&unseen)}) {
    const cv::Rect2d b = *annotation_image_box(cam, *o);
    paint(img, cv::Rect(b) & cv::Rect(0, 0, img.cols, img.rows), {200, 60, 60});
  }
  Frame f = make_frame(0, 0.0, img, cam, cv::Matx44d::eye());
  auto ann = std::make_shared<Annotations>();
  ann->objects = {front, behind, flagged, unseen};
  f.annotations = ann;

  HazardRenderer r = renderer();
  auto refs = references_of(r, f, {});
  ASSERT_EQ(refs.size(), 1u) << "only the front car is whole and unhidden";
  EXPECT_EQ(refs[0].source, "annotation");
  const cv::Rect2f front_box(*annotation_image_box(cam, front));
  EXPECT_GT(box_iou(refs[0].box, front_box), 0.7);

  // The detector found the front car too: it is measured once, as a detection.
  OccluderCandidate det;
  det.box = front_box;
  det.score = 0.9f;
  det.label = "car";
  HazardRenderer r2 = renderer();
  refs = references_of(r2, f, {det});
  ASSERT_EQ(refs.size(), 1u);
  EXPECT_EQ(refs[0].source, "detection");
}

}  // namespace
}  // namespace hf::render
