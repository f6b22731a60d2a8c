// The offline planner: seeded determinism, variety across seeds, the prompt's rules, clear refusals.
#include <gtest/gtest.h>

#include <set>

#include "llm_test_support.hpp"

namespace hf::llm {
namespace {

// The settings of a test street.
llm_hazard::SceneSettings street(bool sidewalks, bool multi_lane, double ego_speed,
                                 std::vector<std::string> kinds, std::vector<std::string> drawable = {}) {
  llm_hazard::SceneSettings s;
  s.rules.asset_classes = std::move(drawable);  // empty: any class
  s.environment = "test street";
  s.road_type = "test";
  s.sidewalks = {sidewalks, "test"};
  s.intersection = {false, "test"};
  s.multi_lane = {multi_lane, "test"};
  s.allowed_kinds = std::move(kinds);
  s.ego_speed_mps = ego_speed;
  return s;
}

// The scene the generator would offer (built from the same synthetic scene as the stage tests).
std::unique_ptr<test::OfflineScene> scene_context(bool sidewalks, bool multi_lane, double ego_speed,
                                                  std::vector<std::string> kinds,
                                                  std::vector<std::string> drawable = {}) {
  return std::make_unique<test::OfflineScene>(
      street(sidewalks, multi_lane, ego_speed, std::move(kinds), std::move(drawable)),
      test::make_frame(5, 2.5, "test"), test::make_states(5, 2.5), test::make_risk(5, true));
}

LlmRequest request(const std::unique_ptr<test::OfflineScene>& scene, int64_t seed) {
  return scene->request(seed);
}

OfflinePlanner planner() {
  OfflinePlanner p;
  p.open(ComponentRegistry::make_params(OfflinePlanner::describe(), Json::object(), {}, "offline"));
  return p;
}

const std::vector<std::string> kAll = {"pedestrian_crossing", "cut_in", "sudden_stop"};

TEST(OfflinePlanner, SameSeedSameReply) {
  OfflinePlanner p = planner();
  auto scene = scene_context(true, true, 10.0, kAll);
  LlmReply a = p.complete(request(scene, 42));
  LlmReply b = p.complete(request(scene, 42));
  EXPECT_EQ(a.content, b.content);
  EXPECT_EQ(a.model, "offline-planner-1");
  Json j = Json::parse(a.content);
  EXPECT_TRUE(j.contains("rationale"));
  EXPECT_EQ(j["target_ttc_s"], 1.0);
}

TEST(OfflinePlanner, SeedsVaryKindAndParameters) {
  OfflinePlanner p = planner();
  auto scene = scene_context(true, true, 10.0, kAll);
  std::set<std::string> kinds, contents;
  for (int64_t seed = 0; seed < 12; ++seed) {
    Json j = Json::parse(p.complete(request(scene, seed)).content);
    kinds.insert(j["kind"].get<std::string>());
    contents.insert(j.dump());
  }
  EXPECT_EQ(kinds, (std::set<std::string>{"pedestrian_crossing", "cut_in", "sudden_stop"}));
  EXPECT_GE(contents.size(), 10u);
}

TEST(OfflinePlanner, FollowsTheRules) {
  OfflinePlanner p = planner();
  // No sidewalks, one lane: only a sudden stop is left.
  auto scene = scene_context(false, false, 10.0, kAll);
  for (int64_t seed = 0; seed < 8; ++seed)
    EXPECT_EQ(Json::parse(p.complete(request(scene, seed)).content)["kind"], "sudden_stop")
        << "seed " << seed;
  // Sidewalks, pedestrian crossings only: the person starts beyond the road edge, crossing towards the road.
  scene = scene_context(true, false, 10.0, {"pedestrian_crossing"});
  for (int64_t seed = 0; seed < 8; ++seed) {
    Json j = Json::parse(p.complete(request(scene, seed)).content);
    EXPECT_EQ(j["object_class"], "person");
    const double y = j["lateral_offset_m"].get<double>();
    EXPECT_GE(std::abs(y), 5.25 + 0.5);
    EXPECT_EQ(j["extra"]["crossing_from"], y > 0 ? "left" : "right");
    EXPECT_EQ(j["heading_deg"].get<double>(), y > 0 ? -90.0 : 90.0);
    EXPECT_LE(j["speed_mps"].get<double>(), 2.5);
  }
}

TEST(OfflinePlanner, RetryDrawsANewPlan) {
  OfflinePlanner p = planner();
  auto scene = scene_context(true, true, 10.0, kAll);
  LlmRequest r = request(scene, 3);
  LlmReply first = p.complete(r);
  r.messages.push_back({"assistant", first.content});
  r.messages.push_back({"user", "rejected"});
  const Json a = Json::parse(first.content), b = Json::parse(p.complete(r).content);
  // Not the same design again: another kind, class, side or track.
  EXPECT_NE(Json::array({a["kind"], a["object_class"], a["side"], a["track_id"]}),
            Json::array({b["kind"], b["object_class"], b["side"], b["track_id"]}));
}

TEST(OfflinePlanner, RefusesClearlyWhenNothingFits) {
  OfflinePlanner p = planner();
  try {
    p.complete(request(scene_context(true, true, 0.0, kAll), 1));
    FAIL();
  } catch (const Error& e) {
    EXPECT_STREQ(
        e.what(),
        "offline: no hazard fits this scene (allowed kinds: pedestrian_crossing, cut_in, "
        "sudden_stop): the ego speed 0.0 m/s is below 1.0 m/s, so no inserted object closes in on it");
  }
  try {
    p.complete(request(scene_context(false, false, 10.0, {"pedestrian_crossing"}), 1));
    FAIL();
  } catch (const Error& e) {
    EXPECT_STREQ(e.what(),
                 "offline: no hazard fits this scene (allowed kinds: pedestrian_crossing): "
                 "pedestrian_crossing: the scene has no sidewalks");
  }
  try {
    LlmRequest empty;
    p.complete(empty);
    FAIL();
  } catch (const Error& e) {
    EXPECT_STREQ(
        e.what(),
        "offline: the request carries no scene context (the offline planner reads LlmRequest::scene)");
  }
}

// A highway clip 1.4 s long after the trigger: ego at 20 m/s in the leftmost of four lanes, no sidewalks.
// `entry_max_height` 0: no rule on how a hazard comes into view.
std::unique_ptr<test::OfflineScene> short_highway(std::vector<std::string> kinds, double max_under_way,
                                                  bool people_on_shoulder, double entry_max_height = 0.07) {
  llm_hazard::SceneSettings s;
  s.environment = "highway";
  s.road_type = "multi-lane highway";
  s.sidewalks = {false, "test"};
  s.intersection = {false, "test"};
  s.multi_lane = {true, "test"};
  s.allowed_kinds = std::move(kinds);
  s.ego_speed_mps = 20.0;
  s.target_ttc_s = 1.4;
  s.horizon_s = 1.4;
  s.max_under_way_s = max_under_way;
  s.pedestrians_without_sidewalks = people_on_shoulder;
  s.road.lanes_left = 0;
  s.road.lanes_right = 3;
  s.rules.entry_max_height = entry_max_height;
  return std::make_unique<test::OfflineScene>(s, test::make_frame(5, 2.5, "test"), test::make_states(5, 2.5),
                                              test::make_risk(5, true));
}

TEST(OfflinePlanner, ShortHorizonSuddenStopIsAlreadyUnderWayWhenAllowed) {
  OfflinePlanner p = planner();
  // Without the rule on coming into view: a lead following at the ego's speed, close ahead.
  try {
    p.complete(request(short_highway({"sudden_stop"}, 0.0, false, 0.0), 7));
    FAIL();
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("sudden_stop: the stop would come too late within the horizon"),
              std::string::npos)
        << e.what();
  }
  for (int64_t seed : {1, 7, 11}) {
    const Json j =
        Json::parse(p.complete(request(short_highway({"sudden_stop"}, 1.0, false, 0.0), seed)).content);
    EXPECT_EQ(j["kind"], "sudden_stop");
    const double b = j["under_way_s"].get<double>();
    EXPECT_GE(b, 0.3);
    EXPECT_LE(b, 0.8);
    EXPECT_EQ(j["extra"]["brake_delay_s"], 0.0);
    EXPECT_DOUBLE_EQ(j["speed_mps"].get<double>(), 20.0);  // it followed at the ego's speed before braking
    EXPECT_LT(j["initial_distance_m"].get<double>(), 40.0);
  }
}

// A lead appearing in the ego lane must be first seen small (7 % of the 900 px image: a car from 34.3 m): a slower
// lead far ahead, already braking when it appears.
TEST(OfflinePlanner, ShortHorizonSuddenStopIsFirstSeenSmall) {
  OfflinePlanner p = planner();
  for (int64_t seed : {1, 7, 11}) {
    auto scene = short_highway({"sudden_stop"}, 1.0, false);
    const Json j = Json::parse(p.complete(request(scene, seed)).content);
    EXPECT_EQ(j["object_class"], "car") << j.dump();
    EXPECT_GT(j["under_way_s"].get<double>(), 0.0);
    EXPECT_LT(j["speed_mps"].get<double>(), 20.0);           // slower than the ego
    EXPECT_GE(j["initial_distance_m"].get<double>(), 34.3);  // where its braking began, farther than it appears
    EXPECT_TRUE(scene->checker().check(j).errors.empty()) << test::coded(scene->checker().check(j).errors).front();
  }
}

// When the tracked lead cannot be the one that brakes, the refusal says why, beside why an inserted lead
// cannot either: in a crawling queue (ego 1.5 m/s, the lead 6.6 m ahead at 0.6 m/s, 3 s of clip left) the
// lead's braking closes in too slowly, and a car first seen small far ahead cannot close in either.
TEST(OfflinePlanner, ARefusedSuddenStopSaysWhyTheTrackedLeadCouldNotBrake) {
  llm_hazard::SceneSettings s = street(false, true, 1.5, {"sudden_stop"});
  s.horizon_s = 3.0;
  ObjectStates st = test::make_states(5, 2.5);
  st.ego_speed_mps = 1.5;
  ObjectState lead = st.objects.front();
  lead.track_id = 9;
  lead.distance_m = 10.0;  // its rear, from the rear axle: 6.6 m ahead of the bumper
  lead.lateral_m = 0.0;
  lead.in_path = true;
  lead.speed_mps = 0.6;
  lead.velocity_rel = cv::Vec2d(-0.9, 0.0);
  st.objects = {lead};
  test::OfflineScene scene(s, test::make_frame(5, 2.5, "test"), st, test::make_risk(5, true));
  OfflinePlanner p = planner();
  try {
    p.complete(scene.request(3));
    FAIL() << "a crawling queue got a sudden stop";
  } catch (const Error& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find("sudden_stop: the car (track 9) 6.6 m ahead at 0.6 m/s cannot bring the TTC to"),
              std::string::npos)
        << what;
    EXPECT_NE(
        what.find("by braking within the 3.0 s horizon (the ego at 1.5 m/s now); an inserted lead: a lead "
                  "first seen small (from 34.3 m) cannot bring the TTC to"),
        std::string::npos)
        << what;
  }
}

// In slow traffic (a queue at 3 m/s) a cut-in is a vehicle from the next lane squeezing into the gap ahead and
// rolling on slower than the ego; a standing ego is not cut off.
TEST(OfflinePlanner, SlowTrafficCutInSqueezesIntoTheGapAndStops) {
  OfflinePlanner p = planner();
  int planned = 0;
  for (int64_t seed : {1, 2, 3, 4, 5, 6, 7, 8}) {
    auto scene = scene_context(false, true, 3.0, {"cut_in"});
    try {
      const Json j = Json::parse(p.complete(request(scene, seed)).content);
      ++planned;
      EXPECT_EQ(j["kind"], "cut_in");
      EXPECT_GT(j["speed_mps"].get<double>(), 3.0 + 1.0) << j.dump();
      EXPECT_LE(j["speed_mps"].get<double>(), 3.0 + 3.5);
      EXPECT_GE(j["extra"]["final_speed_mps"].get<double>(), 0.9 - 0.05);  // slower than the ego, still rolling
      EXPECT_LE(j["extra"]["final_speed_mps"].get<double>(), 1.5 + 0.05);
      EXPECT_NE(j["rationale"].get<std::string>().find("In slow traffic"), std::string::npos);
      EXPECT_TRUE(scene->checker().check(j).errors.empty()) << test::coded(scene->checker().check(j).errors).front();
    } catch (const Error& e) {
      // A seed may draw a class or side that does not fit; it says why.
      EXPECT_NE(std::string(e.what()).find("cut_in: "), std::string::npos) << e.what();
    }
  }
  EXPECT_GE(planned, 4);
  try {
    p.complete(request(scene_context(false, true, 0.5, {"cut_in"}), 1));
    FAIL();
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("the ego speed 0.5 m/s is below 1.0 m/s"), std::string::npos)
        << e.what();
  }
}

// A vehicle's class is drawn among those the renderer can draw: with the default set (no motorcycle) no plan
// is a motorcycle and no draw is wasted on one; with no vehicle pictures at all the refusal names each class.
TEST(OfflinePlanner, ClassesAreDrawnAmongTheDrawableOnes) {
  OfflinePlanner p = planner();
  const std::vector<std::string> defaults = {"bus", "car", "person", "truck"};
  std::set<std::string> drawn;
  for (int64_t seed = 1; seed <= 16; ++seed)
    for (const char* kind : {"cut_in", "sudden_stop"}) {
      auto scene = scene_context(false, true, 10.0, {kind}, defaults);
      try {
        const Json j = Json::parse(p.complete(request(scene, seed)).content);
        drawn.insert(j["object_class"].get<std::string>());
      } catch (const Error& e) {
        EXPECT_EQ(std::string(e.what()).find("appearance assets"), std::string::npos) << e.what();
      }
    }
  EXPECT_TRUE(drawn.count("car")) << drawn.size();
  EXPECT_FALSE(drawn.count("motorcycle"));
  try {
    p.complete(request(scene_context(false, true, 10.0, {"cut_in"}, {"person"}), 1));
    FAIL();
  } catch (const Error& e) {
    EXPECT_NE(
        std::string(e.what()).find("cut_in: no class it could be drawn as ('car': no appearance assets; "
                                   "'motorcycle': no appearance assets; 'truck': no appearance assets)"),
        std::string::npos)
        << e.what();
  }
}

// Same-camera appearances first: with the recording's own cuts showing motorcycles, a kind that may be one is
// planned as one whenever such a plan fits (this street's plans are otherwise cars, the largest that fits), and
// as any of its classes when none does, so no draw that finds a hazard without the preference finds none with
// it; a kind that cannot be one (a person crossing) keeps its own classes.
TEST(OfflinePlanner, AKindIsDrawnAsAClassTheRecordingsOwnCutsShowFirst) {
  OfflinePlanner p = planner();
  const std::vector<std::string> defaults = {"bus", "car", "motorcycle", "person", "truck"};
  auto scene = [&](const char* kind, std::vector<std::string> own) {
    llm_hazard::SceneSettings s = street(true, true, 10.0, {kind}, defaults);
    s.rules.recording_classes = std::move(own);
    return std::make_unique<test::OfflineScene>(std::move(s), test::make_frame(5, 2.5, "test"),
                                                test::make_states(5, 2.5), test::make_risk(5, true));
  };
  auto drawn_class = [&](const char* kind, std::vector<std::string> own, int64_t seed) -> std::string {
    try {
      return Json::parse(p.complete(request(scene(kind, std::move(own)), seed)).content)["object_class"];
    } catch (const Error&) {  // nothing fits this draw
      return "";
    }
  };
  int motorcycles = 0, motorcycles_without = 0;
  for (int64_t seed = 1; seed <= 16; ++seed)
    for (const char* kind : {"cut_in", "sudden_stop"}) {
      const std::string with = drawn_class(kind, {"motorcycle"}, seed), without = drawn_class(kind, {}, seed);
      motorcycles += with == "motorcycle";
      motorcycles_without += without == "motorcycle";
      if (!without.empty()) {
        EXPECT_FALSE(with.empty()) << kind << " seed " << seed;
      }
    }
  EXPECT_GE(motorcycles, 3);
  EXPECT_GT(motorcycles, motorcycles_without);
  EXPECT_EQ(drawn_class("pedestrian_crossing", {"motorcycle"}, 1), "person");
}

TEST(OfflinePlanner, PersonOnTheShoulderOnlyWhenExplicitlyAllowed) {
  OfflinePlanner p = planner();
  EXPECT_THROW(p.complete(request(short_highway({"pedestrian_crossing"}, 1.0, false), 3)), Error);
  const Json j =
      Json::parse(p.complete(request(short_highway({"pedestrian_crossing"}, 1.0, true), 3)).content);
  EXPECT_EQ(j["object_class"], "person");
  // The left shoulder: beyond the road edge at 1.75 m, kerb offset 0.5 m plus up to 0.5 m.
  EXPECT_GE(j["lateral_offset_m"].get<double>(), 2.25 - 1e-9);
  EXPECT_LE(j["lateral_offset_m"].get<double>(), 2.75 + 1e-9);
  EXPECT_NE(j["rationale"].get<std::string>().find("Edge case"), std::string::npos);
  // Too short a horizon to watch the person wait and step off: the walk is already under way.
  EXPECT_GT(j["under_way_s"].get<double>(), 0.0);
  EXPECT_LE(j["under_way_s"].get<double>(), 1.0);
}

}  // namespace
}  // namespace hf::llm
