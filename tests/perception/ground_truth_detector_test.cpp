// Synthetic tests of the ground-truth detector: projection against hand-computed boxes, near-plane clipping,
// filters and errors.
#include <gtest/gtest.h>

#include "ground_truth_detector.hpp"
#include "hazardforge/geometry.hpp"
#include "hazardforge/testing/stage_runner.hpp"

namespace hf {
namespace {

// Level camera 1.5 m above the ground, 1.5 m ahead of the rear axle, f = 1000 px, 1280x720.
Frame frame_with(std::vector<AnnotatedObject> objs) {
  Frame f;
  f.index = 3;
  f.timestamp = 0.3;
  f.source_id = "synthetic";
  f.camera = CameraModel::pinhole(1280, 720, 1000, 1000, 640, 360, 1.5, 0.0, 1.5);
  f.image = cv::Mat(720, 1280, CV_8UC3, cv::Scalar::all(0));
  auto a = std::make_shared<Annotations>();
  a->objects = std::move(objs);
  f.annotations = a;
  return f;
}

AnnotatedObject car(cv::Vec3d centre, cv::Vec3d lwh = {4, 2, 1.5}, double yaw = 0.0,
                    std::string label = "car") {
  AnnotatedObject o;
  o.label = std::move(label);
  o.category = "vehicle.car";
  o.center_ego = centre;
  o.size_lwh = lwh;
  o.yaw_ego = yaw;
  return o;
}

Detections run(const std::string& params, const Frame& f) {
  auto r = testing::StageRunner::create<GroundTruthDetector>(params);
  r.push("frames", f, f.timestamp);
  r.run();
  auto out = r.collect<Detections>("detections");
  EXPECT_EQ(out.size(), 1u);
  return out.empty() ? Detections{} : out[0];
}

TEST(GroundTruthDetector, ProjectsABoxAheadToTheHandComputedRectangle) {
  // Box x in [19.5, 23.5], y in [1, 3], z in [0, 1.5] (ego). Camera frame: X = -y, Y = 1.5 - z, Z = x - 1.5,
  // so Z in [18, 22], X in [-3, -1], Y in [0, 1.5]:
  //   u from 640 + 1000 * (-3 / 18) = 473.333 to 640 + 1000 * (-1 / 22) = 594.545
  //   v from 360 + 0 = 360 to 360 + 1000 * (1.5 / 18) = 443.333
  const Detections d = run("", frame_with({car({21.5, 2.0, 0.75})}));
  ASSERT_EQ(d.items.size(), 1u);
  const cv::Rect2f b = d.items[0].box;
  EXPECT_NEAR(b.x, 473.333, 1e-3);
  EXPECT_NEAR(b.y, 360.0, 1e-3);
  EXPECT_NEAR(b.x + b.width, 594.545, 1e-3);
  EXPECT_NEAR(b.y + b.height, 443.333, 1e-3);
  EXPECT_EQ(d.items[0].label, "car");
  EXPECT_EQ(d.items[0].class_id, 2);
  EXPECT_FLOAT_EQ(d.items[0].score, 1.f);
  EXPECT_EQ(d.items[0].annotation_index, 0);
  EXPECT_EQ(d.frame_index, 3);
  EXPECT_EQ(d.image_size, cv::Size(1280, 720));
}

TEST(GroundTruthDetector, YawRotatesTheFootprint) {
  // Turned by 90 degrees the 4 m length lies across: y in [0, 4], x in [20.5, 22.5] -> Z in [19, 21].
  //   u from 640 - 1000 * 4 / 19 = 429.474 to 640 - 0 = 640; v bottom 360 + 1500 / 19 = 438.947
  const Detections d = run("", frame_with({car({21.5, 2.0, 0.75}, {4, 2, 1.5}, CV_PI / 2)}));
  ASSERT_EQ(d.items.size(), 1u);
  EXPECT_NEAR(d.items[0].box.x, 429.474, 1e-2);
  EXPECT_NEAR(d.items[0].box.x + d.items[0].box.width, 640.0, 1e-2);
  EXPECT_NEAR(d.items[0].box.y + d.items[0].box.height, 438.947, 1e-2);
}

TEST(GroundTruthDetector, BehindTheCameraIsDroppedAndStraddlingIsClippedAtTheNearPlane) {
  // Wholly behind: x in [-7, -3].
  // Straddling: x in [-0.75, 3.75] (camera at 1.5), y in [0.1, 1.9]. The part in front of the near plane
  // (Z >= 0.1) spans Z up to 2.25; its right edge is X = -0.1 at Z = 2.25 -> u = 640 - 100 / 2.25 = 595.556;
  // on the near plane the left and bottom edges run far outside the image and are clipped to 0 and 720.
  const Detections d = run("", frame_with({car({-5, 0, 0.75}), car({1.5, 1.0, 0.75}, {4.5, 1.8, 1.5})}));
  ASSERT_EQ(d.items.size(), 1u);
  EXPECT_EQ(d.items[0].annotation_index, 1);
  const cv::Rect2f b = d.items[0].box;
  EXPECT_NEAR(b.x, 0.0, 1e-4);
  EXPECT_NEAR(b.y, 360.0, 1e-3);
  EXPECT_NEAR(b.x + b.width, 595.556, 1e-3);
  EXPECT_NEAR(b.y + b.height, 720.0, 1e-3);
  // Without clipping at the near plane the corners behind the camera would flip to the other side of the
  // image: the unclipped rectangle straight from annotation_image_box must still end at 595.556 on the right.
  auto raw = annotation_image_box(frame_with({}).camera, car({1.5, 1.0, 0.75}, {4.5, 1.8, 1.5}));
  ASSERT_TRUE(raw.has_value());
  EXPECT_NEAR(raw->x + raw->width, 595.556, 1e-3);
  EXPECT_FALSE(annotation_image_box(frame_with({}).camera, car({-5, 0, 0.75})).has_value());
}

TEST(GroundTruthDetector, OutsideTheFieldOfViewIsDropped) {
  // 20 m ahead but 30 m to the left: projects to u < 0 entirely.
  const Detections d = run("", frame_with({car({21.5, 30.0, 0.75})}));
  EXPECT_TRUE(d.items.empty());
}

TEST(GroundTruthDetector, FiltersClassPointsDistanceArea) {
  AnnotatedObject ped = car({11.5, -1.0, 0.85}, {0.5, 0.6, 1.7}, 0.0, "person");
  AnnotatedObject few = car({31.5, 0.0, 0.75});
  few.num_points = 0;
  AnnotatedObject unknown_pts = car({41.5, -3.0, 0.75});  // num_points -1: passes
  AnnotatedObject barrier = car({15.5, 4.0, 0.5}, {0.5, 2, 1}, 0.0, "");
  const Frame f = frame_with({ped, few, unknown_pts, barrier});

  Detections d = run("", f);
  ASSERT_EQ(d.items.size(), 2u);
  EXPECT_EQ(d.items[0].annotation_index, 0);
  EXPECT_EQ(d.items[0].label, "person");
  EXPECT_EQ(d.items[0].class_id, 0);
  EXPECT_EQ(d.items[1].annotation_index, 2);

  EXPECT_EQ(run("min_points: -1", f).items.size(), 3u);
  EXPECT_EQ(run("classes: [car]", f).items.size(), 1u);
  // Camera at x = 1.5: the person is 10 m away, the car 40.1 m.
  EXPECT_EQ(run("max_distance: 20", f).items.size(), 1u);
  // The pedestrian's box is 0.6 m x 1.7 m at Z = 9.75..10.25 -> about 59 x 166 px; the far car is ~ 49 x 36.
  d = run("min_visible_area: 3000", f);
  ASSERT_EQ(d.items.size(), 1u);
  EXPECT_EQ(d.items[0].label, "person");
}

TEST(GroundTruthDetector, DatasetBoxesArePreferredWhenGiven) {
  AnnotatedObject o = car({21.5, 2.0, 0.75});
  o.box2d = cv::Rect2d(-10, 100, 60, 40);
  const Frame f = frame_with({o});
  Detections d = run("", f);
  ASSERT_EQ(d.items.size(), 1u);
  EXPECT_EQ(d.items[0].box, cv::Rect2f(0, 100, 50, 40));  // clipped to the image
  d = run("prefer_dataset_boxes: false", f);
  EXPECT_NEAR(d.items[0].box.x, 473.333, 1e-3);
}

TEST(GroundTruthDetector, FrameWithoutAnnotationsIsAnError) {
  Frame f = frame_with({});
  f.annotations.reset();
  GroundTruthDetector det;
  try {
    det.detect_frame(f);
    FAIL();
  } catch (const Error& e) {
    EXPECT_EQ(
        std::string(e.what()),
        "ground_truth detector: frame 3 (synthetic) carries no annotations; this detector needs a source "
        "that provides them (or set require_annotations: false)");
  }
  GroundTruthDetector::Config c;
  c.require_annotations = false;
  det.configure(c);
  EXPECT_TRUE(det.detect_frame(f).items.empty());
}

}  // namespace
}  // namespace hf
