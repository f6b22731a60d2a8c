// Feasibility checks: class limits, scene rules, road position, camera view, overlap and the TTC replay.
#include <gtest/gtest.h>

#include <cmath>

#include <hazardforge/geometry.hpp>

#include "feasibility.hpp"
#include "hazard_schema.hpp"
#include "llm_test_support.hpp"

namespace hf::llm_hazard {
namespace {

class Feasibility : public ::testing::Test {
 protected:
  void SetUp() override {
    limits_ = LimitsTable::load(LimitsTable::default_path());
    cfg_.limits = &limits_;
    cfg_.sizes = ClassPriors::load(share_dir() + "/class_sizes.yaml");
    cfg_.sidewalks = true;
    cfg_.intersection = false;
    cfg_.multi_lane = true;
    cfg_.ego_speed_mps = 10.0;
    cfg_.threshold_s = 1.5;
    cfg_.kind_needs = {{"pedestrian_crossing", PedestrianCrossingTemplate::info().needs},
                       {"cut_in", CutInTemplate::info().needs},
                       {"sudden_stop", SuddenStopTemplate::info().needs}};
    scene_.camera = test::test_camera();
    scene_.ego_speed_mps = 10.0;
    scene_.objects = test::make_states(0, 0.0).objects;
  }
  // A car 30 m ahead in the ego lane at ego speed that brakes at 8 m/s^2: TTC falls to 0.
  HazardSpec stop() const {
    HazardSpec s;
    s.kind = "sudden_stop";
    s.object_class = "car";
    s.initial_distance_m = 30;
    s.lateral_offset_m = 0;
    s.side = "center";
    s.speed_mps = 10;
    s.deceleration_mps2 = 8;
    s.target_ttc_s = 1.0;
    return s;
  }
  // A person crossing from the right at `y`, `speed` m/s, as `kind`.
  HazardSpec person(const std::string& kind, double y, double speed = 2.0) const {
    HazardSpec p = stop();
    p.kind = kind;
    p.object_class = "person";
    p.speed_mps = speed;
    p.deceleration_mps2.reset();
    p.heading_deg = 90;
    p.side = "right";
    p.lateral_offset_m = y;
    return p;
  }
  // The reasons' texts (codes: coded()).
  std::vector<std::string> check(const HazardSpec& s) const {
    std::vector<std::string> out;
    for (const Refusal& r : check_feasibility(s, scene_, cfg_, nullptr)) out.push_back(r.text);
    return out;
  }
  std::vector<std::string> coded(const HazardSpec& s) const {
    return test::coded(check_feasibility(s, scene_, cfg_, nullptr));
  }

  LimitsTable limits_;
  FeasibilityConfig cfg_;
  SceneContext scene_;
};

TEST_F(Feasibility, PlausibleSuddenStopPasses) {
  EXPECT_EQ(check(stop()), std::vector<std::string>{});
}

TEST_F(Feasibility, ClassLimitsFromTheSharedTable) {
  HazardSpec s = stop();
  s.speed_mps = 70;
  s.deceleration_mps2 = 14;
  std::vector<std::string> e = coded(s);
  ASSERT_GE(e.size(), 2u);
  EXPECT_EQ(e[0], "class_limit: /speed_mps = 70 is more than a car can do (at most 60 m/s)");
  EXPECT_EQ(e[1], "class_limit: /deceleration_mps2 = 14 is more than a car can brake (at most 10 m/s^2)");
}

TEST_F(Feasibility, SceneRulesFromThePrompt) {
  cfg_.sidewalks = false;
  cfg_.multi_lane = false;
  HazardSpec p = person("pedestrian_crossing", -5.5);
  std::vector<std::string> e = coded(p);
  ASSERT_FALSE(e.empty());
  EXPECT_EQ(e[0], "scene_lacks: /kind = \"pedestrian_crossing\" needs sidewalks: the scene has none (sidewalks = no)");

  HazardSpec c = stop();
  c.kind = "cut_in";
  c.heading_deg = 90;
  e = coded(c);
  ASSERT_GE(e.size(), 2u);
  EXPECT_EQ(e[0],
            "scene_lacks: /heading_deg = 90 makes a vehicle cross the ego path, which needs an intersection (intersection "
            "= no)");
  EXPECT_EQ(
      e[1],
      "scene_lacks: /kind = \"cut_in\" needs a lane beside the ego lane going its way: this road has one lane in the "
      "ego's direction (multi_lane = no)");
}

// What a kind needs of the scene comes from its template (HazardKindInfo::needs), for any kind.
TEST_F(Feasibility, KindNeedsFromTheTemplates) {
  // Traffic keeps right; of the two lanes on the left the outer one is oncoming, the right has none.
  cfg_.road.lanes_left = 1;
  cfg_.road.lanes_right = 0;
  cfg_.road.oncoming_lanes = 1;
  HazardSpec c = stop();
  c.kind = "cut_in";
  std::vector<std::string> e = check(c);
  ASSERT_FALSE(e.empty());
  EXPECT_EQ(
      e[0],
      "/kind = \"cut_in\" needs a lane beside the ego lane going its way: no lane beside the ego lane goes "
      "its way (lanes_left 1, lanes_right 0, oncoming_lanes 1, traffic keeps right)");
  // Keeping left, the oncoming lanes are on the right: the left lane goes the ego's way.
  cfg_.road.driving_side = "left";
  cfg_.road.lanes_right = 1;
  for (const std::string& m : check(c)) EXPECT_EQ(m.find("needs a lane"), std::string::npos) << m;

  cfg_.kind_needs["head_on"] = {scene_condition::kOncomingLane, scene_condition::kTrackedLead};
  c.kind = "head_on";
  cfg_.road.oncoming_lanes = 0;
  e = check(c);
  ASSERT_GE(e.size(), 2u);
  EXPECT_EQ(
      e[0],
      "/kind = \"head_on\" needs a lane with oncoming traffic beside the ego lane: no lane carries oncoming "
      "traffic (lanes_left 1, lanes_right 1, oncoming_lanes 0, traffic keeps left)");
  EXPECT_EQ(e[1],
            "/kind = \"head_on\" needs a tracked vehicle ahead in the ego path: no vehicle is tracked ahead "
            "in the ego path");
}

TEST_F(Feasibility, PersonOnTheShoulderOnlyWithTheExplicitRelaxation) {
  cfg_.sidewalks = false;
  cfg_.sidewalk_width_m = 2.5;
  HazardSpec p = person("pedestrian_crossing", -6.0);  // the right road edge is at 5.25 m: 0.75 m onto the shoulder
  auto has = [](const std::vector<std::string>& e, const std::string& start) {
    for (const auto& m : e)
      if (m.rfind(start, 0) == 0) return true;
    return false;
  };
  std::vector<std::string> e = check(p);
  EXPECT_TRUE(has(e, "/kind = \"pedestrian_crossing\" needs sidewalks"));
  EXPECT_TRUE(has(e, "/lateral_offset_m = -6 puts the person off the road (|y| <= 5.25 m on the right)"));
  cfg_.pedestrians_without_sidewalks = true;
  e = check(p);
  EXPECT_FALSE(has(e, "/kind = \"pedestrian_crossing\" needs sidewalks"));
  EXPECT_FALSE(has(e, "/lateral_offset_m"));
  p.lateral_offset_m = -8.0;  // beyond the 2.5 m shoulder
  EXPECT_TRUE(
      has(check(p), "/lateral_offset_m = -8 puts the person off the road and sidewalk (|y| <= 7.75 m"));
}

TEST_F(Feasibility, APersonMayStandBesideATrackedVehicleBeyondTheRoadEdge) {
  cfg_.sidewalks = false;
  HazardSpec p = person("pedestrian_dart_out", -7.5, 3.0);  // the right road edge is at 5.25 m, no sidewalk
  p.initial_distance_m = 33.5;                                 // a metre beyond the front of the car below
  auto lateral = [&] {
    std::vector<std::string> out;
    for (const std::string& m : check(p))
      if (m.rfind("/lateral_offset_m", 0) == 0) out.push_back(m);
    return out;
  };
  EXPECT_EQ(lateral(), std::vector<std::string>{
                           "/lateral_offset_m = -7.5 puts the person off the road (|y| <= 5.25 m on the right)"});
  // A car parked in a bay there (its rear face 28 m ahead, centred at 30.25 m): the ground beside it is ground.
  ObjectState bay = scene_.objects.front();  // the standing car, 4.5 m long
  bay.track_id = 11;
  bay.distance_m = 28.0;
  bay.lateral_m = -7.5;
  scene_.objects.push_back(bay);
  EXPECT_TRUE(lateral().empty());
  // Not a person far from it.
  p.initial_distance_m = 45.0;
  EXPECT_EQ(lateral().size(), 1u);
}

TEST_F(Feasibility, SideRoadAndOverlap) {
  HazardSpec s = stop();
  s.side = "left";
  s.lateral_offset_m = -3.5;
  s.initial_distance_m = 40;
  std::vector<std::string> e = check(s);
  ASSERT_GE(e.size(), 2u);
  EXPECT_EQ(e[0], "/side = \"left\" contradicts /lateral_offset_m = -3.5 (left of the ego means y > 0)");
  // The car's distance reaches its rear face; its centre lies half its length (4.5 m) further on.
  EXPECT_EQ(e[1], "start point (x 40 m, y -3.5 m) overlaps the detected car (track 7) centred at x 42.25 m, y -3.5 m");

  s = stop();
  s.side = "right";
  s.lateral_offset_m = -9;
  e = check(s);
  ASSERT_FALSE(e.empty());
  EXPECT_EQ(e[0], "/lateral_offset_m = -9 puts the car off the road (|y| <= 5.25 m on the right)");
}

TEST_F(Feasibility, StartPointMustBeInTheCameraView) {
  HazardSpec s = stop();
  s.initial_distance_m = 6;
  s.lateral_offset_m = 4.5;
  s.side = "left";
  std::vector<std::string> e = check(s);
  ASSERT_FALSE(e.empty());
  EXPECT_EQ(e[0],
            "start point (x 6 m, y 4.5 m) is outside the camera view: it projects to pixel (-466, 872) in a "
            "1600x900 image");
}

TEST_F(Feasibility, TargetTtcMustBeReachedAndBelowThreshold) {
  HazardSpec s = stop();
  // Barely brakes: closing 0.5 t, gap 54.35 - 0.25 t^2, so after 6 s TTC = (54.35 - 9) / 3 = 15.1 s.
  s.deceleration_mps2 = 0.5;
  s.initial_distance_m = 60;
  std::vector<std::string> e = check(s);
  ASSERT_EQ(e.size(), 1u);
  EXPECT_EQ(
      e[0],
      "/target_ttc_s = 1 is never reached: with the ego at 10 m/s the lowest TTC within 6 s is 15.13 s");

  s = stop();
  s.target_ttc_s = 2.0;
  e = check(s);
  ASSERT_EQ(e.size(), 1u);
  EXPECT_EQ(e[0], "/target_ttc_s = 2 is not below the risk threshold 1.5 s, so the scene would stay Safe");

  s = stop();
  s.speed_mps = 0;
  s.deceleration_mps2.reset();
  s.initial_distance_m = 8;
  e = check(s);
  ASSERT_EQ(e.size(), 1u);
  EXPECT_EQ(
      e[0],
      "the car would appear with TTC 0.23 s, already below /target_ttc_s = 1: a hazard must develop, not "
      "appear on a collision course (increase /initial_distance_m)");
}

TEST_F(Feasibility, KinematicChecksLeftToTheTemplate) {
  HazardSpec s = stop();
  s.speed_mps = 70;
  cfg_.kinematics = false;
  EXPECT_EQ(check(s), std::vector<std::string>{});
}

TEST(TtcReplay, CrossingPedestrianEntersThePath) {
  HazardSpec s;
  s.object_class = "person";
  s.initial_distance_m = 30;
  s.lateral_offset_m = 5;
  s.speed_mps = 2;
  s.heading_deg = -90;
  // ClassSize is {height, width, length}.
  TtcSimulation sim =
      simulate_ttc(s, ClassSize{1.7, 0.6, 0.5}, 10.0, std::nullopt, hazard::TtcConventions{}, 6.0);
  EXPECT_FALSE(sim.starts_in_collision);
  EXPECT_EQ(sim.ttc_at_start, kInf);
  // In the path once |y| < 1.5 + 0.25, i.e. from t = 1.625 s (gap 30 - 16.25 - 3.4 - 0.3 = 10.05 m, TTC 1.005
  // s); the constant-speed ego then reaches it at t = 2.63 s, before it leaves the path (3.375 s): TTC falls
  // to 0.
  EXPECT_TRUE(sim.enters_path);
  EXPECT_DOUBLE_EQ(sim.min_ttc, 0.0);
  EXPECT_NEAR(sim.t_min_ttc, 2.63, 0.03);
}

TEST(TtcReplay, TheReplayedEgoFollowsItsArc) {
  // The ego turns left at 10 m/s and 0.1 rad/s (100 m radius); a stopped car stands in its lane 40 m along
  // the curve, 7.9 m left of the ego's x axis.
  HazardSpec s;
  s.object_class = "car";
  s.initial_distance_m = 100.0 * std::sin(0.4);
  s.lateral_offset_m = 100.0 * (1 - std::cos(0.4));
  const ClassSize car{1.5, 1.8, 4.5};
  const TtcSimulation along = simulate_ttc(s, car, 10.0, 0.1, hazard::TtcConventions{}, 6.0);
  EXPECT_TRUE(along.enters_path);
  EXPECT_NEAR(along.ttc_at_start, (s.initial_distance_m - 3.4 - 2.25) / 10.0, 1e-9);
  EXPECT_DOUBLE_EQ(along.min_ttc, 0.0);  // the ego drives into it
  EXPECT_DOUBLE_EQ(along.closest_lateral_m, 0.0);
  // A straight corridor, or an unknown yaw rate, replays a straight ego that passes 7.9 m to its right.
  hazard::TtcConventions straight;
  straight.corridor.follow_path = false;
  for (const TtcSimulation& sim : {simulate_ttc(s, car, 10.0, 0.1, straight, 6.0),
                                   simulate_ttc(s, car, 10.0, std::nullopt, hazard::TtcConventions{}, 6.0)}) {
    EXPECT_FALSE(sim.enters_path);
    EXPECT_NEAR(sim.closest_lateral_m, s.lateral_offset_m - 2.4, 1e-9);
  }
}

}  // namespace
}  // namespace hf::llm_hazard
