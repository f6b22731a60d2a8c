// hazard_planner through the StageRunner, with the three templates registered as components.
#include <gtest/gtest.h>

#include <filesystem>

#include "hazard_planner.hpp"
#include "hazardforge/testing/stage_runner.hpp"
#include "scenario_support.hpp"

namespace hf {
namespace {

testing::StageRunner planner(const std::string& yaml = "") {
  testing::StageRunner r;
  r.registrar().add<PedestrianCrossingTemplate>();
  r.registrar().add<CutInTemplate>();
  r.registrar().add<SuddenStopTemplate>();
  r.registrar().add<HazardPlanner>();
  r.build(kind::kPlanner, "hazard_planner", yaml);
  return r;
}

Frame frame(int64_t index, double t, std::optional<double> ego_speed = 15.0) {
  Frame f;
  f.index = index;
  f.timestamp = t;
  f.camera = test::test_camera();
  f.ego.speed_mps = ego_speed;
  return f;
}

HazardSpec stop_spec(double start) {
  HazardSpec s;
  s.kind = "sudden_stop";
  s.object_class = "car";
  s.initial_distance_m = 30;
  s.speed_mps = 15;
  s.deceleration_mps2 = 6;
  s.start_time_s = start;
  return s;
}

TEST(HazardPlanner, EmitsOnceAtTheFirstFrameAtOrAfterTheStartTime) {
  auto r = planner("templates: {sudden_stop: {duration_s: 2}}");
  for (int i = 0; i < 5; ++i) r.push("frames", frame(i, 0.5 * i), 0.5 * i);
  r.push("hazard", stop_spec(0.8), 0.0);  // sticky: seen from the first frame on
  r.run();
  const auto out = r.collect<HazardTrajectory>("trajectory");
  ASSERT_EQ(out.size(), 1u);
  EXPECT_DOUBLE_EQ(r.outputs("trajectory")[0].timestamp(), 1.0);
  const HazardTrajectory& tr = out[0];
  EXPECT_DOUBLE_EQ(tr.anchor_time, 1.0);
  EXPECT_EQ(tr.points.size(), 41u);  // 2 s at 20 Hz, from the template params given per kind
  EXPECT_EQ(tr.kind, "sudden_stop");

  const auto file = r.output_dir() / "trajectory.json";
  ASSERT_TRUE(std::filesystem::exists(file));
  const Json j = Json::parse(test::read_text(file.string()));
  EXPECT_EQ(j["points"].size(), 41u);
  EXPECT_EQ(j["planner"]["frame"], 2);
  EXPECT_EQ(j["planner"]["feasible"], true);
  EXPECT_DOUBLE_EQ(j["planner"]["ego_speed_mps"].get<double>(), 15.0);
  EXPECT_NEAR(j["intended_min_ttc_s"].get<double>(), tr.intended_min_ttc_s, 1e-12);
  EXPECT_FALSE(std::filesystem::exists(r.output_dir() / "trajectory.json.tmp"));
}

TEST(HazardPlanner, UnknownKindNamesTheRegisteredTemplates) {
  auto r = planner();
  r.push("frames", frame(0, 0.0), 0.0);
  HazardSpec s = stop_spec(0.0);
  s.kind = "jaywalker";
  r.push("hazard", s, 0.0);
  try {
    r.run();
    FAIL();
  } catch (const Error& e) {
    EXPECT_EQ(std::string(e.what()),
              "hazard kind 'jaywalker' in the spec at frame 0 (t=0 s) has no registered hazard_template; "
              "registered: "
              "cut_in, pedestrian_crossing, sudden_stop");
  }
}

TEST(HazardPlanner, InfeasibleSpecStopsTheRunWithTheReasons) {
  auto r = planner();
  r.push("frames", frame(0, 0.0), 0.0);
  HazardSpec s = stop_spec(0.0);
  s.deceleration_mps2 = 15;
  r.push("hazard", s, 0.0);
  try {
    r.run();
    FAIL();
  } catch (const Error& e) {
    EXPECT_EQ(
        std::string(e.what()),
        "hazard spec 'sudden_stop' at frame 0 (t=0 s) is infeasible: deceleration_mps2 15 exceeds the car "
        "limit of 10 m/s^2");
  }
  const Json j = Json::parse(test::read_text((r.output_dir() / "trajectory.json").string()));
  EXPECT_EQ(j["planner"]["feasible"], false);
}

TEST(HazardPlanner, InfeasibleSpecIsRecordedAndSkippedWhenAsked) {
  auto r = planner("on_infeasible: skip");
  r.push("frames", frame(0, 0.0), 0.0);
  r.push("frames", frame(1, 0.1), 0.1);
  HazardSpec s = stop_spec(0.0);
  s.kind = "pedestrian_crossing";
  s.object_class = "person";
  s.side = "right";
  s.speed_mps = 12;
  s.deceleration_mps2.reset();
  r.push("hazard", s, 0.0);
  r.run();
  EXPECT_TRUE(r.outputs("trajectory").empty());
  const Json j = Json::parse(test::read_text((r.output_dir() / "trajectory.json").string()));
  EXPECT_EQ(j["planner"]["reasons"],
            Json::array({{{"code", "class_limit"},
                          {"kind", "pedestrian_crossing"},
                          {"text", "speed_mps 12 exceeds the person limit of 7 m/s"}}}));
  ASSERT_FALSE(r.log().empty());
  EXPECT_EQ(
      r.log().back(),
      "warning: hazard spec 'pedestrian_crossing' at frame 0 (t=0 s) is infeasible: speed_mps 12 exceeds the "
      "person limit of 7 m/s (skipped)");
}

TEST(HazardPlanner, TakesTheEgoSpeedFromTheStatesAndTrackedObjects) {
  auto r = planner();
  r.push("frames", frame(0, 0.0, std::nullopt), 0.0);
  ObjectStates st;
  st.ego_speed_mps = 10.0;
  st.distance_origin_x = 1.5;  // measured from the camera, 1.5 m ahead of the rear axle
  ObjectState o;
  o.track_id = 3;
  o.label = "car";
  o.distance_m = 25;
  o.velocity_rel = cv::Vec2d(0, 0);
  o.distance_method = "annotation";
  st.objects.push_back(o);
  r.push("states", st, 0.0);
  HazardSpec s = stop_spec(0.0);
  s.track_id = 3;
  r.push("hazard", s, 0.0);
  r.run();
  const auto out = r.collect<HazardTrajectory>("trajectory");
  ASSERT_EQ(out.size(), 1u);
  EXPECT_DOUBLE_EQ(out[0].ego.front().speed, 10.0);
  // Its rear 25 m from the camera, which the states put 1.5 m ahead of the rear axle; its centre half a car
  // (4.5 m) further.
  EXPECT_DOUBLE_EQ(out[0].points.front().x, 28.75);
  EXPECT_DOUBLE_EQ(out[0].points.front().speed, 10.0);
}

TEST(HazardPlanner, MissingEgoSpeedIsOneClearError) {
  auto r = planner();
  r.push("frames", frame(4, 0.4, std::nullopt), 0.4);
  r.push("hazard", stop_spec(0.0), 0.4);
  try {
    r.run();
    FAIL();
  } catch (const Error& e) {
    EXPECT_EQ(
        std::string(e.what()),
        "hazard spec at frame 4 (t=0.4 s): the ego speed is unknown (neither the frame nor the object states "
        "carry it); set the planner's ego_speed_mps");
  }
}

TEST(HazardPlanner, TemplatesParamNamingAnUnknownKindIsRefusedAtOpen) {
  auto r = planner("templates: {cutin: {duration_s: 4}}");
  r.push("frames", frame(0, 0.0), 0.0);
  try {
    r.run();
    FAIL();
  } catch (const Error& e) {
    EXPECT_EQ(
        std::string(e.what()),
        "node 'hazard_planner': parameter 'templates' names 'cutin', which is no registered hazard_template; "
        "registered: cut_in, pedestrian_crossing, sudden_stop");
  }
}

TEST(HazardPlanner, ASecondSpecIsPlannedIntoItsOwnFile) {
  auto r = planner();
  r.push("frames", frame(0, 0.0), 0.0);
  r.push("frames", frame(1, 1.0), 1.0);
  r.push("hazard", stop_spec(0.0), 0.0);
  HazardSpec later = stop_spec(1.0);
  later.initial_distance_m = 40;
  r.push("hazard", later, 1.0);
  r.run();
  EXPECT_EQ(r.outputs("trajectory").size(), 2u);
  EXPECT_TRUE(std::filesystem::exists(r.output_dir() / "trajectory.json"));
  EXPECT_TRUE(std::filesystem::exists(r.output_dir() / "trajectory_2.json"));
}

}  // namespace
}  // namespace hf
