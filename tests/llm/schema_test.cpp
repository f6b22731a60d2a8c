// The hazard spec schema: the shipped file, the derived reply schema and the validation messages.
#include <gtest/gtest.h>

#include <hazardforge/geometry.hpp>

#include "hazard_schema.hpp"
#include "llm_test_support.hpp"

namespace hf::llm_hazard {
namespace {

Json file_schema() {
  return load_schema_file(share_dir() + "/schemas/hazard_spec.schema.json");
}

// The file with the built-in kinds' extra fields, as the generator uses it when they are registered.
Json shipped() {
  return with_kind_fields(file_schema(), {PedestrianCrossingTemplate::info(), CutInTemplate::info(),
                                          SuddenStopTemplate::info()});
}

TEST(HazardSchema, ShippedFileIsDraft07AndVersioned) {
  Json s = file_schema();
  EXPECT_EQ(s["$schema"], "http://json-schema.org/draft-07/schema#");
  EXPECT_EQ(s["properties"]["schema_version"]["enum"], Json::array({"1.0", "1.1"}));
  EXPECT_EQ(s["additionalProperties"], false);
}

TEST(HazardSchema, ReplySchemaRequiresEveryFieldAndNarrowsKinds) {
  Json r = reply_schema(shipped(), {"cut_in", "sudden_stop"});
  EXPECT_FALSE(r["properties"].contains("provenance"));
  EXPECT_FALSE(r["properties"].contains("schema_version"));
  EXPECT_FALSE(r["properties"].contains("road"));  // the generator writes the road it settled
  // Fields every kind shares are the spec's own, typed (HazardSpec::track_id, under_way_s).
  EXPECT_EQ(r["properties"]["track_id"]["type"], Json::array({"integer", "null"}));
  EXPECT_EQ(r["properties"]["under_way_s"]["type"], Json::array({"number", "null"}));
  EXPECT_EQ(r["properties"]["kind"]["enum"], Json::array({"cut_in", "sudden_stop"}));
  EXPECT_EQ(r["required"].size(), r["properties"].size());
  EXPECT_EQ(r["properties"]["extra"]["required"].size(), 3u);
  EXPECT_EQ(r["properties"]["extra"]["additionalProperties"], false);
}

TEST(HazardSchema, ValidReplyPasses) {
  SchemaValidator v(reply_schema(shipped(), {"pedestrian_crossing"}));
  EXPECT_EQ(v.validate(test::valid_reply()), std::vector<std::string>{});
}

TEST(HazardSchema, MessagesNamePointerValueAndAllowedRange) {
  SchemaValidator v(reply_schema(shipped(), {"pedestrian_crossing", "cut_in"}));
  Json bad = test::valid_reply();
  bad["speed_mps"] = 75.5;
  bad["kind"] = "flying_car";
  bad["heading_deg"] = "left";
  bad.erase("rationale");
  bad["extra"]["crossing_from"] = "north";
  bad["colour"] = "red";
  std::vector<std::string> errs = v.validate(bad);
  std::sort(errs.begin(), errs.end());
  std::vector<std::string> expected = {
      "/colour is not an allowed field (allowed: deceleration_mps2, extra, heading_deg, initial_distance_m, "
      "kind, lateral_offset_m, motion, object_class, rationale, side, speed_mps, start_time_s, target_ttc_s, "
      "track_id, under_way_s)",
      "/extra/crossing_from = \"north\" is not one of \"left\", \"right\", null",
      "/heading_deg = \"left\" has type string, expected number",
      "/kind = \"flying_car\" is not one of \"pedestrian_crossing\", \"cut_in\"",
      "/rationale is missing (required)",
      "/speed_mps = 75.5 is outside the allowed range [0, 50]"};
  std::sort(expected.begin(), expected.end());
  EXPECT_EQ(errs, expected);
}

TEST(HazardSchema, NullableFieldsAcceptNullButNotOtherTypes) {
  SchemaValidator v(reply_schema(shipped(), {"pedestrian_crossing"}));
  Json r = test::valid_reply();
  r["deceleration_mps2"] = "hard";
  EXPECT_EQ(v.validate(r), std::vector<std::string>{
                               "/deceleration_mps2 = \"hard\" has type string, expected number or null"});
}

TEST(HazardSchema, SpecFromReplyFillsDefaultsAndDropsNulls) {
  HazardSpec s = spec_from_reply(test::valid_reply(), 12.5);
  EXPECT_DOUBLE_EQ(s.start_time_s, 12.5);
  EXPECT_FALSE(s.deceleration_mps2.has_value());
  EXPECT_EQ(s.extra, (Json{{"crossing_from", "right"}}));
  ASSERT_TRUE(s.target_ttc_s.has_value());
  EXPECT_DOUBLE_EQ(*s.target_ttc_s, 1.0);
  // What the generator writes must follow the file's schema, and the schema with the kinds' fields.
  s.provenance = {{"provider", "test"}};
  SchemaValidator file(file_schema());
  EXPECT_EQ(file.validate(Json(s)), std::vector<std::string>{});
  SchemaValidator with_kinds(shipped());
  EXPECT_EQ(with_kinds.validate(Json(s)), std::vector<std::string>{});
}

// Each kind brings its own extra fields (SpecField declarations); the file lists none.
TEST(HazardSchema, KindsDeclareTheirExtraFields) {
  EXPECT_EQ(file_schema()["properties"]["extra"]["properties"].size(), 0u);
  const Json extra = shipped()["properties"]["extra"];
  EXPECT_EQ(extra["additionalProperties"], false);
  EXPECT_EQ(extra["properties"]["crossing_from"]["description"],
            "pedestrian_crossing: the road edge the person steps off from (equals side).");
  EXPECT_EQ(extra["properties"]["brake_delay_s"]["type"], Json::array({"number", "null"}));
  EXPECT_EQ(extra["properties"]["crossing_from"]["enum"], Json::array({"left", "right", nullptr}));
  // Two kinds with the same field: one schema, both descriptions; a different schema is refused.
  HazardKindInfo a, b;
  a.kind = "kind_a";
  b.kind = "kind_b";
  a.extra_fields = {{"gap_m", {{"type", {"number", "null"}}}, "gap kept"}};
  b.extra_fields = a.extra_fields;
  b.extra_fields[0].doc = "gap closed";
  EXPECT_EQ(with_kind_fields(file_schema(), {a, b})["properties"]["extra"]["properties"]["gap_m"]["description"],
            "kind_a: gap kept. kind_b: gap closed.");
  b.extra_fields[0].schema = {{"type", {"integer", "null"}}};
  try {
    with_kind_fields(file_schema(), {a, b});
    FAIL();
  } catch (const Error& e) {
    EXPECT_STREQ(e.what(),
                 "hazard kinds 'kind_a' and 'kind_b' declare extra.gap_m differently: "
                 "{\"type\":[\"number\",\"null\"]} vs {\"type\":[\"integer\",\"null\"]}");
  }
}

}  // namespace
}  // namespace hf::llm_hazard
