// Kalman estimator and keypoint scale TTC on synthetic data of known geometry: constant velocity, braking,
// occlusion gaps, truncated boxes, label flips, impossible jumps, pure image scaling with noise and outliers.
#include <gtest/gtest.h>

#include <cmath>
#include <functional>
#include <map>

#include <opencv2/imgproc.hpp>

#include "hazardforge/estimation/keypoint_scale.hpp"
#include "hazardforge/estimation/range_alignment.hpp"
#include "hazardforge/estimation/track_filter.hpp"
#include "hazardforge/testing/stage_runner.hpp"
#include "kalman_estimator.hpp"
#include "synthetic.hpp"
#include "ttc_keypoints_metric.hpp"
#include "ttc_paper_metric.hpp"

namespace hf {
namespace {

using test::box_of;
using test::frame_at;
using test::front_camera;
using test::track;

constexpr double kCarH = 1.52, kCarW = 1.85, kTruckH = 3.0;  // share/class_sizes.yaml
constexpr double kCamX = 1.7, kBumper = 3.4;

struct Step {
  Frame frame;
  Tracks tracks;
};

std::vector<ObjectStates> run_kalman(const std::string& params, const std::vector<Step>& seq) {
  auto r = testing::StageRunner::create<KalmanEstimator>(params);
  for (const Step& s : seq) {
    r.push("frames", s.frame, s.frame.timestamp);
    r.push("tracks", s.tracks, s.frame.timestamp);
  }
  r.run();
  return r.collect<ObjectStates>("states");
}

const ObjectState* find(const ObjectStates& s, int64_t id) {
  for (const ObjectState& o : s.objects)
    if (o.track_id == id) return &o;
  return nullptr;
}

// A car ahead in the ego's lane whose near face is at ego x = x(t); box edges jittered by `noise_px`.
std::vector<Step> lead_sequence(int n, double dt, double ego_speed,
                                const std::function<double(double)>& x_of_t, double noise_px,
                                const std::string& label = "car", double height = kCarH) {
  const CameraModel cam = front_camera();
  cv::RNG rng(7);
  std::vector<Step> seq;
  for (int k = 0; k < n; ++k) {
    const double t = k * dt;
    cv::Rect2f b = box_of(cam, x_of_t(t), 0.2, height, kCarW);
    b.y += static_cast<float>(rng.gaussian(noise_px));
    b.height += static_cast<float>(rng.gaussian(noise_px));
    b.x += static_cast<float>(rng.gaussian(noise_px));
    Step s{frame_at(k, t, cam, ego_speed), {}};
    s.tracks.frame_index = k;
    s.tracks.items = {track(1, label, b)};
    seq.push_back(std::move(s));
  }
  return seq;
}

TEST(KalmanEstimator, ConstantVelocityConvergesAndItsIntervalHoldsTheTruth) {
  // Ego at 12 m/s, lead car at 7 m/s starting 40 m ahead of the ego origin: closing 5 m/s.
  auto x_of = [](double t) { return 40.0 - 5.0 * t; };
  const auto seq = lead_sequence(40, 0.1, 12.0, x_of, 1.0);
  const auto out = run_kalman("keypoints: false", seq);
  ASSERT_EQ(out.size(), seq.size());
  int inside = 0, scored = 0;
  double prev_sigma = 1e9;
  for (size_t k = 20; k < out.size(); ++k) {
    const ObjectState* s = find(out[k], 1);
    ASSERT_NE(s, nullptr);
    ASSERT_TRUE(s->velocity_rel && s->covariance);
    const double t = k * 0.1;
    // 1 px of jitter on a 50-70 px box is 1-2 % of range per frame: a 2.5 m/s^2 process noise keeps the
    // filter responsive, so the velocity wanders by about a metre per second — and the filter says so.
    const double sigma_v = std::sqrt((*s->covariance)(2, 2));
    EXPECT_NEAR((*s->velocity_rel)[0], -5.0, 1.6) << "frame " << k;
    EXPECT_LT(std::abs((*s->velocity_rel)[0] + 5.0), 3.0 * sigma_v) << "frame " << k;
    EXPECT_NEAR(s->distance_m, x_of(t) - kBumper, 0.05 * (x_of(t) - kBumper)) << "frame " << k;
    EXPECT_NEAR(*s->speed_mps, 7.0, 1.6);
    EXPECT_LT(sigma_v, 2.0);
    if (k > 25) {
      EXPECT_LE(sigma_v, prev_sigma * 1.05);  // the filter settles, it does not wander
    }
    prev_sigma = sigma_v;
  }
  // The paper's TTC on the filtered states, with its interval.
  auto m = testing::StageRunner::create<TtcPaperMetric>("");
  for (const ObjectStates& s : out) m.push("states", s, s.timestamp);
  m.run();
  const auto risks = m.collect<RiskAssessment>("risk");
  for (size_t k = 20; k < risks.size(); ++k) {
    ASSERT_EQ(risks[k].objects.size(), 1u);
    const ObjectRisk& o = risks[k].objects[0];
    // The truth against the estimate's own distance (the class-height prior's error is a constant scale).
    const double truth = (x_of(k * 0.1) - kBumper) / 5.0;
    ++scored;
    if (o.low <= truth && truth <= o.high) ++inside;
    EXPECT_LT(o.low, o.value);
    EXPECT_GT(o.high, o.value);
  }
  EXPECT_GE(inside, scored * 8 / 10) << inside << " of " << scored << " intervals hold the true TTC";
}

TEST(KalmanEstimator, FollowsABrakingLeadWithBoundedLag) {
  // Both at 15 m/s, lead 25 m ahead brakes at 4 m/s^2 from t = 1 s (to a stop at t = 4.75 s).
  auto x_of = [](double t) {
    const double tb = std::max(0.0, std::min(t, 4.75) - 1.0);
    const double lead = 15.0 * std::min(t, 1.0) + 15.0 * tb - 2.0 * tb * tb + 0.0;
    return 25.0 + lead - 15.0 * t;
  };
  const auto seq = lead_sequence(40, 0.1, 15.0, x_of, 0.5);  // until the gap is 5 m
  const auto out = run_kalman("keypoints: false", seq);
  for (size_t k = 25; k < out.size(); ++k) {
    const ObjectState* s = find(out[k], 1);
    ASSERT_NE(s, nullptr);
    ASSERT_TRUE(s->velocity_rel);
    const double t = k * 0.1, tb = std::max(0.0, std::min(t, 4.75) - 1.0);
    const double v_lead = 15.0 - 4.0 * tb;
    // Constant-velocity model behind a 4 m/s^2 deceleration: within 2.5 m/s of the true closing speed.
    EXPECT_NEAR((*s->velocity_rel)[0], v_lead - 15.0, 2.5) << "t = " << t;
    EXPECT_LT((*s->velocity_rel)[0], -1.0) << "t = " << t;
  }
}

TEST(KalmanEstimator, PredictsThroughAnOcclusionGapWithoutRestarting) {
  auto x_of = [](double t) { return 30.0 - 4.0 * t; };
  auto seq = lead_sequence(30, 0.1, 10.0, x_of, 0.5);
  for (int k = 15; k < 18; ++k) seq[k].tracks.items[0].misses = k - 14;  // held box for three frames
  const auto out = run_kalman("keypoints: false\nmax_gap_s: 0.45", seq);
  const ObjectState* before = find(out[14], 1);
  ASSERT_NE(before, nullptr);
  const double sigma_before = std::sqrt((*before->covariance)(0, 0));
  for (int k = 15; k < 18; ++k) {
    const ObjectState* s = find(out[k], 1);
    ASSERT_NE(s, nullptr);
    EXPECT_EQ(s->distance_method, "predicted");
    EXPECT_NEAR(s->distance_m, x_of(k * 0.1) - kBumper, 1.5);
    EXPECT_GT(std::sqrt((*s->covariance)(0, 0)), sigma_before);  // uncertainty grows while unobserved
  }
  const ObjectState* after = find(out[18], 1);
  ASSERT_NE(after, nullptr);
  EXPECT_NE(after->distance_method, "rejected");  // the reappearing box is where the prediction expects it
  ASSERT_TRUE(after->velocity_rel);
  EXPECT_NEAR((*after->velocity_rel)[0], -4.0, 1.0);
}

TEST(KalmanEstimator, TruncatedBoxesGiveNoRangeOfTheCutEdge) {
  const CameraModel cam = front_camera();
  KalmanEstimator::Config c;
  const cv::Rect2f whole = box_of(cam, 20.0, 0.0, kCarH, kCarW);
  const RangeCue both = KalmanEstimator::range_cue(cam, whole, 0, kCarH, c);
  ASSERT_TRUE(both.pinhole_depth && both.ground_depth);
  EXPECT_EQ(both.method, "fused");
  EXPECT_NEAR(*both.depth, 20.0 - kCamX, 0.05);
  // Fused variance is below either cue's.
  EXPECT_LT(*both.var, std::min(*both.pinhole_var, *both.ground_var));
  const RangeCue bottom = KalmanEstimator::range_cue(cam, whole, truncation::kBottom, kCarH, c);
  EXPECT_FALSE(bottom.pinhole_depth);
  EXPECT_FALSE(bottom.ground_depth);
  EXPECT_EQ(bottom.method, "");
  const RangeCue top = KalmanEstimator::range_cue(cam, whole, truncation::kTop, kCarH, c);
  EXPECT_FALSE(top.pinhole_depth);
  ASSERT_TRUE(top.ground_depth);
  EXPECT_EQ(top.method, "ground");
  // The ground range's error grows with distance faster than the pinhole's.
  const RangeCue far = KalmanEstimator::range_cue(cam, box_of(cam, 60.0, 0.0, kCarH, kCarW), 0, kCarH, c);
  EXPECT_GT(*far.ground_var / *far.pinhole_var, *both.ground_var / *both.pinhole_var);

  // A lead whose lower part leaves the image: its range goes on predicted, never from the cut box's height,
  // and only its column is measured (bearing) — for max_gap_s without any range or scale measurement
  // (keypoints off here), then it is no longer reported.
  auto x_of = [](double t) { return 12.0 - 2.0 * t; };
  auto seq = lead_sequence(30, 0.1, 5.0, x_of, 0.3);
  for (int k = 15; k < 30; ++k) {
    cv::Rect2f& b = seq[k].tracks.items[0].box;
    b.height = 900.f - b.y;  // cut at the bottom border
    seq[k].tracks.items[0].truncated = truncation::kBottom;
  }
  const auto out = run_kalman("keypoints: false", seq);
  for (int k = 15; k < 30; ++k) {
    const ObjectState* s = find(out[k], 1);
    if (k > 19) {
      EXPECT_EQ(s, nullptr) << "frame " << k << ": 0.5 s without a range measurement";
      continue;
    }
    ASSERT_NE(s, nullptr);
    EXPECT_EQ(s->distance_method, "bearing");
    EXPECT_TRUE(s->truncated & truncation::kBottom);
    EXPECT_NEAR(s->distance_m, x_of(k * 0.1) - kBumper, 1.0) << "frame " << k;
    EXPECT_NEAR(s->lateral_m, 0.2, 0.15) << "frame " << k;
  }
}

TEST(KalmanEstimator, ABoxEndingAboveTheBorderWhileTheStateReachesBelowItIsTruncated) {
  // A lead closing at 2 m/s from 10 m; from x < 5.87 m its ground contact is below the picture, and the
  // detector then ends its box 20 px above the border (the underbody lost in shadow), outside any border
  // margin and without a truncation flag. Its height would read the car 1-3 m too far; the filter's own
  // prediction says the contact is below the picture, so the box is truncated and the range goes on from the
  // prediction.
  auto x_of = [](double t) { return 10.0 - 2.0 * t; };
  auto seq = lead_sequence(30, 0.1, 5.0, x_of, 0.3);
  int first_cut = -1;
  for (int k = 0; k < 30; ++k) {
    cv::Rect2f& b = seq[k].tracks.items[0].box;
    if (b.y + b.height <= 900.f) continue;  // the ground contact is in the picture: a whole box
    b.height = 880.f - b.y;
    if (first_cut < 0) first_cut = k;
  }
  ASSERT_EQ(first_cut, 21);
  const auto out = run_kalman("keypoints: false\nmax_gap_s: 1.5", seq);
  for (int k = first_cut; k < 30; ++k) {
    const ObjectState* s = find(out[k], 1);
    ASSERT_NE(s, nullptr) << "frame " << k;
    EXPECT_TRUE(s->truncated & truncation::kBottom) << "frame " << k;
    EXPECT_NEAR(s->distance_m, x_of(k * 0.1) - kBumper, 0.3) << "frame " << k;
  }
}

TEST(KalmanEstimator, APersonCrossingCloseWithTheFeetCutOffIsFollowedIntoThePath) {
  // A camera with the KITTI raw geometry (1242x375, fy 721.5 px, 1.65 m high): the road is in the picture
  // only from 5.9 m ahead of it. The ego at 2.5 m/s; a person standing 3.5 m to the left (x = 14 - 2.5 t from
  // the rear axle) sets off across the road at 2 m/s just as the feet leave the picture (2.6 s). From then on
  // the boxes measure no range, only their column: the sideways offset must follow the person into the ego's
  // path
  // (|y| < 1.2 m from 3.75 s, 1.2 m ahead of the bumper); the range is carried by the ego's motion.
  const CameraModel cam = CameraModel::pinhole(1242, 375, 721.5, 721.5, 609.6, 172.9, 1.65, 0.0, kCamX);
  auto x_of = [](double t) { return 14.0 - 2.5 * t; };
  auto y_of = [](double t) { return t < 2.6 ? 3.5 : 3.5 - 2.0 * (t - 2.6); };
  cv::RNG rng(11);
  std::vector<Step> seq;
  int first_cut = -1;
  for (int k = 0; k <= 42; ++k) {
    const double t = k * 0.1;
    cv::Rect2f b = box_of(cam, x_of(t), y_of(t), 1.75, 0.5);
    b.x += static_cast<float>(rng.gaussian(0.5));
    Track tr = track(1, "person", b);
    if (b.y + b.height > 375.f) {
      tr.box.height = 375.f - b.y;
      tr.truncated = truncation::kBottom;
      if (first_cut < 0) first_cut = k;
    }
    Step st{frame_at(k, t, cam, 2.5), {}};
    st.tracks.frame_index = k;
    st.tracks.items = {tr};
    seq.push_back(std::move(st));
  }
  ASSERT_EQ(first_cut, 26);
  // Without keypoints (no image here) only max_gap_s keeps a state that has no range measurement; on footage
  // the keypoint scale change refreshes it.
  const auto on = run_kalman("keypoints: false\nmax_gap_s: 2.0", seq);
  int in_path = 0;
  for (int k = first_cut; k <= 42; ++k) {
    const ObjectState* s = find(on[k], 1);
    ASSERT_NE(s, nullptr) << "frame " << k;
    EXPECT_EQ(s->distance_method, "bearing") << "frame " << k;
    EXPECT_NEAR(s->lateral_m, y_of(k * 0.1), 0.3) << "frame " << k;
    EXPECT_NEAR(s->distance_m, x_of(k * 0.1) - kBumper, 0.5) << "frame " << k;
    if (s->in_path) ++in_path;
  }
  EXPECT_GE(in_path, 4);
  // The bearing is what moves it: the same boxes held by the tracker (no measurement at all) leave the offset
  // where the last whole box put it, outside the path.
  auto held = seq;
  for (int k = first_cut; k <= 42; ++k) held[k].tracks.items[0].misses = 1;
  const auto off = run_kalman("keypoints: false\nmax_gap_s: 2.0", held);
  for (int k = first_cut; k <= 42; ++k) {
    const ObjectState* s = find(off[k], 1);
    ASSERT_NE(s, nullptr) << "frame " << k;
    EXPECT_GT(s->lateral_m, 3.0) << "frame " << k;
    EXPECT_FALSE(s->in_path) << "frame " << k;
  }
}

TEST(KalmanEstimator, ALabelFlipNeitherResetsNorJumpsTheTtc) {
  // The box of a truck seen as "car" for 15 frames, then as "truck": the range doubles with the prior, the
  // TTC (range / closing) must not move.
  auto x_of = [](double t) { return 40.0 - 6.0 * t; };
  // (With the size taken from the ground range the box is sized as a truck from its second frame on; the
  // vote alone decides here.)
  auto seq = lead_sequence(30, 0.1, 10.0, x_of, 0.3, "car", kTruckH);
  for (int k = 15; k < 30; ++k) seq[k].tracks.items[0].label = "truck";
  const auto out = run_kalman("keypoints: false\ndistance_origin: camera\nsize_from_ground: false", seq);
  const ObjectState* a = find(out[14], 1);
  const ObjectState* b = find(out[15], 1);
  ASSERT_TRUE(a && b && a->velocity_rel && b->velocity_rel);
  const double ttc_a = a->distance_m / -(*a->velocity_rel)[0];
  const double ttc_b = b->distance_m / -(*b->velocity_rel)[0];
  EXPECT_NEAR(ttc_b, ttc_a - 0.1, 0.1 * ttc_a);
  // The range moves with the prior (by how much depends on how much the fused range leans on the pinhole
  // cue).
  EXPECT_GT(b->distance_m, a->distance_m * 1.1);
  EXPECT_NE(b->distance_method, "rejected");
  for (size_t k = 16; k < out.size(); ++k) {
    const ObjectState* s = find(out[k], 1);
    ASSERT_TRUE(s && s->velocity_rel);
    EXPECT_NE(s->distance_method, "rejected") << "frame " << k;
  }
}

TEST(KalmanEstimator, AVehicleOfTheWrongClassIsSizedByItsGroundRange) {
  // Boxes of a car (1.52 m) called "bus", of a truck (3.0 m) called "car", of a bus called "bus" and of a
  // car called "car", each approaching from 30 m to 12 m ahead of the camera in the ego's lane (ego 10 m/s,
  // closing 6 m/s). Sized by the detector's label, the first two read 2.1x too far and half as far; with
  // their ground-contact ranges they are sized as what they are from their second frame on, and their TTC
  // settles on the truth.
  auto x_of = [](double t) { return kCamX + 30.0 - 6.0 * t; };
  struct Case {
    std::string label;
    double height;
    std::string sized_as;
  };
  const std::vector<Case> cases = {
      {"bus", kCarH, "car"}, {"car", kTruckH, "truck"}, {"bus", 3.2, "bus"}, {"car", kCarH, "car"}};
  for (const Case& c : cases) {
    const auto seq = lead_sequence(30, 0.1, 10.0, x_of, 0.3, c.label, c.height);
    const auto on = run_kalman("keypoints: false\ndistance_origin: camera", seq);
    const auto off = run_kalman("keypoints: false\ndistance_origin: camera\nsize_from_ground: false", seq);
    for (size_t k = 0; k < seq.size(); ++k) {
      const double truth = x_of(0.1 * static_cast<double>(k)) - kCamX;
      const ObjectState* s = find(on[k], 1);
      const ObjectState* o = find(off[k], 1);
      ASSERT_TRUE(s && o && s->velocity_rel) << c.label << " frame " << k;
      EXPECT_EQ(o->label, c.label);
      if (k == 0) {
        EXPECT_EQ(s->label, c.label) << "one box is no evidence";
        continue;
      }
      EXPECT_EQ(s->label, c.sized_as) << c.label << " frame " << k;
      EXPECT_NEAR(s->distance_m, truth, 0.05 * truth) << c.label << " frame " << k;
      if (c.label != c.sized_as) {
        EXPECT_GT(std::abs(std::log(o->distance_m / truth)), 0.5) << c.label << " frame " << k;
      }
      if (k >= 10) {
        const double ttc = s->distance_m / -(*s->velocity_rel)[0];
        EXPECT_NEAR(ttc, truth / 6.0, 0.2 * truth / 6.0) << c.label << " frame " << k;
      }
    }
  }
}

TEST(KalmanEstimator, AFarOrCutBoxDoesNotOverruleTheDetectorsClass) {
  // A car called "truck" 60-70 m ahead (its ground range 25-30 % uncertain at 0.5 deg of pitch), and one
  // 8 m ahead whose box the picture's bottom edge cuts (no ground range): both keep the truck's size.
  const CameraModel cam = front_camera();
  std::vector<Step> seq;
  for (int k = 0; k < 20; ++k) {
    const double t = 0.1 * k;
    Step s{frame_at(k, t, cam, 10.0), {}};
    s.tracks.frame_index = k;
    cv::Rect2f cut = box_of(cam, kCamX + 8.0 - 0.1 * t, -0.2, kCarH, kCarW);
    cut.height = 900.0f - cut.y;
    s.tracks.items = {track(1, "truck", box_of(cam, kCamX + 70.0 - 5.0 * t, 0.2, kCarH, kCarW)),
                      track(2, "truck", cut)};
    seq.push_back(std::move(s));
  }
  const auto out = run_kalman("keypoints: false", seq);
  for (size_t k = 0; k < out.size(); ++k)
    for (const int64_t id : {1, 2}) {
      const ObjectState* s = find(out[k], id);
      if (s) {
        EXPECT_EQ(s->label, "truck") << "track " << id << " frame " << k;
      }
    }
  ASSERT_TRUE(find(out.back(), 1));
}

// The learnt noise the estimator logs at the end of a run ("box edge jitter 0.4 px ...", "body pitch jitter
// ...").
double learnt(const std::vector<std::string>& log, const std::string& what) {
  for (const std::string& line : log) {
    const auto at = line.find(what);
    if (at != std::string::npos) return std::stod(line.substr(at + what.size()));
  }
  ADD_FAILURE() << "no '" << what << "' in the log";
  return -1.0;
}

TEST(KalmanEstimator, LearnsTheBoxJitterFromTheBoxesThemselves) {
  // Stated 1.5 px; the boxes jitter by 0.3 px (label boxes) or 3 px (a coarse detector) on each edge.
  auto x_of = [](double t) { return 40.0 - 5.0 * t; };
  for (const double noise : {0.3, 3.0}) {
    auto r = testing::StageRunner::create<KalmanEstimator>("keypoints: false");
    for (const Step& s : lead_sequence(70, 0.1, 12.0, x_of, noise)) {
      r.push("frames", s.frame, s.frame.timestamp);
      r.push("tracks", s.tracks, s.frame.timestamp);
    }
    r.run();
    // Each edge moves independently here (lead_sequence jitters y and height), so the edge jitter seen
    // through the height is about noise x sqrt(1.5) / sqrt(2); between 0.6 and 1.4 times the edge noise
    // either way.
    const double j = learnt(r.log(), "box edge jitter ");
    EXPECT_GT(j, 0.6 * noise) << "noise " << noise;
    EXPECT_LT(j, 1.4 * noise + 0.1) << "noise " << noise;
  }
}

TEST(RangeAlignment, RecoversAPitchOffsetAndAHeightScaleFromAnApproachingObject) {
  // Ground cue g = a + b p: a pitch error of 0.3 deg with the camera 1.5 m up (a = tan / hc) and a class
  // prior 8 % too tall (b = 1.08), the object approaching from 40 m to 8 m, 0.5 % noise on both cues.
  const double a = std::tan(0.3 * 3.14159265358979 / 180.0) / 1.5, b = 1.08;
  estimation::RangeAlignment fit(std::tan(0.5 * 3.14159265358979 / 180.0) / 1.5, 0.12);
  cv::RNG rng(11);
  for (int k = 0; k < 60; ++k) {
    const double z = 40.0 - 32.0 * k / 59.0;
    const double p = 1.0 / z * (1.0 + rng.gaussian(0.005)), g = a + b / z * (1.0 + rng.gaussian(0.005));
    fit.add(g, p, std::pow(0.005 / z, 2), std::pow(0.005 / z, 2));
  }
  EXPECT_NEAR(fit.offset(), a, 0.15 * a);
  EXPECT_NEAR(fit.scale(), b, 0.02);
  for (const double z : {10.0, 25.0, 40.0}) EXPECT_NEAR(1.0 / fit.to_pinhole(a + b / z), z, 0.02 * z);
  // A track relabelled to a class half as tall: its pinhole ranges halve, so the ground cue maps onto them.
  fit.rescale_pinhole(0.5);
  EXPECT_NEAR(1.0 / fit.to_pinhole(a + b / 20.0), 10.0, 0.3);
}

TEST(KalmanEstimator, TheBodysPitchingDoesNotReadAsAClosingSpeed) {
  // Ego at 10 m/s, lead at 6 m/s from 35 m, a second car in the next lane at the ego's speed; the body
  // pitches by +-0.4 deg with a 1.2 s period, which moves every box up and down by the same rows. The
  // ground-contact range swings by metres at 20-30 m; the closing speed must not.
  const CameraModel cam = front_camera();
  cv::RNG rng(5);
  std::vector<Step> seq;
  for (int k = 0; k < 60; ++k) {
    const double t = 0.1 * k;
    const double pitch = 0.4 * std::sin(2.0 * 3.14159265358979 * t / 1.2) * 3.14159265358979 / 180.0;
    const float dy = static_cast<float>(cam.fy * std::tan(pitch));
    Step s{frame_at(k, t, cam, 10.0), {}};
    s.tracks.frame_index = k;
    cv::Rect2f lead = box_of(cam, 35.0 - 4.0 * t, 0.2, kCarH, kCarW);
    cv::Rect2f side = box_of(cam, 18.0, 3.6, kCarH, kCarW);
    for (cv::Rect2f* b : {&lead, &side}) {
      b->y += dy + static_cast<float>(rng.gaussian(0.4));
      b->height += static_cast<float>(rng.gaussian(0.4));
    }
    s.tracks.items = {track(1, "car", lead), track(2, "car", side)};
    seq.push_back(std::move(s));
  }
  const auto out = run_kalman("keypoints: false", seq);
  for (size_t k = 20; k < out.size(); ++k) {
    const ObjectState* lead = find(out[k], 1);
    const ObjectState* side = find(out[k], 2);
    ASSERT_TRUE(lead && side && lead->velocity_rel && side->velocity_rel) << "frame " << k;
    EXPECT_NEAR((*lead->velocity_rel)[0], -4.0, 1.0) << "frame " << k;
    EXPECT_NEAR((*side->velocity_rel)[0], 0.0, 1.0) << "frame " << k;
  }
}

TEST(TrackFilter, RejectsAPhysicallyImpossibleJumpAndRestartsAfterThree) {
  estimation::TrackFilterConfig c;
  c.max_speed_mps = 60.0;
  estimation::TrackFilter f(c);
  const cv::Matx22d R(0.25, 0, 0, 0.04);
  estimation::EgoDelta ego;
  ego.absolute = true;
  ego.dx = 1.0;  // ego at 10 m/s, a parked car 30 m ahead
  f.init(0.0, {30.0, 0.0}, R);
  for (int k = 1; k <= 5; ++k) {
    f.predict(0.1 * k, ego);
    ASSERT_EQ(f.update_position({30.0 - k, 0.0}, R), estimation::TrackFilter::Update::kAccepted);
  }
  const cv::Vec4d before = f.state();
  // A second car's box 20 m closer: 200 m/s for one frame.
  f.predict(0.6, ego);
  const auto u = f.update_position({5.0, 0.0}, R);
  EXPECT_TRUE(u == estimation::TrackFilter::Update::kImpossible ||
              u == estimation::TrackFilter::Update::kGated);
  EXPECT_NEAR(f.state()[0], before[0] - 1.0, 0.2);  // predicted only
  f.predict(0.7, ego);
  EXPECT_NE(f.update_position({4.0, 0.0}, R), estimation::TrackFilter::Update::kAccepted);
  f.predict(0.8, ego);
  EXPECT_EQ(f.update_position({3.0, 0.0}, R), estimation::TrackFilter::Update::kRestarted);
  EXPECT_NEAR(f.state()[0], 3.0, 1e-9);
}

// ---- keypoint scale
// ------------------------------------------------------------------------------------------

TEST(KeypointScale, MedianRatioIsRobustToNoiseAndOutliers) {
  cv::RNG rng(3);
  std::vector<cv::Point2f> a, b;
  const double scale = 1.04;
  const cv::Point2f c(400, 300);
  for (int i = 0; i < 60; ++i) {
    const cv::Point2f p(static_cast<float>(c.x + rng.uniform(-80.0, 80.0)),
                        static_cast<float>(c.y + rng.uniform(-60.0, 60.0)));
    cv::Point2f q = c + (p - c) * static_cast<float>(scale) + cv::Point2f(12.f, -5.f);
    q += cv::Point2f(static_cast<float>(rng.gaussian(0.2)), static_cast<float>(rng.gaussian(0.2)));
    if (i % 5 == 0)
      q += cv::Point2f(static_cast<float>(rng.uniform(-40.0, 40.0)),
                       static_cast<float>(rng.uniform(-40.0, 40.0)));
    a.push_back(p);
    b.push_back(q);
  }
  const estimation::ScaleRatio r = estimation::scale_from_matches(a, b);
  ASSERT_TRUE(r.valid());
  EXPECT_NEAR(r.ratio, scale, 0.003);
  EXPECT_LT(r.log_sigma, 0.01);
  EXPECT_FALSE(
      estimation::scale_from_matches({a.begin(), a.begin() + 3}, {b.begin(), b.begin() + 3}).valid());
}

// A textured object pasted onto a differently textured background at a given scale about its centre.
cv::Mat render(const cv::Mat& object, const cv::Mat& background, double scale, const cv::Point2d& centre,
               cv::Rect2f* box) {
  cv::Mat img = background.clone();
  cv::Mat obj;
  cv::resize(object, obj, cv::Size(), scale, scale, cv::INTER_LINEAR);
  const cv::Rect r(static_cast<int>(std::lround(centre.x - obj.cols / 2.0)),
                   static_cast<int>(std::lround(centre.y - obj.rows / 2.0)), obj.cols, obj.rows);
  obj.copyTo(img(r));
  *box = cv::Rect2f(r);
  return img;
}

cv::Mat texture(int w, int h, int seed) {
  cv::Mat m(h, w, CV_8UC1);
  cv::RNG(seed).fill(m, cv::RNG::UNIFORM, 0, 255);
  cv::GaussianBlur(m, m, cv::Size(0, 0), 2.0);
  cv::normalize(m, m, 0, 255, cv::NORM_MINMAX);
  cv::Mat bgr;
  cv::cvtColor(m, bgr, cv::COLOR_GRAY2BGR);
  return bgr;
}

// A narrow object (a person's proportions) walks across a textured background while growing by 5 % per frame;
// its box is three times as wide as the object and the object has less contrast, so most corners found in the
// box lie on the background, which does not grow. Only the points moving with the box measure the object.
TEST(KeypointScale, PointsNotMovingWithTheBoxAreLeftOut) {
  auto ratio_with = [](int seed, double off_box_fraction, int* off_box) {
    cv::Mat object = texture(50, 130, seed);
    object.convertTo(object, -1, 0.7, 30);
    const cv::Mat background = texture(800, 600, seed + 1);
    estimation::KeypointScaleConfig c;
    c.max_off_box_fraction = off_box_fraction;
    estimation::KeypointScaleTracker kp(c);
    std::map<int64_t, estimation::ScaleRatio> r;
    for (int k = 0; k < 2; ++k) {
      cv::Rect2f obj;
      const cv::Mat img = render(object, background, k == 0 ? 1.0 : 1.05, {380.0 + 24.0 * k, 300.0}, &obj);
      r = kp.update(img, 0.1 * k, {{7, cv::Rect2f(obj.x - obj.width, obj.y, 3 * obj.width, obj.height)}});
    }
    *off_box = r[7].off_box;
    return r[7].valid() ? std::abs(r[7].ratio - 1.05) : 1.0;
  };
  double err_filtered = 0, err_all = 0;
  int dropped = 0;
  for (int seed : {31, 41, 51, 61, 71}) {
    int off = 0, none = 0;
    const double e = ratio_with(seed, estimation::KeypointScaleConfig{}.max_off_box_fraction, &off);
    EXPECT_LT(e, 0.006) << "seed " << seed;
    err_filtered += e;
    dropped += off;
    err_all += ratio_with(seed, 1e9, &none);
    EXPECT_EQ(none, 0);
  }
  EXPECT_GT(dropped, 10);
  // Without the check the background pulls the median (by up to 0.024 on these seeds).
  EXPECT_LT(err_filtered, 0.5 * err_all);
}

// A detector's dropout: the box is missing for one frame. Its points are kept and tracked from the frame they
// were found in, so the next ratio spans both steps (0.2 s); points older than max_bridge_s are forgotten,
// while consecutive calls that far apart (2 Hz keyframes) still measure.
TEST(KeypointScale, ABoxMissingForAFrameKeepsItsPoints) {
  const cv::Mat object = texture(160, 120, 41), background = texture(800, 600, 42);
  auto frame = [&](double scale, std::map<int64_t, cv::Rect2f>* boxes) {
    cv::Rect2f box;
    cv::Mat img = render(object, background, scale, {400.0, 300.0}, &box);
    (*boxes)[3] = box;
    return img;
  };
  estimation::KeypointScaleTracker kp;
  std::map<int64_t, cv::Rect2f> b0, b1, b2;
  const cv::Mat i0 = frame(1.0, &b0), i1 = frame(1.04, &b1), i2 = frame(1.04 * 1.04, &b2);
  EXPECT_TRUE(kp.update(i0, 0.0, b0).empty());
  EXPECT_TRUE(kp.update(i1, 0.1, {}).empty());  // missed
  const auto r = kp.update(i2, 0.2, b2);
  ASSERT_EQ(r.count(3), 1u);
  ASSERT_TRUE(r.at(3).valid());
  EXPECT_NEAR(r.at(3).dt, 0.2, 1e-9);
  EXPECT_NEAR(r.at(3).ratio, 1.04 * 1.04, 0.005);

  const double bridge = estimation::KeypointScaleConfig{}.max_bridge_s;
  estimation::KeypointScaleTracker forgets;
  forgets.update(i0, 0.0, b0);
  forgets.update(i1, bridge / 2, {});
  EXPECT_TRUE(forgets.update(i2, bridge * 1.01, b2).empty());
  estimation::KeypointScaleTracker keyframes;
  keyframes.update(i0, 0.0, b0);
  EXPECT_EQ(keyframes.update(i2, bridge, b2).count(3), 1u);
}

TEST(TtcKeypoints, PureScalingGivesTheTtcAndIgnoresTheBoxEdges) {
  // Depth d(t) = 20 - 4 t m: image scale 20 / d(t); TTC = d / 4. Boxes jitter by up to 3 px, which would ruin
  // a box-height TTC, and the background inside the box moves differently.
  const cv::Mat object = texture(160, 120, 11), background = texture(800, 600, 12);
  auto m = testing::StageRunner::create<TtcKeypointsMetric>("window_s: 0.3");
  cv::RNG rng(5);
  std::vector<double> truth;
  for (int k = 0; k < 12; ++k) {
    const double t = 0.1 * k, d = 20.0 - 4.0 * t;
    Frame f = frame_at(k, t, front_camera());
    cv::Rect2f box;
    f.image = render(object, background, 20.0 / d, {400 + 3.0 * k, 300}, &box);
    box.x += static_cast<float>(rng.uniform(-3.0, 3.0));
    box.height += static_cast<float>(rng.uniform(-3.0, 3.0));
    ObjectStates s;
    s.frame_index = k;
    s.timestamp = t;
    ObjectState o;
    o.track_id = 4;
    o.box = box;
    o.distance_m = d;
    o.width_m = 1.8;
    s.objects = {o};
    m.push("frames", f, t);
    m.push("states", s, t);
    truth.push_back(d / 4.0);
  }
  m.run();
  const auto risks = m.collect<RiskAssessment>("risk");
  ASSERT_EQ(risks.size(), truth.size());
  EXPECT_TRUE(std::isnan(risks[0].objects[0].value));  // no previous frame yet
  for (size_t k = 1; k < risks.size(); ++k) {
    const ObjectRisk& o = risks[k].objects[0];
    EXPECT_NEAR(o.value, truth[k], 0.06 * truth[k]) << "frame " << k;
    EXPECT_LE(o.low, o.value);
    EXPECT_GE(o.high, o.value);
  }
}

TEST(TtcKeypoints, ARecedingOrStillObjectIsInfinite) {
  const cv::Mat object = texture(160, 120, 21), background = texture(800, 600, 22);
  auto m = testing::StageRunner::create<TtcKeypointsMetric>("");
  for (int k = 0; k < 4; ++k) {
    Frame f = frame_at(k, 0.1 * k, front_camera());
    cv::Rect2f box;
    f.image = render(object, background, 1.0 - 0.02 * k, {400, 300}, &box);
    ObjectStates s;
    s.frame_index = k;
    s.timestamp = 0.1 * k;
    ObjectState o;
    o.track_id = 1;
    o.box = box;
    o.distance_m = 10;
    s.objects = {o};
    m.push("frames", f, 0.1 * k);
    m.push("states", s, 0.1 * k);
  }
  m.run();
  const auto risks = m.collect<RiskAssessment>("risk");
  for (size_t k = 1; k < risks.size(); ++k) EXPECT_TRUE(std::isinf(risks[k].objects[0].value));
}

}  // namespace
}  // namespace hf
