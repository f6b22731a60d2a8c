// Real-data perception checks on nuScenes scene-0916 (41 CAM_FRONT keyframes): projected annotations against
// YOLOv8n / YOLOX-Nano detections, and the trackers' identities against annotation instances.
#include <gtest/gtest.h>

#include <iostream>
#include <map>
#include <numeric>
#include <set>

#include "centroid_tracker.hpp"
#include "ground_truth_detector.hpp"
#include "hazardforge/testing/stage_runner.hpp"
#include "nuscenes_source.hpp"
#include "sort_tracker.hpp"
#include "test_support.hpp"
#include "yolo_detector.hpp"

namespace hf {
namespace {

namespace fs = std::filesystem;

const std::vector<Frame>& scene_frames() {
  static const std::vector<Frame> frames = [] {
    auto r = testing::StageRunner::create<source::NuScenesSource>("dataroot: " +
                                                                  test::shared_data("nuscenes").string());
    r.run();
    return r.collect<Frame>("frames");
  }();
  return frames;
}

// Annotations projected with the default filters (six road-user labels, at least one lidar/radar point).
const std::vector<Detections>& projected() {
  static const std::vector<Detections> out = [] {
    GroundTruthDetector g;
    std::vector<Detections> v;
    for (const Frame& f : scene_frames()) v.push_back(g.detect_frame(f));
    return v;
  }();
  return out;
}

const std::vector<std::vector<Detection>>& yolo_on_scene(const std::string& which) {
  static std::map<std::string, std::vector<std::vector<Detection>>> cache;
  auto it = cache.find(which);
  if (it != cache.end()) return it->second;
  YoloDetector det;
  YoloDetector::Config c;
  if (which == "yolov8n") {
    c.model = test::shared_model("yolov8n/yolov8n_deq_640x384.onnx");
  } else {
    c.model = test::shared_model("yolox_nano/yolox_nano.onnx");
    c.input_width = 640;
    c.input_height = 384;
  }
  det.load(c);
  std::vector<std::vector<Detection>> all;
  for (const Frame& f : scene_frames()) all.push_back(det.detect_image(f.image));
  return cache[which] = all;
}

double iou(const cv::Rect2f& a, const cv::Rect2f& b) {
  const double inter = (cv::Rect2d(a) & cv::Rect2d(b)).area();
  return inter / (double(a.area()) + double(b.area()) - inter);
}

bool vehicle(const std::string& l) {
  return l == "car" || l == "truck" || l == "bus";
}

struct Overlap {
  int n = 0;
  double mean = 0.0;
  double matched_half = 0.0;  // fraction with best IoU > 0.5
};

// Best IoU of a same-class detection for each well-observed, untruncated annotated object of `label`:
// at least `min_points` lidar+radar points and its projected box wholly inside the image.
Overlap overlap(const std::string& model, const std::string& label, int min_points) {
  const auto& frames = scene_frames();
  const auto& dets = yolo_on_scene(model);
  std::vector<double> best;
  for (size_t f = 0; f < frames.size(); ++f) {
    const cv::Size sz = frames[f].image.size();
    for (const Detection& g : projected()[f].items) {
      if (g.label != label) continue;
      const AnnotatedObject& o = frames[f].annotations->objects[g.annotation_index];
      if (o.num_points < min_points) continue;
      if (g.box.x <= 1 || g.box.y <= 1 || g.box.x + g.box.width >= sz.width - 1 ||
          g.box.y + g.box.height >= sz.height - 1)
        continue;
      double b = 0.0;
      for (const Detection& d : dets[f])
        if (label == "car" ? vehicle(d.label) : d.label == label) b = std::max(b, iou(d.box, g.box));
      best.push_back(b);
    }
  }
  Overlap o;
  o.n = static_cast<int>(best.size());
  if (o.n == 0) return o;
  o.mean = std::accumulate(best.begin(), best.end(), 0.0) / o.n;
  o.matched_half =
      static_cast<double>(std::count_if(best.begin(), best.end(), [](double x) { return x > 0.5; })) / o.n;
  return o;
}

class NuScenesPerception : public ::testing::Test {
 protected:
  void SetUp() override {
    HF_REQUIRE_SHARED(test::shared_data("nuscenes/v1.0-mini/sample_annotation.json"));
    HF_REQUIRE_SHARED(test::shared_model("yolov8n/yolov8n_deq_640x384.onnx"));
    HF_REQUIRE_SHARED(test::shared_model("yolox_nano/yolox_nano.onnx"));
  }
};

TEST_F(NuScenesPerception, AnnotationsProjectIntoEveryFrame) {
  ASSERT_EQ(scene_frames().size(), 41u);
  int total = 0;
  for (size_t f = 0; f < projected().size(); ++f) {
    const Detections& d = projected()[f];
    EXPECT_EQ(d.image_size, cv::Size(1600, 900));
    for (const Detection& g : d.items) {
      ASSERT_GE(g.annotation_index, 0);
      const AnnotatedObject& o = scene_frames()[f].annotations->objects[g.annotation_index];
      EXPECT_EQ(g.label, o.label);
      EXPECT_GT(o.center_ego[0], 0.0) << "an object behind the ego vehicle projected into the front camera";
    }
    total += static_cast<int>(d.items.size());
  }
  // scene-0916 is a campus road lined with parked cars and a crowded bus stop.
  EXPECT_GT(total, 300);
}

// One test for cars, pedestrians and the shifted-box control, so the 41 frames go through each network once
// per process (ctest runs every test in its own process).
//
// Cars. The rectangle around a projected 3D box is systematically larger than the tight box a detector draws
// (it encloses the far corners of cars seen at an angle), and nuScenes' visibility table is not available to
// drop occluded objects, so even a perfect detector stays well below IoU 1. Measured on this scene over the
// untruncated cars with >= 10 lidar+radar points (92 objects): mean best IoU 0.633 (YOLOv8n) and 0.635
// (YOLOX-Nano), 78-79 % of them above 0.5. The thresholds sit 0.08 / 0.13 below that.
//
// Pedestrians are harder: most of scene-0916's stand in a crowd at a bus shelter, partly hidden behind each
// other. Measured over the untruncated ones with >= 5 points (77): mean best IoU 0.363 (YOLOv8n), 0.531
// (YOLOX-Nano).
//
// Control: the same comparison with every annotated car box moved sideways by its own width must collapse,
// so the agreement above is not an artefact of large boxes overlapping everything.
TEST_F(NuScenesPerception, DetectionsOverlapProjectedAnnotations) {
  for (const char* model : {"yolov8n", "yolox_nano"}) {
    const Overlap cars = overlap(model, "car", 10);
    std::cout << "[ measured ] " << model << " cars (>=10 pts, untruncated): n=" << cars.n
              << " mean best IoU=" << cars.mean << " share IoU>0.5=" << cars.matched_half << "\n";
    EXPECT_GE(cars.n, 80) << model;
    EXPECT_GT(cars.mean, 0.55) << model;
    EXPECT_GT(cars.matched_half, 0.65) << model;

    const Overlap peds = overlap(model, "person", 5);
    std::cout << "[ measured ] " << model << " pedestrians (>=5 pts, untruncated): n=" << peds.n
              << " mean best IoU=" << peds.mean << " share IoU>0.5=" << peds.matched_half << "\n";
    EXPECT_GE(peds.n, 60) << model;
    EXPECT_GT(peds.mean, 0.30) << model;
  }

  const auto& dets = yolo_on_scene("yolov8n");
  std::vector<double> best;
  for (size_t f = 0; f < scene_frames().size(); ++f)
    for (const Detection& g : projected()[f].items) {
      if (g.label != "car" || scene_frames()[f].annotations->objects[g.annotation_index].num_points < 10)
        continue;
      cv::Rect2f moved = g.box;
      moved.x += moved.width;
      double b = 0.0;
      for (const Detection& d : dets[f])
        if (vehicle(d.label)) b = std::max(b, iou(d.box, moved));
      best.push_back(b);
    }
  ASSERT_FALSE(best.empty());
  const double shifted = std::accumulate(best.begin(), best.end(), 0.0) / best.size();
  std::cout << "[ measured ] yolov8n vs car boxes shifted by their width: mean best IoU=" << shifted << "\n";
  EXPECT_LT(shifted, 0.3);
}

// With perfect detections (projected annotations) a tracker's ids should follow annotation instances. An id
// switch is a track whose matched instance changes; fragmentation counts extra ids per instance.
struct IdStats {
  int switches = 0;
  int instances = 0;
  int ids = 0;
};

template <class T>
IdStats track_annotations(const std::string& params) {
  testing::StageRunner r = testing::StageRunner::create<T>(params);
  for (size_t f = 0; f < scene_frames().size(); ++f) {
    r.push("frames", scene_frames()[f], scene_frames()[f].timestamp);
    r.push("detections", projected()[f], scene_frames()[f].timestamp);
  }
  r.run();
  const auto tracks = r.collect<Tracks>("tracks");
  EXPECT_EQ(tracks.size(), scene_frames().size());
  std::map<int64_t, std::string> instance_of_track;
  std::map<std::string, std::set<int64_t>> ids_of_instance;
  IdStats s;
  for (size_t f = 0; f < tracks.size(); ++f)
    for (const Track& t : tracks[f].items) {
      if (t.annotation_index < 0) continue;
      const std::string& inst = scene_frames()[f].annotations->objects[t.annotation_index].instance_id;
      auto [it, fresh] = instance_of_track.emplace(t.id, inst);
      if (!fresh && it->second != inst) {
        ++s.switches;
        it->second = inst;
      }
      ids_of_instance[inst].insert(t.id);
    }
  s.instances = static_cast<int>(ids_of_instance.size());
  for (const auto& [inst, ids] : ids_of_instance) s.ids += static_cast<int>(ids.size());
  return s;
}

// The keyframes are 0.5 s apart: parked cars along the road move 200-300 px between keyframes, more than
// the spacing between neighbouring cars, and a crowd at a bus stop swaps places, so identities are largely
// lost even with perfect boxes (KITTI at 10 Hz, kitti_tracking_test, shows the same trackers keeping them).
// Measured over all 492 projected boxes (60 instances): centroid 311 ids / 236 switches, SORT (min_hits 1,
// max_age 2) 355 ids / 194 switches. The bounds below are those numbers plus about a fifth, as a regression
// guard; use a 10 Hz+ stream (nuScenes sweeps) to track.
TEST_F(NuScenesPerception, TrackersOnTwoHertzKeyframes) {
  const IdStats c = track_annotations<CentroidTracker>("");
  const IdStats s = track_annotations<SortTracker>("min_hits: 1\nmax_age: 2");
  std::cout << "[ measured ] centroid on projected annotations: instances=" << c.instances << " ids=" << c.ids
            << " switches=" << c.switches << "\n";
  std::cout << "[ measured ] sort on projected annotations: instances=" << s.instances << " ids=" << s.ids
            << " switches=" << s.switches << "\n";
  EXPECT_EQ(c.instances, 60);
  EXPECT_LE(c.switches, 285);
  EXPECT_LE(s.switches, 235);
}

}  // namespace
}  // namespace hf
