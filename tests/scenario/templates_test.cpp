// The three hazard templates on synthetic scenes with a known ego speed and camera.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>

#include "scenario_support.hpp"
#include "temp_dir.hpp"

namespace hf {
namespace {

using test::expect_within_limits;
using test::make_template;
using test::test_scene;

HazardSpec pedestrian(double distance, double speed, std::optional<double> target) {
  HazardSpec s;
  s.kind = "pedestrian_crossing";
  s.object_class = "person";
  s.initial_distance_m = distance;
  s.side = "left";
  s.speed_mps = speed;
  s.target_ttc_s = target;
  s.start_time_s = 2.0;
  return s;
}

HazardSpec lead_stop(double distance, double speed, double decel) {
  HazardSpec s;
  s.kind = "sudden_stop";
  s.object_class = "car";
  s.initial_distance_m = distance;
  s.speed_mps = speed;
  s.deceleration_mps2 = decel;
  s.start_time_s = 2.0;
  return s;
}

HazardSpec cut_in(double x0, double speed, double target) {
  HazardSpec s;
  s.kind = "cut_in";
  s.object_class = "car";
  s.initial_distance_m = x0;
  s.side = "left";
  s.speed_mps = speed;
  s.target_ttc_s = target;
  s.start_time_s = 2.0;
  return s;
}

bool projects_into_image(const CameraModel& cam, const TrajectoryPoint& p, const cv::Vec3d& size) {
  auto px = cam.project_ego(cv::Vec3d(p.x, p.y, size[2] / 2));
  return px && px->x >= 0 && px->x < cam.width && px->y >= 0 && px->y < cam.height;
}

// ---- pedestrian_crossing
// --------------------------------------------------------------------------------------------

TEST(PedestrianCrossing, EntersThePathAtTheTargetTtcAndIsInTheLaneWhenTheEgoArrives) {
  auto tpl = make_template("pedestrian_crossing");
  const SceneContext scene = test_scene(10.0);
  const hazard::PlanOutcome o = tpl->evaluate(pedestrian(50, 1.5, 1.5), scene);
  ASSERT_TRUE(o.reasons.empty()) << o.reasons.front();
  const HazardTrajectory& tr = o.trajectory;
  EXPECT_DOUBLE_EQ(tr.anchor_time, 2.0);
  EXPECT_DOUBLE_EQ(tr.points.front().t, 2.0);
  EXPECT_NEAR(tr.points[1].t - tr.points[0].t, 0.05, 1e-12);
  // Kerb on the left: road edge 1.75 + 3.5 = 5.25 m, plus 0.5 m.
  EXPECT_DOUBLE_EQ(tr.points.front().y, 5.75);
  EXPECT_DOUBLE_EQ(tr.points.front().x, 50.0);
  EXPECT_NEAR(tr.points.front().heading, -M_PI / 2, 1e-12);
  EXPECT_TRUE(projects_into_image(scene.camera, tr.points.front(), tr.size_lwh));
  expect_within_limits(tr, tpl->limits().at("person"));

  // Hand computation: gap 50 - 3.4 - 0.25 = 46.35 m, ego arrives after 4.635 s; the person must enter the
  // path
  // (|y| < 1.0 + 0.5 + 0.3 = 1.8) 1.5 s earlier, at 3.135 s. Walking: 0.8 s S-curve to 1.5 m/s covering 0.6
  // m, then (3.95 - 0.6) / 1.5 s, so 3.0333 s from the kerb: it waits 0.1017 s.
  EXPECT_NEAR(o.notes["wait_s"].get<double>(), 3.135 - (0.8 + 3.35 / 1.5), 1e-6);
  size_t first_in = 0;
  while (first_in < o.ttc.size() && !o.ttc[first_in].in_path) ++first_in;
  ASSERT_LT(first_in, o.ttc.size());
  EXPECT_LE(o.ttc[first_in].ttc, 1.5 + 1e-9);
  EXPECT_GT(o.ttc[first_in].ttc, 1.5 - 0.05 - 1e-9);  // within one sample of the target
  // The plan stops at contact: the ego reaches the crossing line while the person is still in its path.
  ASSERT_TRUE(o.notes.contains("contact_time_s"));
  EXPECT_NEAR(o.notes["contact_time_s"].get<double>(), 2.0 + 4.65, 1e-9);  // first sample at or after 4.635 s
  EXPECT_LT(std::abs(tr.points.back().y), 1.8);
  EXPECT_LT(tr.intended_min_ttc_s, 0.05);
}

TEST(PedestrianCrossing, WithoutTargetThePersonIsOnTheLaneCentreWhenTheEgoArrives) {
  auto tpl = make_template("pedestrian_crossing", {{"duration_s", 10.0}});
  const hazard::PlanOutcome o = tpl->evaluate(pedestrian(60, 2.0, std::nullopt), test_scene(10.0));
  ASSERT_TRUE(o.reasons.empty()) << o.reasons.front();
  // The ego's front reaches the crossing line after (60 - 3.4 - 0.25) / 10 = 5.635 s; the plan ends at that
  // contact (first sample at or after it), with the person on the lane centre to within one sample of
  // walking.
  const TrajectoryPoint& last = o.trajectory.points.back();
  EXPECT_NEAR(last.t, 2.0 + 5.6, 1e-9);
  EXPECT_NEAR(last.y, 0.0, 2.0 * 0.05 + 1e-9);
}

TEST(PedestrianCrossing, RejectsARunnerFasterThanThePersonLimit) {
  auto tpl = make_template("pedestrian_crossing");
  EXPECT_EQ(test::coded(tpl->check(pedestrian(50, 12.0, 1.5), test_scene(10.0))),
            std::vector<std::string>{"class_limit: speed_mps 12 exceeds the person limit of 7 m/s"});
  EXPECT_THROW(tpl->plan(pedestrian(50, 12.0, 1.5), test_scene(10.0)), Error);
}

TEST(PedestrianCrossing, RejectsATargetTtcLongerThanTheCrossing) {
  auto tpl = make_template("pedestrian_crossing");
  // The path is 3.6 m wide; at 1.5 m/s the person is in it for 2.4 s.
  EXPECT_EQ(
      test::coded(tpl->check(pedestrian(50, 1.5, 3.0), test_scene(10.0))),
      std::vector<std::string>{"ttc_unreachable: target_ttc_s 3 is unreachable: at 1.5 m/s the person crosses the ego path in "
                               "2.4 s, so it leaves the path before the ego arrives"});
}

TEST(PedestrianCrossing, RejectsAStartOutOfView) {
  // 10 m ahead and 5.75 m left is outside a 64-degree field of view.
  auto tpl = make_template("pedestrian_crossing", {{"lanes_left", 1}});
  HazardSpec s = pedestrian(10, 3.0, std::nullopt);
  const auto r = test::coded(tpl->check(s, test_scene(2.0)));
  ASSERT_EQ(r.size(), 1u) << r.front();
  EXPECT_EQ(r[0], "not_in_view: the start point (x=10 m, y=5.75 m) is out of the camera's view");
}

TEST(PedestrianCrossing, RejectsAStartOnTheRoadAndAMissingSide) {
  auto tpl = make_template("pedestrian_crossing");
  HazardSpec s = pedestrian(50, 1.5, 1.5);
  s.lateral_offset_m = 3.0;
  EXPECT_EQ(test::coded(tpl->check(s, test_scene(10.0))),
            std::vector<std::string>{
                "placement: the start point y=3 m is on the road (the road edge on the left is at 5.25 m): a "
                "crossing pedestrian starts on the kerb"});
  s.lateral_offset_m = 0;
  s.side = "center";
  EXPECT_EQ(test::coded(tpl->check(s, test_scene(10.0))),
            std::vector<std::string>{"spec: side must be 'left' or 'right' (or lateral_offset_m non-zero) for "
                                     "pedestrian_crossing, got 'center'"});
}

// ---- sudden_stop
// ------------------------------------------------------------------------------------------------

std::filesystem::path limits_with_car_jerk(double jerk) {
  static const hf::test::TempDir tmp;  // this process's, for the test's lifetime
  const auto path = tmp / ("limits_jerk_" + std::to_string(jerk) + ".yaml");
  std::ofstream(path) << "car: {max_speed_mps: 60, max_accel_mps2: 5, max_decel_mps2: 10, max_jerk_mps3: "
                      << jerk
                      << ", max_lateral_accel_mps2: 4, max_lateral_speed_mps: 2, max_yaw_rate_dps: 45}\n";
  return path;
}

TEST(SuddenStop, IntendedMinTtcMatchesTheClosedForm) {
  auto tpl = make_template(
      "sudden_stop",
      {{"limits", limits_with_car_jerk(12.0).string()}, {"duration_s", 1.5}, {"brake_delay_s", 0.5}});
  const hazard::PlanOutcome o = tpl->evaluate(lead_stop(30, 15, 6), test_scene(15.0));
  ASSERT_TRUE(o.reasons.empty()) << o.reasons.front();
  // Lead and ego at 15 m/s, gap 30 - 3.4 - 4.5/2 = 24.35 m. Braking starts at 0.5 s: jerk 12 for 0.5 s
  // (a -> -6, v -> 15 - 12 * 0.5^2 / 2 = 13.5, s = 15 * 0.5 - 12 * 0.5^3 / 6 = 7.25), then -6 for 0.5 s
  // (v -> 10.5, s = 13.5 * 0.5 - 6 * 0.5^2 / 2 = 6.0). At 1.5 s the lead has gone 7.5 + 7.25 + 6.0 = 20.75 m
  // and the ego 22.5 m: gap 22.6 m, closing 15 - 10.5 = 4.5 m/s. TTC falls monotonically, so its minimum is
  // at the end.
  const double expected = (24.35 + 20.75 - 22.5) / (15.0 - 10.5);
  EXPECT_NEAR(o.trajectory.intended_min_ttc_s, expected, 1e-9);
  EXPECT_EQ(o.trajectory.points.size(), 31u);
  EXPECT_NEAR(o.trajectory.points.back().speed, 10.5, 1e-9);
  EXPECT_TRUE(projects_into_image(test::test_camera(), o.trajectory.points.front(), o.trajectory.size_lwh));
  // Ego plan: constant speed from the anchor.
  EXPECT_NEAR(o.trajectory.ego.back().x, 22.5, 1e-9);
  EXPECT_DOUBLE_EQ(o.trajectory.ego.back().speed, 15.0);
}

TEST(SuddenStop, StopsWithinLimitsAndEndsAtContact) {
  auto tpl = make_template("sudden_stop");
  const hazard::PlanOutcome o = tpl->evaluate(lead_stop(30, 15, 8), test_scene(15.0));
  ASSERT_TRUE(o.reasons.empty()) << o.reasons.front();
  expect_within_limits(o.trajectory, tpl->limits().at("car"));
  const test::Peaks k = test::peaks(o.trajectory.points);
  EXPECT_NEAR(k.accel, 8.0, 0.01);  // reaches the requested deceleration
  EXPECT_DOUBLE_EQ(o.trajectory.points.back().speed, 0.0);
  ASSERT_TRUE(o.notes.contains("contact_time_s"));
  EXPECT_LT(o.trajectory.points.back().t, 2.0 + 6.0);
  EXPECT_GT(o.ttc.back().gap, 0.0);
  EXPECT_LT(o.trajectory.intended_min_ttc_s, 0.05);
}

TEST(SuddenStop, RejectsADecelerationAboveTheCarLimit) {
  auto tpl = make_template("sudden_stop");
  EXPECT_EQ(test::coded(tpl->check(lead_stop(30, 15, 15), test_scene(15.0))),
            std::vector<std::string>{"class_limit: deceleration_mps2 15 exceeds the car limit of 10 m/s^2"});
}

TEST(SuddenStop, UsesATrackedObject) {
  auto tpl = make_template("sudden_stop");
  SceneContext scene = test_scene(12.0);  // distances from the rear axle (distance_origin_x 0)
  ObjectState st;
  st.track_id = 7;
  st.label = "car";
  st.distance_m = 20.0;
  st.lateral_m = 0.2;
  st.width_m = 1.9;
  st.length_m = 4.6;
  st.velocity_rel = cv::Vec2d(-1.0, 0.0);
  st.distance_method = "annotation";
  scene.objects.push_back(st);
  HazardSpec s = lead_stop(0, 0, 6);
  s.track_id = 7;
  const hazard::PlanOutcome o = tpl->evaluate(s, scene);
  ASSERT_TRUE(o.reasons.empty()) << o.reasons.front().text;
  EXPECT_DOUBLE_EQ(o.trajectory.points.front().x, 22.3);  // its rear at 20 m: its centre half its length on
  EXPECT_DOUBLE_EQ(o.trajectory.points.front().y, 0.2);
  EXPECT_DOUBLE_EQ(o.trajectory.points.front().speed, 11.0);
  EXPECT_DOUBLE_EQ(o.trajectory.size_lwh[0], 4.6);
  EXPECT_EQ(o.notes["track_id"].get<int64_t>(), 7);

  // Measured from the bumper (the filtered estimator's origin, 3.4 m ahead of the rear axle), the same
  // distance is 3.4 m further on: the states say where they measure from, the scene carries it.
  SceneContext from_bumper = scene;
  from_bumper.distance_origin_x = 3.4;
  EXPECT_DOUBLE_EQ(tpl->plan(s, from_bumper).points.front().x, 25.7);

  s.track_id = 9;
  EXPECT_EQ(test::coded(tpl->check(s, scene)),
            std::vector<std::string>{"spec: track_id 9 is not among the tracked objects (tracked: 7)"});
}

TEST(SuddenStop, RejectsALeadOutsideTheEgoPath) {
  auto tpl = make_template("sudden_stop");
  HazardSpec s = lead_stop(30, 15, 6);
  s.lateral_offset_m = 3.5;
  EXPECT_EQ(test::coded(tpl->check(s, test_scene(15.0))),
            std::vector<std::string>{
                "placement: the lead vehicle at y=3.5 m is not in the ego path (|y| must be below 2.42 m)"});
}

// ---- cut_in
// -----------------------------------------------------------------------------------------------------

TEST(CutIn, OvertakesAndCutsInAtTheTargetTtcInsideTheStoppingDistance) {
  auto tpl = make_template("cut_in");
  const SceneContext scene = test_scene(20.0);
  const hazard::PlanOutcome o = tpl->evaluate(cut_in(-3, 26, 1.2), scene);
  ASSERT_TRUE(o.reasons.empty()) << o.reasons.front();
  const HazardTrajectory& tr = o.trajectory;
  const KinematicLimits& lim = tpl->limits().at("car");
  expect_within_limits(tr, lim);
  EXPECT_LE(test::peaks(tr.points).lateral_speed, lim.max_lateral_speed_mps * 1.02);

  // Starts beside/behind the ego in the left lane, out of view (behind the camera).
  EXPECT_DOUBLE_EQ(tr.points.front().y, 3.5);
  EXPECT_FALSE(projects_into_image(scene.camera, tr.points.front(), tr.size_lwh));
  // Lane change takes the shortest min-jerk time the lateral speed allows (1.875 * 3.5 / 2 s) or longer.
  EXPECT_GE(o.notes["lane_change_s"].get<double>(), 1.875 * 3.5 / 2 - 1e-9);

  // At the end of the lane change: centred in the ego lane, TTC = target, gap inside the stopping distance.
  const double t_end = 2.0 + o.notes["cut_in_end_s"].get<double>();
  const auto obj = tr.at(t_end);
  ASSERT_TRUE(obj.has_value());
  EXPECT_NEAR(obj->y, 0.0, 1e-3);  // linear interpolation between samples
  TrajectoryPoint ego{t_end, 20.0 * (t_end - 2.0), 0.0, 0.0, 20.0, 0.0};
  const hazard::TtcSample s = hazard::ttc_at(ego, *obj, tr.size_lwh, tpl->ttc_conventions());
  EXPECT_TRUE(s.in_path);
  EXPECT_NEAR(s.ttc, 1.2, 0.02);  // linear interpolation between samples
  const double stopping = 20.0 * 1.0 + 20.0 * 20.0 / (2 * 7.0);
  EXPECT_LT(s.gap, stopping);
  EXPECT_NEAR(s.gap, 1.2 * 3.0, 0.05);  // final speed 17 m/s: closing 3 m/s
  EXPECT_TRUE(projects_into_image(scene.camera, *obj, tr.size_lwh));
  // It enters the path only after it has passed.
  for (const auto& t : o.ttc)
    if (t.in_path) {
      EXPECT_GT(t.gap, 0.0);
    }
}

TEST(CutIn, RejectsAStartFullyInViewAndASlowerVehicle) {
  auto tpl = make_template("cut_in");
  EXPECT_EQ(test::coded(tpl->check(cut_in(60, 26, 1.2), test_scene(20.0))),
            std::vector<std::string>{
                "not_in_view: the vehicle starts fully in view (x=60 m, y=3.5 m): a cut-in starts beside or "
                "behind the ego, out of view or at the image edge"});
  EXPECT_EQ(
      test::coded(tpl->check(cut_in(-3, 18, 1.2), test_scene(20.0))),
      std::vector<std::string>{"spec: speed_mps 18 does not exceed the ego speed 20 m/s: a cut-in vehicle must "
                               "overtake"});
}

TEST(CutIn, RejectsAnOvertakerTooFastToBrakeInTime) {
  auto tpl = make_template("cut_in");
  // From 40 m/s down to 17 m/s at 3 m/s^2 takes 7.85 s and 223.8 m while the ego covers 157.1 m: starting 4 m
  // ahead it would have to brake before the hazard even starts.
  const auto r = test::coded(tpl->check(cut_in(4, 40, 1.2), test_scene(20.0)));
  ASSERT_EQ(r.size(), 1u) << r.front();
  EXPECT_EQ(r[0],
            "placement: the vehicle cannot end 3.6 m in front of the ego: from x=4 m at 40 m/s it would have to start "
            "braking 3.08 s before the hazard starts");
}

TEST(CutIn, RejectsAGapBeyondTheStoppingDistanceAndAPedestrian) {
  auto tpl = make_template("cut_in", {{"closing_speed_mps", 15.0}});
  // Gap 4 s x 15 m/s = 60 m > 20 + 28.57 m.
  EXPECT_EQ(
      test::coded(tpl->check(cut_in(-3, 26, 4.0), test_scene(20.0))),
      std::vector<std::string>{"ttc_unreachable: the cut-in would end 60 m ahead, beyond the ego's stopping distance 48.57 m "
                               "(reaction 1 s, braking 7 m/s^2)"});
  HazardSpec p = cut_in(-3, 26, 1.2);
  p.object_class = "person";
  EXPECT_EQ(test::coded(tpl->check(p, test_scene(20.0))),
            std::vector<std::string>{
                "object_class: object_class 'person' is not supported by cut_in (supported: car, truck, bus, "
                "motorcycle)"});
}

}  // namespace
}  // namespace hf
