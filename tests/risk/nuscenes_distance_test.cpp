// Monocular distance on the real nuScenes camera: annotated boxes projected into the image (the ground-truth
// detector) are placed by the pinhole and ground methods and compared with the annotated near-face position.
#include <gtest/gtest.h>

#include <cmath>
#include <iostream>

#include "evaluation_report.hpp"
#include "ground_truth_detector.hpp"
#include "hazardforge/testing/stage_runner.hpp"
#include "monocular_estimator.hpp"
#include "nuscenes_source.hpp"
#include "test_support.hpp"

namespace hf {
namespace {

struct Errors {
  std::vector<double> rel, lat;
};

// Relative longitudinal error and absolute lateral error (m) over every visible, unclipped vehicle / person
// box within 40 m.
Errors distance_errors(const std::vector<Packet>& frames, const std::string& label,
                       const std::string& method) {
  GroundTruthDetector det;
  det.configure(GroundTruthDetector::Config{});
  Errors e;
  for (const Packet& p : frames) {
    const Frame& f = p.get<Frame>();
    const Detections d = det.detect_frame(f);
    Tracks tracks;
    tracks.frame_index = f.index;
    for (const Detection& x : d.items) {
      if (x.label != label) continue;
      // Boxes cut by the image border have lost their height or their bottom edge.
      if (x.box.x <= 1 || x.box.y <= 1 || x.box.x + x.box.width >= f.camera.width - 1 ||
          x.box.y + x.box.height >= f.camera.height - 1)
        continue;
      Track t;
      t.id = x.annotation_index;
      t.label = x.label;
      t.box = x.box;
      t.annotation_index = x.annotation_index;
      tracks.items.push_back(t);
    }
    auto r = testing::StageRunner::create<MonocularEstimator>(
        "{distance_origin: ego_origin, distance_method: " + method + "}");
    r.push("tracks", tracks, f.timestamp);
    r.push("frames", f, f.timestamp);
    r.run();
    const std::vector<ObjectStates> states = r.collect<ObjectStates>("states");
    for (const ObjectState& s : states.at(0).objects) {
      const AnnotatedObject& a = f.annotations->objects.at(static_cast<size_t>(s.annotation_index));
      const double yaw = a.yaw_ego;
      const double near_x = a.center_ego[0] - (a.size_lwh[0] / 2 * std::abs(std::cos(yaw)) +
                                               a.size_lwh[1] / 2 * std::abs(std::sin(yaw)));
      if (near_x > 40.0 || near_x < 3.0) continue;
      e.rel.push_back(std::abs(s.distance_m - near_x) / near_x);
      e.lat.push_back(std::abs(s.lateral_m - a.center_ego[1]));
    }
  }
  return e;
}

TEST(NuScenesDistance, PinholeAndGroundOnProjectedAnnotations) {
  HF_REQUIRE_SHARED(test::shared_data("nuscenes/v1.0-mini/sample_annotation.json"));
  auto src = testing::StageRunner::create<source::NuScenesSource>("dataroot: " +
                                                                  test::shared_data("nuscenes").string());
  src.run();
  const std::vector<Packet>& frames = src.outputs("frames");
  ASSERT_EQ(frames.size(), 41u);
  // label, method, boxes, bound on the median relative distance error, on the median lateral error (m).
  struct Case {
    std::string label, method;
    size_t boxes;
    double rel, lat;
  };
  // The ground method assumes a flat road through the ego origin; in this parking lot the annotated objects'
  // bottoms sit 0.1-0.25 m above that plane, so the ground range is long by 15-20 %.
  for (const Case& c :
       {Case{"car", "pinhole", 161, 0.06, 0.7}, Case{"car", "ground", 161, 0.22, 1.2},
        Case{"person", "pinhole", 113, 0.05, 0.25}, Case{"person", "ground", 113, 0.24, 1.0}}) {
    const Errors e = distance_errors(frames, c.label, c.method);
    std::cout << c.label << " " << c.method << ": " << e.rel.size()
              << " boxes, median relative distance error " << eval::median(e.rel) << ", median lateral error "
              << eval::median(e.lat) << " m\n";
    EXPECT_EQ(e.rel.size(), c.boxes) << c.label;
    EXPECT_LT(eval::median(e.rel), c.rel) << c.label << " " << c.method;
    EXPECT_LT(eval::median(e.lat), c.lat) << c.label << " " << c.method;
  }
}

}  // namespace
}  // namespace hf
