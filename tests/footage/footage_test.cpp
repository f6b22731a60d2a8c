// Horizon, ground-plane odometry and the ego-motion smoother on rendered road sequences of known geometry.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <functional>
#include <limits>
#include <optional>
#include <random>
#include <vector>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <opencv2/videoio.hpp>

#include "hazardforge/footage/attitude.hpp"
#include "hazardforge/footage/camera_height.hpp"
#include "hazardforge/footage/ego_motion.hpp"
#include "hazardforge/footage/horizon.hpp"
#include "hazardforge/footage/lever_arm.hpp"
#include "hazardforge/footage/two_view.hpp"
#include "hazardforge/footage/two_view_calibration.hpp"
#include "synthetic_road.hpp"
#include "test_support.hpp"

namespace {

using hf::CameraModel;
using hf::kRadPerDeg;
using namespace hf::footage;

using namespace hf::test::road;

CameraModel test_camera(double pitch_deg, double roll_deg) {
  return CameraModel::pinhole(800, 450, 720, 720, 400, 225, 1.5, pitch_deg * kRadPerDeg, 1.5,
                              roll_deg * kRadPerDeg);
}

TEST(Horizon, PitchAndRollOfARenderedDriveWithinTolerance) {
  const CameraModel truth = test_camera(3.0, 1.5);
  HorizonEstimator est(CameraModel::pinhole(800, 450, 720, 720, 400, 225));
  // 10 m/s, turning gently so that the road's vanishing point sweeps across the image (it traces the
  // horizon).
  const Pose start{0, -1.0, -0.12};
  for (int i = 0; i < 30; ++i) {
    const double t = 0.1 * i;
    est.add(render(truth, pose_at(t, 10.0, 0.08, start)), t);
  }
  const auto r = est.result();
  ASSERT_TRUE(r.has_value());
  const double true_row = *truth.horizon_y(truth.cx);
  EXPECT_NEAR(r->horizon_y, true_row, 3.0) << r->method;
  EXPECT_NEAR(r->pitch_rad / kRadPerDeg, 3.0, 0.3);
  EXPECT_NEAR(r->roll_rad / kRadPerDeg, 1.5, 0.5) << "roll must be estimated on a clip that shows it";
  EXPECT_GT(r->confidence, 0.3);
  EXPECT_GE(r->frames_used, 10);
  EXPECT_FALSE(r->method.empty());
}

// A camera that nods and rolls while the car drives (a bumpy road at 25 fps): pitch 3 deg + 0.5 deg at 1.5
// Hz, roll 0.4 deg at 1 Hz. The tracker, given only the clip's camera (3 deg, level), recovers each frame's
// deviation.
TEST(Attitude, EachFramesPitchAndRollDeviationOfANoddingCamera) {
  const double fps = 25;
  auto pitch_dev = [](double t) { return 0.5 * std::sin(2 * M_PI * 1.5 * t); };
  auto roll_dev = [](double t) { return 0.4 * std::sin(2 * M_PI * 1.0 * t + 1.0); };
  AttitudeTracker tracker(test_camera(3.0, 0.0));
  std::vector<double> t_of;
  for (int i = 0; i < 50; ++i) {
    const double t = i / fps;
    tracker.add(
        render_with_walls(test_camera(3.0 + pitch_dev(t), roll_dev(t)), pose_at(t, 12.0, 0.0, {0, 0.3, 0})),
        t);
    t_of.push_back(t);
  }
  const auto out = tracker.result();
  ASSERT_EQ(out.size(), 50u);
  EXPECT_FALSE(out[0].measured);
  int measured = 0;
  double worst_pitch = 0, worst_roll = 0, ss_pitch = 0;
  for (size_t k = 0; k < out.size(); ++k) {
    measured += out[k].measured ? 1 : 0;
    const double ep = out[k].pitch_rad / kRadPerDeg - pitch_dev(t_of[k]);
    const double er = out[k].roll_rad / kRadPerDeg - roll_dev(t_of[k]);
    ss_pitch += ep * ep;
    // Within a second of the clip's ends the slow attitude sees only one side (and takes part of the swing).
    if (t_of[k] < 0.25 || t_of[k] > 1.7) continue;
    worst_pitch = std::max(worst_pitch, std::abs(ep));
    worst_roll = std::max(worst_roll, std::abs(er));
  }
  EXPECT_GE(measured, 45);
  EXPECT_LT(worst_pitch, 0.12) << "deg";
  EXPECT_LT(worst_roll, 0.12) << "deg";
  EXPECT_LT(std::sqrt(ss_pitch / out.size()), 0.1) << "deg rms over the whole clip";
  // The frame's camera follows: its horizon row moves with the deviation.
  const CameraModel c = with_attitude(test_camera(3.0, 0.0), out[10]);
  EXPECT_NEAR(c.pitch() / kRadPerDeg, 3.0 + out[10].pitch_rad / kRadPerDeg, 1e-9);
  EXPECT_NEAR(c.roll() / kRadPerDeg, out[10].roll_rad / kRadPerDeg, 1e-9);
}

// A steady camera gives no deviation, and a clip without texture near the horizon measures nothing.
TEST(Attitude, ASteadyCameraAndAFeaturelessClipGiveNoDeviation) {
  AttitudeTracker steady(test_camera(3.0, 0.0));
  for (int i = 0; i < 20; ++i)
    steady.add(render_with_walls(test_camera(3.0, 0.0), pose_at(0.04 * i, 12.0, 0.0, {0, 0.3, 0})), 0.04 * i);
  for (const auto& s : steady.result()) {
    EXPECT_LT(std::abs(s.pitch_rad / kRadPerDeg), 0.05);
    EXPECT_LT(std::abs(s.roll_rad / kRadPerDeg), 0.05);
  }
  // Keyframes half a second apart are not compared.
  AttitudeTracker keyframes(test_camera(3.0, 0.0));
  for (int i = 0; i < 4; ++i)
    keyframes.add(
        render_with_walls(test_camera(3.0 + 0.5 * (i % 2), 0.0), pose_at(0.5 * i, 12.0, 0.0, {0, 0.3, 0})),
        0.5 * i);
  for (const auto& s : keyframes.result()) {
    EXPECT_FALSE(s.measured);
    EXPECT_DOUBLE_EQ(s.pitch_rad, 0.0);
  }
  AttitudeTracker blank(test_camera(3.0, 0.0));
  const cv::Mat grey(450, 800, CV_8UC3, cv::Scalar(128, 128, 128));
  for (int i = 0; i < 5; ++i) blank.add(grey, 0.04 * i);
  for (const auto& s : blank.result()) {
    EXPECT_FALSE(s.measured);
    EXPECT_DOUBLE_EQ(s.pitch_rad, 0.0);
  }
}

// Between video frames the far scene's sideways shift is the ego's turn: on a street with building fronts at
// 25 fps, turning left at 0.1 rad/s, right at 0.05 rad/s or not at all, each step's heading change is within
// 0.03 deg + 20 % and carries a sigma that covers it; the odometry given it keeps that precision (the road's
// own turn over half a metre of asphalt scatters by several deg/s on real footage).
TEST(Attitude, HeadingStepOfATurningDriveAtVideoRate) {
  const double fps = 25;
  for (const double yaw_rate : {0.1, -0.05, 0.0}) {
    const CameraModel cam = test_camera(3.0, 0.0);
    AttitudeTracker tracker(cam);
    GroundOdometry odo(cam);
    std::vector<EgoMotionSample> raw;
    int turns = 0;
    for (int i = 0; i < 20; ++i) {
      const double t = i / fps;
      const cv::Mat img =
          render_with_walls(cam, pose_at(t, 12.0, yaw_rate, {0, 0.3, -0.5 * yaw_rate * 20 / fps}));
      tracker.add(img, t);
      const auto turn = tracker.last_turn();
      if (i == 0) {
        EXPECT_FALSE(turn.has_value());
      } else if (turn) {
        ++turns;
        // The camera 1.5 m ahead of the axle steps sideways as it turns: the walls 11 m to the side shift by
        // up to 15 % more than the turn alone moves them.
        EXPECT_NEAR(turn->yaw / kRadPerDeg, yaw_rate / fps / kRadPerDeg,
                    0.03 + 0.2 * std::abs(yaw_rate / fps / kRadPerDeg))
            << "rate " << yaw_rate << " frame " << i;
        EXPECT_GT(turn->yaw_sigma, 0.0);
        EXPECT_LT(std::abs(turn->yaw - yaw_rate / fps), 4 * turn->yaw_sigma)
            << "rate " << yaw_rate << " frame " << i;
      }
      raw.push_back(odo.add(img, i, t, turn));
    }
    EXPECT_GE(turns, 17) << "rate " << yaw_rate;
    int yaw_measured = 0;
    for (size_t i = 1; i < raw.size(); ++i) {
      if (!raw[i].yaw_measured) continue;
      ++yaw_measured;
      EXPECT_NEAR(raw[i].yaw_rate, yaw_rate, 0.75 * kRadPerDeg + 0.2 * std::abs(yaw_rate))
          << "rate " << yaw_rate << " frame " << i;
    }
    EXPECT_GE(yaw_measured, 17) << "rate " << yaw_rate;
    for (const auto& s : smooth_ego_motion(raw))
      EXPECT_NEAR(s.yaw_rate, yaw_rate, 0.5 * kRadPerDeg + 0.2 * std::abs(yaw_rate)) << "rate " << yaw_rate;
  }
}

TEST(Horizon, StraightDriveGivesTheHorizonRow) {
  const CameraModel truth = test_camera(3.0, 0.0);
  HorizonEstimator est(CameraModel::pinhole(800, 450, 720, 720, 400, 225));
  for (int i = 0; i < 20; ++i) est.add(render(truth, pose_at(0.1 * i, 15.0, 0.0, {0, 0.5, 0})), 0.1 * i);
  const auto r = est.result();
  ASSERT_TRUE(r.has_value());
  EXPECT_NEAR(r->horizon_y, *truth.horizon_y(truth.cx), 3.0);
  EXPECT_NEAR(r->pitch_rad / kRadPerDeg, 3.0, 0.3);
  EXPECT_NEAR(r->roll_rad / kRadPerDeg, 0.0, 0.5);
}

TEST(Horizon, UniformAndSkyOnlyClipsGiveNoEstimate) {
  const CameraModel cam = CameraModel::pinhole(800, 450, 720, 720, 400, 225);
  HorizonEstimator uniform(cam), sky(cam);
  cv::Mat grey(450, 800, CV_8UC3, cv::Scalar(128, 128, 128)), gradient(450, 800, CV_8UC3);
  for (int v = 0; v < 450; ++v) gradient.row(v).setTo(cv::Scalar::all(150 + 80.0 * v / 450));
  for (int i = 0; i < 10; ++i) {
    uniform.add(grey, 0.1 * i);
    sky.add(gradient, 0.1 * i);
  }
  EXPECT_FALSE(uniform.result().has_value());
  EXPECT_FALSE(sky.result().has_value());
}

// Speed and yaw rate of a rendered drive; `dt` from 0.04 s (25 fps) to 0.5 s (nuScenes keyframes).
void check_odometry(double speed, double yaw_rate, double dt, int frames) {
  const CameraModel cam = test_camera(3.0, 1.5);
  GroundOdometry odo(cam);
  std::vector<EgoMotionSample> raw;
  const Pose start{0, 0.0, -0.5 * yaw_rate * dt * frames};
  for (int i = 0; i < frames; ++i) {
    const double t = dt * i;
    raw.push_back(odo.add(render(cam, pose_at(t, speed, yaw_rate, start)), i, t));
  }
  EXPECT_FALSE(raw[0].measured);
  int measured = 0;
  for (size_t i = 1; i < raw.size(); ++i) {
    if (!raw[i].measured) continue;
    ++measured;
    // 5 % of the speed; yaw rate: 0.02 rad/s is 0.1 deg of heading per frame at 10 fps, i.e. 2 cm of lateral
    // displacement 10 m ahead, a third of a bird's-eye-view pixel.
    EXPECT_NEAR(raw[i].speed_mps, speed, 0.05 * speed) << "frame " << i;
    EXPECT_NEAR(raw[i].yaw_rate, yaw_rate, 0.02 / std::max(1.0, dt / 0.1)) << "frame " << i;
  }
  EXPECT_GE(measured, frames - 2);
  const auto smooth = smooth_ego_motion(raw);
  for (const auto& s : smooth) {
    EXPECT_NEAR(s.speed_mps, speed, 0.05 * speed);
    EXPECT_GT(s.speed_sigma, 0.0);
  }
}

TEST(GroundOdometry, TenFramesPerSecondTurning) {
  check_odometry(12.0, 0.1, 0.1, 12);
}

// The road's pitch under a pair (ground_pitch_offset): ground points 5-25 m ahead seen by a 1280x720 camera
// pitched `true_deg`, before and after the ego drove `d` m (turning 3 deg when it moves), with 0.3 px noise;
// the camera assumed at `assumed_deg`.
std::optional<double> pitch_offset_of_a_pair(double true_deg, double assumed_deg, double d = 2.0) {
  const CameraModel truth =
      CameraModel::pinhole(1280, 720, 1000, 1000, 640, 360, 1.5, true_deg * kRadPerDeg, 1.5);
  const CameraModel assumed = with_pitch_roll(truth, assumed_deg * kRadPerDeg, 0.0);
  const double yaw = d > 0 ? 3.0 * kRadPerDeg : 0.0;
  const double tx = d * std::cos(0.5 * yaw), ty = d * std::sin(0.5 * yaw), c = std::cos(yaw),
               s = std::sin(yaw);
  std::mt19937 rng(7);
  std::normal_distribution<double> noise(0.0, 0.3);
  std::vector<cv::Point2d> a, b;
  for (double x = 5.0; x <= 25.0; x += 1.5)
    for (double y = -5.0; y <= 5.0; y += 1.0) {
      // p = R q + t: the point in the current ego frame is q = R^T (p - t).
      const double qx = c * (x - tx) + s * (y - ty), qy = -s * (x - tx) + c * (y - ty);
      const auto pa = truth.project_ego(cv::Vec3d(x, y, 0.0)), pb = truth.project_ego(cv::Vec3d(qx, qy, 0.0));
      if (!pa || !pb) continue;
      a.emplace_back(pa->x + noise(rng), pa->y + noise(rng));
      b.emplace_back(pb->x + noise(rng), pb->y + noise(rng));
    }
  return ground_pitch_offset(assumed, a, b, 8.0 * kRadPerDeg);
}

TEST(GroundPitch, ThePitchThatMakesThePairsRoadMotionRigid) {
  const auto off = pitch_offset_of_a_pair(3.0, 1.0);
  ASSERT_TRUE(off.has_value());
  EXPECT_NEAR(*off / kRadPerDeg, 2.0, 0.1);
  const auto none = pitch_offset_of_a_pair(3.0, 3.0);
  ASSERT_TRUE(none.has_value());
  EXPECT_NEAR(*none / kRadPerDeg, 0.0, 0.1);
  const auto up = pitch_offset_of_a_pair(-1.0, 2.0);
  ASSERT_TRUE(up.has_value());
  EXPECT_NEAR(*up / kRadPerDeg, -3.0, 0.1);
  // Standing still, every pitch fits the (absent) motion alike: nothing pins it down.
  EXPECT_FALSE(pitch_offset_of_a_pair(3.0, 1.0, 0.0).has_value());
}

// A rendered drive at 2 Hz whose camera is pitched 1.5 deg more than the clip's camera says (the body nodding
// under braking, a grade change): the odometry reads the road's pitch under each pair (1.3-1.55 deg), and its
// speeds stay within 3 % (median; every one within 10 %); with the clip's fixed pitch they read 35-57 % high.
TEST(GroundPitch, KeyframesSeenWithAPitchTheClipsCameraDoesNotKnow) {
  const CameraModel truth = test_camera(4.5, 0.0), clip = test_camera(3.0, 0.0);
  const double speed = 6.0, yaw_rate = 0.05, dt = 0.5;
  for (const bool pair_pitch : {true, false}) {
    OdometryOptions o;
    o.pair_pitch = pair_pitch;
    GroundOdometry odo(clip, o);
    int measured = 0, with_pitch = 0;
    std::vector<double> err;
    for (int i = 0; i < 8; ++i) {
      const double t = dt * i;
      const EgoMotionSample r = odo.add(render(truth, pose_at(t, speed, yaw_rate)), i, t);
      if (!r.measured) continue;
      ++measured;
      err.push_back(std::abs(r.speed_mps - speed) / speed);
      if (r.ground_pitch_offset) {
        ++with_pitch;
        EXPECT_NEAR(*r.ground_pitch_offset / kRadPerDeg, 1.5, 0.35) << "frame " << i;
      }
    }
    ASSERT_GE(measured, 5) << "pair_pitch " << pair_pitch;
    std::sort(err.begin(), err.end());
    if (pair_pitch) {
      EXPECT_LT(err[err.size() / 2], 0.03);  // median
      EXPECT_LT(err.back(), 0.10);
      EXPECT_GE(with_pitch, measured - 1);
    } else {
      EXPECT_GT(err.front(), 0.2);  // the fixed pitch misreads every pair's distance by a third
      EXPECT_EQ(with_pitch, 0);
    }
  }
}
TEST(GroundOdometry, TwentyFiveFramesPerSecondHighway) {
  check_odometry(20.0, 0.0, 0.04, 12);
}
TEST(GroundOdometry, KeyframesHalfASecondApart) {
  check_odometry(5.0, 0.05, 0.5, 8);
}

// A dash camera that sees its own bonnet and burns a clock into the picture: the bottom rows and a corner
// hold a static, textured picture in every frame. The speed and yaw rate come from the road as without them.
TEST(GroundOdometry, ABonnetAndATimestampInThePictureDoNotStopTheEgo) {
  const CameraModel cam = test_camera(3.0, 1.5);
  GroundOdometry odo(cam);
  std::mt19937 rng(7);
  cv::Mat bonnet(cam.height, cam.width, CV_8UC3);
  cv::randu(bonnet, cv::Scalar::all(20), cv::Scalar::all(90));  // a dark paint reflecting the scene
  cv::GaussianBlur(bonnet, bonnet, cv::Size(0, 0), 2.0);
  cv::Mat mask = cv::Mat::zeros(cam.height, cam.width, CV_8U);
  for (int u = 0; u < cam.width;
       ++u) {  // its edge bulges up in the middle: 16 % of the rows there, 8 % at the sides
    const double c = (u - cam.width / 2.0) / (cam.width / 2.0);
    const int top = static_cast<int>(cam.height * (0.84 + 0.08 * c * c));
    mask(cv::Rect(u, top, 1, cam.height - top)).setTo(255);
  }
  const double speed = 12.0, yaw_rate = 0.05, dt = 0.1;
  std::vector<EgoMotionSample> raw;
  for (int i = 0; i < 12; ++i) {
    const double t = dt * i;
    cv::Mat img = render(cam, pose_at(t, speed, yaw_rate, Pose{0, 0.0, 0.0}));
    bonnet.copyTo(img, mask);
    cv::rectangle(img, cv::Rect(10, 10, 330, 34), cv::Scalar::all(0), cv::FILLED);
    cv::putText(img, "2026/11/25 14:02:07  87 km/h", cv::Point(16, 34), cv::FONT_HERSHEY_SIMPLEX, 0.6,
                cv::Scalar::all(255), 2);
    raw.push_back(odo.add(img, i, t));
  }
  int measured = 0;
  for (size_t i = 1; i < raw.size(); ++i) {
    if (!raw[i].measured) continue;
    ++measured;
    EXPECT_NEAR(raw[i].speed_mps, speed, 0.05 * speed) << "frame " << i;
    EXPECT_NEAR(raw[i].yaw_rate, yaw_rate, 0.02) << "frame " << i;
  }
  EXPECT_GE(measured, 9);
}

// The heading change between two views from the essential matrix, on a street with building fronts: 2 Hz
// keyframes turning at 0.25 rad/s (7.2 degrees per frame, as nuScenes scene-0916 does in its bends), and 10
// fps.
TEST(TwoViewRotation, HeadingChangeOfATurningDrive) {
  const CameraModel cam = test_camera(3.0, 1.5);
  for (const double dt : {0.5, 0.1}) {
    TwoViewRotation rot(cam);
    int measured = 0;
    for (int i = 0; i < 5; ++i) {
      const double t = dt * i;
      const auto r = rot.add(render_with_walls(cam, pose_at(t, 5.0, 0.25, {0, 0.0, -0.25})));
      if (i == 0) {
        EXPECT_FALSE(r.has_value());
        continue;
      }
      if (!r) continue;  // a decomposition it does not trust (translation not along the axis) is refused
      ++measured;
      EXPECT_NEAR(r->yaw, 0.25 * dt, 0.3 * kRadPerDeg) << "dt " << dt << " frame " << i;
    }
    // 2.5 m between keyframes fixes the geometry every time; 0.5 m at 10 fps nearly every time.
    EXPECT_GE(measured, dt > 0.2 ? 4 : 3) << "dt " << dt;
  }
}

// The camera's pitch change between two views: 2 Hz keyframes of a turning drive whose camera tips down and
// up by up to 0.8 degrees between frames (a road's grade changing under the car, the body's nods), the
// geometry given only the clip's camera. Each change comes back with its sign (+ = further down) within 0.15
// degrees, the heading change within its usual tolerance, and a level drive reads none.
TEST(TwoViewRotation, PitchChangeBetweenViews) {
  const std::vector<double> pitch_deg = {3.0, 3.5, 3.5, 2.7, 3.2, 3.0};
  for (const bool level : {false, true}) {
    TwoViewRotation rot(test_camera(3.0, 0.0));
    int measured = 0;
    for (size_t i = 0; i < pitch_deg.size(); ++i) {
      const double t = 0.5 * static_cast<double>(i);
      const double p = level ? 3.0 : pitch_deg[i];
      const auto r = rot.add(render_with_walls(test_camera(p, 0.0), pose_at(t, 5.0, 0.1, {0, 0.0, -0.25})));
      if (i == 0 || !r) continue;
      ++measured;
      const double change = level ? 0.0 : pitch_deg[i] - pitch_deg[i - 1];
      EXPECT_NEAR(r->pitch / kRadPerDeg, change, 0.15) << "frame " << i << (level ? " (level)" : "");
      EXPECT_GT(r->pitch_sigma, 0.0);
      EXPECT_NEAR(r->yaw, 0.1 * 0.5, 0.3 * kRadPerDeg) << "frame " << i;
    }
    EXPECT_GE(measured, 4) << (level ? "level" : "pitching");
  }
}

// The odometry with the two-view heading: every frame's yaw rate is measured, also where the road alone would
// not fix it, and the smoother keeps it.
TEST(GroundOdometry, KeyframesTurningBetweenBuildings) {
  const CameraModel cam = test_camera(3.0, 1.5);
  GroundOdometry odo(cam);
  std::vector<EgoMotionSample> raw;
  for (int i = 0; i < 8; ++i) {
    const double t = 0.5 * i;
    raw.push_back(odo.add(render_with_walls(cam, pose_at(t, 5.0, 0.2, {0, 0.0, -0.35})), i, t));
  }
  int yaw_measured = 0;
  for (size_t i = 1; i < raw.size(); ++i) {
    // Facing a wall at an angle, one plane fills the view and the picture's turn is refused: the road's
    // remains.
    if (!raw[i].yaw_measured) continue;
    ++yaw_measured;
    EXPECT_NEAR(raw[i].yaw_rate, 0.2, 0.6 * kRadPerDeg / 0.5) << "frame " << i;
    if (raw[i].measured) {
      EXPECT_NEAR(raw[i].speed_mps, 5.0, 0.25) << "frame " << i;
    }
  }
  EXPECT_GE(yaw_measured, 5);
  for (const auto& s : smooth_ego_motion(raw)) EXPECT_NEAR(s.yaw_rate, 0.2, 0.02);
}

// The lever arm: the camera's direction of travel between two views of an arc driven by the rear axle,
// computed from the geometry, gives back the chord for turns both ways, short and long chords; a straight
// pair or no lever arm gives none.
TEST(LeverArm, ChordFromTheDirectionOfTravelOnAnArc) {
  const double L = 1.5;
  auto heading_on_arc = [&](double turn, double chord) {
    const double x = chord * std::cos(turn / 2) + L * (std::cos(turn) - 1),
                 y = chord * std::sin(turn / 2) + L * std::sin(turn);
    return std::atan2(y, x);
  };
  for (const double turn_deg : {-20.0, -10.0, -3.0, 3.0, 10.0, 20.0})
    for (const double chord : {1.0, 3.0, 8.0}) {
      const double turn = turn_deg * kRadPerDeg;
      const auto c = lever_arm_chord(turn, heading_on_arc(turn, chord), L);
      ASSERT_TRUE(c.has_value()) << turn_deg << " deg, " << chord << " m";
      EXPECT_NEAR(*c, chord, 1e-9 * chord) << turn_deg << " deg";
    }
  EXPECT_FALSE(lever_arm_chord(0.0, 0.0, L).has_value());
  EXPECT_FALSE(lever_arm_chord(10 * kRadPerDeg, heading_on_arc(10 * kRadPerDeg, 3.0), 0.0).has_value());
  // A direction on the inside of the chord's (turn/2) is no forward drive for a camera ahead of the axle.
  EXPECT_FALSE(lever_arm_chord(10 * kRadPerDeg, 4 * kRadPerDeg, L).has_value());
}

// fuse(): a pair's geometry from a 2.5 m arc turning 10 deg over 0.5 s, a camera mounted straight (bias 0
// from three straight pairs).
EgoMotionSample pair_on_arc(double turn, double chord, double dt, double heading_sigma_deg, double lever) {
  EgoMotionSample s;
  s.interval_s = dt;
  TwoViewMotion tv;
  tv.yaw = turn;
  tv.yaw_sigma = 0.1 * kRadPerDeg;
  tv.heading = std::atan2(chord * std::sin(turn / 2) + lever * std::sin(turn),
                          chord * std::cos(turn / 2) + lever * (std::cos(turn) - 1));
  tv.heading_sigma = heading_sigma_deg * kRadPerDeg;
  s.two_view = tv;
  return s;
}

TEST(LeverArm, FusesWithTheRoadViewOrReplacesAConfidentWrongOne) {
  LeverArmOptions opt;
  LeverArmScale scale(1.5, opt);
  for (int i = 0; i < 3; ++i) scale.observe(pair_on_arc(0.1 * kRadPerDeg, 2.5, 0.5, 0.25, 1.5));
  ASSERT_TRUE(scale.from_straight_pairs());
  EXPECT_NEAR(scale.bias(), 0.0,
              0.15 * kRadPerDeg);  // a 0.1 deg turn leans the camera's path by about 0.1 deg
  const double turn = 10 * kRadPerDeg, chord = 2.5, dt = 0.5;
  const double speed = chord * (turn / 2) / std::sin(turn / 2) / dt;  // the arc over the interval
  // No road reading: the lever arm's alone.
  EgoMotionSample s = scale.fuse(pair_on_arc(turn, chord, dt, 0.25, 1.5));
  ASSERT_TRUE(s.lever_speed_mps.has_value());
  EXPECT_TRUE(s.measured);
  EXPECT_EQ(s.speed_cue, EgoMotionSample::SpeedCue::kLeverArm);
  EXPECT_NEAR(s.speed_mps, speed, 0.05 * speed);
  EXPECT_GT(s.speed_sigma, 0.0);
  EXPECT_LT(s.speed_sigma, 0.1 * speed);
  // A road reading that agrees: averaged, tighter than either.
  EgoMotionSample agree = pair_on_arc(turn, chord, dt, 0.25, 1.5);
  agree.measured = true;
  agree.speed_mps = speed * 1.03;
  agree.speed_sigma = 0.2;
  agree.speed_cue = EgoMotionSample::SpeedCue::kRoad;
  s = scale.fuse(agree);
  EXPECT_EQ(s.speed_cue, EgoMotionSample::SpeedCue::kRoadAndLeverArm);
  EXPECT_GT(s.speed_mps, std::min(speed, speed * 1.03) - 1e-9);
  EXPECT_LT(s.speed_mps, speed * 1.03 + 1e-9);
  EXPECT_LT(s.speed_sigma, std::hypot(0.2, opt.road_sigma_floor_mps));
  ASSERT_TRUE(s.road_speed_mps.has_value());
  EXPECT_DOUBLE_EQ(*s.road_speed_mps, speed * 1.03);
  // A confident road reading 50 % high (the road view's failure in a bend): the tight lever arm replaces it.
  EgoMotionSample wrong = agree;
  wrong.speed_mps = 1.5 * speed;
  wrong.speed_sigma = 0.05;
  s = scale.fuse(wrong);
  EXPECT_EQ(s.speed_cue, EgoMotionSample::SpeedCue::kLeverArm);
  EXPECT_NEAR(s.speed_mps, speed, 0.05 * speed);
  // The same with a loose direction (1.5 deg): the lever arm is not trusted over the road.
  EgoMotionSample loose = pair_on_arc(turn, chord, dt, 1.5, 1.5);
  loose.measured = true;
  loose.speed_mps = 1.5 * speed;
  loose.speed_sigma = 0.05;
  loose.speed_cue = EgoMotionSample::SpeedCue::kRoad;
  s = scale.fuse(loose);
  EXPECT_EQ(s.speed_cue, EgoMotionSample::SpeedCue::kRoad);
  EXPECT_DOUBLE_EQ(s.speed_mps, 1.5 * speed);
  // A gentle turn (1 deg) gives no distance; the sample passes unchanged.
  s = scale.fuse(pair_on_arc(1 * kRadPerDeg, chord, dt, 0.25, 1.5));
  EXPECT_FALSE(s.lever_speed_mps.has_value());
  EXPECT_FALSE(s.measured);
}

// Without straight pairs the mounting yaw is the prior, and its sigma loosens every distance: a camera turned
// 1 deg to the left, told so by the prior, reads the arc; told nothing, it reads the bend off by more.
TEST(LeverArm, MountingYawFromThePriorWithoutStraightPairs) {
  const double turn = -10 * kRadPerDeg, chord = 2.5, dt = 0.5;
  const double speed = chord * (std::abs(turn) / 2) / std::sin(std::abs(turn) / 2) / dt;
  EgoMotionSample s = pair_on_arc(turn, chord, dt, 0.25, 1.5);
  s.two_view->heading += 1 * kRadPerDeg;
  LeverArmOptions told;
  told.prior_bias = 1 * kRadPerDeg;
  told.prior_bias_sigma_deg = 0.1;
  const auto a = LeverArmScale(1.5, told).fuse(s);
  ASSERT_TRUE(a.lever_speed_mps.has_value());
  EXPECT_NEAR(*a.lever_speed_mps, speed, 0.02 * speed);
  // The prior from the lane lines' column: 1 deg right of the principal point is a travel 1 deg to the right.
  const CameraModel cam = test_camera(0.0, 0.0);
  EXPECT_NEAR(with_travel_column({}, cam, cam.cx + cam.fx * std::tan(1 * kRadPerDeg)).prior_bias,
              -1 * kRadPerDeg, 1e-9);
  EXPECT_EQ(with_travel_column(told, cam, std::numeric_limits<double>::quiet_NaN()).prior_bias,
            told.prior_bias);
  const LeverArmScale untold(1.5);
  EXPECT_FALSE(untold.from_straight_pairs());
  const auto b = untold.fuse(s);
  if (b.lever_speed_mps) {
    EXPECT_GT(std::abs(*b.lever_speed_mps - speed), 0.1 * speed);
    EXPECT_GT(b.lever_speed_sigma, a.lever_speed_sigma * 2);
  }
}

// The whole chain on rendered keyframes: 2 Hz, 5 m/s between building fronts, straight for 2 s and then a
// bend at 0.25 rad/s (7.2 deg per keyframe, as nuScenes scene-0916's bends). The straight pairs give the
// mounting yaw, the bend's pairs the lever arm's speed.
TEST(LeverArm, KeyframesThroughABendBetweenBuildings) {
  const CameraModel cam = test_camera(3.0, 1.5);
  GroundOdometry odo(cam);
  std::vector<EgoMotionSample> raw;
  const Pose start{0, 0.0, 0.0};
  const Pose bend = pose_at(2.0, 5.0, 0.0, start);
  for (int i = 0; i < 10; ++i) {
    const double t = 0.5 * i;
    const Pose p = t <= 2.0 ? pose_at(t, 5.0, 0.0, start) : pose_at(t - 2.0, 5.0, 0.25, bend);
    raw.push_back(odo.add(render_with_walls(cam, p), i, t));
  }
  const LeverArmScale scale = apply_lever_arm(raw, cam.cam_to_ego({0, 0, 0})[0]);
  EXPECT_GE(scale.straight_pairs(), 3);
  EXPECT_NEAR(scale.bias(), 0.0, 0.3 * kRadPerDeg);
  // Each reading within its own sigma (the direction's from interleaved inlier subsets; on these walls the
  // direction scatters by up to 2 deg in the bend, 20-30 % of the distance), and what the fusion leaves
  // within 10 % of the truth: a loose reading does not replace the road view's good one.
  int lever = 0, measured = 0;
  for (size_t i = 5; i < raw.size(); ++i) {
    if (raw[i].measured) {
      ++measured;
      EXPECT_NEAR(raw[i].speed_mps, 5.0, 0.1 * 5.0) << "frame " << i;
    }
    if (!raw[i].lever_speed_mps) continue;
    ++lever;
    EXPECT_NEAR(*raw[i].lever_speed_mps, 5.0, 6.0 * raw[i].lever_speed_sigma) << "frame " << i;
  }
  EXPECT_GE(lever, 2);
  EXPECT_GE(measured, 4);
  for (size_t i = 1; i <= 4; ++i) EXPECT_FALSE(raw[i].lever_speed_mps.has_value()) << "straight frame " << i;
}

TEST(GroundOdometry, UniformFramesAreNotMeasured) {
  GroundOdometry odo(test_camera(3.0, 0.0));
  cv::Mat grey(450, 800, CV_8UC3, cv::Scalar::all(90));
  for (int i = 0; i < 5; ++i) {
    const auto s = odo.add(grey, i, 0.1 * i);
    EXPECT_FALSE(s.measured);
  }
}

TEST(GroundOdometry, StandingStillMeasuresZero) {
  const CameraModel cam = test_camera(3.0, 0.0);
  GroundOdometry odo(cam);
  const cv::Mat img = render(cam, {});
  odo.add(img, 0, 0.0);
  const auto s = odo.add(img, 1, 0.1);
  ASSERT_TRUE(s.measured);
  EXPECT_NEAR(s.speed_mps, 0.0, 0.05);
  EXPECT_NEAR(s.yaw_rate, 0.0, 0.01);
}

// Camera height from the lane lines: the rendered road's lanes are 3.5 m wide (line centres), the camera is
// 1.5 m high; the estimator is told a wrong height and the true lane width.
void check_height(double stated_height, double yaw_rate) {
  const CameraModel truth = test_camera(3.0, 1.5);
  const CameraModel told = with_height(truth, stated_height);
  HeightOptions opt;
  opt.lane_width_m = 3.5;
  CameraHeightEstimator est(told, opt);
  for (int i = 0; i < 20; ++i) est.add(render(truth, pose_at(0.1 * i, 12.0, yaw_rate, Pose{0, 0.3, 0.03})));
  const auto h = est.result();
  ASSERT_TRUE(h.has_value());
  EXPECT_NEAR(h->height_m, 1.5, 0.03 * 1.5);
  EXPECT_GE(h->frames_used, 6);  // the nearest 4.5 m of the view must show a piece of a dash
  EXPECT_GT(h->confidence, 0.4);
  EXPECT_GT(h->sigma_m, 0.05);  // the lane-width assumption's spread is part of it
}

TEST(CameraHeight, LaneLinesGiveTheHeightFromTooLow) {
  check_height(1.2, 0.0);
}
TEST(CameraHeight, LaneLinesGiveTheHeightFromTooHighWhileTurning) {
  check_height(2.0, 0.05);
}

// Lane markings on the rendered road (dashed lines, 3 m dash in a 12 m cycle, at +-1.75 and +-5.25 m; solid
// edge lines at +-7 m): in the middle lane and in the lane left of it, the ego lane's lines are dashed on
// both sides (in the left lane the solid edge line 3.5 m to the left is not taken for the ego lane's).
TEST(CameraHeight, LaneMarkingsCountTheLanesBesideTheEgo) {
  const CameraModel cam = test_camera(3.0, 0.0);
  HeightOptions opt;
  opt.lane_width_m = 3.5;
  for (const double y : {0.0, 3.5}) {
    CameraHeightEstimator est(cam, opt);
    for (int i = 0; i < 20; ++i) est.add(render(cam, pose_at(0.1 * i, 12.0, 0.0, Pose{0, y, 0})));
    const auto m = est.markings();
    ASSERT_TRUE(m.has_value());
    EXPECT_EQ(m->frames, 20);
    EXPECT_EQ(m->source, "video");
    for (const hf::LaneMarkingSide* side : {&m->left, &m->right}) {
      EXPECT_EQ(side->boundary, "dashed") << m->note;
      EXPECT_EQ(side->colour, "white") << m->note;
      EXPECT_GE(side->seen_share, 0.2) << m->note;
    }
    // A lane beyond each dashed line; the further lines, 5.25 m to the side, show only from 9.5 m on in this
    // 58 deg view and are rarely found, so the count is at least one, not the two there are.
    EXPECT_GE(m->left.lanes, 1) << "ego at y " << y << ": " << m->note;
    EXPECT_GE(m->right.lanes, 1) << "ego at y " << y << ": " << m->note;
  }
  // Without lines nothing is said about either side.
  CameraHeightEstimator blank(cam, opt);
  for (int i = 0; i < 8; ++i) blank.add(cv::Mat(450, 800, CV_8UC3, cv::Scalar::all(90)));
  const auto none = blank.markings();
  ASSERT_TRUE(none.has_value());
  EXPECT_EQ(none->left.lanes, -1);
  EXPECT_EQ(none->right.boundary, "none");
}

// The Udacity clip (a highway's leftmost lane): a solid yellow line on the left, a dashed white one on the
// right.
TEST(CameraHeight, LaneMarkingsOfTheUdacityHighwayClip) {
  const auto path = hf::test::shared_data("udacity-highway/test_video.mp4");
  HF_REQUIRE_SHARED(path);
  cv::VideoCapture cap(path.string());
  ASSERT_TRUE(cap.isOpened());
  std::vector<cv::Mat> frames;
  for (cv::Mat f; cap.read(f);) frames.push_back(f.clone());
  ASSERT_GE(frames.size(), 30u);
  // 60 deg field of view, pitch from the horizon estimate as the video source does.
  const CameraModel intr = CameraModel::pinhole(1280, 720, 1108.5, 1108.5, 640, 360);
  HorizonEstimator hz(intr);
  for (size_t i = 0; i < frames.size(); ++i) hz.add(frames[i], i / 25.0);
  const auto h = hz.result();
  ASSERT_TRUE(h.has_value());
  CameraHeightEstimator est(HorizonEstimator::apply(intr, *h));
  for (const cv::Mat& f : frames) est.add(f);
  const auto m = est.markings();
  ASSERT_TRUE(m.has_value());
  EXPECT_EQ(m->left.boundary, "solid") << m->note;
  EXPECT_EQ(m->left.colour, "yellow") << m->note;
  EXPECT_EQ(m->left.lanes, 0) << m->note;
  EXPECT_EQ(m->right.boundary, "dashed") << m->note;
  EXPECT_EQ(m->right.colour, "white") << m->note;
  EXPECT_GE(m->right.lanes, 1) << m->note;
}

TEST(CameraHeight, NoLinesGiveNoEstimate) {
  const CameraModel cam = test_camera(3.0, 0.0);
  cv::Mat grey(450, 800, CV_8UC3, cv::Scalar::all(90));
  cv::RNG rng(7);
  std::vector<cv::Mat> frames;
  for (int i = 0; i < 8; ++i) {
    cv::Mat f = grey.clone();
    cv::Mat noise(f.size(), CV_8UC3);
    rng.fill(noise, cv::RNG::UNIFORM, 0, 20);
    f += noise;
    frames.push_back(f);
  }
  EXPECT_FALSE(estimate_camera_height(frames, cam).has_value());
}

TEST(EgoMotionSmoother, RejectsAnOutlierAndFillsGaps) {
  std::vector<EgoMotionSample> raw;
  std::mt19937 rng(7);
  std::normal_distribution<double> noise(0.0, 0.1);
  for (int i = 0; i < 40; ++i) {
    EgoMotionSample s;
    s.frame = i;
    s.t = 0.1 * i;
    s.speed_mps = 10.0 + 0.5 * s.t + noise(rng);  // accelerating at 0.5 m/s^2
    s.yaw_rate = 0.05;
    s.speed_sigma = 0.1;
    s.yaw_rate_sigma = 0.01;
    s.measured = i > 0 && !(i >= 20 && i <= 24);
    raw.push_back(s);
  }
  raw[10].speed_mps = 25.0;  // a truck filled the road
  raw[30].yaw_rate = 0.6;
  const auto out = smooth_ego_motion(raw);
  ASSERT_EQ(out.size(), raw.size());
  EXPECT_FALSE(out[10].measured);
  EXPECT_FALSE(out[30].measured);
  EXPECT_NEAR(out[10].speed_mps, 10.5, 0.3);
  EXPECT_NEAR(out[30].yaw_rate, 0.05, 0.03);
  for (int i = 20; i <= 24; ++i) {
    EXPECT_FALSE(out[i].measured);
    EXPECT_NEAR(out[i].speed_mps, 10.0 + 0.05 * i, 0.3) << i;
    EXPECT_GT(out[i].speed_sigma, out[15].speed_sigma);  // the gap is less certain than measured frames
  }
  EXPECT_NEAR(out[0].speed_mps, 10.0, 0.3);  // the first frame (never measured) is filled backwards
  for (const auto& s : out) {
    EXPECT_TRUE(std::isfinite(s.speed_sigma));
    EXPECT_GT(s.speed_sigma, 0.0);
  }
}

// `frames` raw speed readings `interval` s apart, the i-th reading speed(i) with sigma `sigma`; the first
// frame has no interval and no reading.
std::vector<EgoMotionSample> readings(int frames, double interval, double sigma,
                                      const std::function<double(int)>& speed) {
  std::vector<EgoMotionSample> raw;
  for (int i = 0; i < frames; ++i) {
    EgoMotionSample s;
    s.frame = i;
    s.t = interval * i;
    s.interval_s = i > 0 ? interval : 0.0;
    s.speed_mps = speed(i);
    s.speed_sigma = sigma;
    s.yaw_rate_sigma = 0.01;
    s.measured = i > 0;
    raw.push_back(s);
  }
  return raw;
}

// Three readings in a row that disagree with a confident filter restart it from the third: that reading is
// then the state, with its own variance plus 1 (m/s)^2. Applied a second time as a measurement, with the
// innovation variance of the state it replaced, the update drove the speed variance negative (a restart on
// the last frame came back with sigma 0; on the Udacity clip the negative variance ran into the backward
// pass).
TEST(EgoMotionSmoother, ARestartStartsFromItsMeasurementWithItsVariance) {
  const auto raw = readings(23, 0.04, 0.3, [](int i) { return i < 20 ? 20.0 : 24.0; });
  SmoothOptions opt;
  opt.median_window = 1;  // the pre-gate passes the last three; the filter's gate is tested here
  SmoothReport report;
  const auto out = smooth_ego_motion(raw, opt, &report);
  EXPECT_EQ(report.rejected, 2);
  EXPECT_EQ(report.restarts, 1);
  EXPECT_FALSE(out[20].measured);
  EXPECT_FALSE(out[21].measured);
  ASSERT_TRUE(out[22].measured);
  EXPECT_DOUBLE_EQ(out[22].speed_mps, 24.0);
  const double rv = 0.3 * 0.3 + opt.speed_sigma_floor * opt.speed_sigma_floor;
  EXPECT_NEAR(out[22].speed_sigma, std::sqrt(rv + 1.0), 1e-9);
  const double rw = 0.01 * 0.01 + opt.yaw_sigma_floor * opt.yaw_sigma_floor;  // nor is its yaw rate
  EXPECT_NEAR(out[22].yaw_rate_sigma, std::sqrt(rw + 0.01), 1e-9);
}

// Raw speeds that scatter more than their sigmas say (the Udacity clip's road view claims 0.2-0.3 m/s and
// scatters by about 2 m/s) are weighed by the scatter: otherwise the filter keeps rejecting readings,
// restarting on single ones and following them. 20 clips at 25 fps, 31 m/s scattered by 1.8 m/s, each reading
// claiming 0.2 m/s: every smoothed frame stays within 1.8 m/s of 31 (unscaled, the readings are followed to
// 27 and 34 m/s).
TEST(EgoMotionSmoother, OverconfidentRawSpeedsAreWeighedByTheirScatter) {
  std::mt19937 rng(7);
  std::normal_distribution<double> scatter(0.0, 1.8);
  std::vector<double> scales;
  for (int clip = 0; clip < 20; ++clip) {
    auto raw = readings(38, 0.04, 0.2, [&](int) { return 31.0 + scatter(rng); });
    raw[1].measured = false;
    SmoothReport report;
    const auto out = smooth_ego_motion(raw, {}, &report);
    scales.push_back(report.noise_scale);
    EXPECT_GT(report.noise_scale, 2.0) << clip;
    EXPECT_EQ(report.restarts, 0) << clip;
    for (const auto& s : out) {
      EXPECT_NEAR(s.speed_mps, 31.0, 1.8) << "clip " << clip << " frame " << s.frame;
      EXPECT_GT(s.speed_sigma, 0.05) << "clip " << clip << " frame " << s.frame;
    }
  }
  // The scatter over the claimed sigma (0.2 m/s and the 0.2 m/s floor): 6.4. A clip's 32 residuals measure it
  // to about +-35 % (5-95 %: 4.1-9.1 over 2000 clips); the median of 20 clips to about 10 %.
  std::sort(scales.begin(), scales.end());
  EXPECT_NEAR(0.5 * (scales[9] + scales[10]), 1.8 / std::hypot(0.2, SmoothOptions{}.speed_sigma_floor), 0.9);
}

// A raw speed is a distance over the interval since the previous frame: the mean speed over that interval,
// which at 2 Hz keyframes lags the speed at the frame by a quarter of a second. Accelerating at 1 m/s^2 and
// then braking at 0.8 m/s^2, read as each interval's mean, the smoothed speed is the speed at each frame
// (taken as the frame's own, it would read 0.25 m/s low while accelerating and 0.2 m/s high while braking).
TEST(EgoMotionSmoother, AnIntervalsMeanSpeedIsPlacedHalfAnIntervalEarlier) {
  auto speed = [](double t) { return t <= 5.0 ? 4.0 + t : 9.0 - 0.8 * (t - 5.0); };
  const auto raw = readings(21, 0.5, 0.05, [&](int i) {
    double mean = 0;  // over (t - 0.5, t], by the midpoint rule (exact for a linear stretch)
    for (int k = 0; k < 100; ++k) mean += speed(0.5 * i - 0.5 + 0.005 * (k + 0.5)) / 100.0;
    return mean;
  });
  SmoothReport report;
  const auto out = smooth_ego_motion(raw, {}, &report);
  EXPECT_EQ(report.noise_scale, 1.0);  // readings that keep to their sigmas are not rescaled
  EXPECT_EQ(report.rejected, 0);
  for (int i = 2; i < 21; ++i) {
    if (std::abs(out[i].t - 5.0) <= 1.0) continue;  // the kink: no filter follows it at once
    EXPECT_NEAR(out[i].speed_mps, speed(out[i].t), 0.08) << "frame " << i;
  }
}

// Queued behind a lead, traffic moving through the road region makes the odometry read a small reverse speed:
// the ego of a front camera does not reverse, so the smoothed speed stops at zero (unless reversing is
// allowed). `frames` measured samples 0.1 s apart: braking from 2 m/s to a stop at frame 20, then
// `stopped_speed`; yaw rate `turning` until then and `stopped_yaw_rate` after.
std::vector<EgoMotionSample> braking_to_a_stop(int frames, double stopped_speed, double turning,
                                               double stopped_yaw_rate, double yaw_sigma, bool yaw_measured) {
  std::vector<EgoMotionSample> raw;
  for (int i = 0; i < frames; ++i) {
    EgoMotionSample s;
    s.frame = i;
    s.t = 0.1 * i;
    s.speed_mps = i < 20 ? 2.0 - 0.1 * i : stopped_speed;
    s.yaw_rate = i < 20 ? turning : stopped_yaw_rate;
    s.speed_sigma = 0.1;
    s.yaw_rate_sigma = yaw_sigma;
    s.measured = true;
    s.yaw_measured = yaw_measured;
    raw.push_back(s);
  }
  return raw;
}

TEST(EgoMotionSmoother, AStandstillDoesNotBecomeReversing) {
  // Then a reverse-looking read.
  const auto raw = braking_to_a_stop(60, -0.3, 0.0, 0.0, 0.01, false);
  const auto out = smooth_ego_motion(raw);
  for (const auto& s : out) EXPECT_GE(s.speed_mps, 0.0) << s.frame;
  EXPECT_NEAR(out[5].speed_mps, 1.5, 0.2);
  EXPECT_EQ(out[45].speed_mps, 0.0);
  SmoothOptions reverse;
  reverse.min_speed = -std::numeric_limits<double>::infinity();
  EXPECT_NEAR(smooth_ego_motion(raw, reverse)[45].speed_mps, -0.3, 0.1);
}

// Stopped in a queue, traffic passing beside the ego shifts the far scene sideways, which reads as a small
// yaw rate: a car does not turn on the spot, so the smoothed yaw rate goes to zero with the speed, and a stop
// does not turn the recorded path. While the ego moves, a real turn is kept.
TEST(EgoMotionSmoother, AStoppedCarDoesNotTurn) {
  // Turning left, then the queue's bias (-0.3 deg/s).
  const auto raw = braking_to_a_stop(80, 0.0, 0.1, -0.005, 0.002, true);
  const auto out = smooth_ego_motion(raw);
  EXPECT_NEAR(out[5].yaw_rate, 0.1, 0.02);  // 1.5 m/s may turn at up to 0.3 rad/s
  double turned = 0;                        // over the stop: the raw yaw rate integrates to -1.6 deg
  for (size_t i = 25; i < out.size(); ++i) {
    EXPECT_LT(out[i].speed_mps, 0.01) << i;
    EXPECT_LE(std::abs(out[i].yaw_rate), 0.2 * out[i].speed_mps + 1e-12) << i;
    turned += 0.1 * out[i].yaw_rate;
  }
  EXPECT_LT(std::abs(turned) / kRadPerDeg, 0.02);
  SmoothOptions unlimited;
  unlimited.max_curvature = 0;
  EXPECT_NEAR(smooth_ego_motion(raw, unlimited)[60].yaw_rate, -0.005, 0.002);
}

TEST(EgoMotionSmoother, NoMeasurementsGivesUnmeasuredOutput) {
  std::vector<EgoMotionSample> raw(5);
  for (int i = 0; i < 5; ++i) raw[i].t = 0.1 * i;
  const auto out = smooth_ego_motion(raw);
  for (const auto& s : out) {
    EXPECT_FALSE(s.measured);
    EXPECT_GT(s.speed_sigma, 5.0);  // nothing known: the prior's uncertainty, not a made-up precision
  }
}

}  // namespace

// Two views of a scene of known geometry as matched points: random points 4-60 m ahead, seen by a camera of
// focal length f (1280x720, principal point at the centre, pitched down by 3 degrees) before and after the
// car turned left by `yaw_deg` and moved `forward_m` along the chord of its arc; 0.3 px of noise, and 15 % of
// the pairs replaced by random ones.
struct PointPair {
  std::vector<cv::Point2f> a, b;
  cv::Point2d epipole;  // the later view's image of the earlier camera centre
};
PointPair synthetic_views(double f, double yaw_deg, double forward_m, unsigned seed, double pitch_deg = 3.0) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> ux(-25, 25), uy(-8, 1.5), uz(4, 60), upx(0, 1280), upy(0, 720),
      u01(0, 1);
  std::normal_distribution<double> noise(0.0, 0.3);
  const cv::Matx33d K(f, 0, 640, 0, f, 360, 0, 0, 1);
  // World: x right, y down, z ahead (level). A left turn shows what was ahead to the right.
  const double yaw = yaw_deg * kRadPerDeg, p = pitch_deg * kRadPerDeg;
  const cv::Matx33d Ryaw(std::cos(yaw), 0, std::sin(yaw), 0, 1, 0, -std::sin(yaw), 0, std::cos(yaw));
  const cv::Matx33d Rp(1, 0, 0, 0, std::cos(p), -std::sin(p), 0, std::sin(p), std::cos(p));
  const cv::Vec3d Cb(-std::sin(yaw / 2) * forward_m, 0, std::cos(yaw / 2) * forward_m);
  const cv::Matx33d Rb = Rp * Ryaw;
  PointPair out;
  const cv::Vec3d e = K * (Rb * (-Cb));
  out.epipole = {e[0] / e[2], e[1] / e[2]};
  while (out.a.size() < 600) {
    const cv::Vec3d X(ux(rng), uy(rng), uz(rng));
    const cv::Vec3d Xa = Rp * X, Xb = Rb * (X - Cb);
    if (Xa[2] < 2 || Xb[2] < 2) continue;
    const cv::Vec3d pa = K * Xa, pb = K * Xb;
    const cv::Point2f a(static_cast<float>(pa[0] / pa[2] + noise(rng)),
                        static_cast<float>(pa[1] / pa[2] + noise(rng)));
    const cv::Point2f b(static_cast<float>(pb[0] / pb[2] + noise(rng)),
                        static_cast<float>(pb[1] / pb[2] + noise(rng)));
    if (a.x < 0 || a.x >= 1280 || a.y < 0 || a.y >= 720 || b.x < 0 || b.x >= 1280 || b.y < 0 || b.y >= 720)
      continue;
    const bool outlier = u01(rng) < 0.15;
    out.a.push_back(a);
    out.b.push_back(outlier ? cv::Point2f(static_cast<float>(upx(rng)), static_cast<float>(upy(rng))) : b);
  }
  return out;
}

// Pairs of a drive turning by 5-8 degrees fix the focal length, whatever the lens (no pull towards a
// default); each pair alone is noisy, their median is not. The epipoles are the direction of travel.
TEST(TwoViewCalibration, TurningPairsFixTheFocalLength) {
  for (const double f : {500.0, 896.0, 1500.0}) {
    TwoViewCalibration est({1280, 720});
    std::vector<double> rows;
    double true_row = 0;
    for (int i = 0; i < 25; ++i) {
      const PointPair v = synthetic_views(f, i % 2 ? 5.0 : -8.0, 3.0, static_cast<unsigned>(f) + i);
      const auto r = TwoViewCalibration::measure_pair(v.a, v.b, {1280, 720}, est.options());
      ASSERT_TRUE(r.has_value()) << "f " << f << " pair " << i;
      est.add_pair(*r, i);
      true_row = v.epipole.y;
    }
    const auto e = est.result();
    ASSERT_TRUE(e.has_value()) << "f " << f << ": " << est.why_not();
    EXPECT_NEAR(e->fx, f, 0.06 * f) << e->note;
    EXPECT_GE(e->pairs, 20) << e->note;
    EXPECT_LT(e->sigma, 0.05 * f);
    ASSERT_GE(est.epipoles().size(), 18u) << "f " << f;
    for (const auto& ep : est.epipoles()) rows.push_back(ep.point.y);
    const auto mid = rows.begin() + static_cast<std::ptrdiff_t>(rows.size() / 2);
    std::nth_element(rows.begin(), mid, rows.end());
    EXPECT_NEAR(*mid, true_row, 3.0) << "f " << f;  // the horizon row at 3 degrees of pitch
  }
}

// Driving straight does not fix it: pure translation makes every E(f) an essential matrix, so no pair counts,
// though each gives the point ahead. Standing still gives neither.
TEST(TwoViewCalibration, AStraightDriveDoesNotFixTheFocalLength) {
  TwoViewCalibration est({1280, 720});
  std::vector<double> rows;
  double true_row = 0;
  for (int i = 0; i < 25; ++i) {
    const PointPair v = synthetic_views(896.0, 0.0, 3.0, 40u + i);
    const auto r = TwoViewCalibration::measure_pair(v.a, v.b, {1280, 720}, est.options());
    ASSERT_TRUE(r.has_value());
    EXPECT_FALSE(r->accepted) << "f " << r->f << " rotation " << r->rotation_deg << " sharpness "
                              << r->sharpness;
    ASSERT_TRUE(r->epipole.has_value());
    rows.push_back(r->epipole->y);
    true_row = v.epipole.y;
    est.add_pair(*r, i);
  }
  std::nth_element(rows.begin(), rows.begin() + 12, rows.end());
  EXPECT_NEAR(rows[12], true_row, 3.0);
  EXPECT_FALSE(est.result().has_value());
  EXPECT_NE(est.why_not().find("straight drive"), std::string::npos) << est.why_not();
  const PointPair v = synthetic_views(896.0, 0.0, 3.0, 7);
  const auto still = TwoViewCalibration::measure_pair(v.a, v.a, {1280, 720}, est.options());
  EXPECT_TRUE(!still || (!still->accepted && !still->epipole));
}

// A level camera turning on a plane is the degenerate case: whatever its pairs say, no estimate, and the
// reason.
TEST(TwoViewCalibration, ALevelCameraDoesNotFixTheFocalLength) {
  TwoViewCalibration est({1280, 720});
  for (int i = 0; i < 25; ++i) {
    const PointPair v = synthetic_views(896.0, i % 2 ? 5.0 : -8.0, 3.0, 70u + i, 0.0);
    if (const auto r = TwoViewCalibration::measure_pair(v.a, v.b, {1280, 720}, est.options()))
      est.add_pair(*r, i);
  }
  EXPECT_FALSE(est.result().has_value());
  EXPECT_TRUE(est.why_not().find("level") != std::string::npos ||
              est.why_not().find("scatter") != std::string::npos ||
              est.why_not().find("straight drive") != std::string::npos)
      << est.why_not();
}

// The real nuScenes keyframes (2 Hz, a drive through two bends; calibrated fx 1266.4 px at 1600x900,
// principal point 16 px right of and 41 px below the centre): the focal length from the bends, and a straight
// run that the estimator must not take for one.
TEST(TwoViewCalibration, NuScenesKeyframes) {
  std::vector<std::filesystem::path> files;
  for (const auto& e :
       std::filesystem::directory_iterator(hf::test::shared_data("nuscenes/samples/CAM_FRONT")))
    files.push_back(e.path());
  std::sort(files.begin(), files.end());  // the names carry the timestamps
  ASSERT_EQ(files.size(), 41u);
  TwoViewCalibration views({1600, 900});
  TwoViewCalibration straight({1600, 900});
  for (size_t i = 0; i < files.size(); ++i) {
    const cv::Mat img = cv::imread(files[i].string());
    views.add(img, static_cast<int>(i));
    if (i >= 21 && i <= 31) straight.add(img, static_cast<int>(i));  // about 0.3 deg per keyframe
  }
  const auto f = views.result();
  ASSERT_TRUE(f.has_value()) << views.why_not();
  EXPECT_NEAR(f->fx, 1266.4, 0.05 * 1266.4) << f->note;
  EXPECT_GE(f->pairs, 10);
  EXPECT_FALSE(straight.result().has_value());
  // The epipoles' median row against the horizon row the calibration implies at x = 800 (484.4 px).
  std::vector<double> rows;
  for (const auto& e : views.epipoles()) rows.push_back(e.point.y);
  ASSERT_GE(rows.size(), 30u);
  std::nth_element(rows.begin(), rows.begin() + static_cast<std::ptrdiff_t>(rows.size() / 2), rows.end());
  EXPECT_NEAR(rows[rows.size() / 2], 484.4, 8.0);
}

// The epipoles as a horizon cue: with them the estimator's horizon is the true one also from views alone.
TEST(Horizon, EpipolesAreAHorizonCue) {
  const CameraModel cam = CameraModel::pinhole(800, 450, 560, 560, 400, 225, 1.5, 2.0 * kRadPerDeg, 1.5, 0.0);
  HorizonEstimator h(cam);
  for (int i = 0; i < 12; ++i)
    h.add_epipole({380.0 + 3.0 * i, *cam.horizon_y(380.0 + 3.0 * i) + (i % 2 ? 1.5 : -1.5)}, i);
  const auto est = h.result();
  ASSERT_TRUE(est.has_value());
  EXPECT_EQ(est->epipoles, 12);
  EXPECT_NE(est->method.find("epipole"), std::string::npos);
  EXPECT_NEAR(est->horizon_y, *cam.horizon_y(cam.cx), 1.6);
  EXPECT_NEAR(est->pitch_rad, 2.0 * kRadPerDeg, 0.2 * kRadPerDeg);
}
