// Trackers on real trajectories: KITTI tracking ground-truth boxes (sequences 0000-0010, 10 Hz) fed as
// detections; the tracker's ids are compared with KITTI's track ids.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <fstream>
#include <iostream>
#include <map>
#include <set>
#include <sstream>

#include "centroid_tracker.hpp"
#include "sort_tracker.hpp"
#include "test_support.hpp"

namespace hf {
namespace {

struct LabelLine {
  int frame = 0;
  int track = -1;
  std::string type;
  cv::Rect2f box;
};

// KITTI tracking label_02: frame track_id type truncated occluded alpha x1 y1 x2 y2 h w l X Y Z ry.
std::vector<LabelLine> read_labels(const std::filesystem::path& p) {
  std::ifstream in(p);
  if (!in) throw Error("cannot open " + p.string());
  std::vector<LabelLine> out;
  std::string line;
  for (int n = 1; std::getline(in, line); ++n) {
    std::istringstream s(line);
    LabelLine l;
    double trunc, occ, alpha, x1, y1, x2, y2;
    if (!(s >> l.frame >> l.track >> l.type >> trunc >> occ >> alpha >> x1 >> y1 >> x2 >> y2))
      throw Error(p.string() + ":" + std::to_string(n) + ": not a KITTI tracking label line");
    if (l.type == "DontCare") continue;
    l.box = cv::Rect2f(static_cast<float>(x1), static_cast<float>(y1), static_cast<float>(x2 - x1),
                       static_cast<float>(y2 - y1));
    out.push_back(l);
  }
  return out;
}

std::string project_label(const std::string& t) {
  if (t == "Car" || t == "Van") return "car";
  if (t == "Truck") return "truck";
  if (t == "Pedestrian" || t == "Person_sitting") return "person";
  if (t == "Cyclist") return "bicycle";
  return t;  // Tram, Misc: kept under their own names
}

struct IdStats {
  int detections = 0;
  int switches = 0;   // a tracker id whose KITTI track changes
  int extra_ids = 0;  // tracker ids per KITTI track beyond the first
};

// Runs one tracker over the label boxes of sequences 0000-0010; the KITTI track id rides in annotation_index.
template <class T, class Cfg>
IdStats run_sequences(const Cfg& cfg) {
  IdStats s;
  for (int seq = 0; seq <= 10; ++seq) {
    char name[32];
    std::snprintf(name, sizeof name, "%04d.txt", seq);
    const auto labels = read_labels(test::shared_data("kitti-tracking/training/label_02") / name);
    int last_frame = 0;
    for (const LabelLine& l : labels) last_frame = std::max(last_frame, l.frame);
    std::map<int, std::vector<const LabelLine*>> by_frame;
    for (const LabelLine& l : labels) by_frame[l.frame].push_back(&l);

    T tracker;
    tracker.configure(cfg);
    std::map<int64_t, int> kitti_of;
    std::map<int, std::set<int64_t>> ids_of;
    for (int f = 0; f <= last_frame; ++f) {
      Frame fr;
      fr.index = f;
      fr.timestamp = 0.1 * f;
      Detections d;
      d.frame_index = f;
      d.image_size = cv::Size(1242, 375);
      for (const LabelLine* l : by_frame[f]) {
        Detection det;
        det.box = l->box;
        det.label = project_label(l->type);
        det.score = 1.f;
        det.annotation_index = l->track;
        d.items.push_back(det);
      }
      s.detections += static_cast<int>(d.items.size());
      for (const Track& t : tracker.step(d, fr).items) {
        if (t.annotation_index < 0) continue;
        auto [it, fresh] = kitti_of.emplace(t.id, t.annotation_index);
        if (!fresh && it->second != t.annotation_index) {
          ++s.switches;
          it->second = t.annotation_index;
        }
        ids_of[t.annotation_index].insert(t.id);
      }
    }
    for (const auto& [k, ids] : ids_of) s.extra_ids += static_cast<int>(ids.size()) - 1;
  }
  return s;
}

void print(const char* what, const IdStats& s) {
  std::cout << "[ measured ] " << what << ": detections=" << s.detections << " id switches=" << s.switches
            << " extra ids=" << s.extra_ids << "\n";
}

class KittiTracking : public ::testing::Test {
 protected:
  void SetUp() override { HF_REQUIRE_SHARED(test::shared_data("kitti-tracking/training/label_02/0010.txt")); }
};

// Bounds are the measured values plus about a third, so a regression in association shows up.
TEST_F(KittiTracking, CentroidWithPredictionKeepsIdentities) {
  const IdStats s = run_sequences<CentroidTracker>(CentroidTracker::Config{});
  print("centroid (greedy, predict)", s);
  EXPECT_EQ(s.detections, 17786);
  EXPECT_LE(s.switches, 40);   // measured 29
  EXPECT_LE(s.extra_ids, 30);  // measured 21
}

TEST_F(KittiTracking, PredictionIsWhatMakesCentroidTrackingWork) {
  // The original method compares with the last centre: objects passing each other swap ids far more often.
  CentroidTracker::Config original;
  original.predict = false;
  const IdStats without = run_sequences<CentroidTracker>(original);
  const IdStats with = run_sequences<CentroidTracker>(CentroidTracker::Config{});
  print("centroid (greedy, last centre)", without);
  EXPECT_GT(without.switches, 10 * with.switches);
  CentroidTracker::Config hungarian;
  hungarian.hungarian = true;
  print("centroid (hungarian, predict)", run_sequences<CentroidTracker>(hungarian));
}

TEST_F(KittiTracking, SortKeepsIdentitiesButFragments) {
  SortTracker::Config c;
  c.min_hits = 1;  // count every track, not only confirmed ones
  const IdStats s = run_sequences<SortTracker>(c);
  print("sort (iou 0.3, max_age 1)", s);
  EXPECT_LE(s.switches, 135);  // measured 102
  // SORT restarts a track whenever predicted and detected boxes overlap by less than iou_threshold: 459 of
  // the 17341 consecutive label pairs do, even with exact boxes (fast near objects, truncation at the edge).
  EXPECT_LE(s.extra_ids, 650);  // measured 505
}

// The centroid tracker's default gate, 0.1 x the image diagonal (129.7 px at 1242x375), against how far the
// labelled box centres move between consecutive frames. Measured: median 7.4 px, 99th percentile 62.8 px,
// 99.9th 109.1 px, largest 174.5 px (3 of 17341 steps exceed the gate). Also counts the steps whose boxes
// overlap by less than SORT's IoU threshold: 459.
TEST_F(KittiTracking, DefaultGateCoversFrameToFrameMotion) {
  std::vector<double> steps;
  int low_overlap = 0;  // consecutive boxes of one object with IoU < 0.3 (SORT's default threshold)
  for (int seq = 0; seq <= 10; ++seq) {
    char name[32];
    std::snprintf(name, sizeof name, "%04d.txt", seq);
    std::map<int, std::pair<int, cv::Rect2f>> last;  // KITTI track -> (frame, box)
    for (const LabelLine& l : read_labels(test::shared_data("kitti-tracking/training/label_02") / name)) {
      auto it = last.find(l.track);
      if (it != last.end() && it->second.first == l.frame - 1) {
        const cv::Rect2f& p = it->second.second;
        const cv::Point2f c(l.box.x + l.box.width / 2, l.box.y + l.box.height / 2);
        steps.push_back(cv::norm(c - cv::Point2f(p.x + p.width / 2, p.y + p.height / 2)));
        const double inter = (p & l.box).area();
        low_overlap += inter / (double(p.area()) + l.box.area() - inter) < 0.3 ? 1 : 0;
      }
      last[l.track] = {l.frame, l.box};
    }
  }
  ASSERT_EQ(steps.size(), 17341u);
  std::sort(steps.begin(), steps.end());
  const double gate = CentroidTracker::kAutoGateFraction * std::hypot(1242.0, 375.0);
  const double p99 = steps[steps.size() * 99 / 100], p999 = steps[steps.size() * 999 / 1000];
  std::cout << "[ measured ] KITTI box-centre step per frame: median " << steps[steps.size() / 2]
            << " px, p99 " << p99 << " px, p99.9 " << p999 << " px, max " << steps.back() << " px; gate "
            << gate << " px\n";
  std::cout << "[ measured ] consecutive label boxes with IoU < 0.3: " << low_overlap << "\n";
  EXPECT_LT(p999, gate);
  EXPECT_LT(std::count_if(steps.begin(), steps.end(), [&](double d) { return d > gate; }), 10);
  EXPECT_EQ(low_overlap, 459);  // the floor under SORT's fragmentation (SortKeepsIdentitiesButFragments)
}

}  // namespace
}  // namespace hf
