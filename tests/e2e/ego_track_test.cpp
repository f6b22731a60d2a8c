// Planning against the recorded ego track: the EgoPath geometry on a synthetic circular drive, the three
// templates keeping their hazard in the turning ego's path, the nuscenes source's ego_track, and the
// messages.
#include <gtest/gtest.h>

#include <cmath>
#include <numbers>

#include "cut_in_template.hpp"
#include "hazardforge/angles.hpp"
#include "hazardforge/hazard/ego_path.hpp"
#include "hazardforge/registry.hpp"
#include "hazardforge/testing/stage_runner.hpp"
#include "nuscenes_source.hpp"
#include "pedestrian_crossing_template.hpp"
#include "refusal_support.hpp"
#include "sudden_stop_template.hpp"
#include "test_support.hpp"

namespace hf {
namespace {

using hazard::EgoPath;
using hazard::EgoTrackSample;

// A drive along a circle of radius r (positive = turning left) at speed v, sampled at 2 Hz like nuScenes
// keyframes, in a world frame where it starts at (100, 50) heading 30 degrees.
std::shared_ptr<EgoTrack> circle_track(double r, double v, double t_end = 12.0) {
  const double h0 = 30 * kPi / 180;
  const cv::Vec2d p0(100, 50), centre = p0 + r * cv::Vec2d(-std::sin(h0), std::cos(h0));
  auto track = std::make_shared<EgoTrack>();
  track->source = "dataset";
  for (double t = 0; t <= t_end + 1e-9; t += 0.5) {
    const double turn = v * t / r;
    const double phi = h0 - kPi / 2 + turn;
    const cv::Vec2d p = centre + r * cv::Vec2d(std::cos(phi), std::sin(phi));
    track->samples.push_back({t, p[0], p[1], h0 + turn, v, v / r});
  }
  return track;
}

// Where the ego is on that circle tau seconds after the anchor, in the anchor frame.
cv::Vec3d on_circle(double r, double v, double tau) {
  const double a = v * tau / r;
  return {r * std::sin(a), r * (1 - std::cos(a)), a};
}

SceneContext turning_scene(double r, double v, double anchor = 2.0) {
  SceneContext s;
  s.timestamp = anchor;
  s.ego_speed_mps = v;
  // nuScenes-like front camera: 1600x900, f = 1266 px, 1.5 m high, 1.5 m ahead of the rear axle.
  s.camera = CameraModel::pinhole(1600, 900, 1266, 1266, 800, 450, 1.5, 0.0, 1.5);
  s.ego_track = circle_track(r, v);
  return s;
}

std::unique_ptr<hazard::TemplateBase> make(const std::string& kind, const Json& params = Json::object()) {
  static ComponentRegistry reg;
  static const bool registered = [] {
    reg.add<PedestrianCrossingTemplate>();
    reg.add<CutInTemplate>();
    reg.add<SuddenStopTemplate>();
    return true;
  }();
  (void)registered;
  return reg.create<hazard::TemplateBase>(kind::kHazardTemplate, kind, params);
}

// The object relative to the real ego at a sample (what the re-assessment measures).
hazard::TtcSample seen_by(const EgoPath& ego, const HazardTrajectory& tr, size_t k) {
  TrajectoryPoint e = ego.at(tr.points[k].t - tr.anchor_time);
  e.t = tr.points[k].t;
  return hazard::ttc_at(e, tr.points[k], tr.size_lwh, hazard::TtcConventions{});
}

TEST(EgoPath, FollowsACircularTrackInTheAnchorFrame) {
  const double r = 20, v = 5;
  const auto track = circle_track(r, v)->samples;
  // Unsmoothed: the interpolating spline of the poses.
  const EgoPath ego = EgoPath::recorded(track, 2.0, "test", 0.0);
  ASSERT_TRUE(ego.is_recorded());
  const TrajectoryPoint start = ego.at(0);
  EXPECT_NEAR(start.x, 0, 1e-9);
  EXPECT_NEAR(start.y, 0, 1e-9);
  for (double tau : {0.5, 1.7, 3.0, 5.0, 8.0}) {
    const cv::Vec3d want = on_circle(r, v, tau);
    const TrajectoryPoint p = ego.at(tau);
    EXPECT_NEAR(p.x, want[0], 0.02) << tau;
    EXPECT_NEAR(p.y, want[1], 0.02) << tau;
    EXPECT_NEAR(p.heading, want[2], 0.01) << tau;
    EXPECT_NEAR(p.speed, v, 0.02) << tau;
    EXPECT_NEAR(ego.s_at(tau), v * tau, 0.02) << tau;
    EXPECT_NEAR(*ego.time_at(v * tau), tau, 0.005) << tau;
  }
  // Curvature 1/r, positive for a left turn.
  EXPECT_NEAR(ego.point(15).curvature, 1 / r, 0.002);
  // Road coordinates: the point 4 m left of the path 12 m ahead, and back.
  const cv::Vec2d a = ego.to_anchor(12, 4);
  const cv::Vec3d c = on_circle(r, v, 12 / v);
  EXPECT_NEAR(a[0], c[0] - 4 * std::sin(c[2]), 0.02);
  EXPECT_NEAR(a[1], c[1] + 4 * std::cos(c[2]), 0.02);
  const cv::Vec2d back = ego.to_road(a[0], a[1]);
  EXPECT_NEAR(back[0], 12, 0.01);
  EXPECT_NEAR(back[1], 4, 0.01);
  // The default smoothing (a 0.25 s Gaussian against pose noise) cuts this 20 m circle by a few centimetres
  // only, and still passes through the anchor pose.
  const EgoPath smooth = EgoPath::recorded(track, 2.0, "test");
  EXPECT_NEAR(smooth.at(0).x, 0, 1e-9);
  EXPECT_NEAR(smooth.at(0).y, 0, 1e-9);
  for (double tau : {1.0, 3.0, 5.0}) {
    const cv::Vec3d want = on_circle(r, v, tau);
    EXPECT_NEAR(smooth.at(tau).x, want[0], 0.06) << tau;
    EXPECT_NEAR(smooth.at(tau).y, want[1], 0.06) << tau;
    EXPECT_NEAR(smooth.point(10).curvature, 1 / r, 0.002);
  }
  // Beyond the recorded 12 s the ego goes straight on at its last speed.
  const TrajectoryPoint end = ego.at(10), later = ego.at(11);
  EXPECT_NEAR(later.heading, end.heading, 1e-9);
  EXPECT_NEAR(std::hypot(later.x - end.x, later.y - end.y), end.speed * 1.0, 1e-6);
}

// The smoothing keeps a steady motion's speed up to the track's ends: on a clip of 1.5 s (a dash-camera clip
// at highway speed) a kernel cut off at the ends read the ego 40 % slow throughout.
TEST(EgoPath, SmoothingKeepsTheSpeedAtTheEndsOfAShortTrack) {
  const double v = 27.0, a = 1.5;  // m/s, m/s^2
  std::vector<EgoTrackSample> track;
  for (int i = 0; i <= 38; ++i) {
    EgoTrackSample s;
    s.t = 0.04 * i;
    s.x = v * s.t + 0.5 * a * s.t * s.t;
    s.y = (i % 2 ? 0.02 : -0.02);  // pose noise
    s.speed_mps = v + a * s.t;
    track.push_back(s);
  }
  for (double anchor : {0.0, 0.2, 0.76, 1.52}) {
    const EgoPath ego = EgoPath::recorded(track, anchor, "test");
    for (double tau : {-anchor, 0.0, 1.52 - anchor}) {
      EXPECT_NEAR(ego.at(tau).speed, v + a * (anchor + tau), 0.3) << anchor << " " << tau;
      EXPECT_NEAR(ego.s_at(tau), v * tau + 0.5 * a * ((anchor + tau) * (anchor + tau) - anchor * anchor), 0.1)
          << anchor << " " << tau;
    }
    EXPECT_NEAR(ego.at(1.52 - anchor).y, 0.0, 0.03) << anchor;  // the end pose, noise and all
  }
}

// Pose noise while standing (a few centimetres backwards) does not turn the path round: the heading is held,
// so an object planned along the path ahead stays ahead and keeps its direction.
TEST(EgoPath, BackwardsNoiseAtAStandstillKeepsTheHeading) {
  std::vector<EgoTrackSample> track;
  double x = 0;
  for (int i = 0; i <= 60; ++i) {
    const double v =
        i < 30 ? 2.0 - 2.0 * i / 30.0 : -0.3 * std::exp(-(i - 30) / 10.0);  // stop, then drift back
    EgoTrackSample s;
    s.t = 0.1 * i;
    s.x = x;
    s.speed_mps = v;
    track.push_back(s);
    x += v * 0.1;
  }
  const EgoPath ego = EgoPath::recorded(track, 0.0, "test");
  for (double tau = 0; tau <= 6.0; tau += 0.05) EXPECT_NEAR(ego.at(tau).heading, 0.0, 1e-6) << tau;
  for (double s = 0; s <= 12.0; s += 0.25) {
    EXPECT_NEAR(ego.point(s).heading, 0.0, 1e-6) << s;
    EXPECT_NEAR(ego.point(s).y, 0.0, 1e-6) << s;
  }
}

TEST(EgoPath, StraightIsTheConstantSpeedPlan) {
  const EgoPath ego = EgoPath::straight(8);
  EXPECT_DOUBLE_EQ(ego.at(1.5).x, 12);
  EXPECT_DOUBLE_EQ(ego.at(1.5).y, 0);
  EXPECT_DOUBLE_EQ(*ego.time_at(20), 2.5);
  EXPECT_FALSE(EgoPath::straight(0).time_at(1));
  const cv::Vec2d a = ego.to_anchor(7, -2);
  EXPECT_DOUBLE_EQ(a[0], 7);
  EXPECT_DOUBLE_EQ(a[1], -2);
}

TEST(EgoPath, MalformedTracksAreNamed) {
  auto msg = [](std::vector<EgoTrackSample> samples, double anchor = 0.25) {
    try {
      EgoTrack t;
      t.samples = std::move(samples);
      t.validate("frame 4");
      EgoPath::recorded(t.samples, anchor, "frame 4");
    } catch (const Error& e) {
      return std::string(e.what());
    }
    return std::string();
  };
  const double nan = std::numeric_limits<double>::quiet_NaN();
  EXPECT_EQ(msg({{0, 1, 2, nan}}), "frame 4: ego track sample 0 has a value that is not finite");
  EXPECT_EQ(
      msg({{0, 1, 2, 0}, {0, 1, 2, 0}}),
      "frame 4: ego track sample 1: t=0.000000 s does not come after the previous sample's t=0.000000 s");
  EXPECT_EQ(msg({{0, 1, 2, 0}}), "frame 4: ego_track has 1 sample(s); a recorded path needs at least two");
  EXPECT_EQ(msg({{1, 1, 2, 0}, {2, 2, 2, 0}}),
            "frame 4: the anchor time 0.25 s is outside the ego_track's span [1, 2] s");
  EXPECT_EQ(msg({{1, 1, 2, 0}, {2, 2, 2, 0}}, 1.5), "");
}

HazardSpec pedestrian(double x, double y, double speed, double target) {
  HazardSpec s;
  s.kind = "pedestrian_crossing";
  s.object_class = "person";
  s.initial_distance_m = x;
  s.lateral_offset_m = y;
  s.side = y > 0 ? "left" : "right";
  s.speed_mps = speed;
  s.heading_deg = y > 0 ? -90 : 90;
  s.target_ttc_s = target;
  return s;
}

TEST(RecordedEgoTrack, PedestrianIsInTheTurningEgosPathWhenItArrives) {
  // A left turn of radius 30 m at 5 m/s (9.5 deg/s, like scene-0916's bends); the person waits on the right
  // kerb 30 m down the road.
  const SceneContext scene = turning_scene(30, 5);
  const HazardSpec spec = pedestrian(30, -5.75, 1.5, 1.0);
  auto tpl = make("pedestrian_crossing");
  const hazard::PlanOutcome o = tpl->evaluate(spec, scene);
  ASSERT_TRUE(o.reasons.empty()) << o.reasons.front();
  EXPECT_EQ(o.notes["ego_plan"], "recorded");
  const HazardTrajectory& tr = o.trajectory;
  // The kerb point is 30 m along the curve and 5.75 m to its right, not at (30, -5.75) in the anchor frame.
  const cv::Vec3d c = on_circle(30, 5, 6.0);
  EXPECT_NEAR(tr.points.front().x, c[0] + 5.75 * std::sin(c[2]), 0.03);
  EXPECT_NEAR(tr.points.front().y, c[1] - 5.75 * std::cos(c[2]), 0.03);
  // The planned ego is the recorded one.
  EXPECT_NEAR(tr.ego[40].x, on_circle(30, 5, 2.0)[0], 0.02);
  EXPECT_NEAR(tr.ego[40].y, on_circle(30, 5, 2.0)[1], 0.02);
  // At the collision time the person is in the path of the real (turning) ego: within its corridor (|y| < 1.8
  // m) and within one sample of contact.
  ASSERT_TRUE(o.notes.contains("contact_time_s"));
  const EgoPath real = EgoPath::recorded(scene.ego_track->samples, 2.0, "t");
  const hazard::TtcSample last = seen_by(real, tr, tr.points.size() - 1);
  EXPECT_TRUE(last.in_path);
  EXPECT_LT(std::abs(last.y_rel), 1.0);
  EXPECT_GT(last.gap, 0);
  EXPECT_LT(last.gap, 5 * 0.05 + 1e-6);
  EXPECT_LT(tr.intended_min_ttc_s, 0.05);
  // Timing along the road: the person steps into the lane (|offset from the ego's path| < 1.8 m) the target
  // TTC before the ego's front reaches the crossing line. (The protocol's straight corridor, along the ego's
  // current heading, meets a person 30 m down a bend earlier, so the planned TTC series there starts higher.)
  size_t first_in = 0;
  while (first_in < tr.points.size() &&
         std::abs(real.to_road(tr.points[first_in].x, tr.points[first_in].y)[1]) >= 1.8)
    ++first_in;
  ASSERT_LT(first_in, tr.points.size());
  EXPECT_NEAR(tr.points[first_in].t - 2.0, o.notes["enters_path_s"].get<double>(), 0.05);
  EXPECT_NEAR(o.notes["ego_arrives_s"].get<double>() - o.notes["enters_path_s"].get<double>(), 1.0, 1e-6);
  EXPECT_NEAR(*real.time_at(30 - 3.4 - 0.25), o.notes["ego_arrives_s"].get<double>(), 1e-9);

  // The same spec planned against a straight ego misses the turning ego completely: it crosses 30 m straight
  // ahead while the real ego has turned away, never in its path.
  auto straight = make("pedestrian_crossing", {{"ego_plan", "constant_speed"}});
  const hazard::PlanOutcome s = straight->evaluate(spec, scene);
  ASSERT_TRUE(s.reasons.empty()) << s.reasons.front();
  EXPECT_EQ(s.notes["ego_plan"], "constant_speed");
  for (size_t k = 0; k < s.trajectory.points.size(); ++k)
    EXPECT_FALSE(seen_by(real, s.trajectory, k).in_path) << k;
}

TEST(RecordedEgoTrack, PedestrianStopsInTheLaneAndStays) {
  const SceneContext scene = turning_scene(-30, 5);  // a right turn
  HazardSpec spec = pedestrian(30, 5.75, 1.6, 1.4);
  auto tpl = make("pedestrian_crossing", {{"stop_in_path", true}, {"stop_offset_m", 0.3}});
  const hazard::PlanOutcome o = tpl->evaluate(spec, scene);
  ASSERT_TRUE(o.reasons.empty()) << o.reasons.front();
  const EgoPath real = EgoPath::recorded(scene.ego_track->samples, 2.0, "t");
  // Once in the ego's corridor it never leaves it, and it stands still (0.3 m left of the path's centre line)
  // before the ego arrives.
  size_t first_in = 0;
  while (first_in < o.ttc.size() && !o.ttc[first_in].in_path) ++first_in;
  ASSERT_LT(first_in, o.ttc.size());
  for (size_t k = first_in; k < o.ttc.size(); ++k) EXPECT_TRUE(seen_by(real, o.trajectory, k).in_path) << k;
  EXPECT_NEAR(o.notes["ego_arrives_s"].get<double>() - o.notes["enters_path_s"].get<double>(), 1.4, 1e-6);
  const double stands = o.notes["stands_from_s"].get<double>();
  EXPECT_LT(stands, o.notes["ego_arrives_s"].get<double>());
  EXPECT_DOUBLE_EQ(o.notes["stops_at_y_m"].get<double>(), 0.3);
  const TrajectoryPoint& end = o.trajectory.points.back();
  EXPECT_LT(end.speed, 1e-6);
  const cv::Vec2d road = real.to_road(end.x, end.y);
  EXPECT_NEAR(road[0], 30, 0.01);
  EXPECT_NEAR(road[1], 0.3, 0.01);
  // Within the person's limits while following the road.
  EXPECT_TRUE(hazard::exceeded_limits(o.stats, tpl->limits().at("person")).empty());
  // A stop point outside the path (narrower with a 0.5 m ego half-width) is refused.
  auto wide = make("pedestrian_crossing",
                   {{"stop_in_path", true}, {"stop_offset_m", 1.5}, {"corridor_half_width", 0.5}});
  EXPECT_EQ(test::coded(wide->check(spec, scene)),
            std::vector<std::string>{"spec: stop_offset_m 1.5 is outside the ego path "
                                     "(|offset| must be below 1.3 m for a 0.6 m wide "
                                     "person)"});
}

TEST(RecordedEgoTrack, SuddenStopLeadFollowsTheBendUntilContact) {
  const SceneContext scene = turning_scene(25, 5);
  HazardSpec spec;
  spec.kind = "sudden_stop";
  spec.object_class = "car";
  spec.initial_distance_m = 14;
  spec.side = "center";
  spec.speed_mps = 5;
  spec.deceleration_mps2 = 6;
  spec.extra = {{"brake_delay_s", 0.5}};
  auto tpl = make("sudden_stop");
  const hazard::PlanOutcome o = tpl->evaluate(spec, scene);
  ASSERT_TRUE(o.reasons.empty()) << o.reasons.front();
  const EgoPath real = EgoPath::recorded(scene.ego_track->samples, 2.0, "t");
  // On the road the turning ego follows at every sample (the straight corridor of the TTC protocol only holds
  // it near the end: 14 m down a 25 m bend is 3.9 m to the side of the ego's heading), and the plan ends at
  // contact, in the ego's path.
  for (const TrajectoryPoint& p : o.trajectory.points) EXPECT_LT(std::abs(real.to_road(p.x, p.y)[1]), 0.01);
  ASSERT_TRUE(o.notes.contains("contact_time_s"));
  const hazard::TtcSample last = seen_by(real, o.trajectory, o.trajectory.points.size() - 1);
  EXPECT_TRUE(last.in_path);
  EXPECT_LT(std::abs(last.y_rel), 1.0);  // the bend's sagitta 5.65 m ahead of the rear axle: 0.64 m
  EXPECT_LT(last.gap, 0.3);
  EXPECT_LT(o.trajectory.intended_min_ttc_s, 0.1);
  EXPECT_TRUE(hazard::exceeded_limits(o.stats, tpl->limits().at("car")).empty());
  // Heading along the road: at standstill the car points where the path points.
  const TrajectoryPoint& end = o.trajectory.points.back();
  const cv::Vec2d road = real.to_road(end.x, end.y);
  EXPECT_NEAR(end.heading, real.point(road[0]).heading, 1e-3);

  // Planned straight, the same lead stops where the turning ego never comes: never in its path within 2 m.
  auto straight = make("sudden_stop", {{"ego_plan", "constant_speed"}});
  const hazard::PlanOutcome s = straight->evaluate(spec, scene);
  ASSERT_TRUE(s.reasons.empty());
  for (size_t k = 0; k < s.trajectory.points.size(); ++k) {
    const hazard::TtcSample t = seen_by(real, s.trajectory, k);
    EXPECT_FALSE(t.in_path && t.gap < 2.0) << k;
  }
}

TEST(RecordedEgoTrack, CutInEndsInTheCurvingLaneAtTheTargetGap) {
  // A gentle 60 m bend: the cut-in ends 2.4 m (1.2 s x 2 m/s) ahead of the ego's bumper, in its lane.
  const SceneContext scene = turning_scene(60, 8);
  HazardSpec spec;
  spec.kind = "cut_in";
  spec.object_class = "car";
  spec.initial_distance_m = -6;
  spec.lateral_offset_m = 3.5;
  spec.side = "left";
  spec.speed_mps = 12;
  spec.target_ttc_s = 1.2;
  spec.extra = {{"final_speed_mps", 6.0}};
  auto tpl = make("cut_in", {{"duration_s", 8.0}});
  const hazard::PlanOutcome o = tpl->evaluate(spec, scene);
  ASSERT_TRUE(o.reasons.empty()) << o.reasons.front();
  const EgoPath real = EgoPath::recorded(scene.ego_track->samples, 2.0, "t");
  const double t_end = o.notes["cut_in_end_s"].get<double>();
  const size_t k = static_cast<size_t>(std::lround(t_end * 20));
  ASSERT_LT(k, o.trajectory.points.size());
  const cv::Vec2d car = real.to_road(o.trajectory.points[k].x, o.trajectory.points[k].y);
  // Gap along the road (arc length) at the end of the lane change, and in the lane.
  EXPECT_NEAR(car[0] - real.s_at(o.trajectory.points[k].t - 2.0) - 3.4 - 4.5 / 2, 1.2 * 2.0, 0.15);
  EXPECT_LT(std::abs(car[1]), 0.05);
  EXPECT_TRUE(seen_by(real, o.trajectory, k).in_path);
  EXPECT_TRUE(hazard::exceeded_limits(o.stats, tpl->limits().at("car")).empty());
}

TEST(RecordedEgoTrack, PoseNoiseIsSmoothedAwayForAnAdjacentLane) {
  // A straight drive at 8 m/s whose recorded positions wobble by up to 1.5 cm sideways (localisation noise):
  // the interpolating spline's curvature then wiggles, and a vehicle a lane to the side, following the road
  // at 12 m/s, gets jerk spikes the car limit refuses. The default 0.25 s smoothing removes them.
  auto track = std::make_shared<EgoTrack>();
  for (int k = 0; k <= 24; ++k) {
    const double wobble = 0.015 * ((k * 7) % 5 - 2) / 2.0;
    track->samples.push_back({0.5 * k, 4.0 * k, wobble, 0.0, 8.0, 0.0});
  }
  SceneContext scene = turning_scene(60, 8);
  scene.ego_track = track;
  HazardSpec spec;
  spec.kind = "cut_in";
  spec.object_class = "car";
  spec.initial_distance_m = -6;
  spec.lateral_offset_m = 3.5;
  spec.side = "left";
  spec.speed_mps = 12;
  spec.target_ttc_s = 1.2;
  spec.extra = {{"final_speed_mps", 6.0}};
  const auto raw = make("cut_in", {{"duration_s", 8.0}, {"ego_smoothing_s", 0.0}})->check(spec, scene);
  ASSERT_EQ(raw.size(), 1u);
  EXPECT_EQ(raw[0].text.rfind("peak jerk ", 0), 0u) << raw[0];
  EXPECT_EQ(raw[0].code, refusal::kClassLimit);
  const auto smooth = make("cut_in", {{"duration_s", 8.0}})->check(spec, scene);
  EXPECT_TRUE(smooth.empty()) << smooth.front();
}

TEST(RecordedEgoTrack, RecordedPlanWithoutATrackIsRefused) {
  SceneContext scene = turning_scene(20, 5);
  scene.ego_track = nullptr;
  auto tpl = make("sudden_stop", {{"ego_plan", "recorded"}});
  HazardSpec spec;
  spec.kind = "sudden_stop";
  spec.object_class = "car";
  spec.initial_distance_m = 14;
  spec.speed_mps = 5;
  spec.deceleration_mps2 = 6;
  EXPECT_EQ(
      test::coded(tpl->check(spec, scene)),
      std::vector<std::string>{"scene_data: ego_plan 'recorded' needs the recording's ego track (from dataset poses or "
                               "estimated from the video), which this scene does not carry"});
}

TEST(NuScenesEgoTrack, EveryFrameCarriesTheWholeRecordedTrack) {
  const auto root = test::shared_data("nuscenes");
  HF_REQUIRE_SHARED(root / "v1.0-mini/scene.json");
  auto r = testing::StageRunner::create<source::NuScenesSource>("{dataroot: '" + root.string() +
                                                                "', annotations: false, max_frames: 6}");
  r.run();
  const auto frames = r.collect<Frame>("frames");
  ASSERT_EQ(frames.size(), 6u);
  for (const Frame& f : frames) {
    ASSERT_TRUE(f.ego_track);
    EXPECT_EQ(f.ego_track->source, "dataset");
    EXPECT_EQ(f.ego.source, "dataset");
    const auto& track = f.ego_track->samples;
    // The whole scene (41 keyframes), even though only 6 frames are emitted.
    ASSERT_EQ(track.size(), 41u);
    const EgoTrackSample& own = track[static_cast<size_t>(f.index)];
    EXPECT_DOUBLE_EQ(own.t, f.timestamp);
    const cv::Matx44d& T = *f.ego.T_world_ego;
    EXPECT_DOUBLE_EQ(own.x, T(0, 3));
    EXPECT_DOUBLE_EQ(own.y, T(1, 3));
    EXPECT_DOUBLE_EQ(own.yaw, std::atan2(T(1, 0), T(0, 0)));
  }
  // Scene-0916 turns right by 44 degrees over its first 2.4 s (yaw -73.5 -> -117.9 deg).
  const auto& track = frames[0].ego_track->samples;
  EXPECT_NEAR(track[3].speed_mps, *frames[3].ego.speed_mps, 1e-9);
  EXPECT_NEAR((track[5].yaw - track[0].yaw) * 180 / kPi, -44.4, 0.1);
  auto off = testing::StageRunner::create<source::NuScenesSource>("{dataroot: '" + root.string() +
                                                                  "', annotations: false, max_frames: 1, "
                                                                  "ego_track: false}");
  off.run();
  EXPECT_FALSE(off.collect<Frame>("frames").front().ego_track);
}

}  // namespace
}  // namespace hf
