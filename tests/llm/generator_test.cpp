// The llm_hazard stage end to end: trigger rules, the retry loop against loopback model servers, transport
// failures, the run records, third-party templates and the offline planner with the built-in templates.
#include <gtest/gtest.h>

#include <chrono>
#include <fstream>
#include <functional>
#include <set>
#include <thread>

#include "hazardforge/llm/hash.hpp"
#include "llm_test_support.hpp"
#include "temp_dir.hpp"

namespace hf {
namespace {

using test::ScriptedServer;

using test::kDescription;

std::string ollama_yaml(const std::string& url, const std::string& extra = "") {
  return "provider: {name: ollama, host: '" + url + "', read_timeout_s: 2}\nseed: 7\ntemperature: 0\n" +
         extra;
}

using test::run_error;

// A small third-party template: cargo lying on the road, which must not move.
class FallenCargoTemplate : public HazardTemplate {
 public:
  static ComponentInfo describe() {
    ComponentInfo i;
    i.name = "fallen_cargo";
    i.kind = kind::kHazardTemplate;
    i.summary = "test template";
    return i;
  }
  void open(const Params&) override {}
  std::string hazard_kind() const override { return "fallen_cargo"; }
  std::vector<Refusal> check(const HazardSpec& spec, const SceneContext&) const override {
    if (spec.speed_mps != 0)
      return {{refusal::kSpec,
               "cargo lies still (speed_mps must be 0, got " + std::to_string(int(spec.speed_mps)) + ")",
               "fallen_cargo"}};
    return {};
  }
  HazardTrajectory plan(const HazardSpec&, const SceneContext&) const override { return {}; }
};

TEST(LlmHazard, OfflineSpecAtFirstSafeFrameAfterWarmup) {
  auto r = test::make_runner("seed: 3\n");
  test::push_scene(r, 8, kDescription);
  r.run();
  auto out = r.collect<HazardSpec>("hazard");
  ASSERT_EQ(out.size(), 1u);
  EXPECT_DOUBLE_EQ(r.outputs("hazard")[0].timestamp(), 2.5);  // frame 5 = the first after 5 warm-up frames
  const HazardSpec& s = out[0];
  EXPECT_DOUBLE_EQ(s.start_time_s, 2.5);
  EXPECT_EQ(s.schema_version, "1.1");
  EXPECT_EQ(s.provenance["provider"], "offline");
  EXPECT_EQ(s.provenance["model"], "offline-planner-1");
  EXPECT_EQ(s.provenance["attempts"], 1);
  EXPECT_EQ(s.provenance["frame_index"], 5);
  // The road the spec was made for, typed, for the planner and exports: the road params and scene facts as
  // the generator settled them, each with what it rests on.
  ASSERT_TRUE(s.road);
  EXPECT_EQ(s.road->driving_side, "right");
  EXPECT_EQ(s.road->lanes_left, 1);
  EXPECT_EQ(s.road->lane_width_m, 3.5);
  EXPECT_EQ(s.road->source("driving_side").from, "default");
  EXPECT_FALSE(s.provenance.contains("scene"));

  Json file = test::read_json(r.output_dir() / "hazard_spec.json");
  EXPECT_EQ(file, Json(s));
  auto calls = test::read_jsonl(r.output_dir() / "llm" / "calls.jsonl");
  ASSERT_EQ(calls.size(), 1u);
  EXPECT_EQ(calls[0]["accepted"], true);
  EXPECT_EQ(calls[0]["backend"], "offline planner");
  EXPECT_EQ(calls[0]["seed"], 3);
  EXPECT_EQ(calls[0]["errors"], Json::array());
  const std::string prompt = calls[0]["messages"][0]["content"];
  EXPECT_EQ(calls[0]["prompt_sha256"], llm::sha256_hex(prompt));
  EXPECT_EQ(s.provenance["prompt_sha256"], calls[0]["prompt_sha256"]);
  EXPECT_NE(prompt.find("- Environment: Busy city street"), std::string::npos);
  EXPECT_EQ(Json::parse(calls[0]["reply"].get<std::string>())["kind"], s.kind);
}

// Every offline plan must survive the generic checks and the built-in templates' own check() first time.
// road.jsonl: the road as the generator settles it on every frame, one record where a fact changes, and on after
// the hazard is made. Here a person followed for 1 s (people_seen_s) shows there are pavements from frame 3 on.
TEST(LlmHazard, TheRoadIsRecordedWhereAFactChanges) {
  auto r = test::make_runner("seed: 3\n");
  for (int i = 0; i < 10; ++i) {
    const double t = 0.5 * i;
    r.push("frames", test::make_frame(i, t, "a road"), t);
    ObjectStates states = test::make_states(i, t);
    if (i >= 1) {
      ObjectState person;
      person.track_id = 20;
      person.label = "person";
      person.distance_m = 60.0;
      person.lateral_m = 8.0;
      states.objects.push_back(person);
    }
    r.push("states", states, t);
    r.push("risk", test::make_risk(i, true), t, "ttc");
  }
  r.run();
  ASSERT_EQ(r.collect<HazardSpec>("hazard").size(), 1u);  // made at frame 5
  const std::vector<Json> road = test::read_jsonl(r.output_dir() / "road.jsonl");
  ASSERT_EQ(road.size(), 2u) << road[0].dump();
  EXPECT_EQ(road[0]["frame"], 0);
  EXPECT_EQ(road[0]["road"]["sidewalks"], false);
  EXPECT_EQ(road[1]["frame"], 3);  // the person seen at 0.5 s, followed for 1 s at 1.5 s
  EXPECT_EQ(road[1]["road"]["sidewalks"], true);
  EXPECT_EQ(road[1]["road"]["sources"]["sidewalks"]["from"], "measured");
  const RoadLayout layout = road[1]["road"].get<RoadLayout>();
  EXPECT_EQ(layout.lanes_left, 1);
  EXPECT_FALSE(road[1]["road"].contains("environment"));
}

TEST(LlmHazard, OfflinePlansPassTheTemplatesForManySeeds) {
  std::map<std::string, int> kinds;
  for (int seed = 0; seed < 16; ++seed) {
    auto r = test::make_runner("seed: " + std::to_string(seed) + "\nmax_retries: 0\n");
    test::push_scene(r, 6, kDescription);
    ASSERT_EQ(run_error(r), "(no error)") << "seed " << seed;
    auto out = r.collect<HazardSpec>("hazard");
    ASSERT_EQ(out.size(), 1u);
    kinds[out[0].kind]++;
  }
  EXPECT_EQ(kinds.size(), 3u);
}

TEST(LlmHazard, UnsafeTriggerFrameGeneratesNothing) {
  auto r = test::make_runner("trigger: frame\ntrigger_frame: 3\n");
  test::push_scene(r, 6, kDescription, {3});
  r.run();
  EXPECT_TRUE(r.outputs("hazard").empty());
  EXPECT_FALSE(std::filesystem::exists(r.output_dir() / "hazard_spec.json"));
  const auto& log = r.log();
  EXPECT_NE(
      std::find(log.begin(), log.end(),
                "warning: frame 3 is Unsafe (ttc = 0.9 s (threshold 1.5)): it is already critical, no hazard "
                "generated"),
      log.end());
}

TEST(LlmHazard, FirstSafeSkipsUnsafeFrames) {
  auto r = test::make_runner("warmup_frames: 2\n");
  test::push_scene(r, 6, kDescription, {2, 3});
  r.run();
  ASSERT_EQ(r.outputs("hazard").size(), 1u);
  EXPECT_DOUBLE_EQ(r.outputs("hazard")[0].timestamp(), 2.0);  // frame 4
}

TEST(LlmHazard, NoSafeFrameIsLoggedAtTheEnd) {
  auto r = test::make_runner("");
  test::push_scene(r, 6, kDescription, {5});
  r.run();
  EXPECT_TRUE(r.outputs("hazard").empty());
  EXPECT_EQ(r.log().back(),
            "warning: no hazard generated: no frame after the 5 warm-up frames was Safe (6 frames seen)");
}

TEST(LlmHazard, OllamaRetriesWithTheErrorsUntilValid) {
  ScriptedServer srv("/api/chat");
  Json bad_schema = test::valid_reply();
  bad_schema["speed_mps"] = "fast";
  Json impossible = test::valid_reply();
  impossible["speed_mps"] = 9;
  srv.then_ollama("Here is a realistic hazard:\n" + bad_schema.dump() + "\nLet me know!");
  srv.then_ollama(impossible.dump());
  srv.then_ollama("```json\n" + test::valid_reply().dump(2) + "\n```");
  auto r = test::make_runner(ollama_yaml(srv.url()));
  test::push_scene(r, 6, kDescription);
  r.run();

  auto out = r.collect<HazardSpec>("hazard");
  ASSERT_EQ(out.size(), 1u);
  EXPECT_EQ(out[0].kind, "pedestrian_crossing");
  EXPECT_DOUBLE_EQ(out[0].speed_mps, 2.0);
  EXPECT_EQ(out[0].provenance["attempts"], 3);
  EXPECT_EQ(out[0].provenance["retries"], 2);
  EXPECT_EQ(out[0].provenance["model"], "llama3:8b");
  EXPECT_EQ(out[0].provenance["backend"], "ollama llama3 @ " + srv.url());

  auto got = srv.requests();
  ASSERT_EQ(got.size(), 3u);
  for (const Json& g : got) {
    EXPECT_EQ(g["model"], "llama3");
    EXPECT_EQ(g["options"]["seed"], 7);
    EXPECT_EQ(g["options"]["temperature"], 0.0);
    EXPECT_EQ(g["format"]["properties"]["kind"]["enum"],
              Json::array({"pedestrian_crossing", "cut_in", "sudden_stop"}));
    EXPECT_EQ(g["format"]["required"].size(), 15u);
  }
  ASSERT_EQ(got[1]["messages"].size(), 3u);
  EXPECT_EQ(got[1]["messages"][1]["role"], "assistant");
  EXPECT_EQ(got[1]["messages"][1]["content"],
            "Here is a realistic hazard:\n" + bad_schema.dump() + "\nLet me know!");
  EXPECT_EQ(got[1]["messages"][2]["content"],
            "Your answer was rejected:\n- /speed_mps = \"fast\" has type string, expected number\n\nReply "
            "again with "
            "ONLY the corrected JSON object that follows the schema and fixes every point above.\n");
  ASSERT_EQ(got[2]["messages"].size(), 5u);
  EXPECT_NE(got[2]["messages"][4]["content"].get<std::string>().find(
                "- hazard template 'pedestrian_crossing': speed_mps 9 exceeds the person limit of 7 m/s"),
            std::string::npos);

  auto calls = test::read_jsonl(r.output_dir() / "llm" / "calls.jsonl");
  ASSERT_EQ(calls.size(), 3u);
  EXPECT_EQ(calls[0]["attempt"], 1);
  EXPECT_EQ(calls[0]["errors"], Json::array({"/speed_mps = \"fast\" has type string, expected number"}));
  EXPECT_EQ(calls[1]["accepted"], false);
  EXPECT_EQ(calls[2]["accepted"], true);
  EXPECT_EQ(calls[2]["model"], "llama3:8b");
  EXPECT_EQ(calls[0]["prompt_sha256"], calls[2]["prompt_sha256"]);
  EXPECT_EQ(calls[2]["response"]["done"], true);
}

TEST(LlmHazard, GivesUpWithTheLastErrors) {
  ScriptedServer srv("/api/chat");
  srv.then_ollama("I think a pedestrian would be nice.");
  srv.then_ollama("{\"kind\": \"pedestrian_crossing\"");
  auto r = test::make_runner(ollama_yaml(srv.url(), "max_retries: 1\ntrigger: frame\ntrigger_frame: 5\n"));
  test::push_scene(r, 6, kDescription);
  EXPECT_EQ(run_error(r), "no valid hazard spec after 2 attempt(s) from ollama llama3 @ " + srv.url() +
                              "; last errors: reply JSON object is cut off: the '{' at character 0 is "
                              "never closed");
  EXPECT_TRUE(r.outputs("hazard").empty());
  EXPECT_FALSE(std::filesystem::exists(r.output_dir() / "hazard_spec.json"));
  EXPECT_EQ(test::read_jsonl(r.output_dir() / "llm" / "calls.jsonl").size(), 2u);
}

TEST(LlmHazard, FirstSafeTriesALaterFrameWhenNoHazardFits) {
  ScriptedServer srv("/api/chat");
  srv.then_ollama("I think a pedestrian would be nice.");
  srv.then_ollama("{\"kind\": \"pedestrian_crossing\"");
  srv.then_ollama(test::valid_reply().dump());
  // Frames every 0.5 s: frame 1 gets two invalid replies; the next try is the first Safe frame from t = 1.5 s
  // on, and frame 3 is Unsafe, so frame 4.
  auto r =
      test::make_runner(ollama_yaml(srv.url(), "max_retries: 1\nwarmup_frames: 1\nretry_every_s: 1.0\n"));
  test::push_scene(r, 8, kDescription, {3});
  r.run();
  auto out = r.collect<HazardSpec>("hazard");
  ASSERT_EQ(out.size(), 1u);
  EXPECT_DOUBLE_EQ(r.outputs("hazard")[0].timestamp(), 2.0);
  EXPECT_EQ(out[0].provenance["frame_index"], 4);
  ASSERT_EQ(out[0].provenance["frames_without_a_fit"].size(), 1u);
  EXPECT_EQ(out[0].provenance["frames_without_a_fit"][0]["frame_index"], 1);
  EXPECT_NE(out[0].provenance["frames_without_a_fit"][0]["why"].get<std::string>().find(
                "no valid hazard spec after 2 attempt(s)"),
            std::string::npos);
  const Json written = test::read_json(r.output_dir() / "hazard_spec.json");
  EXPECT_EQ(written["provenance"]["frames_without_a_fit"], out[0].provenance["frames_without_a_fit"]);
  const auto calls = test::read_jsonl(r.output_dir() / "llm" / "calls.jsonl");
  ASSERT_EQ(calls.size(), 3u);
  EXPECT_EQ(calls[1]["frame_index"], 1);
  EXPECT_EQ(calls[2]["frame_index"], 4);
  const auto& log = r.log();
  EXPECT_NE(std::find_if(log.begin(), log.end(),
                         [](const std::string& l) {
                           return l.rfind("warning: frame 1: no valid hazard spec after 2 attempt(s)", 0) ==
                                      0 &&
                                  l.find("; trying a Safe frame from t = 1.5 s on") != std::string::npos;
                         }),
            log.end());
}

TEST(LlmHazard, TheAutomaticHorizonIsShortenedWhileNoHazardFits) {
  // A reply whose walk is already under way when it appears: with the whole 6 s horizon nothing may be (the
  // clip can show all of it), with 5 s up to 1 s may.
  Json under_way = test::valid_reply();
  under_way["under_way_s"] = 0.2;
  for (const bool shorten : {true, false}) {
    ScriptedServer srv("/api/chat");
    srv.then_ollama(under_way.dump());
    srv.then_ollama(under_way.dump());
    auto r = test::make_runner(ollama_yaml(srv.url(), std::string("max_retries: 0\ntrigger: frame\n") +
                                                          "trigger_frame: 2\n" +
                                                          (shorten ? "min_horizon_s: 3\n" : "")));
    test::push_scene(r, 8, kDescription);
    if (!shorten) {
      const std::string e = run_error(r);
      EXPECT_NE(e.find("under_way_s 0.2 s exceeds max_under_way_s 0 s"), std::string::npos) << e;
      EXPECT_EQ(test::read_jsonl(r.output_dir() / "llm" / "calls.jsonl").size(), 1u);
      continue;
    }
    r.run();
    auto out = r.collect<HazardSpec>("hazard");
    ASSERT_EQ(out.size(), 1u);
    ASSERT_TRUE(out[0].horizon_s && out[0].max_under_way_s);
    EXPECT_DOUBLE_EQ(*out[0].horizon_s, 5.0);
    EXPECT_DOUBLE_EQ(*out[0].max_under_way_s, 1.0);
    const auto calls = test::read_jsonl(r.output_dir() / "llm" / "calls.jsonl");
    ASSERT_EQ(calls.size(), 2u);
    EXPECT_FALSE(calls[0]["accepted"].get<bool>());
    EXPECT_TRUE(calls[1]["accepted"].get<bool>());
    const auto& log = r.log();
    EXPECT_NE(std::find_if(log.begin(), log.end(),
                           [](const std::string& l) {
                             return l.rfind("warning: frame 2, horizon 6 s: ", 0) == 0 &&
                                    l.find("; trying a horizon of 5 s") != std::string::npos;
                           }),
              log.end());
  }
}

// The recorded ego path turns at 0.3 rad/s until t = `turn_until`, then runs straight; 10 m/s, frames every
// 0.5 s.
void push_turning_scene(testing::StageRunner& r, int n, double turn_until) {
  auto track = std::make_shared<EgoTrack>();
  track->source = "dataset";
  for (int i = 0; i <= 2 * n; ++i) {
    const double t = 0.25 * i;
    track->samples.push_back(
        {t, 10.0 * t, 0.0, 0.3 * std::min(t, turn_until), 10.0, t < turn_until ? 0.3 : 0.0});
  }
  for (int i = 0; i < n; ++i) {
    const double t = 0.5 * i;
    Frame f = test::make_frame(i, t, kDescription);
    f.ego_track = track;
    f.stream_end = 0.5 * (n - 1);
    r.push("frames", f, t);
    r.push("states", test::make_states(i, t), t);
    r.push("risk", test::make_risk(i, true), t, "ttc");
  }
}

TEST(LlmHazard, FirstSafeWaitsForAStraighterStretchOfTheEgoPath) {
  // At t = 0.5 the path turns 0.3 rad/s x 1.5 s = 25.8 deg over the horizon (to the clip's end at 5 s); from
  // t = 1.0 on at most 17.2 deg: frame 2. A path that turns until t = 4.5 looks straight only over the short
  // horizons at the clip's end, which do not count.
  auto r = test::make_runner("warmup_frames: 1\n");
  push_turning_scene(r, 11, 2.0);
  r.run();
  const auto calls = test::read_jsonl(r.output_dir() / "llm" / "calls.jsonl");
  ASSERT_FALSE(calls.empty());
  EXPECT_EQ(calls[0]["frame_index"], 2);
  const auto& log = r.log();
  EXPECT_NE(
      std::find(log.begin(), log.end(),
                "info: frame 1: the ego path turns 25.78 deg over the horizon (max_turn_deg 20); waiting for "
                "the straighter stretch from t = 1 s"),
      log.end());
  // A path that never straightens out: the first Safe frame, as without the rule; max_turn_deg 0: no rule.
  for (const char* yaml : {"warmup_frames: 1\n", "warmup_frames: 1\nmax_turn_deg: 0\n"}) {
    auto again = test::make_runner(yaml);
    push_turning_scene(again, 11, 4.5);
    again.run();
    const auto c = test::read_jsonl(again.output_dir() / "llm" / "calls.jsonl");
    ASSERT_FALSE(c.empty()) << yaml;
    EXPECT_EQ(c[0]["frame_index"], 1) << yaml;
  }
}

// A scouting run's file of object states as the jsonl sink writes it: frames 0..last at 2 Hz, each record
// `"estimator.states": <states>` (the text may go on with more of the record's keys).
std::filesystem::path scout_file(const test::TempDir& tmp, int last, const std::string& states) {
  const auto file = tmp / "scout.jsonl";
  std::ofstream f(file);
  for (int i = 0; i <= last; ++i)
    f << "{\"frame\":" << i << ",\"timestamp\":" << 0.5 * i << ",\"estimator.states\":" << states << "}\n";
  return file;
}

// Runs six Safe frames 0.5 s apart with `add` putting objects into each frame's states. No hazard may fit:
// what the generator logged or emitted is what the tests check.
void run_six(testing::StageRunner& r, const std::function<void(int, ObjectStates&)>& add) {
  for (int i = 0; i < 6; ++i) {
    const double t = 0.5 * i;
    ObjectStates st = test::make_states(i, t);
    add(i, st);
    r.push("frames", test::make_frame(i, t, "a road"), t);
    r.push("states", st, t);
    r.push("risk", test::make_risk(i, true), t, "ttc");
  }
  try {
    r.run();
  } catch (const Error&) {
  }
}

// The generator's log line that says how it read the scene ("... is Safe: generating a hazard (sidewalks ...,
// multi-lane ...)") after run_six.
std::string scene_reading(const std::string& yaml, const std::function<void(int, ObjectStates&)>& add) {
  auto r = test::make_runner(yaml);
  run_six(r, add);
  for (const std::string& l : r.log())
    if (l.find("is Safe: generating a hazard (") != std::string::npos) return l;
  return std::string("(no generation)");
}

// A run that starts at its trigger frame (a campaign's attempt whose hazard is there from the clip's first
// frame): its own tracks have no velocities yet, so the hazard is planned on the whole recording's estimates of
// the same objects there (recording_states, matched by box), keeping the run's track ids.
TEST(LlmHazard, AHazardMadeAtTheRunsFirstFrameIsPlannedOnTheRecordingsStates) {
  test::TempDir tmp;
  const auto scout = tmp / "scout.jsonl";
  {
    std::ofstream f(scout);
    for (int i = 0; i <= 9; ++i)
      f << "{\"frame\":" << i << ",\"timestamp\":" << 0.5 * i
        << ",\"estimator.states\":{\"frame\":" << i
        << ",\"ego_speed_mps\":8.0,\"objects\":[{\"track_id\":31,\"label\":\"car\",\"box\":[600,300,80,60],"
           "\"distance_m\":40.0,\"lateral_m\":-3.5,\"width_m\":1.85,\"length_m\":4.5,\"speed_mps\":0.0,"
           "\"velocity_rel\":[-8.0,0.0],\"sigma\":{\"distance_m\":0.5,\"lateral_m\":0.1,"
           "\"velocity_rel\":[0.3,0.3]}}]}}\n";
  }
  auto run_from = [&](int first, int trigger) {
    auto r = test::make_runner("seed: 3\ntrigger: frame\ntrigger_frame: " + std::to_string(trigger) +
                               "\nrecording_states: " + scout.string() + "\n");
    for (int i = first; i <= 9; ++i) {
      const double t = 0.5 * i;
      ObjectStates st = test::make_states(i, t);
      st.objects.front().box = cv::Rect2f(601, 300, 80, 60);
      if (i == first) {  // a track the run has just started: no velocity, no ego speed yet
        st.objects.front().velocity_rel.reset();
        st.ego_speed_mps.reset();
      }
      r.push("frames", test::make_frame(i, t, "a road"), t);
      r.push("states", st, t);
      r.push("risk", test::make_risk(i, true), t, "ttc");
    }
    r.run();
    std::string said;
    for (const std::string& l : r.log())
      if (l.find("planned on recording_states") != std::string::npos) said = l;
    return std::make_pair(r.collect<HazardSpec>("hazard").size(), said);
  };
  const auto [made, said] = run_from(3, 3);
  EXPECT_EQ(made, 1u);
  EXPECT_NE(said.find("frame 3 is the run's frame 1: planned on recording_states' estimates there (1 of 1 objects "
                      "matched, ego speed 8 m/s)"),
            std::string::npos)
      << said;
  // A run with warmup_frames (5) of history before its trigger plans on its own tracks.
  EXPECT_EQ(run_from(0, 5).second, "");
}

// Sidewalks on auto with a scene text that says nothing about them: the people the recording shows decide.
TEST(LlmHazard, PeopleTheRecordingShowsMeanSidewalks) {
  auto sidewalks_line = [](const std::string& yaml, int person_frames) {
    const std::string l = scene_reading(yaml, [&](int i, ObjectStates& st) {
      if (i >= person_frames) return;
      ObjectState p = st.objects.front();
      p.track_id = 9;
      p.label = "person";
      p.distance_m = 25.0;
      p.lateral_m = 6.0;
      st.objects.push_back(p);
    });
    const size_t from = l.find("(sidewalks");
    return from == std::string::npos ? l : l.substr(from + 1, l.find("; intersection") - from - 1);
  };
  EXPECT_EQ(sidewalks_line("trigger: frame\ntrigger_frame: 5\n", 5),
            "sidewalks yes, auto: the recording shows people (person track 9 followed for 2 s)");
  EXPECT_EQ(sidewalks_line("trigger: frame\ntrigger_frame: 5\n", 2),
            "sidewalks no, auto: nothing in the scene text suggests sidewalks");  // 0.5 s < people_seen_s 1 s
  EXPECT_EQ(sidewalks_line("trigger: frame\ntrigger_frame: 5\npeople_seen_s: 0\n", 5),
            "sidewalks no, auto: nothing in the scene text suggests sidewalks");
  EXPECT_EQ(sidewalks_line("trigger: frame\ntrigger_frame: 5\nsidewalks: 'no'\n", 5),
            "sidewalks no, set to no");

  // A run that sees only a window of the recording (a campaign's attempt): the whole recording's states, as
  // its scouting run wrote them, say a person was followed for 3 s elsewhere in the clip.
  test::TempDir tmp;
  const auto states = scout_file(tmp, 6,
                                 "{\"objects\":[{\"label\":\"person\",\"track_id\":4},"
                                 "{\"label\":\"car\",\"track_id\":5}]},\"ttc.risk\":{\"label\":\"Safe\"}");
  EXPECT_EQ(
      sidewalks_line("trigger: frame\ntrigger_frame: 5\nrecording_states: " + states.string() + "\n", 0),
      "sidewalks yes, auto: the recording shows people (person track 4 followed for 3 s in scout.jsonl)");
  // A file that is not the jsonl sink's: one message naming the file and line.
  const auto bad = tmp / "bad.jsonl";
  std::ofstream(bad) << "{\"frame\":0,\"timestamp\":0}\nnot json\n";
  auto r = test::make_runner("recording_states: " + bad.string() + "\n");
  try {
    r.run();
    ADD_FAILURE() << "a malformed recording_states file was accepted";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find(bad.string() + ":2: not a record of the jsonl sink"),
              std::string::npos)
        << e.what();
  }
}

// Multi-lane on auto with a scene text that says nothing about lanes: a vehicle the filtered estimator
// follows travelling the ego's way in the next lane decides; a parked car, oncoming traffic, a car in the ego
// lane, a velocity without its uncertainty or a run broken by one frame do not.
TEST(LlmHazard, TrafficBesideTheEgoMeansSeveralLanes) {
  struct Other {
    double lateral = 3.5, ground_vx = 8.0;  // left lane, 8 m/s the ego's way (the ego drives at 10 m/s)
    double sigma_v = 0.5;         // 1-sigma of its velocity; < 0: no covariance (the paper's estimator)
    int frames = 6, gap_at = -1;  // frames it is seen in; a frame where it stands still
  };
  auto lanes_line = [](const Other& o, const std::string& more = "") {
    const std::string l =
        scene_reading("trigger: frame\ntrigger_frame: 5\n" + more, [&](int i, ObjectStates& st) {
          if (i >= o.frames) return;
          ObjectState c = st.objects.front();
          c.track_id = 12;
          c.distance_m = 20.0;
          c.lateral_m = o.lateral;
          c.velocity_rel = cv::Vec2d((i == o.gap_at ? 0.0 : o.ground_vx) - 10.0, 0.0);
          if (o.sigma_v >= 0) {
            cv::Matx44d P = cv::Matx44d::eye() * 0.25;
            P(2, 2) = P(3, 3) = o.sigma_v * o.sigma_v;
            c.covariance = P;
          }
          st.objects.push_back(c);
        });
    const size_t from = l.find("multi-lane");
    return from == std::string::npos ? l : l.substr(from, l.find("; lanes left") - from);
  };
  const std::string none = "multi-lane no, auto: nothing in the scene text suggests several lanes";
  EXPECT_EQ(lanes_line({}),
            "multi-lane yes, auto: the recording shows a car travelling the ego's way in the lane left of it "
            "(track 12, followed for 2.5 s)");
  Other right;
  right.lateral = -3.2;
  EXPECT_NE(lanes_line(right).find("in the lane right of it"), std::string::npos);
  Other parked, oncoming, in_lane, unsure, paper, brief, broken;
  parked.ground_vx = 0.0;
  oncoming.ground_vx = -8.0;
  in_lane.lateral = 0.4;
  unsure.sigma_v = 5.0;  // 8 m/s within its uncertainty: standing as far as the estimator can tell
  paper.sigma_v = -1;
  brief.frames = 2;   // 0.5 s < traffic_seen_s 1 s
  broken.gap_at = 3;  // standing at frame 3: runs of 1 s (frames 0-2) and 0.5 s (frames 4-5)
  for (const Other& o : {parked, oncoming, in_lane, unsure, paper, brief}) EXPECT_EQ(lanes_line(o), none);
  EXPECT_EQ(lanes_line(broken),
            "multi-lane yes, auto: the recording shows a car travelling the ego's way in the lane left of it "
            "(track 12, followed for 1 s)");
  broken.gap_at = 2;  // runs of 0.5 s and 1 s (frames 3-5): still 1 s
  EXPECT_NE(lanes_line(broken).find("followed for 1 s"), std::string::npos);
  Other split;
  split.gap_at = 2;
  EXPECT_EQ(lanes_line(split, "traffic_seen_s: 1.5\n"), none);  // no unbroken 1.5 s
  EXPECT_EQ(lanes_line({}, "traffic_seen_s: 0\n"), none);
  EXPECT_EQ(lanes_line({}, "multi_lane: 'no'\n"), "multi-lane no, set to no");

  // A campaign's attempt sees a window only: the scouting run's states (jsonl sink records, 1-sigma values
  // instead of the covariance) show a car travelling beside the ego for 2 s elsewhere in the clip.
  test::TempDir tmp;
  const auto states = scout_file(tmp, 4,
                                 "{\"ego_speed_mps\":10,\"objects\":[{\"label\":\"car\",\"track_id\":3,"
                                 "\"distance_m\":15,\"lateral_m\":-3.4,\"velocity_rel\":[-2,0.1],\"sigma\":{"
                                 "\"distance_m\":0.5,\"lateral_m\":0.1,\"velocity_rel\":[0.6,0.4]}}]}");
  Other away;
  away.frames = 0;
  EXPECT_EQ(
      lanes_line(away, "recording_states: " + states.string() + "\n"),
      "multi-lane yes, auto: the recording shows a car travelling the ego's way in the lane right of it "
      "(track 3, followed for 2 s in scout.jsonl)");
}

// Driving side not stated: a whole vehicle the filtered estimator follows coming towards the ego beside its
// lane decides (oncoming traffic passes on the other side from the one traffic keeps to), and the lanes on
// its side carry oncoming traffic. A parked car whose closing speed the monocular range error inflates (below
// the ego's own speed), a car cut by the image border, one travelling the ego's way, a brief sighting or a
// velocity within its uncertainty do not; a stated side is kept, with a warning when the traffic contradicts
// it.
TEST(LlmHazard, OncomingTrafficTellsTheSideTrafficKeepsTo) {
  struct Other {
    double lateral = 5.0, ground_vx = -10.0;  // left, 10 m/s towards the ego (which drives at 10 m/s)
    double sigma_v = 0.5;
    int frames = 6;
    unsigned truncated = 0;
  };
  auto add = [](const Other& o) {
    return [o](int i, ObjectStates& st) {
      if (i >= o.frames) return;
      ObjectState c = st.objects.front();
      c.track_id = 12;
      c.distance_m = 30.0 - 2.0 * i;
      c.lateral_m = o.lateral;
      c.truncated = o.truncated;
      c.velocity_rel = cv::Vec2d(o.ground_vx - 10.0, 0.0);
      cv::Matx44d P = cv::Matx44d::eye() * 0.25;
      P(2, 2) = P(3, 3) = o.sigma_v * o.sigma_v;
      c.covariance = P;
      st.objects.push_back(c);
    };
  };
  auto side_line = [&](const Other& o, const std::string& more = "") {
    const std::string l = scene_reading("trigger: frame\ntrigger_frame: 5\n" + more, add(o));
    const size_t from = l.rfind("traffic keeps");
    return from == std::string::npos ? l : l.substr(from, l.size() - 1 - from);
  };
  EXPECT_EQ(side_line({}),
            "traffic keeps right, auto: the recording shows a car coming towards the ego left of its lane "
            "(track 12, followed for 2.5 s)");
  Other right;
  right.lateral = -6.0;
  EXPECT_EQ(side_line(right),
            "traffic keeps left, auto: the recording shows a car coming towards the ego right of its lane "
            "(track 12, followed for 2.5 s)");
  const std::string none =
      "traffic keeps right, default: no oncoming traffic followed for 1 s in the recording";
  Other misread, cut, with_ego, brief, unsure, in_lane;
  misread.ground_vx = -6.0;  // closing at 16 m/s: 0.6 of the ego's speed could be the range error
  cut.truncated = truncation::kLeft;
  with_ego.ground_vx = 8.0;
  brief.frames = 2;
  unsure.sigma_v = 8.0;
  in_lane.lateral = 0.5;
  for (const Other& o : {misread, cut, with_ego, brief, unsure, in_lane}) EXPECT_EQ(side_line(o), none);
  EXPECT_EQ(side_line({}, "traffic_seen_s: 0\n"),
            "traffic keeps right, default: no oncoming traffic followed for 0 s in the recording");

  // The lanes on the oncoming side carry oncoming traffic: the log line and the prompt's road say so.
  const std::string line = scene_reading("trigger: frame\ntrigger_frame: 5\n", add(right));
  EXPECT_NE(
      line.find("right 1 lane(s) with oncoming traffic: the recording shows a car coming towards the ego"),
      std::string::npos)
      << line;

  // Stated, the side is kept; traffic that contradicts it is reported once.
  auto stated = test::make_runner("trigger: frame\ntrigger_frame: 5\ndriving_side: left\n");
  run_six(stated, add({}));
  int warned = 0;
  bool kept = false;
  for (const std::string& l : stated.log()) {
    warned += l.find(
                  "but driving_side is stated as left (oncoming traffic on the right); the stated side is "
                  "kept") != std::string::npos;
    kept = kept || l.find("traffic keeps left, stated)") != std::string::npos;
  }
  EXPECT_EQ(warned, 1);
  EXPECT_TRUE(kept);
}

// A cut-in on a road whose lanes on one side carry oncoming traffic (seen, not stated) comes from the other
// side, for every seed; with nothing seen, or the rule off, it comes from either.
TEST(LlmHazard, ACutInDoesNotComeFromLanesWithOncomingTraffic) {
  auto sides = [](bool oncoming, const std::string& more = "") {
    std::set<std::string> out;
    for (int seed = 1; seed <= 6; ++seed) {
      auto r = test::make_runner(
          "trigger: frame\ntrigger_frame: 5\nforce_kind: cut_in\nmulti_lane: 'yes'\n"
          "lanes_left: 2\nseed: " +
          std::to_string(seed) + "\n" + more);
      run_six(r, [oncoming](int i, ObjectStates& st) {
        st.objects.clear();
        if (!oncoming) return;
        ObjectState c;  // two lanes over on the left, 45 m ahead, coming at 12 m/s
        c.track_id = 12;
        c.label = "car";
        c.distance_m = 45.0 - 11.0 * i;
        c.lateral_m = 7.5;
        c.width_m = 1.85;
        c.length_m = 4.5;
        c.velocity_rel = cv::Vec2d(-22.0, 0.0);
        c.covariance = cv::Matx44d::eye() * 0.25;
        st.objects.push_back(c);
      });
      for (const HazardSpec& h : r.collect<HazardSpec>("hazard")) out.insert(h.side);
    }
    return out;
  };
  EXPECT_EQ(sides(true), std::set<std::string>{"right"});
  EXPECT_EQ(sides(false), (std::set<std::string>{"left", "right"}));
  EXPECT_EQ(sides(true, "traffic_seen_s: 0\n"), (std::set<std::string>{"left", "right"}));
}

TEST(LlmHazard, FirstSafeStopsAfterMaxTriggerAttemptsAndSaysWhichFrames) {
  ScriptedServer srv("/api/chat");
  for (int i = 0; i < 2; ++i) srv.then_ollama("no JSON here");
  auto r = test::make_runner(ollama_yaml(
      srv.url(), "max_retries: 0\nwarmup_frames: 1\nretry_every_s: 0.5\nmax_trigger_attempts: 2\n"));
  test::push_scene(r, 8, kDescription);
  r.run();  // not a fault: the scene got no hazard, the run goes on
  EXPECT_TRUE(r.outputs("hazard").empty());
  EXPECT_EQ(srv.requests().size(), 2u);
  EXPECT_FALSE(std::filesystem::exists(r.output_dir() / "hazard_spec.json"));
  EXPECT_EQ(
      r.log().back().rfind("warning: no hazard generated: none fitted the scene at frame(s) 1, 2 (the last: "
                           "no valid hazard spec after 1 attempt(s)",
                           0),
      0u)
      << r.log().back();
}

TEST(LlmHazard, Http500FailsAtOnceWithTheServersWords) {
  ScriptedServer srv("/api/chat");
  srv.then([](const httplib::Request&, httplib::Response& res) {
    res.status = 500;
    res.set_content(R"({"error":"model \"llama3\" not found, try pulling it first"})", "application/json");
  });
  auto r = test::make_runner(ollama_yaml(srv.url()));
  test::push_scene(r, 6, kDescription);
  EXPECT_EQ(run_error(r),
            "ollama: POST " + srv.url() +
                "/api/chat returned HTTP 500: model \"llama3\" not found, try pulling it first");
  EXPECT_EQ(srv.requests().size(), 1u);
  auto calls = test::read_jsonl(r.output_dir() / "llm" / "calls.jsonl");
  ASSERT_EQ(calls.size(), 1u);
  EXPECT_EQ(calls[0]["transport_error"],
            "ollama: POST " + srv.url() +
                "/api/chat returned HTTP 500: model \"llama3\" not found, try pulling it first");
}

TEST(LlmHazard, ReadTimeout) {
  ScriptedServer srv("/api/chat");
  srv.then([](const httplib::Request&, httplib::Response& res) {
    std::this_thread::sleep_for(std::chrono::milliseconds(1500));
    res.set_content("{}", "application/json");
  });
  auto r = test::make_runner("provider: {name: ollama, host: '" + srv.url() + "', read_timeout_s: 0.3}\n");
  test::push_scene(r, 6, kDescription);
  EXPECT_EQ(run_error(r), "ollama: POST " + srv.url() + "/api/chat failed: Timeout was reached");
}

TEST(LlmHazard, ConnectionRefused) {
  const std::string url = "http://127.0.0.1:" + std::to_string(test::unused_port());
  auto r = test::make_runner(ollama_yaml(url));
  test::push_scene(r, 6, kDescription);
  EXPECT_EQ(run_error(r), "ollama: POST " + url + "/api/chat failed: Couldn't connect to server");
}

TEST(LlmHazard, TruncatedBody) {
  ScriptedServer srv("/api/chat");
  srv.then([](const httplib::Request&, httplib::Response& res) {
    res.set_content_provider(4096, "application/json", [](size_t, size_t, httplib::DataSink& sink) {
      const std::string part = R"({"model":"llama3","message":{"role":"assistant","content":"{\"kind)";
      sink.write(part.data(), part.size());
      return false;  // the connection drops mid-body
    });
  });
  auto r = test::make_runner(ollama_yaml(srv.url()));
  test::push_scene(r, 6, kDescription);
  EXPECT_EQ(run_error(r), "ollama: POST " + srv.url() + "/api/chat failed: Transferred a partial file");
}

TEST(LlmHazard, OpenAiCompatibleServer) {
  ScriptedServer srv("/v1/chat/completions");
  srv.then_openai("Sure.\n```\n" + test::valid_reply().dump() + "\n```");
  auto r = test::make_runner("provider: {name: openai, base_url: '" + srv.url() +
                             "/v1', model: llama3}\nseed: 11\n"
                             "force_kind: pedestrian_crossing\n");
  test::push_scene(r, 6, kDescription);
  r.run();
  ASSERT_EQ(r.outputs("hazard").size(), 1u);
  Json got = srv.requests().at(0);
  EXPECT_EQ(got["seed"], 11);
  EXPECT_EQ(got["response_format"]["json_schema"]["strict"], true);
  EXPECT_EQ(got["response_format"]["json_schema"]["schema"]["properties"]["kind"]["enum"],
            Json::array({"pedestrian_crossing"}));
}

TEST(LlmHazard, ThirdPartyKindsComeFromRegisteredTemplates) {
  ScriptedServer srv("/api/chat");
  Json cargo = test::valid_reply();
  cargo["kind"] = "fallen_cargo";
  cargo["object_class"] = "car";
  cargo["initial_distance_m"] = 30;
  cargo["lateral_offset_m"] = 0;
  cargo["side"] = "center";
  cargo["heading_deg"] = 0;
  cargo["speed_mps"] = 3;
  cargo["extra"] = Json::object();  // no built-in kind is registered: their fields are unknown
  srv.then_ollama(cargo.dump());
  cargo["speed_mps"] = 0;
  srv.then_ollama(cargo.dump());
  auto r = test::make_runner(ollama_yaml(srv.url()), /*with_templates=*/false,
                             [](Registrar& reg) { reg.add<FallenCargoTemplate>(); });
  test::push_scene(r, 6, kDescription);
  r.run();
  ASSERT_EQ(r.outputs("hazard").size(), 1u);
  auto got = srv.requests();
  ASSERT_EQ(got.size(), 2u);
  EXPECT_EQ(got[0]["format"]["properties"]["kind"]["enum"], Json::array({"fallen_cargo"}));
  EXPECT_NE(got[1]["messages"][2]["content"].get<std::string>().find(
                "- hazard template 'fallen_cargo': cargo lies still (speed_mps must be 0, got 3)"),
            std::string::npos);
}

TEST(LlmHazard, ConfigurationErrors) {
  auto none = test::make_runner("", /*with_templates=*/false);
  test::push_scene(none, 1, kDescription);
  EXPECT_EQ(run_error(none),
            "no hazard kinds to choose from: no hazard_template component is "
            "registered and param 'kinds' is empty");
  auto forced = test::make_runner("kinds: [cut_in, sudden_stop]\nforce_kind: pedestrian_crossing\n");
  test::push_scene(forced, 1, kDescription);
  EXPECT_EQ(run_error(forced),
            "force_kind 'pedestrian_crossing' is not among the allowed kinds (cut_in, sudden_stop)");
  auto unknown = test::make_runner("provider: {name: olama}\n");
  test::push_scene(unknown, 1, kDescription);
  EXPECT_EQ(run_error(unknown), "unknown llm_provider 'olama'; did you mean 'ollama'?");
}

}  // namespace
}  // namespace hf
