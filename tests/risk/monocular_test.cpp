// Monocular estimator on synthetic cameras and boxes of known geometry: distance, placement, velocity,
// heading.
#include <gtest/gtest.h>

#include <cmath>

#include "hazardforge/testing/stage_runner.hpp"
#include "monocular_estimator.hpp"
#include "synthetic.hpp"

namespace hf {
namespace {

using test::box_of;
using test::frame_at;
using test::front_camera;
using test::track;

constexpr double kCarH = 1.52, kCarW = 1.85;  // share/class_sizes.yaml

// Runs the estimator over (frame, tracks) pairs and returns its states.
std::vector<ObjectStates> run(const std::string& params, const std::vector<std::pair<Frame, Tracks>>& seq,
                              std::vector<std::string>* log = nullptr) {
  auto r = testing::StageRunner::create<MonocularEstimator>(params);
  for (const auto& [f, t] : seq) {
    r.push("frames", f, f.timestamp);
    r.push("tracks", t, f.timestamp);
  }
  r.run();
  if (log) *log = r.log();
  return r.collect<ObjectStates>("states");
}

Tracks tracks_of(std::vector<Track> items, int64_t frame = 0) {
  Tracks t;
  t.frame_index = frame;
  t.items = std::move(items);
  return t;
}

TEST(MonocularGeometry, PinholeDepthAndHorizon) {
  EXPECT_DOUBLE_EQ(monocular::pinhole_depth(1250, 1.52, 95.0), 1250 * 1.52 / 95.0);
  const CameraModel level = front_camera();
  EXPECT_NEAR(*monocular::horizon_row(level, 300), 450.0, 1e-9);
  // Pitched down by 0.05 rad, the horizon moves up by fy * tan(0.05).
  const CameraModel pitched = front_camera(0.05);
  EXPECT_NEAR(*monocular::horizon_row(pitched, 800), 450.0 - 1250 * std::tan(0.05), 1e-9);
  EXPECT_DOUBLE_EQ(*monocular::ls_slope({0, 1, 2}, {1, 3, 5}), 2.0);
  EXPECT_FALSE(monocular::ls_slope({1}, {1}));
  EXPECT_FALSE(monocular::ls_slope({1, 1}, {1, 2}));
}

TEST(Monocular, PinholeDistanceIsExactForLevelCamera) {
  const CameraModel cam = front_camera();
  // Car whose near face is 20 m ahead of the camera (ego x = 21.7) and 1 m to the left.
  const cv::Rect2f box = box_of(cam, 21.7, 1.0, kCarH, kCarW);
  EXPECT_NEAR(box.height, 1250 * kCarH / 20.0, 1e-3);
  auto out = run("", {{frame_at(0, 0.0, cam, 8.0), tracks_of({track(7, "car", box)})}});
  ASSERT_EQ(out.size(), 1u);
  ASSERT_EQ(out[0].objects.size(), 1u);
  const ObjectState& s = out[0].objects[0];
  EXPECT_EQ(s.track_id, 7);
  EXPECT_EQ(s.distance_method, "pinhole");
  EXPECT_NEAR(s.distance_m, 20.0, 1e-3);  // camera-to-object depth = ego x - camera x
  EXPECT_NEAR(s.lateral_m, 1.0, 1e-4);
  EXPECT_DOUBLE_EQ(s.width_m, kCarW);
  EXPECT_DOUBLE_EQ(s.length_m, 4.5);
  EXPECT_TRUE(s.in_path);        // |1.0| < 1.0 + 0.5 + 0.925
  EXPECT_FALSE(s.velocity_rel);  // a single position has no velocity
  ASSERT_TRUE(out[0].ego_speed_mps);
  EXPECT_DOUBLE_EQ(*out[0].ego_speed_mps, 8.0);

  // The same object measured from the bumper and from the rear axle.
  auto bumper = run("distance_origin: bumper", {{frame_at(0, 0.0, cam), tracks_of({track(7, "car", box)})}});
  EXPECT_NEAR(bumper[0].objects[0].distance_m, 21.7 - 3.4, 1e-3);
  auto axle =
      run("distance_origin: ego_origin", {{frame_at(0, 0.0, cam), tracks_of({track(7, "car", box)})}});
  EXPECT_NEAR(axle[0].objects[0].distance_m, 21.7, 1e-3);
}

TEST(Monocular, PersonUsesItsOwnHeightPrior) {
  const CameraModel cam = front_camera();
  const cv::Rect2f box = box_of(cam, 11.7, -0.5, 1.70, 0.6);
  auto out = run("", {{frame_at(0, 0.0, cam), tracks_of({track(1, "person", box)})}});
  EXPECT_NEAR(out[0].objects[0].distance_m, 10.0, 1e-3);
  EXPECT_NEAR(out[0].objects[0].lateral_m, -0.5, 1e-4);
}

TEST(Monocular, GroundMethodIsExactWithPitchedCamera) {
  const CameraModel cam = front_camera(0.05, 1.6);
  const cv::Rect2f box = box_of(cam, 25.0, -2.0, kCarH, kCarW);
  auto out = run("distance_method: ground", {{frame_at(0, 0.0, cam), tracks_of({track(1, "car", box)})}});
  const ObjectState& s = out[0].objects[0];
  EXPECT_EQ(s.distance_method, "ground");
  EXPECT_NEAR(s.distance_m, 25.0 - 1.7, 2e-3);
  EXPECT_NEAR(s.lateral_m, -2.0, 2e-4);
  // The pinhole range ignores the pitch and is only approximate here: it must differ from the exact answer.
  auto pin = run("", {{frame_at(0, 0.0, cam), tracks_of({track(1, "car", box)})}});
  EXPECT_GT(std::abs(pin[0].objects[0].distance_m - 23.3), 0.01);
  EXPECT_LT(std::abs(pin[0].objects[0].distance_m - 23.3), 0.5);
}

TEST(Monocular, GroundMethodFallsBackToPinholeAboveHorizon) {
  const CameraModel cam = front_camera();
  cv::Rect2f box = box_of(cam, 21.7, 0.0, kCarH, kCarW);
  box.y -= 200;  // bottom edge now above the horizon row (450)
  auto out = run("distance_method: ground", {{frame_at(0, 0.0, cam), tracks_of({track(1, "car", box)})}});
  EXPECT_EQ(out[0].objects[0].distance_method, "pinhole");
  EXPECT_NEAR(out[0].objects[0].distance_m, 20.0, 1e-3);
}

TEST(Monocular, FusedPicksGroundOnlyWellBelowHorizonAndUnclipped) {
  const CameraModel cam = front_camera();
  const cv::Rect2f near = box_of(cam, 11.7, 0.0, kCarH, kCarW);  // bottom 187.5 px below the horizon
  const cv::Rect2f far = box_of(cam, 81.7, 0.0, kCarH, kCarW);   // bottom 23.4 px below the horizon
  cv::Rect2f clipped = box_of(cam, 4.7, 0.0, kCarH, kCarW);      // bottom row 1075 > 900
  clipped.height = 900 - clipped.y;
  auto out = run("distance_method: fused",
                 {{frame_at(0, 0.0, cam),
                   tracks_of({track(1, "car", near), track(2, "car", far), track(3, "car", clipped)})}});
  ASSERT_EQ(out[0].objects.size(), 3u);
  EXPECT_EQ(out[0].objects[0].distance_method, "ground");
  EXPECT_NEAR(out[0].objects[0].distance_m, 10.0, 1e-3);
  EXPECT_EQ(out[0].objects[1].distance_method, "pinhole");
  EXPECT_NEAR(out[0].objects[1].distance_m, 80.0, 0.05);
  EXPECT_EQ(out[0].objects[2].distance_method, "pinhole");
  // A lower horizon margin accepts the far box for the ground method.
  auto lax = run("{distance_method: fused, fused_horizon_margin_px: 20}",
                 {{frame_at(0, 0.0, cam), tracks_of({track(2, "car", far)})}});
  EXPECT_EQ(lax[0].objects[0].distance_method, "ground");
}

// Object moving with constant absolute velocity (vx, vy) while the ego drives straight at ego_speed.
std::vector<std::pair<Frame, Tracks>> constant_velocity(double ego_speed, double vx, double vy, int n,
                                                        std::optional<double> frame_ego, double dt = 0.1) {
  const CameraModel cam = front_camera();
  std::vector<std::pair<Frame, Tracks>> seq;
  for (int k = 0; k < n; ++k) {
    const double t = k * dt;
    const double x = 31.7 + (vx - ego_speed) * t, y = -3.0 + vy * t;
    seq.push_back(
        {frame_at(k, t, cam, frame_ego), tracks_of({track(4, "car", box_of(cam, x, y, kCarH, kCarW))}, k)});
  }
  return seq;
}

TEST(Monocular, ConstantVelocityGivesExactSpeedAndHeading) {
  // Ego 10 m/s; object at 6 m/s forward and 2 m/s to the left: relative (-4, 2), heading atan2(2, 6).
  auto out = run("{velocity_window: 5, velocity_min_age: 3}", constant_velocity(10.0, 6.0, 2.0, 8, 10.0));
  ASSERT_EQ(out.size(), 8u);
  EXPECT_FALSE(out[1].objects[0].velocity_rel);  // two positions < velocity_min_age
  for (int k = 2; k < 8; ++k) {
    const ObjectState& s = out[k].objects[0];
    ASSERT_TRUE(s.velocity_rel) << "frame " << k;
    EXPECT_NEAR((*s.velocity_rel)[0], -4.0, 5e-3);
    EXPECT_NEAR((*s.velocity_rel)[1], 2.0, 5e-3);
    ASSERT_TRUE(s.speed_mps);
    EXPECT_NEAR(*s.speed_mps, std::hypot(6.0, 2.0), 5e-3);
    EXPECT_NEAR(*s.heading_rad, std::atan2(2.0, 6.0), 1e-3);
    ASSERT_TRUE(s.scale_rate);
    // ln h = const - ln Z(t): the window's slope is close to closing / Z at the window's mid time.
    const int n = std::min(k + 1, 5);
    const double mid = (k - (n - 1) / 2.0) * 0.1;
    EXPECT_NEAR(*s.scale_rate, 4.0 / (30.0 - 4.0 * mid), 1e-3);
  }
}

TEST(Monocular, OncomingAndStationaryObjects) {
  // Parked car seen from an ego at 12 m/s: relative -12, absolute 0.
  auto parked = run("", constant_velocity(12.0, 0.0, 0.0, 4, 12.0));
  EXPECT_NEAR(*parked.back().objects[0].speed_mps, 0.0, 5e-3);
  EXPECT_NEAR((*parked.back().objects[0].velocity_rel)[0], -12.0, 5e-3);
  // Oncoming car at 8 m/s: heading pi.
  auto oncoming = run("", constant_velocity(5.0, -8.0, 0.0, 4, 5.0));
  EXPECT_NEAR(*oncoming.back().objects[0].speed_mps, 8.0, 5e-3);
  EXPECT_NEAR(std::abs(*oncoming.back().objects[0].heading_rad), M_PI, 1e-3);
}

TEST(Monocular, UnknownEgoSpeedKeepsRelativeVelocityOnly) {
  auto out = run("", constant_velocity(10.0, 6.0, 0.0, 4, std::nullopt));
  const ObjectState& s = out.back().objects[0];
  EXPECT_FALSE(out.back().ego_speed_mps);
  ASSERT_TRUE(s.velocity_rel);
  EXPECT_NEAR((*s.velocity_rel)[0], -4.0, 5e-3);
  EXPECT_FALSE(s.speed_mps);
  EXPECT_FALSE(s.heading_rad);
  // The param supplies the ego speed when frames carry none.
  auto with_param = run("ego_speed_mps: 10", constant_velocity(10.0, 6.0, 0.0, 4, std::nullopt));
  EXPECT_NEAR(*with_param.back().objects[0].speed_mps, 6.0, 5e-3);
  EXPECT_DOUBLE_EQ(*with_param.back().ego_speed_mps, 10.0);
}

TEST(Monocular, DatasetPoseGivesAbsoluteVelocity) {
  // Ego heading north (world +y) at 10 m/s; a car ahead heading north at 6 m/s, drifting 1 m/s to the ego's
  // left (world -x). The dataset pose and world velocity are on every frame.
  const CameraModel cam = front_camera();
  std::vector<std::pair<Frame, Tracks>> seq;
  for (int k = 0; k < 5; ++k) {
    const double t = k * 0.1;
    Frame f = frame_at(k, t, cam, 10.0);
    f.ego.T_world_ego = cv::Matx44d(0, -1, 0, 500.0, 1, 0, 0, 200.0 + 10.0 * t, 0, 0, 1, 3.0, 0, 0, 0, 1);
    f.ego.velocity_world = cv::Vec3d(0, 10.0, 0);
    seq.push_back(
        {f, tracks_of({track(1, "car", box_of(cam, 31.7 - 4.0 * t, -1.0 + 1.0 * t, kCarH, kCarW))}, k)});
  }
  auto out = run("", seq);
  const ObjectState& s = out.back().objects[0];
  EXPECT_NEAR(*s.speed_mps, std::hypot(6.0, 1.0), 5e-3);
  EXPECT_NEAR(*s.heading_rad, std::atan2(1.0, 6.0), 1e-3);
  EXPECT_NEAR((*s.velocity_rel)[0], -4.0, 5e-3);
  EXPECT_NEAR((*s.velocity_rel)[1], 1.0, 5e-3);
}

TEST(Monocular, YawRateIsCompensated) {
  // Ego turning left at 0.2 rad/s and 10 m/s past a parked car: without compensation the car seems to move.
  const CameraModel cam = front_camera();
  const double v = 10.0, w = 0.2;
  const cv::Vec2d world(30.0, 4.0);
  std::vector<std::pair<Frame, Tracks>> seq;
  for (int k = 0; k < 5; ++k) {
    const double t = k * 0.1, th = w * t;
    const cv::Vec2d ego(v / w * std::sin(th), v / w * (1 - std::cos(th)));
    const cv::Vec2d d = world - ego;
    const double x = std::cos(th) * d[0] + std::sin(th) * d[1],
                 y = -std::sin(th) * d[0] + std::cos(th) * d[1];
    Frame f = frame_at(k, t, cam, v);
    f.ego.yaw_rate = w;
    seq.push_back({f, tracks_of({track(1, "car", box_of(cam, x, y, kCarH, kCarW))}, k)});
  }
  auto out = run("velocity_window: 3", seq);
  EXPECT_NEAR(*out.back().objects[0].speed_mps, 0.0, 0.05);
  auto raw = run("{velocity_window: 3, use_yaw_rate: false}", seq);
  EXPECT_GT(*raw.back().objects[0].speed_mps, 5.0);  // |w x p| ~ 0.2 * 30 m
}

TEST(Monocular, MissedFramesAreNotMeasurements) {
  auto seq = constant_velocity(10.0, 6.0, 0.0, 6, 10.0);
  // Frames 3 and 4: the tracker holds the frame-2 box (a miss); the velocity must ignore those boxes.
  for (int k : {3, 4}) {
    seq[k].second.items[0].box = seq[2].second.items[0].box;
    seq[k].second.items[0].misses = k - 2;
  }
  auto out = run("{velocity_window: 5, velocity_min_age: 3}", seq);
  EXPECT_NEAR((*out[5].objects[0].velocity_rel)[0], -4.0, 5e-3);
  EXPECT_EQ(out[4].objects[0].misses, 2);
  // With max_misses 1 the held box of frame 4 (second miss) is not estimated, but the track's history
  // survives.
  auto strict = run("{velocity_window: 5, velocity_min_age: 3, max_misses: 1}", seq);
  EXPECT_EQ(strict[3].objects.size(), 1u);
  EXPECT_TRUE(strict[4].objects.empty());
  EXPECT_NEAR((*strict[5].objects[0].velocity_rel)[0], -4.0, 5e-3);
}

TEST(Monocular, VelocityWindowForgetsVanishedTracks) {
  auto seq = constant_velocity(10.0, 6.0, 0.0, 3, 10.0);
  seq.push_back({frame_at(3, 0.3, front_camera(), 10.0), tracks_of({}, 3)});  // track gone
  auto again = constant_velocity(10.0, 6.0, 0.0, 6, 10.0);
  seq.push_back(again[4]);  // same id reappears: history restarts
  seq.back().first.index = 4;
  auto out = run("velocity_min_age: 2", seq);
  EXPECT_TRUE(out[2].objects[0].velocity_rel);
  EXPECT_TRUE(out[3].objects.empty());
  EXPECT_FALSE(out[4].objects[0].velocity_rel);
}

TEST(Monocular, CorridorParamsDecideInPath) {
  const CameraModel cam = front_camera();
  const cv::Rect2f box = box_of(cam, 21.7, 3.0, kCarH, kCarW);  // 3.0 > 1.0 + 0.5 + 0.925
  auto out = run("", {{frame_at(0, 0.0, cam), tracks_of({track(1, "car", box)})}});
  EXPECT_FALSE(out[0].objects[0].in_path);
  auto wide = run("corridor_half_width: 2.0", {{frame_at(0, 0.0, cam), tracks_of({track(1, "car", box)})}});
  EXPECT_TRUE(wide[0].objects[0].in_path);  // 3.0 < 2.0 + 0.5 + 0.925
}

TEST(Monocular, UnknownClassIsSkippedWithOneWarning) {
  const CameraModel cam = front_camera();
  const cv::Rect2f box = box_of(cam, 21.7, 0.0, kCarH, kCarW);
  std::vector<std::string> log;
  auto out = run("",
                 {{frame_at(0, 0.0, cam), tracks_of({track(1, "kite", box), track(2, "car", box)})},
                  {frame_at(1, 0.1, cam), tracks_of({track(1, "kite", box)})}},
                 &log);
  ASSERT_EQ(out[0].objects.size(), 1u);
  EXPECT_EQ(out[0].objects[0].track_id, 2);
  ASSERT_EQ(log.size(), 1u);
  EXPECT_NE(log[0].find("'kite'"), std::string::npos);
}

TEST(Monocular, BadInputsGetOneClearMessage) {
  Frame f = frame_at(3, 0.0, CameraModel{});
  try {
    run("", {{f, tracks_of({})}});
    FAIL();
  } catch (const Error& e) {
    EXPECT_EQ(
        std::string(e.what()),
        "frame 3 (synthetic_3): the camera model has no intrinsics (width, height, fx, fy); the monocular "
        "estimator needs them");
  }
  EXPECT_THROW(run("{velocity_window: 3, velocity_min_age: 4}", {}), Error);
  EXPECT_THROW(run("class_sizes: /nonexistent/sizes.yaml", {}), Error);
}

}  // namespace
}  // namespace hf
