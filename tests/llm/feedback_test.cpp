// Feedback from failed attempts: the file's contract, what the prompt says, and how the offline planner changes
// its choice (no repeated design; a lower TTC or a larger, nearer object when the reasons ask for it).
#include <gtest/gtest.h>

#include <fstream>

#include "feedback.hpp"
#include "llm_test_support.hpp"
#include "temp_dir.hpp"

namespace hf {
namespace {

using llm_hazard::Feedback;

const char* kCity = "Busy city street, peds on the sidewalk, two lanes each way";

Json attempt(const Json& spec, std::vector<std::string> reasons, int64_t frame = 5, int64_t seed = 3) {
  return {{"kind", spec.value("kind", "sudden_stop")},
          {"object_class", spec.value("object_class", "car")},
          {"spec", spec},
          {"reasons", reasons},
          {"trigger_frame", frame},
          {"seed", seed}};
}

// Runs the generator (offline provider) at frame 5 of the synthetic city scene; `feedback` written to a file.
struct Generated {
  HazardSpec spec;
  Json call;  // its llm/calls.jsonl record
};
Generated generate(const std::string& yaml, const Json& feedback = nullptr, bool with_lead = false) {
  test::TempDir dir;
  std::string params = "trigger: frame\ntrigger_frame: 5\n" + yaml;  // as a campaign's attempt runs it
  if (!feedback.is_null()) {
    std::ofstream(dir / "feedback.json") << feedback.dump();
    params += "feedback: '" + (dir / "feedback.json").string() + "'\n";
  }
  auto r = test::make_runner(params);
  if (!with_lead) {
    test::push_scene(r, 6, kCity);
  } else {
    // The same street with a car 22 m ahead in the ego lane at 7 m/s (the ego at 10 m/s): a lead to take over.
    for (int i = 0; i < 6; ++i) {
      const double t = 0.5 * i;
      ObjectStates st = test::make_states(i, t);
      ObjectState lead = st.objects.front();
      lead.track_id = 3;
      lead.distance_m = 22.0 - 1.5 * t;
      lead.lateral_m = 0.1;
      lead.speed_mps = 7.0;
      lead.velocity_rel = cv::Vec2d(-3.0, 0.0);
      lead.in_path = true;
      st.objects.push_back(lead);
      RiskAssessment risk = test::make_risk(i, true);
      risk.objects.push_back({3, 22.0 / 3.0, true});
      r.push("frames", test::make_frame(i, t, kCity), t);
      r.push("states", st, t);
      r.push("risk", risk, t, "ttc");
    }
  }
  r.run();
  auto specs = r.collect<HazardSpec>("hazard");
  if (specs.size() != 1) throw std::runtime_error("no spec");
  return {specs[0], test::read_jsonl(r.output_dir() / "llm/calls.jsonl").back()};
}

std::string signature(const HazardSpec& s) {
  return s.kind + "/" + s.object_class + "/" + s.side + "/" +
         (s.track_id ? std::to_string(*s.track_id) : std::string("-"));
}

TEST(Feedback, TheFilesContract) {
  const Feedback f = Feedback::from_json(
      {{"attempts",
        {attempt({{"kind", "cut_in"}, {"object_class", "car"}, {"side", "left"}, {"extra", {{"track_id", 4}}}},
                 {"the inserted object is never visible (0 of 15 frames)"}, 10, 2),
         {{"kind", "sudden_stop"}, {"object_class", "truck"}, {"spec", nullptr}, {"reasons", Json::array()}}}}},
      "fb.json");
  ASSERT_EQ(f.attempts().size(), 2u);
  EXPECT_EQ(f.attempts()[0].side, "left");
  EXPECT_EQ(f.attempts()[0].track_id, 4);
  EXPECT_EQ(f.attempts()[0].trigger_frame, 10);
  EXPECT_FALSE(f.attempts()[1].has_spec);
  EXPECT_TRUE(f.more_visible());
  EXPECT_FALSE(f.lower_ttc());
  EXPECT_EQ(f.prompt_text(),
            "Earlier attempts on this recording failed because:\n"
            "- cut_in, car, side left, track 4 (frame 10): the inserted object is never visible (0 of 15 frames)\n"
            "- sudden_stop, truck: no reason given\n"
            "Do not repeat a failed design (the same kind, class, side and track); change what the reasons name — "
            "an object that was never re-detected should be larger or nearer when it appears.");
  EXPECT_EQ(f.scene_json(10)["attempts"][0]["same_frame"], true);
  EXPECT_EQ(f.scene_json(11)["attempts"][0]["same_frame"], false);
  EXPECT_EQ(Feedback().prompt_text(), "Earlier attempts on this recording: none.");
  test::TempDir dir;
  try {
    Feedback::load((dir / "missing.json").string());
    FAIL();
  } catch (const Error& e) {
    EXPECT_EQ(std::string(e.what()), (dir / "missing.json").string() + ": cannot open the feedback file");
  }

  auto error = [](const Json& doc) {
    try {
      Feedback::from_json(doc, "fb.json");
    } catch (const Error& e) {
      return std::string(e.what());
    }
    return std::string("(no error)");
  };
  EXPECT_EQ(error(Json::array()), "fb.json: /attempts must be a list of failed attempts");
  EXPECT_EQ(error({{"attempts", {{{"kind", "cut_in"}}}}}), "fb.json: /attempts/0/object_class must be a string");
  EXPECT_EQ(error({{"attempts", {{{"kind", "cut_in"}, {"object_class", "car"}, {"reasons", {"ok", 3}}}}}}),
            "fb.json: /attempts/0/reasons/1 must be a string");
  EXPECT_EQ(error({{"attempts", {{{"kind", "cut_in"}, {"object_class", "car"}, {"reasons", Json::array()},
                                  {"trigger_frame", "22"}}}}}),
            "fb.json: /attempts/0/trigger_frame must be an integer");
}

// The reasons reach a model in the prompt, and the offline planner in the scene context.
TEST(Feedback, ReasonsReachThePromptAndTheSceneContext) {
  const Generated first = generate("seed: 3\n");
  const Json fb = {{"attempts", {attempt(Json(first.spec), {"the scene never becomes Unsafe while the hazard is "
                                                           "visible (minimum scene TTC 2.26 s)"})}}};
  const Generated again = generate("seed: 3\n", fb);
  const std::string prompt = again.call["messages"][0]["content"];
  EXPECT_NE(prompt.find("Earlier attempts on this recording failed because:\n- " + first.spec.kind + ", " +
                        first.spec.object_class + ", side " + first.spec.side),
            std::string::npos)
      << prompt;
  EXPECT_NE(prompt.find("(frame 5): the scene never becomes Unsafe while the hazard is visible (minimum scene TTC "
                        "2.26 s)"),
            std::string::npos);
  EXPECT_NE(prompt.find("where the TTC was not reached, aim for a lower one."), std::string::npos);
  // Without feedback the prompt says there is none.
  EXPECT_NE(first.call["messages"][0]["content"].get<std::string>().find("Earlier attempts on this recording: none."),
            std::string::npos);
}

// The same seed, told its design failed, proposes another; never-critical feedback lowers the aim.
TEST(Feedback, TheOfflinePlannerChangesItsChoice) {
  for (int64_t seed : {1, 3, 7}) {
    const std::string yaml = "seed: " + std::to_string(seed) + "\n";
    const Generated first = generate(yaml);
    const Json fb = {{"attempts", {attempt(Json(first.spec), {"the scene never becomes Unsafe while the hazard is "
                                                             "visible (minimum scene TTC 1.89 s)"})}}};
    const Generated again = generate(yaml, fb);
    EXPECT_NE(signature(again.spec), signature(first.spec)) << "seed " << seed;
    EXPECT_EQ(again.spec.provenance["attempts"], 1);
    EXPECT_DOUBLE_EQ(again.call["response"]["feedback"]["aim"].get<double>(), 0.75 * 0.85);
    EXPECT_EQ(again.call["response"]["feedback"]["avoided"], 1);
  }
}

// A lead taken over in a failed attempt is not taken over again at the same frame; at another frame (another
// state of the lead, another aim) it may be.
TEST(Feedback, AFailedTakeoverRulesOutItsTrackOnlyAtItsFrame) {
  const std::string yaml = "force_kind: sudden_stop\nseed: 1\n";
  const Generated first = generate(yaml, nullptr, true);
  ASSERT_TRUE(first.spec.track_id) << Json(first.spec).dump();
  const Json failed = attempt(Json(first.spec), {"the scene never becomes Unsafe while the hazard is visible "
                                                 "(minimum scene TTC 1.94 s)"},
                              first.spec.provenance.value("frame_index", int64_t{5}));
  try {  // the lead avoided, no inserted lead fits at this frame
    generate(yaml, {{"attempts", {failed}}}, true);
    FAIL() << "expected no plan at the failed attempt's frame";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("offline: no hazard fits this scene (allowed kinds: sudden_stop)"),
              std::string::npos)
        << e.what();
  }
  Json elsewhere = failed;
  elsewhere["trigger_frame"] = elsewhere["trigger_frame"].get<int64_t>() + 10;
  const Generated there = generate(yaml, {{"attempts", {elsewhere}}}, true);
  ASSERT_TRUE(there.spec.track_id) << Json(there.spec).dump();
  EXPECT_EQ(there.spec.track_id, first.spec.track_id);
}

// Never re-detected: of each kind's plans the largest object, then the nearest (a cut-in by a truck rather than a
// car where one fits).
TEST(Feedback, NeverRedetectedPicksLargerObjects) {
  int large_before = 0, large_after = 0;
  const Json fb = {{"attempts",
                    {{{"kind", "pedestrian_crossing"},
                      {"object_class", "person"},
                      {"spec", nullptr},
                      {"reasons", {"re-detection rate 0.2 is below min_redetection_rate 0.5 (1 of 5 visible frames "
                                   "with IoU >= 0.5)"}},
                      {"trigger_frame", 2},
                      {"seed", 0}}}}};
  for (int64_t seed = 0; seed < 6; ++seed) {
    // Under way allowed: a truck's longer lane change fits the horizon then.
    const std::string yaml = "force_kind: cut_in\nmax_under_way_s: 6\nseed: " + std::to_string(seed) + "\n";
    const std::string before = generate(yaml).spec.object_class, after = generate(yaml, fb).spec.object_class;
    large_before += before != "car";
    large_after += after != "car";
  }
  EXPECT_GT(large_after, large_before);
}

// A failed attempt without a spec rules out its kind and class on every side; at another frame only while
// something else fits.
TEST(Feedback, AnAttemptWithoutASpecRulesOutItsKindAndClass) {
  const Generated first = generate("force_kind: pedestrian_crossing\nseed: 2\n");
  const Json fb = {{"attempts",
                    {{{"kind", "pedestrian_crossing"}, {"object_class", "person"}, {"spec", nullptr},
                      {"reasons", {"the planner failed"}}, {"trigger_frame", 5}}}}};
  try {
    generate("force_kind: pedestrian_crossing\nseed: 2\n", fb);
    FAIL() << "expected no plan";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("pedestrian_crossing: the plan (pedestrian_crossing person "),
              std::string::npos)
        << e.what();
  }
  // Made for another frame, it no longer rules the design out when nothing else fits.
  Json other = fb;
  other["attempts"][0]["trigger_frame"] = 9;
  EXPECT_EQ(generate("force_kind: pedestrian_crossing\nseed: 2\n", other).spec.kind, "pedestrian_crossing");
}

}  // namespace
}  // namespace hf
