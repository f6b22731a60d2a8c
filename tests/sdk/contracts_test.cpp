// The typed contracts between stages: their JSON forms, the schema 1.0 fields they still read, and the
// messages that name a bad field.
#include <gtest/gtest.h>

#include "hazardforge/error.hpp"
#include "hazardforge/stage.hpp"
#include "hazardforge/types.hpp"

namespace hf {
namespace {

HazardSpec spec() {
  HazardSpec s;
  s.kind = "sudden_stop";
  s.object_class = "car";
  s.initial_distance_m = 30;
  s.speed_mps = 10;
  return s;
}

TEST(Contracts, TheSpecsSharedFieldsAndRoadRoundTrip) {
  HazardSpec s = spec();
  s.track_id = 7;
  s.under_way_s = 0.5;
  RoadLayout road;
  road.lanes_left = 2;
  road.oncoming_lanes = 1;
  road.sources["lanes_left"] = {"measured", "a dashed white line in 80 % of 38 frames"};
  s.road = road;
  const Json j = s;
  EXPECT_EQ(j["schema_version"], "1.1");
  EXPECT_EQ(j["track_id"], 7);
  EXPECT_EQ(j["under_way_s"], 0.5);
  EXPECT_FALSE(j.contains("extra"));
  const HazardSpec back = j.get<HazardSpec>();
  EXPECT_EQ(back.track_id, 7);
  EXPECT_EQ(back.under_way_s, 0.5);
  ASSERT_TRUE(back.road);
  EXPECT_EQ(back.road->lanes_left, 2);
  EXPECT_EQ(back.road->source("lanes_left").from, "measured");
  EXPECT_EQ(back.road->source("driving_side").from, "default");  // not listed: a default
}

TEST(Contracts, ASchema10SpecIsReadWithItsSharedFieldsOutOfExtra) {
  Json j = spec();
  j["schema_version"] = "1.0";
  j["extra"] = {{"track_id", 3}, {"under_way_s", 0.25}, {"brake_delay_s", 1.0}};
  const HazardSpec s = j.get<HazardSpec>();
  EXPECT_EQ(s.track_id, 3);
  EXPECT_EQ(s.under_way_s, 0.25);
  EXPECT_EQ(s.extra, (Json{{"brake_delay_s", 1.0}}));  // the kind's own field stays
  EXPECT_EQ(spec_track_id({{"extra", {{"track_id", 4}}}}), 4);  // a partial spec (campaign feedback)
  EXPECT_EQ(spec_track_id({{"kind", "cut_in"}}), std::nullopt);
}

TEST(Contracts, BadSharedFieldsAndRoadsAreNamed) {
  Json j = spec();
  j["track_id"] = -1;
  EXPECT_THROW((void)j.get<HazardSpec>(), Error);
  j["track_id"] = 2.5;
  try {
    (void)j.get<HazardSpec>();
    FAIL();
  } catch (const Error& e) {
    EXPECT_STREQ(e.what(), "track_id must be a non-negative whole number or null, got 2.5");
  }
  j = spec();
  j["road"] = {{"lane_width_m", 9.0}};
  try {
    (void)j.get<HazardSpec>();
    FAIL();
  } catch (const Error& e) {
    EXPECT_STREQ(e.what(), "road.lane_width_m must be in [2, 6], got 9");
  }
  j["road"] = {{"sidewalks", "yes"}};
  try {
    (void)j.get<HazardSpec>();
    FAIL();
  } catch (const Error& e) {
    EXPECT_STREQ(e.what(), "road.sidewalks must be true or false, got \"yes\"");
  }
}

TEST(Contracts, TheRoadsGeometryFollowsTheDrivingSide) {
  RoadLayout r;  // one lane each side, traffic keeps right, every lane the ego's way
  EXPECT_DOUBLE_EQ(r.edge(1), 3.5 * 1.5);
  EXPECT_EQ(r.same_direction_lanes(1), 1);
  r.oncoming_lanes = 1;
  EXPECT_EQ(r.oncoming_lanes_on(1), 1);  // the left: oncoming traffic passes there
  EXPECT_FALSE(r.same_direction_at(3.5));
  EXPECT_TRUE(r.same_direction_at(-3.5));
  r.driving_side = "left";
  EXPECT_EQ(r.oncoming_lanes_on(1), 0);
  EXPECT_EQ(r.oncoming_lanes_on(-1), 1);  // keeping left, oncoming traffic passes on the right
  EXPECT_NO_THROW(r.validate("road"));
  r.lanes_right = 0;
  try {
    r.validate("road");
    FAIL();
  } catch (const Error& e) {
    EXPECT_STREQ(e.what(),
                 "road.oncoming_lanes 1 exceeds the 0 lane(s) on the right, where oncoming traffic passes when "
                 "traffic keeps left");
  }
}

TEST(Contracts, AKindsFieldIsDeclaredReadAndWrittenThroughItsHandle) {
  const SpecField<double> delay("brake_delay_s", "seconds before it brakes", {{"minimum", 0}});
  const HazardField d = delay.declaration();
  EXPECT_EQ(d.name, "brake_delay_s");
  EXPECT_EQ(d.schema["type"], Json::array({"number", "null"}));
  EXPECT_EQ(d.schema["minimum"], 0);
  const SpecField<std::string> from("crossing_from", "kerb", {{"enum", {"left", "right"}}});
  EXPECT_EQ(from.declaration().schema["enum"], Json::array({"left", "right", nullptr}));

  HazardSpec s = spec();
  EXPECT_EQ(delay.get(s), std::nullopt);
  Json proposal = {{"kind", "sudden_stop"}};
  delay.set(proposal, 1.5);
  EXPECT_EQ(proposal["extra"]["brake_delay_s"], 1.5);
  s.extra = proposal["extra"];
  EXPECT_EQ(delay.get(s), 1.5);
  s.extra["brake_delay_s"] = "soon";
  try {
    (void)delay.get(s);
    FAIL();
  } catch (const Error& e) {
    EXPECT_STREQ(e.what(), "extra.brake_delay_s must be number or null, got \"soon\"");
  }
}

TEST(Contracts, RefusalsAreCountedByCode) {
  const std::vector<Refusal> traffic = {{refusal::kTraffic, "a car in the way", "cut_in"},
                                        {refusal::kTraffic, "a truck in the way", "cut_in"}};
  EXPECT_TRUE(only_traffic(traffic));
  EXPECT_FALSE(only_traffic({}));
  std::vector<Refusal> mixed = traffic;
  mixed.push_back({refusal::kSceneLacks, "a single lane", "cut_in"});
  EXPECT_FALSE(only_traffic(mixed));
  EXPECT_EQ(refusal_text(mixed), "a car in the way; a truck in the way; a single lane");
  EXPECT_EQ(refusal_text({mixed[2]}, true), "cut_in: a single lane");
  const Json j = mixed[2];
  EXPECT_EQ(j, (Json{{"code", "scene_lacks"}, {"text", "a single lane"}, {"kind", "cut_in"}}));
  EXPECT_EQ(j.get<Refusal>().code, refusal::kSceneLacks);
}

TEST(Contracts, AVerificationOutcomeReadsAsItIsWritten) {
  VerificationOutcome o;
  o.passed = false;
  o.reasons = {{verdict::kNeverUnsafe, "the scene never becomes Unsafe", "cut_in"}};
  o.kind = "cut_in";
  o.object_class = "car";
  o.intended_min_ttc_s = 1.1;
  o.achieved_min_ttc_s = 2.3;
  o.achieved_at_frame = 14;
  o.hazard_critical_frames = 0;
  o.spurious_frames = {12, 13};
  const Json j = o;
  EXPECT_EQ(j["reasons"], Json::array({"the scene never becomes Unsafe"}));
  EXPECT_EQ(j["reason_codes"], Json::array({"never_unsafe"}));
  EXPECT_EQ(j["ttc"]["intended_min_ttc_visible_s"], 1.1);
  EXPECT_TRUE(j["redetection"]["rate"].is_null());
  const VerificationOutcome back = j.get<VerificationOutcome>();
  EXPECT_FALSE(back.passed);
  ASSERT_EQ(back.reasons.size(), 1u);
  EXPECT_EQ(back.reasons[0].code, verdict::kNeverUnsafe);
  EXPECT_EQ(back.achieved_at_frame, 14);
  EXPECT_EQ(back.spurious_frames, (std::vector<int64_t>{12, 13}));
  // A file written before the codes: the reasons without them.
  Json old = j;
  old.erase("reason_codes");
  EXPECT_EQ(old.get<VerificationOutcome>().reasons[0].code, "");
  old["passed"] = "no";
  EXPECT_THROW((void)old.get<VerificationOutcome>(), Error);
  old["passed"] = false;
  old["ttc"]["achieved_min_ttc_s"] = "2.3";
  try {
    (void)old.get<VerificationOutcome>();
    FAIL();
  } catch (const Error& e) {
    EXPECT_STREQ(e.what(), "ttc.achieved_min_ttc_s must be a number or null, got \"2.3\"");
  }
}

}  // namespace
}  // namespace hf
