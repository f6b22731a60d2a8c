// The hazard spec schema: the shipped file, the derived reply schema and the validation messages.
#include <gtest/gtest.h>

#include <hazardforge/geometry.hpp>

#include "hazard_schema.hpp"
#include "llm_test_support.hpp"

namespace hf::llm_hazard {
namespace {

Json shipped() {
  return load_schema_file(share_dir() + "/schemas/hazard_spec.schema.json");
}

TEST(HazardSchema, ShippedFileIsDraft07AndVersioned) {
  Json s = shipped();
  EXPECT_EQ(s["$schema"], "http://json-schema.org/draft-07/schema#");
  EXPECT_EQ(s["properties"]["schema_version"]["enum"], Json::array({"1.0"}));
  EXPECT_EQ(s["additionalProperties"], false);
}

TEST(HazardSchema, ReplySchemaRequiresEveryFieldAndNarrowsKinds) {
  Json r = reply_schema(shipped(), {"cut_in", "sudden_stop"});
  EXPECT_FALSE(r["properties"].contains("provenance"));
  EXPECT_FALSE(r["properties"].contains("schema_version"));
  EXPECT_EQ(r["properties"]["kind"]["enum"], Json::array({"cut_in", "sudden_stop"}));
  EXPECT_EQ(r["required"].size(), r["properties"].size());
  EXPECT_EQ(r["properties"]["extra"]["required"].size(), 5u);
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
      "kind, lateral_offset_m, motion, object_class, rationale, side, speed_mps, start_time_s, target_ttc_s)",
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
  // What the generator writes must follow the file's schema.
  s.provenance = {{"provider", "test"}};
  SchemaValidator file(shipped());
  EXPECT_EQ(file.validate(Json(s)), std::vector<std::string>{});
}

}  // namespace
}  // namespace hf::llm_hazard
