// Synthetic tracker tests: Hungarian solver, crossing objects, occlusion gaps, velocity, SORT prediction.
#include <gtest/gtest.h>

#include <cmath>
#include <map>
#include <optional>
#include <set>

#include "centroid_tracker.hpp"
#include "hazardforge/testing/stage_runner.hpp"
#include "hazardforge/tracking/hungarian.hpp"
#include "sort_tracker.hpp"

namespace hf {
namespace {

constexpr double kInfCost = std::numeric_limits<double>::infinity();

// One synthetic object in one frame.
struct Obj {
  cv::Rect2f box;
  std::string label = "car";
  int annotation = -1;
};

// Feeds `frames` (per-frame objects at timestamps `times`) through a tracker stage; returns its tracks.
template <class T>
std::vector<Tracks> run_tracker(const std::string& params, const std::vector<std::vector<Obj>>& frames,
                                const std::vector<double>& times) {
  testing::StageRunner r = testing::StageRunner::create<T>(params);
  for (size_t f = 0; f < frames.size(); ++f) {
    Frame fr;
    fr.index = static_cast<int64_t>(f);
    fr.timestamp = times[f];
    Detections d;
    d.frame_index = fr.index;
    d.image_size = cv::Size(1280, 720);
    for (const Obj& o : frames[f]) {
      Detection det;
      det.box = o.box;
      det.label = o.label;
      det.score = 0.9f;
      det.annotation_index = o.annotation;
      d.items.push_back(det);
    }
    r.push("frames", fr, fr.timestamp);
    r.push("detections", d, fr.timestamp);
  }
  r.run();
  return r.collect<Tracks>("tracks");
}

std::vector<double> regular_times(size_t n, double dt = 0.1) {
  std::vector<double> t(n);
  for (size_t i = 0; i < n; ++i) t[i] = static_cast<double>(i) * dt;
  return t;
}

cv::Rect2f box_at(double cx, double cy, double w = 40, double h = 30) {
  return cv::Rect2f(static_cast<float>(cx - w / 2), static_cast<float>(cy - h / 2), static_cast<float>(w),
                    static_cast<float>(h));
}

const Track* find_near(const Tracks& t, double cx, double cy, double tol = 1.0) {
  for (const Track& tr : t.items) {
    const double x = tr.box.x + tr.box.width / 2, y = tr.box.y + tr.box.height / 2;
    if (std::hypot(x - cx, y - cy) <= tol) return &tr;
  }
  return nullptr;
}

const Track* find_id(const Tracks& t, int64_t id) {
  for (const Track& tr : t.items)
    if (tr.id == id) return &tr;
  return nullptr;
}

// ---- Hungarian
// ---------------------------------------------------------------------------------------------

TEST(Hungarian, SquareOptimum) {
  // Greedy on the cheapest entry takes (0,0) = 1 and ends at 1 + 9 + 2 = 12; the optimum is
  // (0,1) + (1,0) + (2,2) = 2 + 2 + 2 = 6.
  const tracking::CostMatrix c = {{1, 2, 9}, {2, 9, 9}, {9, 9, 2}};
  const auto m = tracking::hungarian(c);
  ASSERT_EQ(m.size(), 3u);
  EXPECT_EQ(m[0], std::make_pair(0, 1));
  EXPECT_EQ(m[1], std::make_pair(1, 0));
  EXPECT_EQ(m[2], std::make_pair(2, 2));
}

TEST(Hungarian, RectangularBothWays) {
  const tracking::CostMatrix wide = {{5, 1, 7, 3}, {2, 8, 1, 9}};
  auto m = tracking::hungarian(wide);
  ASSERT_EQ(m.size(), 2u);
  EXPECT_EQ(m[0], std::make_pair(0, 1));
  EXPECT_EQ(m[1], std::make_pair(1, 2));
  const tracking::CostMatrix tall = {{5, 2}, {1, 8}, {7, 1}, {3, 9}};
  m = tracking::hungarian(tall);
  ASSERT_EQ(m.size(), 2u);
  EXPECT_EQ(m[0], std::make_pair(1, 0));
  EXPECT_EQ(m[1], std::make_pair(2, 1));
}

TEST(Hungarian, ForbiddenPairsAreNeverReturned) {
  // Row 1 can only take column 0; the solver must give row 0 column 1 even though (0,0) is cheaper.
  const tracking::CostMatrix c = {{-0.9, -0.5}, {-0.4, kInfCost}};
  auto m = tracking::hungarian(c);
  ASSERT_EQ(m.size(), 2u);
  EXPECT_EQ(m[0], std::make_pair(0, 1));
  EXPECT_EQ(m[1], std::make_pair(1, 0));
  // Nothing allowed at all: no pairs.
  EXPECT_TRUE(tracking::hungarian({{kInfCost, kInfCost}}).empty());
  EXPECT_TRUE(tracking::hungarian({}).empty());
}

// ---- Centroid tracker
// --------------------------------------------------------------------------------------

// Two cars on the same line driving head-on through each other: their centres coincide at frame 10.
std::vector<std::vector<Obj>> head_on_crossing(int n = 21, double y_a = 300, double y_b = 300) {
  std::vector<std::vector<Obj>> frames;
  for (int f = 0; f < n; ++f)
    frames.push_back({{box_at(100 + 20.0 * f, y_a, 60, 40)}, {box_at(500 - 20.0 * f, y_b, 50, 36)}});
  return frames;
}

void expect_no_swap(const std::vector<Tracks>& out, int n, double y_a, double y_b) {
  ASSERT_EQ(out.size(), static_cast<size_t>(n));
  const Track* a0 = find_near(out[0], 100, y_a);
  const Track* b0 = find_near(out[0], 500, y_b);
  ASSERT_TRUE(a0 && b0);
  const int64_t id_a = a0->id, id_b = b0->id;
  ASSERT_NE(id_a, id_b);
  for (int f = 0; f < n; ++f) {
    const Track* a = find_id(out[f], id_a);
    const Track* b = find_id(out[f], id_b);
    ASSERT_TRUE(a && b) << "frame " << f;
    // Each id stays on its own object: the box width identifies it (60 px vs 50 px).
    EXPECT_FLOAT_EQ(a->box.width, 60.f) << "frame " << f;
    EXPECT_FLOAT_EQ(b->box.width, 50.f) << "frame " << f;
    EXPECT_NEAR(a->box.x + 30, 100 + 20.0 * f, 1e-3) << "frame " << f;
  }
}

TEST(CentroidTracker, HeadOnCrossingKeepsIdsWithPrediction) {
  const auto frames = head_on_crossing();
  for (const char* assoc : {"greedy", "hungarian"}) {
    SCOPED_TRACE(assoc);
    const auto out =
        run_tracker<CentroidTracker>(std::string("association: ") + assoc, frames, regular_times(21));
    expect_no_swap(out, 21, 300, 300);
    EXPECT_EQ(out.back().items.size(), 2u);
  }
}

TEST(CentroidTracker, PassingInAdjacentLanesKeepsIdsWithoutPrediction) {
  // The original method (last centre, no prediction) separates objects that pass 40 px apart.
  const auto out =
      run_tracker<CentroidTracker>("predict: false", head_on_crossing(21, 300, 340), regular_times(21));
  expect_no_swap(out, 21, 300, 340);
}

TEST(CentroidTracker, ClassGateSeparatesCarAndPersonAtTheSamePlace) {
  // A car and a pedestrian swap positions between two frames: distance alone would swap the ids.
  std::vector<std::vector<Obj>> frames = {
      {{box_at(300, 300), "car"}, {box_at(330, 300), "person"}},
      {{box_at(330, 300), "car"}, {box_at(300, 300), "person"}},
  };
  const auto out = run_tracker<CentroidTracker>("predict: false", frames, regular_times(2));
  ASSERT_EQ(out.size(), 2u);
  const int64_t car = find_near(out[0], 300, 300)->id;
  EXPECT_EQ(find_near(out[1], 330, 300)->id, car);
  EXPECT_EQ(find_near(out[1], 330, 300)->label, "car");
  // Without the class gate the person's detection (now at the car's old place) takes the car's id.
  const auto swapped =
      run_tracker<CentroidTracker>("predict: false\nmatch_class: false", frames, regular_times(2));
  EXPECT_EQ(find_near(swapped[1], 300, 300)->id, car);
}

TEST(CentroidTracker, ClassGroupsKeepACarThatFlickersToTruck) {
  std::vector<std::vector<Obj>> frames = {
      {{box_at(300, 300), "car"}}, {{box_at(310, 300), "truck"}}, {{box_at(320, 300), "car"}}};
  auto out = run_tracker<CentroidTracker>("", frames, regular_times(3));
  ASSERT_EQ(out[2].items.size(), 1u);
  EXPECT_EQ(out[2].items[0].id, 1);
  EXPECT_EQ(out[2].items[0].label, "car");
  // Without groups the truck detection starts a second track and the first one misses.
  out = run_tracker<CentroidTracker>("class_groups: []", frames, regular_times(3));
  ASSERT_EQ(out[1].items.size(), 2u);
  EXPECT_EQ(out[1].items[0].misses, 1);
  EXPECT_EQ(out[1].items[1].id, 2);
}

TEST(ClassGroups, ParsesCommaSeparatedGroups) {
  const tracking::ClassGroups g({"car, truck,bus", "bicycle,motorcycle"});
  EXPECT_TRUE(g.same("truck", "bus"));
  EXPECT_TRUE(g.same("person", "person"));
  EXPECT_FALSE(g.same("car", "bicycle"));
  EXPECT_FALSE(g.same("person", "car"));
}

// One object moving at 5 px/frame, absent in frames [10, 10 + gap).
std::vector<std::vector<Obj>> occluded(int gap, int n = 30) {
  std::vector<std::vector<Obj>> frames;
  for (int f = 0; f < n; ++f) {
    if (f >= 10 && f < 10 + gap)
      frames.push_back({});
    else
      frames.push_back({{box_at(200 + 5.0 * f, 400)}});
  }
  return frames;
}

// Two parked cars 2.5 m apart, 20 m ahead, seen from 2 Hz keyframes while the ego turns right at 20 deg/s:
// the picture sweeps 10 deg (about 220 px at fx 1250) between frames. Moving the tracks with the ego's
// heading keeps both identities; without it the sweep is a jump the tracker cannot tell from the neighbour.
std::vector<Tracks> turning_parked_cars(bool compensate, bool poses) {
  const CameraModel cam = CameraModel::pinhole(1600, 900, 1250, 1250, 800, 450, 1.5, 0.0, 1.7);
  testing::StageRunner r = testing::StageRunner::create<CentroidTracker>(std::string("compensate_turn: ") +
                                                                         (compensate ? "true" : "false"));
  const double rate = -20.0 * CV_PI / 180.0;
  for (int f = 0; f < 6; ++f) {
    const double t = 0.5 * f, yaw = rate * t;
    Frame fr;
    fr.index = f;
    fr.timestamp = t;
    fr.camera = cam;
    if (poses) {
      cv::Matx44d T = cv::Matx44d::eye();
      T(0, 0) = T(1, 1) = std::cos(yaw);
      T(1, 0) = std::sin(yaw);
      T(0, 1) = -std::sin(yaw);
      fr.ego.T_world_ego = T;
    } else {
      fr.ego.yaw_rate = rate;
    }
    Detections d;
    d.frame_index = f;
    d.image_size = cv::Size(1600, 900);
    for (const double wy : {1.0, 3.5}) {  // world points, the ego turning in place at the origin
      const double c = std::cos(-yaw), s = std::sin(-yaw);
      const cv::Vec3d ego(c * 20.0 - s * wy, s * 20.0 + c * wy, 0.0);
      const auto px = cam.project_ego(ego);
      Detection det;
      det.box = cv::Rect2f(static_cast<float>(px->x - 40), static_cast<float>(px->y - 60), 80.f, 60.f);
      det.label = "car";
      det.score = 0.9f;
      d.items.push_back(det);
    }
    r.push("frames", fr, t);
    r.push("detections", d, t);
  }
  r.run();
  return r.collect<Tracks>("tracks");
}

TEST(CentroidTracker, TurnCompensationKeepsIdentitiesWhileTheEgoTurns) {
  for (const bool poses : {true, false}) {
    const auto out = turning_parked_cars(true, poses);
    ASSERT_EQ(out.size(), 6u);
    for (const Tracks& t : out) {
      std::set<int64_t> ids;
      for (const Track& tr : t.items)
        if (tr.misses == 0) ids.insert(tr.id);
      EXPECT_EQ(ids, (std::set<int64_t>{1, 2}))
          << (poses ? "poses" : "yaw rate") << ", frame " << t.frame_index;
    }
  }
  // Without it, new identities are born in the turn.
  const auto plain = turning_parked_cars(false, true);
  int64_t highest = 0;
  for (const Tracks& t : plain)
    for (const Track& tr : t.items) highest = std::max(highest, tr.id);
  EXPECT_GT(highest, 2);
}

TEST(CentroidTracker, ShortOcclusionKeepsTheId) {
  const int gap = 4;
  const auto out = run_tracker<CentroidTracker>("max_disappeared: 5", occluded(gap), regular_times(30));
  ASSERT_EQ(out.size(), 30u);
  for (int f = 0; f < 30; ++f) {
    ASSERT_EQ(out[f].items.size(), 1u) << "frame " << f;
    const Track& t = out[f].items[0];
    EXPECT_EQ(t.id, 1) << "frame " << f;
    EXPECT_EQ(t.age, f);
    if (f >= 10 && f < 10 + gap) {
      EXPECT_EQ(t.misses, f - 9);
      EXPECT_EQ(t.detection_index, -1);
      EXPECT_NEAR(t.box.x + t.box.width / 2, 200 + 5.0 * 9, 1e-3);  // held at the last seen box
    } else {
      EXPECT_EQ(t.misses, 0);
      EXPECT_EQ(t.detection_index, 0);
    }
  }
  EXPECT_EQ(out.back().items[0].hits, 30 - gap);
}

TEST(CentroidTracker, LongOcclusionDropsTheTrackAndANewIdIsBorn) {
  const int gap = 8;
  const auto out = run_tracker<CentroidTracker>("max_disappeared: 5", occluded(gap), regular_times(30));
  // Misses 1..5 are still reported; the 6th miss (frame 15) drops the track.
  EXPECT_EQ(out[14].items.size(), 1u);
  EXPECT_EQ(out[14].items[0].misses, 5);
  EXPECT_TRUE(out[15].items.empty());
  ASSERT_EQ(out[18].items.size(), 1u);
  EXPECT_EQ(out[18].items[0].id, 2);
  EXPECT_EQ(out[18].items[0].hits, 1);
  EXPECT_EQ(out[29].items[0].id, 2);
}

TEST(CentroidTracker, VelocityIsExactForConstantMotionWithIrregularTimestamps) {
  // Centre moves at (150, -40) px/s; frames arrive at irregular times, one frame without a detection.
  const std::vector<double> times = {0.0, 0.04, 0.1, 0.13, 0.2, 0.31, 0.4, 0.45};
  std::vector<std::vector<Obj>> frames;
  for (size_t f = 0; f < times.size(); ++f) {
    if (f == 5)
      frames.push_back({});
    else
      frames.push_back({{box_at(300 + 150 * times[f], 500 - 40 * times[f]), "car", 7}});
  }
  const auto out = run_tracker<CentroidTracker>("velocity_smoothing: 0.3", frames, times);
  ASSERT_EQ(out.size(), times.size());
  EXPECT_FLOAT_EQ(out[0].items[0].velocity_px.x, 0.f);  // one observation: unknown, reported as zero
  for (size_t f = 1; f < times.size(); ++f) {
    ASSERT_EQ(out[f].items.size(), 1u);
    EXPECT_NEAR(out[f].items[0].velocity_px.x, 150.0, 1e-2) << "frame " << f;
    EXPECT_NEAR(out[f].items[0].velocity_px.y, -40.0, 1e-2) << "frame " << f;
    EXPECT_EQ(out[f].items[0].annotation_index, f == 5 ? -1 : 7);
  }
}

TEST(CentroidTracker, GateRefusesFarJumpsAndLabelIsTheMajority) {
  // 0.1 x diag(1280x720) = 146.9 px: a jump of 150 px starts a new track, 140 px does not.
  std::vector<std::vector<Obj>> frames = {{{box_at(100, 100), "car"}},
                                          {{box_at(240, 100), "truck"}},
                                          {{box_at(240, 100), "car"}},
                                          {{box_at(390, 100), "car"}}};
  const auto out =
      run_tracker<CentroidTracker>("predict: false\nmatch_class: false", frames, regular_times(4));
  EXPECT_EQ(out[1].items.size(), 1u);
  EXPECT_EQ(out[1].items[0].id, 1);
  EXPECT_EQ(out[2].items[0].label, "car");  // car 2 : truck 1
  ASSERT_EQ(out[3].items.size(), 2u);
  EXPECT_EQ(out[3].items[1].id, 2);
  EXPECT_EQ(out[3].items[0].misses, 1);
}

TEST(CentroidTracker, NonIncreasingTimestampIsAnError) {
  CentroidTracker t;
  Frame f0, f1;
  f0.index = 0;
  f0.timestamp = 0.5;
  f1.index = 1;
  f1.timestamp = 0.5;
  Detections d;
  d.image_size = cv::Size(100, 100);
  t.step(d, f0);
  try {
    t.step(d, f1);
    FAIL();
  } catch (const Error& e) {
    EXPECT_EQ(std::string(e.what()),
              "centroid tracker: frame 1 has timestamp 0.500000 s, not after frame 0 at 0.500000 s");
  }
}

// ---- SORT
// --------------------------------------------------------------------------------------------------

TEST(SortTracker, KalmanPredictionCarriesTheTrackThroughAGap) {
  // 40 px wide box moving 15 px/frame; absent for 4 frames. After the gap it has moved 75 px: the last seen
  // box no longer overlaps it at all, so only the constant-velocity prediction can re-associate it.
  const int n = 24, gap_start = 12, gap = 4;
  std::vector<std::vector<Obj>> frames;
  for (int f = 0; f < n; ++f) {
    if (f >= gap_start && f < gap_start + gap)
      frames.push_back({});
    else
      frames.push_back({{box_at(100 + 15.0 * f, 300, 40, 80)}});
  }
  const auto out = run_tracker<SortTracker>("max_age: 5\nemit_unmatched: true", frames, regular_times(n));
  ASSERT_EQ(out.size(), static_cast<size_t>(n));
  for (int f = 0; f < n; ++f) {
    ASSERT_EQ(out[f].items.size(), 1u) << "frame " << f;
    const Track& t = out[f].items[0];
    EXPECT_EQ(t.id, 1) << "frame " << f;
    const double cx = t.box.x + t.box.width / 2, truth = 100 + 15.0 * f;
    if (f >= gap_start && f < gap_start + gap) {
      EXPECT_EQ(t.misses, f - gap_start + 1);
      EXPECT_NEAR(cx, truth, 2.0) << "predicted centre, frame " << f;
      EXPECT_NEAR(t.box.width, 40.0, 1.0);
    } else {
      EXPECT_EQ(t.misses, 0);
      EXPECT_NEAR(cx, truth, f < 3 ? 15.0 : 2.0) << "frame " << f;
    }
  }
  // The held (unpredicted) box of the last seen frame does not overlap the reappearing object.
  EXPECT_EQ(box_iou(box_at(100 + 15.0 * (gap_start - 1), 300, 40, 80),
                    box_at(100 + 15.0 * (gap_start + gap), 300, 40, 80)),
            0.0);
  EXPECT_NEAR(out.back().items[0].velocity_px.x, 150.0, 1e-2);  // 15 px per 0.1 s
}

TEST(SortTracker, WithoutPredictionTheSameGapWouldBreakTheTrack) {
  // Same scene with max_age shorter than the gap: the track dies and the object gets a new id.
  const int n = 24;
  std::vector<std::vector<Obj>> frames;
  for (int f = 0; f < n; ++f)
    frames.push_back(f >= 12 && f < 16 ? std::vector<Obj>{}
                                       : std::vector<Obj>{{box_at(100 + 15.0 * f, 300, 40, 80)}});
  const auto out = run_tracker<SortTracker>("max_age: 2", frames, regular_times(n));
  EXPECT_TRUE(out[12].items.empty());  // SORT emits only tracks matched this frame
  // Reborn at frame 16; confirmed after min_hits = 3 consecutive hits (frame 18).
  EXPECT_TRUE(out[16].items.empty());
  EXPECT_TRUE(out[17].items.empty());
  ASSERT_EQ(out[18].items.size(), 1u);
  EXPECT_EQ(out[18].items[0].id, 2);
  EXPECT_EQ(out[18].items[0].hits, 3);
}

TEST(SortTracker, CrossingObjectsKeepTheirIds) {
  const auto out = run_tracker<SortTracker>("min_hits: 1", head_on_crossing(), regular_times(21));
  ASSERT_EQ(out.size(), 21u);
  const int64_t id_a = find_near(out[0], 100, 300)->id, id_b = find_near(out[0], 500, 300)->id;
  for (int f = 0; f < 21; ++f) {
    if (f == 10) continue;  // both centres coincide; the Kalman estimate sits between them for one frame
    const Track* a = find_id(out[f], id_a);
    const Track* b = find_id(out[f], id_b);
    ASSERT_TRUE(a && b) << "frame " << f;
    EXPECT_NEAR(a->box.x + a->box.width / 2, 100 + 20.0 * f, 6.0) << "frame " << f;
    EXPECT_NEAR(b->box.x + b->box.width / 2, 500 - 20.0 * f, 6.0) << "frame " << f;
  }
}

TEST(SortTracker, MinHitsSuppressesOneFrameFalsePositives) {
  // A steady car, and at frame 6 a one-frame ghost elsewhere; at frame 8 a new car that stays.
  std::vector<std::vector<Obj>> frames;
  for (int f = 0; f < 14; ++f) {
    std::vector<Obj> v = {{box_at(400 + 2.0 * f, 300), "car", 3}};
    if (f == 6) v.push_back({box_at(900, 500), "person"});
    if (f >= 8) v.push_back({box_at(100, 600 - 3.0 * f), "bus"});
    frames.push_back(v);
  }
  const auto out = run_tracker<SortTracker>("", frames, regular_times(14));
  for (int f = 0; f < 14; ++f) {
    const size_t expected = f < 10 ? 1u : 2u;  // bus confirmed at its 3rd hit (frame 10)
    ASSERT_EQ(out[f].items.size(), expected) << "frame " << f;
    EXPECT_EQ(out[f].items[0].id, 1);
    EXPECT_EQ(out[f].items[0].annotation_index, 3);
    EXPECT_EQ(out[f].items[0].detection_index, 0);
  }
  EXPECT_EQ(out[10].items[1].id, 3);  // the ghost took id 2, never shown
  EXPECT_EQ(out[10].items[1].label, "bus");
}

TEST(SortTracker, InvalidParamsRefused) {
  EXPECT_THROW(testing::StageRunner::create<SortTracker>("max_age: 0"), DiagnosticError);
  EXPECT_THROW(testing::StageRunner::create<SortTracker>("iou_threshold: 1.5"), DiagnosticError);
  EXPECT_THROW(testing::StageRunner::create<CentroidTracker>("association: optimal"), DiagnosticError);
}

}  // namespace
}  // namespace hf
