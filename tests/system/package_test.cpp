// The scenario package: KITTI conventions of its 3D boxes, its JSON read back with faults named, and the sink
// and the source on synthetic frames.
#include <gtest/gtest.h>

#include <cmath>
#include <fstream>

#include <opencv2/imgproc.hpp>

#include "hazardforge/angles.hpp"
#include "hazardforge/error.hpp"
#include "hazardforge/scenario_package.hpp"
#include "hazardforge/testing/stage_runner.hpp"
#include "scenario_package_sink.hpp"
#include "scenario_source.hpp"
#include "temp_dir.hpp"

namespace hf {
namespace {

namespace fs = std::filesystem;

CameraModel camera() {
  return CameraModel::pinhole(640, 360, 500, 500, 320, 180, 1.5, 0.0, 1.5);
}

TEST(ScenarioPackage, Box3dFollowsKittiConventions) {
  const CameraModel cam = camera();
  // A car 20.5 m ahead on the ground (16 m... from the camera 1.5 m ahead of the ego origin), driving away.
  const auto ahead = scenario::box3d(cam, {21.5, 0.0, 0.0}, 0.0, {4.5, 1.8, 1.5});
  EXPECT_NEAR(ahead.location_cam[0], 0.0, 1e-9);
  EXPECT_NEAR(ahead.location_cam[1], 1.5, 1e-9);   // the ground is 1.5 m below the camera (y down)
  EXPECT_NEAR(ahead.location_cam[2], 20.0, 1e-9);  // 20 m in front of the camera
  EXPECT_NEAR(ahead.rotation_y, -kPi / 2, 1e-9);   // KITTI: a car driving away has rotation_y -pi/2
  EXPECT_NEAR(ahead.dimensions_hwl[0], 1.5, 1e-12);
  EXPECT_NEAR(ahead.dimensions_hwl[2], 4.5, 1e-12);
  EXPECT_NEAR(scenario::observation_angle(ahead), -kPi / 2, 1e-9);
  // Crossing from the left to the right (heading -90 deg in the ego frame): facing the camera's x axis.
  const auto crossing = scenario::box3d(cam, {11.5, 3.0, 0.0}, -kPi / 2, {0.6, 0.6, 1.7});
  EXPECT_NEAR(crossing.rotation_y, 0.0, 1e-9);
  EXPECT_NEAR(crossing.location_cam[0], -3.0, 1e-9);  // 3 m to the left: negative x
  // Observation angle: rotation_y less the azimuth of the location (atan2(x, z)).
  EXPECT_NEAR(scenario::observation_angle(crossing), -std::atan2(-3.0, 10.0), 1e-9);
}

TEST(ScenarioPackage, ReadBackNamesTheFileLineAndFieldOfAFault) {
  test::TempDir dir;
  scenario::PackageHeader h;
  h.kind = "cut_in";
  h.object_class = "car";
  h.frames = 2;
  { std::ofstream(dir / "scenario.json") << scenario::to_json(h).dump(); }
  scenario::PackageFrame f;
  f.frame = 3;
  f.timestamp = 0.3;
  f.augmented = "augmented/000003.jpg";
  f.original = "original/000003.jpg";
  f.camera = camera();
  scenario::LabelledObject o;
  o.label = "car";
  o.inserted = true;
  o.visible = true;
  o.box = cv::Rect2f(10, 20, 30, 40);
  o.ttc_s = 2.5;
  o.box3d = scenario::box3d(f.camera, {20, 1, 0}, 0.1, {4.5, 1.8, 1.5});
  f.hazard = o;
  scenario::PackageFrame f2 = f;
  f2.frame = 4;
  f2.hazard.reset();
  {
    std::ofstream out(dir / "frames.jsonl");
    out << scenario::to_json(f).dump() << "\n" << scenario::to_json(f2).dump() << "\n";
  }
  const scenario::Package p = scenario::read_package(dir.path());
  ASSERT_EQ(p.frames.size(), 2u);
  ASSERT_TRUE(p.frames[0].hazard);
  EXPECT_EQ(p.frames[0].hazard->box, o.box);
  EXPECT_DOUBLE_EQ(*p.frames[0].hazard->ttc_s, 2.5);
  ASSERT_TRUE(p.frames[0].hazard->box3d);
  EXPECT_NEAR(p.frames[0].hazard->box3d->rotation_y, o.box3d->rotation_y, 1e-12);
  EXPECT_FALSE(p.frames[1].hazard);
  EXPECT_EQ(p.picture(p.frames[0], true), dir.path() / "augmented/000003.jpg");

  // A frame out of order, a picture outside the package, a bad field: each named with its line.
  auto fails_with = [&](const std::string& second_line, const std::string& needle) {
    {
      std::ofstream out(dir / "frames.jsonl");
      out << scenario::to_json(f).dump() << "\n" << second_line << "\n";
    }
    try {
      scenario::read_package(dir.path());
      ADD_FAILURE() << "accepted: " << second_line;
    } catch (const Error& e) {
      EXPECT_NE(std::string(e.what()).find("frames.jsonl' line 2"), std::string::npos) << e.what();
      EXPECT_NE(std::string(e.what()).find(needle), std::string::npos) << e.what();
    }
  };
  Json bad = scenario::to_json(f2);
  bad["frame"] = 2;
  fails_with(bad.dump(), "does not follow frame 3");
  bad = scenario::to_json(f2);
  bad["augmented"] = "../../etc/passwd";
  fails_with(bad.dump(), "'augmented' must be a file inside the package");
  bad = scenario::to_json(f);
  bad["frame"] = 5;
  bad["hazard"]["truncation"] = 1.5;
  fails_with(bad.dump(), "'truncation' and 'occlusion' must lie in [0, 1]");
  fails_with("{not json", "not a JSON object");
}

TEST(ScenarioPackageSink, WritesPicturesAndLabelsThatTheScenarioSourceReadsBack) {
  auto sink = testing::StageRunner::create<sinks::ScenarioPackageSink>("image_format: png");
  const CameraModel cam = camera();
  for (int i = 0; i < 3; ++i) {
    Frame orig;
    orig.index = 10 + i;
    orig.timestamp = 0.1 * i;
    orig.camera = cam;
    orig.ego.speed_mps = 8.0;
    orig.image = cv::Mat(360, 640, CV_8UC3, cv::Scalar(40, 60, 80));
    Frame aug = orig;
    aug.image = orig.image.clone();
    cv::rectangle(aug.image, cv::Rect(300, 150, 40, 30), cv::Scalar(0, 0, 255), cv::FILLED);
    HazardInstance hz;
    hz.frame_index = orig.index;
    if (i > 0) {  // placed from the second frame on
      hz.visible = true;
      hz.kind = "sudden_stop";
      hz.object_class = "car";
      hz.box = cv::Rect2f(300, 150, 40, 30);
      hz.drawn_box = cv::Rect2f(300, 150, 40, 30);
      hz.distance_m = 20.0;
      hz.intended_ttc_s = 2.0 - 0.5 * i;
      hz.occluded_fraction = 0.25;
      hz.centre_ego = {21.5, 0.0, 0.0};
      hz.heading_ego = 0.0;
      hz.size_lwh = {4.5, 1.8, 1.5};
    }
    sink.push("original", orig, orig.timestamp);
    sink.push("augmented", aug, aug.timestamp);
    sink.push("hazard", hz, orig.timestamp);
  }
  sink.run();
  const fs::path dir = sink.output_dir() / "scenario";
  const scenario::Package p = scenario::read_package(sink.output_dir());
  EXPECT_EQ(p.dir, dir);
  EXPECT_EQ(p.header.kind, "sudden_stop");
  ASSERT_EQ(p.frames.size(), 3u);
  EXPECT_FALSE(p.frames[0].hazard);
  ASSERT_TRUE(p.frames[2].hazard);
  EXPECT_EQ(p.frames[2].hazard->box, cv::Rect2f(300, 150, 40, 30));
  EXPECT_NEAR(*p.frames[2].hazard->ttc_s, 1.0, 1e-12);
  EXPECT_NEAR(p.frames[2].hazard->occlusion, 0.25, 1e-12);
  EXPECT_NEAR(p.frames[2].hazard->box3d->location_cam[2], 20.0, 1e-9);
  EXPECT_DOUBLE_EQ(*p.frames[1].ego_speed_mps, 8.0);

  auto src = testing::StageRunner::create<source::ScenarioSource>("path: " + sink.output_dir().string() +
                                                                  "\nview: augmented");
  src.run();
  const auto frames = src.collect<Frame>("frames");
  ASSERT_EQ(frames.size(), 3u);
  EXPECT_EQ(frames[1].index, 11);
  EXPECT_DOUBLE_EQ(*frames[1].ego.speed_mps, 8.0);
  EXPECT_EQ(frames[1].camera.fx, cam.fx);
  EXPECT_EQ(frames[1].image.at<cv::Vec3b>(160, 310), cv::Vec3b(0, 0, 255));  // PNG: lossless
  auto orig_src =
      testing::StageRunner::create<source::ScenarioSource>("path: " + dir.string() + "\nview: original");
  orig_src.run();
  EXPECT_EQ(orig_src.collect<Frame>("frames")[1].image.at<cv::Vec3b>(160, 310), cv::Vec3b(40, 60, 80));
}

}  // namespace
}  // namespace hf
