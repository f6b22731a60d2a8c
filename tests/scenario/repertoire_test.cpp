// The pre-crash kinds beyond the first three (stopped_vehicle, pull_out, pedestrian_along_road,
// pedestrian_dart_out) on synthetic scenes of known geometry:
// their plans in closed form, their limits, and proposals that plan as proposed and refuse only for physical
// reasons.
#include <gtest/gtest.h>

#include <functional>

#include "hazardforge/hazard/proposal.hpp"
#include "scenario_support.hpp"

namespace hf {
namespace {

using test::expect_within_limits;
using test::make_template;
using test::test_scene;

HazardSpec standing(double distance, double y = 0.0) {
  HazardSpec s;
  s.kind = "stopped_vehicle";
  s.object_class = "car";
  s.initial_distance_m = distance;
  s.lateral_offset_m = y;
  s.side = "center";
  s.start_time_s = 2.0;
  return s;
}

HazardSpec parked(double distance, const std::string& side, double after, double speed) {
  HazardSpec s;
  s.kind = "pull_out";
  s.object_class = "car";
  s.initial_distance_m = distance;
  s.side = side;
  s.start_time_s = 2.0;
  s.extra = {{"pull_out_after_s", after}, {"pull_out_speed_mps", speed}};
  return s;
}

// A proposal request at 10 m/s on the test camera with the first-seen rule of the generator's default (7 % of
// the image height).
ProposalRequest request_at(const SceneContext& scene) {
  ProposalRequest req(scene);
  req.target_ttc_s = 1.4;
  req.horizon_s = 6.0;
  req.first_seen_max_height = 0.07;
  return req;
}

// The spec a proposal stands for, with the generator's part (its start time) filled in.
HazardSpec answered(const HazardProposal& p, const SceneContext& scene) {
  Json answer = p.spec;
  answer["start_time_s"] = scene.timestamp;
  return answer.get<HazardSpec>();
}

TEST(StoppedVehicle, TheGapClosesAtTheEgoSpeedToContact) {
  auto tpl = make_template("stopped_vehicle", {{"duration_s", 6.0}});
  const hazard::PlanOutcome o = tpl->evaluate(standing(40.0, 0.2), test_scene(10.0));
  ASSERT_TRUE(o.reasons.empty()) << o.reasons.front();
  // Gap at the start: 40 - 3.4 (ego front) - 4.5 / 2 = 34.35 m; the ego at 10 m/s reaches it after 3.435 s,
  // where the plan ends; one second in the TTC is (34.35 - 10) / 10.
  ASSERT_GE(o.ttc.size(), 21u);
  EXPECT_NEAR(o.ttc.front().gap, 34.35, 1e-9);
  EXPECT_NEAR(o.ttc[20].ttc, 2.435, 1e-9);
  EXPECT_LT(o.trajectory.intended_min_ttc_s, 0.05);
  EXPECT_NEAR(o.trajectory.points.back().t - 2.0, 3.435, 0.051);
  for (const TrajectoryPoint& p : o.trajectory.points) {
    EXPECT_DOUBLE_EQ(p.x, 40.0);
    EXPECT_DOUBLE_EQ(p.y, 0.2);
    EXPECT_DOUBLE_EQ(p.speed, 0.0);
    EXPECT_DOUBLE_EQ(p.heading, 0.0);
  }
}

TEST(StoppedVehicle, RefusesAMovingVehicleOneBesideThePathAndATakeOver) {
  auto tpl = make_template("stopped_vehicle");
  HazardSpec s = standing(40.0, 2.5);
  s.speed_mps = 3.0;
  s.track_id = 7;
  const std::vector<std::string> got = test::coded(tpl->check(s, test_scene(10.0)));
  ASSERT_EQ(got.size(), 3u);
  EXPECT_EQ(got[0], "spec: track_id 7: a stopped vehicle is inserted, it does not take over a tracked object");
  EXPECT_EQ(got[1], "spec: speed_mps 3: a stopped vehicle stands (speed_mps 0)");
  EXPECT_EQ(got[2].rfind("placement: the vehicle at y=2.5 m is not in the ego path", 0), 0u) << got[2];
}

TEST(StoppedVehicle, ProposalsAreFirstSeenSmallAndReachTheTargetWithinTheHorizon) {
  auto tpl = make_template("stopped_vehicle");
  const SceneContext scene = test_scene(10.0);
  const ProposalRequest req = request_at(scene);
  const hazard::ProposalScene sc = hazard::ProposalScene::of(req, *tpl);
  int planned = 0;
  for (uint64_t seed = 1; seed <= 12; ++seed) {
    test::Bits bits(seed);
    const HazardProposal p = tpl->propose(req, bits);
    ASSERT_FALSE(p.spec.is_null()) << seed << ": " << p.problem;
    const HazardSpec spec = answered(p, scene);
    EXPECT_GE(spec.initial_distance_m + 0.05, sc.first_seen_small_from(spec.object_class)) << seed;
    const hazard::PlanOutcome o = tpl->evaluate(spec, scene);
    ASSERT_TRUE(o.reasons.empty()) << seed << ": " << o.reasons.front();
    // The TTC falls below the aimed value (aim x target) before the horizon's last 0.7 s.
    bool reached = false;
    for (const hazard::TtcSample& t : o.ttc)
      if (t.t - scene.timestamp <= 6.0 - 0.7 && t.ttc <= req.aim * req.target_ttc_s + 0.05) reached = true;
    EXPECT_TRUE(reached) << seed << ": " << p.spec.dump();
    ++planned;
  }
  EXPECT_EQ(planned, 12);
}

TEST(StoppedVehicle, NoProposalWhereTheEgoStandsOrALeadDrivesInTheWay) {
  auto tpl = make_template("stopped_vehicle");
  const SceneContext standing_ego = test_scene(0.2);
  test::Bits bits(3);
  const HazardProposal still = tpl->propose(request_at(standing_ego), bits);
  EXPECT_TRUE(still.spec.is_null());
  EXPECT_EQ(still.problem.code, refusal::kEgoMotion);

  SceneContext traffic = test_scene(10.0);
  ObjectState lead;
  lead.track_id = 4;
  lead.label = "car";
  lead.distance_m = 18.0;
  lead.lateral_m = 0.1;
  lead.in_path = true;
  traffic.objects.push_back(lead);
  test::Bits bits2(3);
  const HazardProposal blocked = tpl->propose(request_at(traffic), bits2);
  EXPECT_TRUE(blocked.spec.is_null());
  EXPECT_EQ(blocked.problem.code, refusal::kTraffic) << blocked.problem;
}

TEST(PullOut, StandsBesideTheRoadThenSteersIntoTheEgoLaneWithinTheCarLimits) {
  // An ego at 6 m/s, slow enough to watch the whole manoeuvre within 10 s before it reaches the car.
  auto tpl = make_template("pull_out", {{"duration_s", 10.0}});
  const hazard::PlanOutcome o = tpl->evaluate(parked(45.0, "right", 1.0, 4.0), test_scene(6.0));
  ASSERT_TRUE(o.reasons.empty()) << o.reasons.front();
  expect_within_limits(o.trajectory, tpl->limits().at("car"));
  // Parked beyond the default road's one lane on the right (edge 1.5 x 3.5 m), half its width and 0.3 m out,
  // aligned with the road, for the first second.
  const auto& pts = o.trajectory.points;
  const double y_park = -(1.5 * 3.5 + tpl->class_sizes().at("car").width / 2 + 0.3);
  EXPECT_NEAR(pts.front().y, y_park, 1e-9);
  double most_off_road = 0;
  bool in_lane = false;
  for (const TrajectoryPoint& p : pts) {
    if (p.t - 2.0 <= 1.0 + 1e-9) {
      EXPECT_NEAR(p.x, 45.0, 1e-9);
      EXPECT_NEAR(p.heading, 0.0, 1e-12);
    }
    most_off_road = std::max(most_off_road, rad_to_deg(std::abs(p.heading)));
    // Once in the ego lane's centre it drives along it at 4 m/s.
    if (std::abs(p.y) < 0.01) {
      in_lane = true;
      EXPECT_NEAR(p.speed, 4.0, 0.01);
      EXPECT_NEAR(p.heading, 0.0, 0.03);
    }
  }
  EXPECT_TRUE(in_lane);
  EXPECT_LE(most_off_road, 35.5);
  EXPECT_GT(o.notes["gap_entering_m"].get<double>(), 0.0);
}

TEST(PullOut, RefusesAMovingStartAPlaceInThePathAndTooFastAnEnd) {
  auto tpl = make_template("pull_out");
  HazardSpec s = parked(45.0, "right", 1.0, 4.0);
  s.lateral_offset_m = -0.5;
  s.speed_mps = 2.0;
  const std::vector<std::string> got = test::coded(tpl->check(s, test_scene(10.0)));
  ASSERT_GE(got.size(), 2u);
  EXPECT_EQ(got[0].rfind("placement: the parking place y=-0.5 m is in the ego path", 0), 0u) << got[0];
  EXPECT_EQ(got[1], "spec: speed_mps 2: a parked vehicle stands (speed_mps 0)");
  HazardSpec fast = parked(45.0, "right", 1.0, 36.0);
  fast.object_class = "truck";
  EXPECT_EQ(test::coded(tpl->check(fast, test_scene(10.0))),
            std::vector<std::string>{"class_limit: pull_out_speed_mps 36 is above the truck limit of 35 m/s"});
}

TEST(PullOut, ProposalsParkOnTheDrivingSideAndAreCriticalWithinTheHorizon) {
  auto tpl = make_template("pull_out");
  for (const char* driving : {"right", "left"}) {
    SceneContext scene = test_scene(10.0);
    RoadLayout road;  // a two-way road, the ego lane at the kerb
    road.driving_side = driving;
    road.lanes_left = road.lanes_right = 0;
    (std::string(driving) == "right" ? road.lanes_left : road.lanes_right) = 1;
    road.oncoming_lanes = 1;
    scene.road = road;
    const ProposalRequest req = request_at(scene);
    int planned = 0;
    for (uint64_t seed = 1; seed <= 12; ++seed) {
      test::Bits bits(seed);
      const HazardProposal p = tpl->propose(req, bits);
      if (p.spec.is_null()) {
        // Only when no class's drive-off fits in time, never the road or the rules.
        EXPECT_EQ(p.problem.code, refusal::kTtcUnreachable) << seed << ": " << p.problem;
        continue;
      }
      const HazardSpec spec = answered(p, scene);
      EXPECT_EQ(spec.side, driving) << seed;
      EXPECT_EQ(spec.lateral_offset_m > 0, std::string(driving) == "left") << seed;
      const hazard::PlanOutcome o = tpl->evaluate(spec, scene);
      ASSERT_TRUE(o.reasons.empty()) << seed << ": " << o.reasons.front() << "\n" << p.spec.dump();
      EXPECT_LE(o.trajectory.intended_min_ttc_s, req.target_ttc_s) << seed << ": " << p.spec.dump();
      ++planned;
    }
    EXPECT_GE(planned, 11) << driving;
  }
  // A lane between the kerb and the ego's: the vehicle would pull out into that one.
  SceneContext arterial = test_scene(10.0);
  RoadLayout two_lanes;
  two_lanes.lanes_right = 1;
  arterial.road = two_lanes;
  test::Bits bits(1);
  const HazardProposal p = tpl->propose(request_at(arterial), bits);
  EXPECT_TRUE(p.spec.is_null());
  EXPECT_EQ(p.problem.code, refusal::kSceneLacks) << p.problem;
}

// The ego in the leftmost lane of a divided road (a median barrier on its left, two lanes on its right, traffic
// keeps right), and on a one-lane one-way street (both edges border the ego lane).
RoadLayout divided_road() {
  RoadLayout road;
  road.lanes_left = 0;
  road.lanes_right = 2;
  road.oncoming_lanes = 0;
  return road;
}

RoadLayout one_way_street() {
  RoadLayout road;
  road.lanes_left = road.lanes_right = 0;
  road.oncoming_lanes = 0;
  return road;
}

// Proposals for seeds 1..n, each answered and planned (its plan must pass); a proposal refused only for time
// (ttc_unreachable) is skipped. `each` sees the spec and its plan; returns how many planned.
int plan_proposals(const hazard::TemplateBase& tpl, const SceneContext& scene, const ProposalRequest& req, int n,
                   const std::function<void(const HazardSpec&, const hazard::PlanOutcome&)>& each) {
  int planned = 0;
  for (uint64_t seed = 1; seed <= static_cast<uint64_t>(n); ++seed) {
    test::Bits bits(seed);
    const HazardProposal p = tpl.propose(req, bits);
    if (p.spec.is_null()) {
      EXPECT_EQ(p.problem.code, refusal::kTtcUnreachable) << seed << ": " << p.problem;
      continue;
    }
    const HazardSpec spec = answered(p, scene);
    const hazard::PlanOutcome o = tpl.evaluate(spec, scene);
    EXPECT_TRUE(o.reasons.empty()) << seed << ": " << (o.reasons.empty() ? "" : o.reasons.front().text) << "\n"
                                   << p.spec.dump();
    each(spec, o);
    ++planned;
  }
  return planned;
}

// The sides of a kind's proposals on a road, over 24 seeds: {left, right} counts; every proposal plans.
std::pair<int, int> proposal_sides(const hazard::TemplateBase& tpl, const RoadLayout& road) {
  SceneContext scene = test_scene(10.0);
  scene.road = road;
  int left = 0, right = 0;
  plan_proposals(tpl, scene, request_at(scene), 24,
                 [&](const HazardSpec& spec, const hazard::PlanOutcome&) { ++(spec.lateral_offset_m > 0 ? left : right); });
  return {left, right};
}

TEST(RoadEdge, OnADividedRoadTheMedianSideIsTheEdgeTheEgoLaneBorders) {
  for (const char* kind : {"pull_out", "pedestrian_along_road"}) {
    auto tpl = make_template(kind);
    const auto [left, right] = proposal_sides(*tpl, divided_road());
    EXPECT_GE(left, 20) << kind;
    EXPECT_EQ(right, 0) << kind;
  }
}

TEST(RoadEdge, OnAOneWayStreetBothEdgesTheKerbMostly) {
  for (const char* kind : {"pull_out", "pedestrian_along_road"}) {
    auto tpl = make_template(kind);
    const auto [left, right] = proposal_sides(*tpl, one_way_street());
    EXPECT_GT(right, left) << kind;  // traffic keeps right: the kerb is on the right
    EXPECT_GE(left, 1) << kind;
    EXPECT_GE(left + right, 20) << kind;
  }
}

// A clip too short for a whole pull-out (1.4 s left, a highway's 25 m/s): the vehicle is already pulling out from
// the median shoulder when the hazard appears, and enters the ego path within the horizon at the target TTC.
TEST(PullOut, OnAShortClipItIsAlreadyPullingOutWhenItAppears) {
  auto tpl = make_template("pull_out", {{"duration_s", 1.4}, {"max_under_way_s", 4.6}});
  SceneContext scene = test_scene(25.0);
  scene.road = divided_road();
  ProposalRequest req = request_at(scene);
  req.horizon_s = 1.4;
  req.max_under_way_s = 4.6;
  const int planned =
      plan_proposals(*tpl, scene, req, 12, [&](const HazardSpec& spec, const hazard::PlanOutcome& o) {
        ASSERT_TRUE(spec.under_way_s);
        EXPECT_GT(*spec.under_way_s, 0.0);
        EXPECT_LE(*spec.under_way_s, 4.6);
        EXPECT_GT(spec.lateral_offset_m, 0.0);  // the median shoulder, on the left
        EXPECT_LE(o.trajectory.intended_min_ttc_s, req.target_ttc_s + 0.05);
      });
  EXPECT_GE(planned, 10);
  // Not allowed under way: refused, saying why.
  req.max_under_way_s = 0.0;
  test::Bits bits(1);
  const HazardProposal p = tpl->propose(req, bits);
  EXPECT_EQ(p.problem.code, refusal::kTtcUnreachable) << p.problem;
}

HazardSpec walker(double distance, double y, double speed, double heading_deg) {
  HazardSpec s;
  s.kind = "pedestrian_along_road";
  s.object_class = "person";
  s.initial_distance_m = distance;
  s.lateral_offset_m = y;
  s.side = y > 0 ? "left" : "right";
  s.speed_mps = speed;
  s.heading_deg = heading_deg;
  s.start_time_s = 2.0;
  return s;
}

TEST(PedestrianAlongRoad, TheEgoClosesInAtItsSpeedLessOrMoreThePersons) {
  auto tpl = make_template("pedestrian_along_road");
  // Walking the ego's way at 1.5 m/s, 30 m ahead: gap 30 - 3.4 - length / 2, closing 10 - 1.5 = 8.5 m/s.
  const double half_len = tpl->class_sizes().at("person").length / 2;
  const hazard::PlanOutcome away = tpl->evaluate(walker(30.0, -1.0, 1.5, 0.0), test_scene(10.0));
  ASSERT_TRUE(away.reasons.empty()) << away.reasons.front();
  ASSERT_GE(away.ttc.size(), 21u);
  EXPECT_NEAR(away.ttc[20].ttc, (30.0 - 3.4 - half_len + 1.5 - 10.0) / 8.5, 1e-9);
  EXPECT_NEAR(away.trajectory.points[20].x, 31.5, 1e-9);
  EXPECT_DOUBLE_EQ(away.trajectory.points[20].heading, 0.0);
  // Towards the ego: closing 11.5 m/s, facing it.
  const hazard::PlanOutcome towards = tpl->evaluate(walker(30.0, -1.0, 1.5, 180.0), test_scene(10.0));
  ASSERT_TRUE(towards.reasons.empty()) << towards.reasons.front();
  EXPECT_NEAR(towards.ttc[20].ttc, (30.0 - 3.4 - half_len - 1.5 - 10.0) / 11.5, 1e-9);
  EXPECT_NEAR(std::abs(towards.trajectory.points[20].heading), kPi, 1e-9);
}

TEST(PedestrianAlongRoad, RefusesACrossingHeadingAPlaceBesideThePathAndOffTheRoad) {
  auto tpl = make_template("pedestrian_along_road");
  EXPECT_EQ(test::coded(tpl->check(walker(30.0, -1.0, 1.5, 90.0), test_scene(10.0))),
            std::vector<std::string>{
                "spec: heading_deg 90: a person walking along the road heads 0 (the ego's way) or 180 (towards it)"});
  const std::vector<std::string> beside = test::coded(tpl->check(walker(30.0, -3.0, 1.5, 0.0), test_scene(10.0)));
  ASSERT_FALSE(beside.empty());
  EXPECT_EQ(beside[0].rfind("placement: the person at y=-3 m is not in the ego path", 0), 0u) << beside[0];
}

TEST(PedestrianAlongRoad, ProposedOnlyWhereTheEgoLaneBordersTheRoadEdge) {
  auto tpl = make_template("pedestrian_along_road");
  SceneContext scene = test_scene(10.0);
  RoadLayout rural;  // one lane each way, traffic keeps right: the ego lane borders the right edge
  rural.lanes_left = 1;
  rural.lanes_right = 0;
  rural.oncoming_lanes = 1;
  scene.road = rural;
  const ProposalRequest req = request_at(scene);
  for (uint64_t seed = 1; seed <= 12; ++seed) {
    test::Bits bits(seed);
    const HazardProposal p = tpl->propose(req, bits);
    ASSERT_FALSE(p.spec.is_null()) << seed << ": " << p.problem;
    const HazardSpec spec = answered(p, scene);
    EXPECT_LT(spec.lateral_offset_m, 0.0) << seed;
    const hazard::PlanOutcome o = tpl->evaluate(spec, scene);
    ASSERT_TRUE(o.reasons.empty()) << seed << ": " << o.reasons.front() << "\n" << p.spec.dump();
    EXPECT_LE(o.trajectory.intended_min_ttc_s, req.aim * req.target_ttc_s + 0.05) << seed;
  }
  // A lane between the ego and the kerb: a person at the edge walks in that lane, not in the ego path.
  SceneContext arterial = test_scene(10.0);
  RoadLayout two_lanes;
  two_lanes.lanes_right = 1;
  arterial.road = two_lanes;
  test::Bits bits(1);
  const HazardProposal p = tpl->propose(request_at(arterial), bits);
  EXPECT_TRUE(p.spec.is_null());
  EXPECT_EQ(p.problem.code, refusal::kSceneLacks) << p.problem;
}

// A car parked 25 m ahead on the right, beside the ego path, standing; its tracked box as the test camera sees it.
ObjectState parked_car(const CameraModel& cam, double ego_speed) {
  ObjectState o;
  o.track_id = 9;
  o.label = "car";
  o.distance_m = 25.0;  // to its rear face (the states' origin: the rear axle)
  o.lateral_m = -4.5;
  o.length_m = 4.5;
  o.width_m = 1.8;
  o.velocity_rel = cv::Vec2d(-ego_speed, 0.0);
  o.speed_mps = 0.0;
  const hazard::BoxView v = hazard::view_of(cam, 25.0 + 2.25, -4.5, 0.0, {4.5, 1.8, 1.5});
  o.box = cv::Rect2f(v.box);
  return o;
}

TEST(PedestrianDartOut, APersonHiddenBehindAParkedCarRunsIntoThePathAtTheTarget) {
  auto tpl = make_template("pedestrian_dart_out");
  SceneContext scene = test_scene(8.0);
  scene.objects.push_back(parked_car(scene.camera, 8.0));
  const ProposalRequest req = request_at(scene);
  for (uint64_t seed = 1; seed <= 6; ++seed) {
    test::Bits bits(seed);
    const HazardProposal p = tpl->propose(req, bits);
    ASSERT_FALSE(p.spec.is_null()) << seed << ": " << p.problem;
    const HazardSpec spec = answered(p, scene);
    // Just beyond the car's front end (25 + 4.5 + 0.4 m), on its centre line, running to the left.
    EXPECT_NEAR(spec.initial_distance_m, 29.9, 0.05) << seed;
    EXPECT_NEAR(spec.lateral_offset_m, -4.5, 0.03) << seed;
    EXPECT_GE(spec.speed_mps, 2.0);
    EXPECT_LE(spec.speed_mps, 3.5);
    const hazard::PlanOutcome o = tpl->evaluate(spec, scene);
    ASSERT_TRUE(o.reasons.empty()) << seed << ": " << o.reasons.front();
    expect_within_limits(o.trajectory, tpl->limits().at("person"));
    // It stands until it runs, enters the path when the TTC is the target, and the plan ends in a collision
    // course (the TTC keeps falling while it crosses).
    EXPECT_GT(o.notes["wait_s"].get<double>(), 0.3 - 1e-9);
    double ttc_entering = kInf;
    for (const hazard::TtcSample& t : o.ttc)
      if (t.in_path) {
        ttc_entering = t.ttc;
        break;
      }
    EXPECT_NEAR(ttc_entering, req.target_ttc_s, 0.06) << seed;
    EXPECT_LE(o.trajectory.intended_min_ttc_s, req.target_ttc_s) << seed;
  }
}

TEST(PedestrianDartOut, NoProposalWithoutAParkedVehicleOrWhereItHidesNothing) {
  auto tpl = make_template("pedestrian_dart_out");
  SceneContext empty = test_scene(8.0);
  test::Bits bits(1);
  const HazardProposal none = tpl->propose(request_at(empty), bits);
  EXPECT_TRUE(none.spec.is_null());
  EXPECT_EQ(none.problem.code, refusal::kTraffic) << none.problem;
  // Its tracked box only a sliver of what the camera sees: it hides nothing.
  SceneContext sliver = test_scene(8.0);
  ObjectState car = parked_car(sliver.camera, 8.0);
  car.box.height = 5;
  sliver.objects.push_back(car);
  test::Bits bits2(1);
  const HazardProposal open = tpl->propose(request_at(sliver), bits2);
  EXPECT_TRUE(open.spec.is_null());
  EXPECT_EQ(open.problem.code, refusal::kPlacement) << open.problem;
}

TEST(PedestrianDartOut, RefusesAStartInThePathAndASpeedNoPersonRuns) {
  auto tpl = make_template("pedestrian_dart_out");
  HazardSpec s;
  s.kind = "pedestrian_dart_out";
  s.object_class = "person";
  s.initial_distance_m = 30.0;
  s.lateral_offset_m = -1.0;
  s.side = "right";
  s.speed_mps = 9.0;
  s.target_ttc_s = 1.4;
  const std::vector<std::string> got = test::coded(tpl->check(s, test_scene(8.0)));
  ASSERT_FALSE(got.empty());
  EXPECT_EQ(got, std::vector<std::string>{"class_limit: speed_mps 9 exceeds the person limit of 7 m/s"});
  s.speed_mps = 0.2;
  EXPECT_EQ(test::coded(tpl->check(s, test_scene(8.0))).back(),
            "spec: speed_mps 0.2 is too slow to run out (at least 0.5 m/s)");
  s.speed_mps = 3.0;
  const std::vector<std::string> in_path = test::coded(tpl->check(s, test_scene(8.0)));
  ASSERT_EQ(in_path.size(), 1u) << ::testing::PrintToString(in_path);
  EXPECT_EQ(in_path[0].rfind("placement: the start y=-1 m is in or at the ego path", 0), 0u) << in_path[0];
}

}  // namespace
}  // namespace hf
