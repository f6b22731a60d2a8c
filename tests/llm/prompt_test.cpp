// Prompt templates: placeholder substitution, comment stripping, unknown-name errors, the shipped template.
#include <gtest/gtest.h>

#include <hazardforge/geometry.hpp>

#include "llm_test_support.hpp"
#include "prompt.hpp"
#include "scene_summary.hpp"

namespace hf::llm_hazard {
namespace {

TEST(PromptTemplate, SubstitutesAndStripsComments) {
  auto t = PromptTemplate::from_text(
      "<!-- for editors: {{not_a_placeholder}} -->\nSpeed {{v}} m/s, {{v}} again.\n", "p.md");
  EXPECT_EQ(t.render({{"v", "8.5"}}), "Speed 8.5 m/s, 8.5 again.\n");
  EXPECT_EQ(t.placeholders(), std::set<std::string>{"v"});
}

TEST(PromptTemplate, UnknownPlaceholderNamesFileAndLine) {
  auto t = PromptTemplate::from_text("line one\n<!-- two\nthree -->\nego {{ego_sped}}\n", "prompts/x.md");
  try {
    t.render({{"ego_speed", "1"}, {"objects", "-"}});
    FAIL();
  } catch (const Error& e) {
    EXPECT_STREQ(e.what(), "prompts/x.md:4: unknown placeholder {{ego_sped}} (known: ego_speed, objects)");
  }
}

TEST(PromptTemplate, ValuesAreNotRescanned) {
  auto t = PromptTemplate::from_text("{{a}}|{{b}}", "p");
  EXPECT_EQ(t.render({{"a", "{{b}}"}, {"b", "x"}}), "{{b}}|x");
}

TEST(PromptTemplate, ShippedTemplateRendersTheScene) {
  auto t = PromptTemplate::load(share_dir() + "/prompts/hazard_generation.md");
  SceneSettings s;
  s.description = "Rainy city street, peds on sidewalk";
  s.environment = s.description;
  s.road_type = "urban two-lane street";
  s.sidewalks = resolve_sidewalks("auto", s.environment);
  s.intersection = resolve_intersection("no", "");
  s.multi_lane = resolve_multi_lane("auto", s.road_type);
  s.allowed_kinds = {"pedestrian_crossing", "sudden_stop"};
  s.ego_speed_mps = 10.0;
  Frame f = test::make_frame(6, 3.0, s.description);
  ObjectStates st = test::make_states(6, 3.0);
  RiskAssessment r = test::make_risk(6, true);
  LimitsTable limits = LimitsTable::load(LimitsTable::default_path());
  ClassPriors sizes = ClassPriors::load(share_dir() + "/class_sizes.yaml");
  s.kinds = {PedestrianCrossingTemplate::info(), SuddenStopTemplate::info()};
  s.rules.asset_classes = {"bus", "car", "person", "truck"};
  s.road.driving_side = "left";
  s.road.lanes_right = 2;
  s.road.oncoming_lanes = 1;
  SceneSummary sum = summarize_scene(f, st, {&r}, s, limits, sizes);
  auto values = sum.placeholders;
  values["schema"] = "{}";
  std::string prompt = t.render(values);
  // The kinds as their templates describe themselves, with whether their needs are met here.
  // The scene's rules: what can be drawn, the lanes and their directions, coming into view, taking over.
  EXPECT_NE(prompt.find("8. Only these classes can be drawn into the video: bus, car, person, truck.\n"),
            std::string::npos);
  EXPECT_NE(prompt.find(
                "9. Lanes and directions: traffic keeps left; lanes 3.5 m wide; left of the ego lane: 1 lane "
                "going the ego's way; right of it: 1 lane going the ego's way, then 1 lane with oncoming "
                "traffic."),
            std::string::npos);
  EXPECT_NE(
      prompt.find(
          "10. The object must come into view plausibly: from beyond the image border (beside or behind "
          "the ego), from behind a detected object, or far enough away to be small when first seen (at "
          "most 63 px of the 900 px image height) — never popping up on the road close ahead.\n"),
      std::string::npos);
  EXPECT_NE(
      prompt.find(
          "11. A detected vehicle may itself become the hazard (track_id): the renderer removes the "
          "real one."),
      std::string::npos);
  EXPECT_NE(prompt.find("Earlier attempts on this recording: none.\n"), std::string::npos);
  EXPECT_NE(
      prompt.find("- pedestrian_crossing (person): a person steps off the kerb and crosses the ego lane. "
                  "Played out: waits on the kerb just beyond the road edge"),
      std::string::npos)
      << prompt;
  EXPECT_NE(
      prompt.find("Needs sidewalks (given here).\n  extra.crossing_from: the road edge the person steps "
                  "off from (equals side).\n- sudden_stop (car, truck, bus, motorcycle): a lead vehicle "
                  "brakes hard to a stop."),
      std::string::npos);
  EXPECT_EQ(prompt.find("<!--"), std::string::npos);
  EXPECT_NE(prompt.find("# Role"), std::string::npos);
  EXPECT_NE(prompt.find("- Environment: Rainy city street, peds on sidewalk\n"), std::string::npos);
  EXPECT_NE(prompt.find("- Sidewalks: yes\n"), std::string::npos);
  EXPECT_NE(prompt.find("- Intersection: no\n"), std::string::npos);
  EXPECT_NE(prompt.find("- Ego speed: 10 m/s\n"), std::string::npos);
  // The car's rear is 40 m from the states' origin (the rear axle here): its centre, where a spec's start
  // point would be compared with it, is half its 4.5 m further on.
  EXPECT_NE(prompt.find("- track 7: car, x 42.25 m, y -3.5 m, speed 0 m/s\n"), std::string::npos);
  EXPECT_EQ(sum.scene["objects"][0]["x_m"], 42.25);
  EXPECT_EQ(sum.scene["objects"][0]["distance_m"], 40.0);
  EXPECT_NE(prompt.find("Allowed hazard kinds: pedestrian_crossing, sudden_stop\n"), std::string::npos);
  EXPECT_NE(prompt.find("- Scene TTC: inf s (Unsafe below 1.5 s)"), std::string::npos);
  EXPECT_NE(prompt.find("- person: speed <= 7 m/s"), std::string::npos);
  EXPECT_EQ(sum.scene["sidewalks"], true);
  // A two-lane street has one lane per direction: no lane to cut in from.
  EXPECT_EQ(sum.scene["multi_lane"], false);
  EXPECT_EQ(sum.scene["objects"][0]["track_id"], 7);
  EXPECT_EQ(sum.scene["road"]["edge_left_m"], 5.25);
  // No recorded ego track on this frame: the templates plan against a straight ego.
  EXPECT_FALSE(sum.context.ego_track);
  // With one (dataset poses or the video's ego motion), the templates get it too.
  auto track = std::make_shared<EgoTrack>();
  track->source = "video";
  track->samples = {{2.5, 0.0, 0.0, 0.0, 10.0, 0.0}, {3.5, 10.0, 0.0, 0.0, 10.0, 0.0}};
  f.ego_track = track;
  const SceneSummary with_track = summarize_scene(f, st, {&r}, s, limits, sizes);
  EXPECT_EQ(with_track.context.ego_track, f.ego_track);
  // Distances measured from the front bumper (3.4 m ahead of the rear axle) move every object that far on.
  st.distance_origin_x = 3.4;
  const SceneSummary from_bumper = summarize_scene(f, st, {&r}, s, limits, sizes);
  EXPECT_NE(from_bumper.placeholders.at("objects").find("- track 7: car, x 45.65 m, y -3.5 m"),
            std::string::npos)
      << from_bumper.placeholders.at("objects");
}

TEST(SceneRules, AutoResolutionFromText) {
  EXPECT_TRUE(resolve_sidewalks("auto", "Parking lot, bicycle rack, many peds").value);
  EXPECT_EQ(resolve_sidewalks("auto", "Parking lot, bicycle rack, many peds").why,
            "auto: the scene text mentions 'parking'");
  EXPECT_FALSE(resolve_sidewalks("auto", "Highway at night, peds unlikely").value);
  EXPECT_FALSE(resolve_sidewalks("auto", "empty test track").value);
  EXPECT_TRUE(resolve_sidewalks("yes", "highway").value);
  EXPECT_TRUE(resolve_intersection("auto", "Wait at intersection, turn right").value);
  EXPECT_FALSE(resolve_intersection("auto", "Parking lot").value);
  EXPECT_TRUE(resolve_multi_lane("auto", "three lanes, highway").value);
  EXPECT_FALSE(resolve_multi_lane("auto", "narrow residential street").value);
}

}  // namespace
}  // namespace hf::llm_hazard
