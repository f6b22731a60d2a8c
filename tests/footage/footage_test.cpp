// Horizon, ground-plane odometry and the ego-motion smoother on rendered road sequences of known geometry.
#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <vector>

#include <opencv2/imgproc.hpp>

#include "hazardforge/footage/ego_motion.hpp"
#include "hazardforge/footage/horizon.hpp"

namespace {

using hf::CameraModel;
using namespace hf::footage;

constexpr double kDeg = M_PI / 180.0;

// A straight road along the world x axis: asphalt noise (features of ~10 cm), dashed lane lines (3 m dash, 9 m
// gap) at +-1.75 m and +-5.25 m, solid edge lines at +-7 m, kerb-side grass beyond. Stored as a texture pyramid so
// that each pixel samples the level matching its ground footprint (no aliasing far away).
class RoadWorld {
 public:
  static constexpr double kRes = 0.04;  // m per texel at level 0
  static constexpr double kX0 = -20, kY0 = -20;
  RoadWorld() {
    const int w = static_cast<int>(160 / kRes), h = static_cast<int>(40 / kRes);  // x: -20..140 m, y: -20..20 m
    cv::Mat noise(h, w, CV_32F);
    cv::RNG rng(1234);
    rng.fill(noise, cv::RNG::NORMAL, 0, 1);
    cv::GaussianBlur(noise, noise, cv::Size(0, 0), 1.2);
    cv::normalize(noise, noise, 0, 1, cv::NORM_MINMAX);
    cv::Mat coarse(h / 16, w / 16, CV_32F);
    rng.fill(coarse, cv::RNG::NORMAL, 0, 1);
    cv::resize(coarse, coarse, noise.size(), 0, 0, cv::INTER_CUBIC);
    cv::Mat tex = 40 + 90 * noise + 8 * coarse;
    auto paint = [&](double y, double width, bool dashed) {
      for (int c = 0; c < w; ++c) {
        const double x = kX0 + c * kRes;
        if (dashed && std::fmod(x + 1000.0, 12.0) >= 3.0) continue;
        const int r0 = static_cast<int>((y - width / 2 - kY0) / kRes), r1 = static_cast<int>((y + width / 2 - kY0) / kRes);
        for (int r = r0; r <= r1; ++r) tex.at<float>(r, c) = 215;
      }
    };
    for (double y : {-5.25, -1.75, 1.75, 5.25}) paint(y, 0.15, true);
    for (double y : {-7.0, 7.0}) paint(y, 0.2, false);
    for (int r = 0; r < h; ++r) {
      const double y = kY0 + r * kRes;
      if (std::abs(y) > 8.0)
        for (int c = 0; c < w; ++c) tex.at<float>(r, c) = 0.6f * tex.at<float>(r, c) + 10;  // darker verge
    }
    levels_.push_back(tex);
    for (int i = 0; i < 6; ++i) {
      cv::Mat d;
      cv::pyrDown(levels_.back(), d);
      levels_.push_back(d);
    }
  }
  // Grey level at world (x, y) for a ground footprint of `foot` metres.
  float sample(double x, double y, double foot) const {
    const double lev = std::clamp(std::log2(std::max(foot, 1e-6) / kRes), 0.0, static_cast<double>(levels_.size() - 1));
    const int l = static_cast<int>(lev);
    const cv::Mat& t = levels_[l];
    const double s = kRes * std::pow(2.0, l);
    const double u = (x - kX0) / s, v = (y - kY0) / s;
    const int u0 = static_cast<int>(std::floor(u)), v0 = static_cast<int>(std::floor(v));
    if (u0 < 0 || v0 < 0 || u0 + 1 >= t.cols || v0 + 1 >= t.rows) return 70.f;
    const double a = u - u0, b = v - v0;
    return static_cast<float>((1 - a) * (1 - b) * t.at<float>(v0, u0) + a * (1 - b) * t.at<float>(v0, u0 + 1) +
                              (1 - a) * b * t.at<float>(v0 + 1, u0) + a * b * t.at<float>(v0 + 1, u0 + 1));
  }

 private:
  std::vector<cv::Mat> levels_;
};

const RoadWorld& world() {
  static const RoadWorld w;
  return w;
}

struct Pose {
  double x = 0, y = 0, yaw = 0;
};

// Inverse mapping: every pixel's ray meets the ground in the ego frame, the ego pose takes it to the world, the
// texture gives its grey level. Sky above the horizon (and beyond 150 m) is a smooth gradient.
cv::Mat render(const CameraModel& cam, const Pose& pose) {
  cv::Mat img(cam.height, cam.width, CV_8UC3);
  const double c = std::cos(pose.yaw), s = std::sin(pose.yaw);
  for (int v = 0; v < cam.height; ++v) {
    for (int u = 0; u < cam.width; ++u) {
      const auto g = cam.pixel_to_ground({u + 0.5, v + 0.5});
      double val;
      if (!g || std::hypot((*g)[0], (*g)[1]) > 150) {
        val = 170 + 40.0 * v / cam.height;
      } else {
        const auto g2 = cam.pixel_to_ground({u + 0.5, v + 1.5});
        const double foot = g2 ? std::max(cv::norm(*g - *g2), cv::norm(*g) / cam.fx) : 1.0;
        const double wx = pose.x + c * (*g)[0] - s * (*g)[1], wy = pose.y + s * (*g)[0] + c * (*g)[1];
        val = world().sample(wx, wy, foot);
      }
      const auto b = cv::saturate_cast<uchar>(val);
      img.at<cv::Vec3b>(v, u) = cv::Vec3b(b, b, b);
    }
  }
  return img;
}

// Constant speed and yaw rate from a start pose: the exact arc.
Pose pose_at(double t, double speed, double yaw_rate, Pose start = {}) {
  Pose p = start;
  p.yaw = start.yaw + yaw_rate * t;
  if (std::abs(yaw_rate) < 1e-9) {
    p.x += speed * t * std::cos(start.yaw);
    p.y += speed * t * std::sin(start.yaw);
  } else {
    const double r = speed / yaw_rate;
    p.x += r * (std::sin(p.yaw) - std::sin(start.yaw));
    p.y += -r * (std::cos(p.yaw) - std::cos(start.yaw));
  }
  return p;
}

CameraModel test_camera(double pitch_deg, double roll_deg) {
  return CameraModel::pinhole(800, 450, 720, 720, 400, 225, 1.5, pitch_deg * kDeg, 1.5, roll_deg * kDeg);
}

TEST(Horizon, PitchAndRollOfARenderedDriveWithinTolerance) {
  const CameraModel truth = test_camera(3.0, 1.5);
  HorizonEstimator est(CameraModel::pinhole(800, 450, 720, 720, 400, 225));
  // 10 m/s, turning gently so that the road's vanishing point sweeps across the image (it traces the horizon).
  const Pose start{0, -1.0, -0.12};
  for (int i = 0; i < 30; ++i) {
    const double t = 0.1 * i;
    est.add(render(truth, pose_at(t, 10.0, 0.08, start)), t);
  }
  const auto r = est.result();
  ASSERT_TRUE(r.has_value());
  const double true_row = *truth.horizon_y(truth.cx);
  EXPECT_NEAR(r->horizon_y, true_row, 3.0) << r->method;
  EXPECT_NEAR(r->pitch_rad / kDeg, 3.0, 0.3);
  EXPECT_NEAR(r->roll_rad / kDeg, 1.5, 0.5) << "roll must be estimated on a clip that shows it";
  EXPECT_GT(r->confidence, 0.3);
  EXPECT_GE(r->frames_used, 10);
  EXPECT_FALSE(r->method.empty());
}

TEST(Horizon, StraightDriveGivesTheHorizonRow) {
  const CameraModel truth = test_camera(3.0, 0.0);
  HorizonEstimator est(CameraModel::pinhole(800, 450, 720, 720, 400, 225));
  for (int i = 0; i < 20; ++i) est.add(render(truth, pose_at(0.1 * i, 15.0, 0.0, {0, 0.5, 0})), 0.1 * i);
  const auto r = est.result();
  ASSERT_TRUE(r.has_value());
  EXPECT_NEAR(r->horizon_y, *truth.horizon_y(truth.cx), 3.0);
  EXPECT_NEAR(r->pitch_rad / kDeg, 3.0, 0.3);
  EXPECT_NEAR(r->roll_rad / kDeg, 0.0, 0.5);
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

TEST(GroundOdometry, TenFramesPerSecondTurning) { check_odometry(12.0, 0.1, 0.1, 12); }
TEST(GroundOdometry, TwentyFiveFramesPerSecondHighway) { check_odometry(20.0, 0.0, 0.04, 12); }
TEST(GroundOdometry, KeyframesHalfASecondApart) { check_odometry(5.0, 0.05, 0.5, 8); }

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
