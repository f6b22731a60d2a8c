// Scene-aware refusals, for every kind: paths through tracked objects, classes without appearance assets,
// lanes used against their traffic, hazards popping up on the road, taken-over tracks; and the offline
// planner keeps to the same rules.
#include <gtest/gtest.h>

#include <opencv2/core.hpp>

#include "hazardforge/assets/asset_library.hpp"
#include "hazardforge/hazard/kinematics.hpp"
#include "llm_test_support.hpp"
#include "scene_rules.hpp"
#include "temp_dir.hpp"

namespace hf::llm_hazard {
namespace {

// A straight ego at 10 m/s; `pts` the hazard's samples (x, y, heading) at 20 Hz from t = 0.
HazardTrajectory trajectory(const std::string& cls, const std::vector<cv::Vec3d>& pts, cv::Vec3d size) {
  HazardTrajectory tr;
  tr.kind = "test";
  tr.object_class = cls;
  tr.size_lwh = size;
  for (size_t k = 0; k < pts.size(); ++k) {
    const double t = 0.05 * k;
    tr.points.push_back({t, pts[k][0], pts[k][1], pts[k][2], 0, 0});
    tr.ego.push_back({t, 10.0 * t, 0.0, 0.0, 10.0, 0.0});
  }
  return tr;
}

SceneContext scene_with(std::vector<ObjectState> objects) {
  SceneContext sc;
  sc.ego_speed_mps = 10.0;
  sc.camera = test::test_camera();
  sc.objects = std::move(objects);
  return sc;
}

ObjectState tracked(int64_t id, const std::string& label, double x, double y, double vx_abs) {
  ObjectState o;
  o.track_id = id;
  o.label = label;
  o.distance_m = x;
  o.lateral_m = y;
  o.velocity_rel = cv::Vec2d(vx_abs - 10.0, 0.0);
  return o;
}

const ClassPriors& sizes() {
  static const ClassPriors s = ClassPriors::load(share_dir() + "/class_sizes.yaml");
  return s;
}

const cv::Vec3d kPerson(0.5, 0.6, 1.7), kCar(4.5, 1.85, 1.52);

// A person crossing at x = 40 m from the left kerb (y 5.75 m) at 2 m/s.
HazardTrajectory crossing_at_40m() {
  std::vector<cv::Vec3d> walk;
  for (int k = 0; k <= 120; ++k) walk.push_back({40.0, 5.75 - 0.1 * k, -M_PI / 2});
  return trajectory("person", walk, kPerson);
}

// A person who crosses at x = 40 m from the left kerb (2 m/s) walks through the car parked there on the
// right.
TEST(SceneRules, NoPathThroughATrackedObjectsPredictedPositions) {
  const HazardTrajectory tr = crossing_at_40m();
  hazard::RoadModel road;
  SceneRules rules;
  // The car's rear 37.75 m ahead (what distance_m measures): its centre at 40 m.
  const auto errs = test::coded(
      check_trajectory_rules(tr, scene_with({tracked(7, "car", 37.75, -3.5, 0.0)}), road, sizes(), rules));
  ASSERT_EQ(errs.size(), 1u);
  EXPECT_EQ(
      errs[0],
      "traffic: the planned path of the person runs into the tracked car (track 7, predicted at constant velocity): "
      "3.9 s after it appears the person would be at (x 40, y -2.05) m and the car at (x 40, y -3.5) m. "
      "Place "
      "it where its path stays clear of the tracked objects");
  // A car driving away at 15 m/s is past the crossing by then: its predicted positions are clear.
  EXPECT_TRUE(
      check_trajectory_rules(tr, scene_with({tracked(7, "car", 20.0, -3.5, 15.0)}), road, sizes(), rules)
          .empty());
  // Predicted, not only where it is now: a car 60 m ahead coming at 5 m/s meets the person 4 s later.
  EXPECT_EQ(
      check_trajectory_rules(tr, scene_with({tracked(9, "car", 60.0, -1.75, -5.0)}), road, sizes(), rules)
          .size(),
      1u);
  // The object a spec takes over is the hazard itself.
  HazardTrajectory over = tr;
  over.spec.track_id = 7;
  EXPECT_TRUE(
      check_trajectory_rules(over, scene_with({tracked(7, "car", 40.0, -3.5, 0.0)}), road, sizes(), rules)
          .empty());
}

// A filtered estimator's covariance says when a velocity is indistinguishable from standing still: a parked
// car that reads 1.5 m/s forward with a 1 m/s sigma (an ego speed estimated too high does that) stays parked
// in the prediction, so a person crossing just beyond it is clear; the same velocity with a tight covariance
// is a car creeping on into the crossing.
TEST(SceneRules, AVelocityWithinItsUncertaintyIsStandingStill) {
  const HazardTrajectory tr = crossing_at_40m();
  hazard::RoadModel road;
  SceneRules rules;
  // Its front 2.6 m short of the crossing (centre 34.9 m), 3.5 m right: standing, it is clear of the person.
  ObjectState parked = tracked(4, "car", 32.65, -3.5, 1.5);
  auto with_sigma = [](ObjectState o, double sigma) {
    cv::Matx44d P = cv::Matx44d::eye() * 0.04;
    P(2, 2) = P(3, 3) = sigma * sigma;
    o.covariance = P;
    return o;
  };
  EXPECT_TRUE(
      check_trajectory_rules(tr, scene_with({with_sigma(parked, 1.0)}), road, sizes(), rules).empty());
  // Without a covariance (the paper's estimator) the velocity is taken as it is: 1.5 m/s for 4.6 s is 6.9 m.
  EXPECT_EQ(check_trajectory_rules(tr, scene_with({parked}), road, sizes(), rules).size(), 1u);
  EXPECT_EQ(check_trajectory_rules(tr, scene_with({with_sigma(parked, 0.3)}), road, sizes(), rules).size(),
            1u);
  EXPECT_EQ(hazard::ground_velocity(with_sigma(parked, 1.0), 10.0), cv::Vec2d(0, 0));
  EXPECT_EQ(hazard::ground_velocity(with_sigma(parked, 0.3), 10.0), cv::Vec2d(1.5, 0));
  EXPECT_FALSE(hazard::ground_velocity(ObjectState{}, 10.0).has_value());
}

// What the renderer cannot draw is not asked for: the class must have appearance assets.
TEST(SceneRules, OnlyClassesWithAppearanceAssets) {
  EXPECT_EQ(asset_classes(""), (std::vector<std::string>{"bus", "car", "person", "truck"}));
  // A harvested folder adds its classes to the default set the renderer falls back to.
  test::TempDir dir;
  render::AssetSpec a;
  a.file = "moto.png";
  a.object_class = "motorcycle";
  a.view = "rear";
  a.size_lwh = {2.1, 0.8, 1.5};
  a.image_size = {8, 8};
  a.anchor_px = {4, 7};
  for (auto& c : a.box_corners_px) c = {4, 4};
  a.source = "harvested";
  render::write_png_atomic(dir / "moto.png", cv::Mat(8, 8, CV_8UC4, cv::Scalar(0, 0, 0, 255)));
  render::save_asset_index(dir.path(), {{a}}, "test");
  EXPECT_EQ(asset_classes(dir.path().string()),
            (std::vector<std::string>{"bus", "car", "motorcycle", "person", "truck"}));

  HazardSpec s;
  s.object_class = "motorcycle";
  SceneRules rules;
  rules.asset_classes = asset_classes("");
  rules.assets_where = "the default set, share/assets";
  EXPECT_EQ(
      test::coded(check_spec_rules(s, scene_with({}), rules)),
      std::vector<std::string>{
          "object_class: /object_class = \"motorcycle\" has no appearance assets, so the renderer cannot draw it (classes "
          "with assets: bus, car, person, truck; the default set, share/assets)"});
}

// The generator offers a model only the drawable classes, and refuses the rest.
TEST(SceneRules, TheReplySchemaOffersOnlyDrawableClasses) {
  test::ScriptedServer srv("/api/chat");
  Json moto = test::valid_reply();
  moto["kind"] = "cut_in";
  moto["object_class"] = "motorcycle";
  srv.then_ollama(moto.dump());
  srv.then_ollama(test::valid_reply().dump());
  auto r = test::make_runner("provider: {name: ollama, host: '" + srv.url() + "'}\n");
  test::push_scene(r, 6, "Busy city street, peds on the sidewalk, two lanes each way");
  r.run();
  ASSERT_EQ(r.outputs("hazard").size(), 1u);
  const auto got = srv.requests();
  EXPECT_EQ(got[0]["format"]["properties"]["object_class"]["enum"],
            Json::array({"person", "car", "bus", "truck"}));
  EXPECT_NE(got[1]["messages"][2]["content"].get<std::string>().find(
                "- /object_class = \"motorcycle\" is not one of \"person\", \"car\", \"bus\", \"truck\""),
            std::string::npos);
}

// Traffic keeps right and the lane left of the ego's is oncoming: a vehicle there drives towards the ego, so
// a cut-in from the left is refused; one from the right (a lane going the ego's way) is not.
TEST(SceneRules, NoCutInFromALaneWithOncomingTraffic) {
  hazard::RoadModel road;
  road.oncoming_lanes = 1;
  SceneRules rules;
  std::vector<cv::Vec3d> left, right;
  for (int k = 0; k <= 40; ++k) {
    left.push_back({-2.0 + 0.7 * k, 3.5, 0.0});
    right.push_back({-2.0 + 0.7 * k, -3.5, 0.0});
  }
  EXPECT_EQ(
      test::coded(check_trajectory_rules(trajectory("car", left, kCar), scene_with({}), road, sizes(), rules)),
      std::vector<std::string>{
          "placement: the car starts at y 3.5 m in a lane with oncoming traffic (lanes_left 1, lanes_right 1, "
          "oncoming_lanes 1, traffic keeps right) but drives the ego's way, against that lane's traffic"});
  EXPECT_TRUE(
      check_trajectory_rules(trajectory("car", right, kCar), scene_with({}), road, sizes(), rules).empty());
  // Keeping left, the oncoming lane is the right one.
  road.driving_side = "left";
  EXPECT_TRUE(
      check_trajectory_rules(trajectory("car", left, kCar), scene_with({}), road, sizes(), rules).empty());
  EXPECT_EQ(
      check_trajectory_rules(trajectory("car", right, kCar), scene_with({}), road, sizes(), rules).size(),
      1u);
}

// The lanes the footage's markings show take the place of unstated lane counts, never of stated ones: a solid
// line leaves no lane beyond it, a dashed one a lane; yellow on the oncoming side parts opposing traffic.
TEST(SceneRules, TheFootagesLaneMarkingsSetTheLanesNotStated) {
  RoadMarkings m;
  m.frames = 38;
  m.left = {0, "solid", "yellow", 1.0};
  m.right = {1, "dashed", "white", 0.55};
  const hazard::RoadModel road;  // nothing stated: 1 lane each side by default
  EXPECT_EQ(road.with_markings(nullptr).lanes_left, 1);
  const hazard::RoadModel seen = road.with_markings(&m);
  EXPECT_EQ(seen.lanes_left, 0);
  EXPECT_EQ(seen.lanes_right, 1);
  EXPECT_EQ(seen.oncoming_lanes, 0);
  EXPECT_EQ(seen.lanes_from,
            "the footage's lane markings (left 0 lane(s): a solid yellow line in 100 % of 38 "
            "frames; right 1 lane(s): a dashed white line in 55 % of 38 frames)");
  // A dashed yellow line on the oncoming side (a two-lane road where passing is allowed): that lane is
  // oncoming.
  m.left = {1, "dashed", "yellow", 0.6};
  EXPECT_EQ(road.with_markings(&m).oncoming_lanes, 1);
  EXPECT_EQ(road.with_markings(&m).same_direction_lanes(1), 0);
  // A side the markings do not show keeps its value; a stated side is never overridden.
  m.left = {-1, "", "", 0.1};
  EXPECT_EQ(road.with_markings(&m).lanes_left, 1);
  hazard::RoadModel stated;
  stated.lanes_right = 3;
  stated.lanes_right_stated = true;
  EXPECT_EQ(stated.with_markings(&m).lanes_right, 3);
}

// The generator reads them from the frames: with nothing stated, a dashed line right of the ego lane makes
// the road multi-lane and a solid one on the left leaves no lane there, so every cut-in comes from the right.
TEST(SceneRules, CutInsComeFromTheSideTheLaneMarkingsOpen) {
  auto markings = std::make_shared<RoadMarkings>();
  markings->source = "video";
  markings->frames = 6;
  markings->left = {0, "solid", "yellow", 1.0};
  markings->right = {1, "dashed", "white", 0.5};
  for (int64_t seed = 0; seed < 4; ++seed) {
    auto r = test::make_runner("force_kind: cut_in\nseed: " + std::to_string(seed) + "\n");
    for (int i = 0; i < 6; ++i) {
      const double t = 0.5 * i;
      Frame f = test::make_frame(i, t, "a road");
      f.road_markings = markings;
      r.push("frames", f, t);
      ObjectStates st;  // an empty road: nothing for the cut-in's path to run into
      st.frame_index = i;
      st.timestamp = t;
      st.ego_speed_mps = 10.0;
      r.push("states", st, t);
      r.push("risk", test::make_risk(i, true), t, "ttc");
    }
    r.run();
    const auto specs = r.collect<HazardSpec>("hazard");
    ASSERT_EQ(specs.size(), 1u) << "seed " << seed;
    EXPECT_TRUE(specs[0].side == "right" || specs[0].lateral_offset_m < 0) << "seed " << seed;
    ASSERT_TRUE(specs[0].road);
    EXPECT_EQ(specs[0].road->lanes_left, 0);
    EXPECT_EQ(specs[0].road->lanes_right, 1);
  }
}

// The offline planner keeps to it: traffic keeping left, the lane on the right is oncoming (the car parked in
// it is the synthetic scene's), and every cut-in comes from the left.
TEST(SceneRules, TheOfflinePlannerCutsInOnlyFromALaneGoingTheEgosWay) {
  std::set<std::string> sides;
  for (int64_t seed = 0; seed < 10; ++seed) {
    auto r = test::make_runner(
        "force_kind: cut_in\nmulti_lane: 'yes'\ndriving_side: left\noncoming_lanes: 1\nseed: " +
        std::to_string(seed) + "\n");
    test::push_scene(r, 6, "city street");
    r.run();
    const auto specs = r.collect<HazardSpec>("hazard");
    ASSERT_EQ(specs.size(), 1u);
    sides.insert(specs[0].side);
    EXPECT_EQ(specs[0].provenance["attempts"], 1);
  }
  EXPECT_EQ(sides, std::set<std::string>{"left"});
}

// A hazard that appears fully in view on the road must be far enough to be small, hidden by a nearer tracked
// object or entering from the image border.
TEST(SceneRules, NoHazardPopsUpOnTheRoadCloseAhead) {
  hazard::RoadModel road;
  SceneRules rules;
  auto standing = [](double x, double y) { return std::vector<cv::Vec3d>(20, cv::Vec3d(x, y, 0.0)); };
  const SceneContext empty = scene_with({});
  EXPECT_EQ(
      test::coded(
          check_trajectory_rules(trajectory("car", standing(20.0, 0.0), kCar), empty, road, sizes(), rules)),
      std::vector<std::string>{
          "not_in_view: the car would pop up on the road 20 m ahead: when it is first seen (0 s after it appears) its box "
          "is "
          "fully in view, 118 px tall, and no tracked object hides it. Let it enter from beyond the image "
          "border, from behind a nearer tracked object, or far enough to be first seen small (at most 63 px "
          "tall, 7 % of the image height)"});
  // Far enough to be small (39 px at 50 m), or beside the ego at the image border, or not on the road.
  EXPECT_TRUE(
      check_trajectory_rules(trajectory("car", standing(50.0, 0.0), kCar), empty, road, sizes(), rules)
          .empty());
  EXPECT_TRUE(check_trajectory_rules(trajectory("car", standing(5.0, 3.5), kCar), empty, road, sizes(), rules)
                  .empty());
  EXPECT_TRUE(
      check_trajectory_rules(trajectory("person", standing(20.0, 6.0), kPerson), empty, road, sizes(), rules)
          .empty());
  // Hidden behind a van standing nearer, at the left kerb, whose box covers it in the image.
  ObjectState van = tracked(4, "truck", 12.0, 4.5, 0.0);
  const hazard::BoxView seen = hazard::view_of(test::test_camera(), 20.0, 0.0, 0.0, kCar);
  van.box = cv::Rect2f(static_cast<float>(seen.box.x - 10), static_cast<float>(seen.box.y - 10),
                       static_cast<float>(seen.box.width + 20), static_cast<float>(seen.box.height + 20));
  EXPECT_TRUE(check_trajectory_rules(trajectory("car", standing(20.0, 0.0), kCar), scene_with({van}), road,
                                     sizes(), rules)
                  .empty());
}

// A taken-over lead is the real one, where the recording shows it: its neighbour in the next lane as close as
// the recording has them is no collision (coming closer is), and it does not pop up (it was in view already).
TEST(SceneRules, ATakenOverLeadStartsWhereTheRealOneIs) {
  hazard::RoadModel road;
  SceneRules rules;
  // The lead at 20 m braking from 4 m/s; a truck beside it in the right lane, 2.3 m away (closer than the
  // clearance: estimated positions scatter), driving on at 6 m/s.
  std::vector<cv::Vec3d> brake;
  for (int k = 0; k <= 40; ++k)
    brake.push_back({20.0 + std::max(0.0, 4.0 * 0.05 * k - 2.0 * 0.0025 * k * k), 0.0, 0.0});
  HazardTrajectory lead = trajectory("car", brake, kCar);
  lead.spec.track_id = 3;
  const ObjectState truck = tracked(2, "truck", 20.0, -2.3, 6.0);
  EXPECT_TRUE(check_trajectory_rules(lead, scene_with({tracked(3, "car", 20.0, 0.0, 4.0), truck}), road,
                                     sizes(), rules)
                  .empty());
  // A person beside it walking towards it comes closer than the recording shows: refused. (A vehicle's
  // tracked lateral speed is not extrapolated: vehicles keep their lanes.)
  ObjectState walker = tracked(5, "person", 20.0, -1.5, 0.0);
  walker.velocity_rel = cv::Vec2d(-10.0, 1.0);
  EXPECT_EQ(check_trajectory_rules(lead, scene_with({walker}), road, sizes(), rules).size(), 1u);
  ObjectState drifting = truck;
  drifting.velocity_rel = cv::Vec2d(6.0 - 10.0, 1.0);
  EXPECT_TRUE(check_trajectory_rules(lead, scene_with({drifting}), road, sizes(), rules).empty());
  // The same plan as a new, inserted car is refused twice: next to the truck, and popping up 20 m ahead.
  HazardTrajectory inserted = lead;
  inserted.spec.track_id.reset();
  EXPECT_EQ(check_trajectory_rules(inserted, scene_with({truck}), road, sizes(), rules).size(), 2u);
}

// Taking over a tracked object (the real lead of a sudden stop) is allowed by default, since the renderer
// removes the real one; a scene that switches takeovers off refuses it.
TEST(SceneRules, TakingOverATrackedObjectIsRefusedWhereTakeoversAreOff) {
  HazardSpec s;
  s.object_class = "car";
  s.track_id = 7;
  SceneRules rules;
  EXPECT_TRUE(check_spec_rules(s, scene_with({tracked(7, "car", 40.0, -3.5, 0.0)}), rules).empty());
  rules.take_over_tracks = false;
  EXPECT_EQ(
      test::coded(check_spec_rules(s, scene_with({tracked(7, "car", 40.0, -3.5, 0.0)}), rules)),
      std::vector<std::string>{
          "spec: /track_id = 7 takes over the tracked car, but this scene does not allow takeovers "
          "(take_over_tracks false: the renderer would leave the real one in the video beside the inserted "
          "one). Insert a new object instead (track_id null)"});
}

}  // namespace
}  // namespace hf::llm_hazard
