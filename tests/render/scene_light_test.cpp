// The scene's light from the shadows beside vehicles, on synthetic streets of known geometry: parked cars on
// a grey road (bodies riding on wheels inside their ends, the road under them in their own shade), with a sun
// shadow cast in a known direction, or only the soft dark rim of overcast light.
#include <cmath>
#include <filesystem>

#include <gtest/gtest.h>
#include <opencv2/imgproc.hpp>

#include "ar_renderer.hpp"
#include "hazardforge/angles.hpp"
#include "hazardforge/geometry.hpp"
#include "render_fixtures.hpp"
#include "scene_light.hpp"

namespace {

using namespace hf;
using namespace hf::render;
using hf::test::test_camera;

struct Car {
  double x, y;  // footprint centre, ego frame
};

std::vector<cv::Point> project(const CameraModel& cam, const std::vector<cv::Vec3d>& pts) {
  std::vector<cv::Point> px;
  for (const auto& p : pts)
    if (auto q = cam.project_ego(p))
      px.emplace_back(static_cast<int>(std::lround(q->x)), static_cast<int>(std::lround(q->y)));
  std::vector<cv::Point> hull;
  if (px.size() >= 3) cv::convexHull(px, hull);
  return hull;
}

std::vector<cv::Vec3d> footprint(const Car& c, double grow = 0.0, cv::Vec2d shift = {0, 0}) {
  const double hl = 2.25 + grow, hw = 0.925 + grow;
  return {{c.x - hl + shift[0], c.y - hw + shift[1], 0},
          {c.x + hl + shift[0], c.y - hw + shift[1], 0},
          {c.x + hl + shift[0], c.y + hw + shift[1], 0},
          {c.x - hl + shift[0], c.y + hw + shift[1], 0}};
}

// A street of parked cars; shadow(car, image) paints each car's shadow on the road before the car is drawn.
template <class Shadow>
std::pair<cv::Mat, std::vector<VehicleView>> street(const CameraModel& cam, const std::vector<Car>& cars,
                                                    Shadow shadow, unsigned seed) {
  cv::Mat grey = hf::test::noise_texture({cam.width, cam.height}, seed, 12.0);  // asphalt around 128
  cv::Mat img;
  cv::cvtColor(grey, img, cv::COLOR_GRAY2BGR);
  img.rowRange(0, 455).setTo(cv::Scalar(200, 180, 160));  // sky above the horizon
  for (const Car& c : cars) shadow(c, img);
  std::vector<VehicleView> views;
  for (const Car& c : cars) {
    // Like a real car: the road under the body is in its shade in any light; the body rides 0.3 m above the
    // road on wheels 0.87 m inside its ends, so the box's bottom is where the near wheels touch the road.
    {
      const auto under = project(cam, footprint(c));
      cv::Mat mask(img.size(), CV_8U, cv::Scalar(0));
      cv::fillConvexPoly(mask, under, cv::Scalar(255));
      cv::Mat shaded;
      img.convertTo(shaded, -1, 0.35);
      shaded.copyTo(img, mask);
    }
    std::vector<cv::Point> all;
    for (const double wx : {c.x - 1.38, c.x + 1.42})
      for (const double wy : {c.y - 0.815, c.y + 0.815}) {
        std::vector<cv::Vec3d> tyre;
        for (const double dx : {-0.33, 0.33})
          for (const double dy : {-0.11, 0.11})
            for (const double z : {0.0, 0.66}) tyre.push_back({wx + dx, wy + dy, z});
        const auto hull = project(cam, tyre);
        cv::fillConvexPoly(img, hull, cv::Scalar(25, 25, 25));
        all.insert(all.end(), hull.begin(), hull.end());
      }
    std::vector<cv::Vec3d> body;
    for (const auto& p : footprint(c)) body.push_back({p[0], p[1], 0.3});
    for (const auto& p : footprint(c)) body.push_back({p[0], p[1], 1.5});
    const auto hull = project(cam, body);
    cv::fillConvexPoly(img, hull, cv::Scalar(60, 50, 150));
    all.insert(all.end(), hull.begin(), hull.end());
    VehicleView v;
    v.box = cv::Rect2f(cv::boundingRect(all));
    views.push_back(v);
  }
  return {img, views};
}

// A sun shadow: the footprint swept `reach` metres along `dir` (ego frame), the road there `gain` as bright.
auto sun_shadow(const CameraModel& cam, cv::Vec2d dir, double reach, double gain) {
  return [=](const Car& c, cv::Mat& img) {
    std::vector<cv::Vec3d> pts = footprint(c);
    for (const auto& p : footprint(c, 0.0, reach * dir)) pts.push_back(p);
    const auto hull = project(cam, pts);
    cv::Mat mask(img.size(), CV_8U, cv::Scalar(0));
    cv::fillConvexPoly(mask, hull, cv::Scalar(255));
    cv::Mat shaded;
    img.convertTo(shaded, -1, gain);
    shaded.copyTo(img, mask);
  };
}

// Three frames of parked and leading cars that do not hide each other in the picture.
const std::vector<Car> kStreets[3] = {{{12, 4.0}, {20, -4.0}, {35, 0.5}},
                                      {{10, -4.2}, {16, 4.2}, {28, -0.5}},
                                      {{14, -3.8}, {22, 3.8}, {40, 0.0}}};

TEST(SceneLight, FindsTheDirectionLengthAndDarknessOfASunShadow) {
  const CameraModel cam = test_camera();
  for (const double phi_deg : {90.0, -60.0, 150.0}) {
    const cv::Vec2d dir(std::cos(phi_deg * kRadPerDeg), std::sin(phi_deg * kRadPerDeg));
    const double reach = 1.2;  // m beyond the footprint: a 1.5 m car in a sun 51 degrees high
    const auto sun = sun_shadow(cam, dir, reach, 0.5);
    SceneLightEstimator est;
    for (unsigned frame = 0; frame < 3; ++frame) {
      auto [img, views] = street(cam, kStreets[frame], sun, 11 + frame);
      est.add(img, cam, views);
    }
    const SceneLight light = est.estimate();
    ASSERT_TRUE(light.directional) << "sun at " << phi_deg << ": " << light.directional_samples << " of "
                                   << light.samples << " views, consistency " << light.consistency;
    // A shadow pointing away from the camera is partly hidden behind its car: the visible part pulls the
    // estimate towards the side (150 degrees reads 120-170 per car).
    EXPECT_LT(std::abs(std::remainder(light.azimuth - phi_deg * kRadPerDeg, 2 * CV_PI)), 30 * kRadPerDeg)
        << phi_deg;
    EXPECT_NEAR(light.darkness, 0.5, 0.12) << phi_deg;
    // The reach is read in 0.3 m steps along the shadow's direction from an edge placed across the line of
    // sight: 0.63 m/m at 90 and -60 degrees, 0.43 at 150 (towards the camera), against 0.8.
    EXPECT_NEAR(light.length_per_height, reach / 1.5, 0.4) << phi_deg;
  }
}

// Only the body's own shade under its overhang, nothing cast: the light is diffuse. Placing the footprint's
// near edge at the box's bottom (the wheels' contact, no overhang) reads that shade as a sun shadow pointing
// at the camera on every car — what the recordings' queued cars seen from behind showed before.
TEST(SceneLight, TheRoadUnderACarsOverhangIsNoSunShadow) {
  const CameraModel cam = test_camera();
  auto nothing = [](const Car&, cv::Mat&) {};
  SceneLightOptions no_overhang;
  no_overhang.overhang_fraction = 0.0;
  SceneLightEstimator est, naive(no_overhang);
  for (unsigned frame = 0; frame < 3; ++frame) {
    auto [img, views] = street(cam, kStreets[frame], nothing, 31 + frame);
    est.add(img, cam, views);
    naive.add(img, cam, views);
  }
  const SceneLight light = est.estimate(), wrong = naive.estimate();
  EXPECT_FALSE(light.directional) << light.directional_samples << " of " << light.samples << " views";
  ASSERT_TRUE(wrong.directional);
  EXPECT_GT(std::abs(std::remainder(wrong.azimuth, 2 * CV_PI)), 120 * kRadPerDeg)
      << wrong.azimuth / kRadPerDeg;
}

TEST(SceneLight, OvercastLightIsDiffuseWithTheDarknessBesideTheVehicle) {
  const CameraModel cam = test_camera();
  auto rim = [&](const Car& c, cv::Mat& img) {
    // Sky light blocked under and right beside the car: a dark rim all around, fading within half a metre.
    for (const auto& [grow, gain] : {std::pair(0.45, 0.9), std::pair(0.25, 0.8)}) {
      const auto hull = project(cam, footprint(c, grow));
      cv::Mat mask(img.size(), CV_8U, cv::Scalar(0));
      cv::fillConvexPoly(mask, hull, cv::Scalar(255));
      cv::Mat shaded;
      img.convertTo(shaded, -1, gain);
      shaded.copyTo(img, mask);
    }
  };
  SceneLightEstimator est;
  for (unsigned frame = 0; frame < 3; ++frame) {
    auto [img, views] = street(cam, kStreets[frame], rim, 21 + frame);
    est.add(img, cam, views);
  }
  const SceneLight light = est.estimate();
  EXPECT_GE(light.samples, 7);
  EXPECT_FALSE(light.directional) << light.directional_samples << " of " << light.samples;
  // The rim is 0.1-0.28 dark within half a metre; the footprint is only known from the box, so the samples
  // beside it fall on either part.
  EXPECT_GT(light.darkness, 0.06);
  EXPECT_LT(light.darkness, 0.3);
}

TEST(SceneLight, DirectionsFollowTheWorldWhileTheEgoTurns) {
  // The same sun seen from an ego that has turned by 30 degrees: in the ego frame the shadows point 30
  // degrees the other way; with the ego's heading passed in, the estimate stays where the sun is.
  const CameraModel cam = test_camera();
  const double world_phi = 100 * kRadPerDeg, heading = 30 * kRadPerDeg;
  const cv::Vec2d dir(std::cos(world_phi - heading), std::sin(world_phi - heading));
  const auto sun = sun_shadow(cam, dir, 1.0, 0.55);
  SceneLightEstimator est;
  for (unsigned frame = 0; frame < 3; ++frame) {
    auto [img, views] = street(cam, kStreets[frame], sun, 31 + frame);
    est.add(img, cam, views, heading);
  }
  const SceneLight light = est.estimate();
  ASSERT_TRUE(light.directional);
  EXPECT_LT(std::abs(std::remainder(light.azimuth - world_phi, 2 * CV_PI)), 25 * kRadPerDeg);
}

TEST(SceneLight, AShadowBehindTheCarsIsNotSeen) {
  // The sun in front of the ego: every shadow falls behind its car, hidden by it; the light is not called
  // directional from what cannot be seen.
  const CameraModel cam = test_camera();
  const auto sun = sun_shadow(cam, {1.0, 0.0}, 1.2, 0.5);
  SceneLightEstimator est;
  for (unsigned frame = 0; frame < 3; ++frame) {
    auto [img, views] = street(cam, kStreets[frame], sun, 41 + frame);
    est.add(img, cam, views);
  }
  EXPECT_GE(est.estimate().samples, 7);
  EXPECT_FALSE(est.estimate().directional);
}

// The renderer casts the hazard's shadow the way the recording's cars cast theirs: with the scene light on,
// the road on the shadow's side of an inserted car is darker than with it off; on the other side it is not.
TEST(SceneLight, TheHazardCastsItsShadowLikeTheRecordingsCars) {
  const CameraModel cam = test_camera();
  const cv::Vec2d left(0.0, 1.0);
  const auto sun = sun_shadow(cam, left, 1.2, 0.5);
  auto render = [&](bool scene_light) {
    RendererOptions o;
    o.composite.shadow = true;
    o.composite.exposure_s = 0;
    o.ego.mode = EgoMotionMode::kPoses;
    o.scene_light = scene_light;
    HazardRenderer r(o, std::make_shared<const AssetLibrary>(
                            AssetLibrary::load(std::filesystem::path(share_dir()) / "assets")));
    // The inserted car stands 18 m ahead in the ego lane; the real cars stand beside the road.
    auto traj = std::make_shared<const HazardTrajectory>(
        hf::test::static_object("car", 18.0, 0.0, 0.0, 0.0, 1.0, 0.0, cv::Vec3d(4.5, 1.85, 1.52)));
    HazardRenderer::Result res;
    for (unsigned frame = 0; frame < 3; ++frame) {
      auto [img, views] = street(cam, {kStreets[frame][0], kStreets[frame][1]}, sun, 51);
      std::vector<OccluderCandidate> occ;
      for (const auto& v : views) occ.push_back({v.box, 0.9f, std::nullopt, "car", 0, 0, -1, std::nullopt});
      res = r.render(hf::test::make_frame(frame, 0.1 * frame, img, cam, cv::Matx44d::eye()), traj, occ);
    }
    EXPECT_TRUE(r.light().directional || !scene_light);
    return res;
  };
  const auto lit = render(false), shaded = render(true);
  ASSERT_TRUE(lit.composite.drawn && shaded.composite.drawn);
  // Road points 0.6 m beside the car's left and right flanks, at its middle.
  auto grey_at = [&](const HazardRenderer::Result& r, double y) {
    const cv::Point2d px = *cam.project_ego({18.0, y, 0.0});
    const cv::Vec3b c = r.frame.image.at<cv::Vec3b>(static_cast<int>(px.y), static_cast<int>(px.x));
    return (c[0] + c[1] + c[2]) / 3.0;
  };
  EXPECT_LT(grey_at(shaded, 0.925 + 0.6), 0.8 * grey_at(lit, 0.925 + 0.6));     // left: in the sun's shadow
  EXPECT_NEAR(grey_at(shaded, -0.925 - 0.6), grey_at(lit, -0.925 - 0.6), 4.0);  // right: as before
}

TEST(SceneLight, NothingMeasuredWithoutVehicles) {
  const CameraModel cam = test_camera();
  SceneLightEstimator est;
  est.add(cv::Mat(cam.height, cam.width, CV_8UC3, cv::Scalar(128, 128, 128)), cam, {});
  EXPECT_FALSE(est.estimate().measured());
  EXPECT_FALSE(est.estimate().directional);
}

}  // namespace
