// A third party's hazard kind, the oncoming_overtaker test plugin (one file, loaded as the host loads plugins),
// takes part everywhere without a line elsewhere: the prompt, the reply schema, the offline planner's choice, the
// generator's checks, the planner and `hazardforge inspect`.
#include <dlfcn.h>
#include <gtest/gtest.h>

#include <cmath>
#include <set>

#include "command.hpp"
#include "hazard_planner.hpp"
#include "llm_test_support.hpp"

namespace hf {
namespace {

// Registers what the built plugin registers, as the host's loader would.
void register_overtaker(Registrar& reg) {
  static void* lib = dlopen(ONCOMING_OVERTAKER_PLUGIN, RTLD_NOW | RTLD_LOCAL);
  if (!lib) throw std::runtime_error(dlerror());
  auto entry = reinterpret_cast<hf_plugin_entry_fn>(dlsym(lib, HF_PLUGIN_ENTRY_SYMBOL));
  if (!entry) throw std::runtime_error("no entry symbol in " ONCOMING_OVERTAKER_PLUGIN);
  char err[512] = {};
  if (entry()->register_components(&reg, err, sizeof err) != 0) throw std::runtime_error(err);
}

// Traffic keeps right; the lane left of the ego lane carries oncoming traffic.
const std::string kRoad = "lanes_left: 1\nlanes_right: 1\noncoming_lanes: 1\n";

HazardSpec generate(int64_t seed, testing::StageRunner* keep = nullptr) {
  auto r = test::make_runner("kinds: [oncoming_overtaker]\n" + kRoad + "seed: " + std::to_string(seed) + "\n",
                             true, &register_overtaker);
  test::push_scene(r, 6, "city street");
  r.run();
  auto specs = r.collect<HazardSpec>("hazard");
  if (specs.size() != 1) throw std::runtime_error("no spec");
  if (keep) *keep = std::move(r);
  return specs[0];
}

TEST(ThirdPartyKind, TheOfflinePlannerPlansItFromItsTemplate) {
  std::set<std::string> classes;
  for (int64_t seed = 0; seed < 8; ++seed) {
    const HazardSpec s = generate(seed);
    EXPECT_EQ(s.kind, "oncoming_overtaker");
    EXPECT_EQ(s.provenance["attempts"], 1) << "seed " << seed;
    EXPECT_DOUBLE_EQ(s.lateral_offset_m, 3.5);  // the oncoming lane, left of the ego's when traffic keeps right
    EXPECT_EQ(s.side, "left");
    EXPECT_DOUBLE_EQ(s.heading_deg, 180.0);
    EXPECT_GE(s.initial_distance_m, 40.0);
    EXPECT_GT(s.extra.at("swerve_after_s").get<double>(), 0.0);
    classes.insert(s.object_class);
  }
  EXPECT_GE(classes.size(), 2u);
}

TEST(ThirdPartyKind, ThePromptAndTheReplySchemaDescribeIt) {
  testing::StageRunner r;
  generate(1, &r);
  const auto calls = test::read_jsonl(r.output_dir() / "llm/calls.jsonl");
  ASSERT_EQ(calls.size(), 1u);
  const std::string prompt = calls[0]["messages"][0]["content"];
  EXPECT_NE(prompt.find("- oncoming_overtaker (car, truck, bus): an oncoming vehicle swerves into the ego lane to "
                        "overtake, head-on. Played out: drives towards the ego (heading_deg 180)"),
            std::string::npos)
      << prompt;
  EXPECT_NE(prompt.find("Needs a lane with oncoming traffic beside the ego lane (given here).\n  "
                        "extra.swerve_after_s: seconds it drives on in its own lane before it swerves into the ego "
                        "lane."),
            std::string::npos);
  EXPECT_NE(prompt.find("\"swerve_after_s\": {\n"), std::string::npos);
  EXPECT_NE(prompt.find("oncoming_overtaker: seconds it drives on in its own lane"), std::string::npos);
}

TEST(ThirdPartyKind, TheScenesConditionsApplyToIt) {
  // Without an oncoming lane the prompt says so, and the offline planner finds nothing to propose.
  auto r = test::make_runner("kinds: [oncoming_overtaker]\nseed: 3\ntrigger: frame\ntrigger_frame: 5\n", true,
                             &register_overtaker);
  test::push_scene(r, 6, "city street");
  try {
    r.run();
    FAIL() << "expected no hazard";
  } catch (const Error& e) {
    EXPECT_STREQ(e.what(),
                 "offline: no hazard fits this scene (allowed kinds: oncoming_overtaker): oncoming_overtaker: no "
                 "lane carries oncoming traffic");
  }
  const auto calls = test::read_jsonl(r.output_dir() / "llm/calls.jsonl");
  ASSERT_EQ(calls.size(), 1u);
  EXPECT_NE(calls[0]["messages"][0]["content"].get<std::string>().find(
                "Needs a lane with oncoming traffic beside the ego lane — NOT given here, so do not choose it."),
            std::string::npos);
}

TEST(ThirdPartyKind, TheHazardPlannerPlansIt) {
  const HazardSpec spec = generate(5);
  testing::StageRunner p;
  p.registrar().add<HazardPlanner>();
  register_overtaker(p.registrar());
  p.build(kind::kPlanner, "hazard_planner", "templates: {oncoming_overtaker: {" + std::string(
                                                "lanes_left: 1, lanes_right: 1, oncoming_lanes: 1}}"));
  const double t = spec.start_time_s;
  p.push("hazard", spec, t);
  p.push("frames", test::make_frame(5, t, "city street"), t);
  p.push("states", test::make_states(5, t), t);
  p.run();
  const auto trajs = p.collect<HazardTrajectory>("trajectory");
  ASSERT_EQ(trajs.size(), 1u);
  const HazardTrajectory& tr = trajs[0];
  EXPECT_EQ(tr.kind, "oncoming_overtaker");
  EXPECT_NEAR(tr.points.front().x, spec.initial_distance_m, 1e-9);
  EXPECT_NEAR(tr.points.front().y, 3.5, 1e-9);
  EXPECT_NEAR(std::abs(tr.points.front().heading), M_PI, 1e-6);
  // It ends in the ego path (half-width 1 m + margin 0.5 m + its own half-width), coming head-on: the plan stops
  // at contact, below the target TTC.
  EXPECT_LT(std::abs(tr.points.back().y), 1.5 + tr.size_lwh[1] / 2);
  EXPECT_LT(tr.points.back().x - tr.ego.back().x, 3.4 + tr.size_lwh[0] / 2 + 1.5);  // one step from contact
  EXPECT_LE(tr.intended_min_ttc_s, *spec.target_ttc_s);
}

TEST(ThirdPartyKind, InspectShowsWhatItIs) {
  const auto dir = std::filesystem::path(ONCOMING_OVERTAKER_PLUGIN).parent_path();
  const test::CommandResult c =
      test::run_command(std::string(HF_EXE) + " --plugin-path " + test::quote(dir) + " inspect oncoming_overtaker");
  ASSERT_EQ(c.code, 0) << c.out;
  EXPECT_NE(c.out.find("Classes: car, truck, bus. Needs: oncoming_lane. Extra fields: extra.swerve_after_s: seconds "
                       "it drives on in its own lane before it swerves into the ego lane."),
            std::string::npos)
      << c.out;
}

// Every registered kind, by name: it describes itself under its name, and the offline provider's plans from its
// template pass the generator's checks at the first attempt on a road where every kind applies.
TEST(RegisteredKinds, DescribeThemselvesAndTheirPlansPass) {
  ComponentRegistry reg;
  reg.add<PedestrianCrossingTemplate>();
  reg.add<CutInTemplate>();
  reg.add<SuddenStopTemplate>();
  register_overtaker(reg);
  const auto names = reg.component_names(kind::kHazardTemplate);
  ASSERT_EQ(names.size(), 4u);
  for (const std::string& name : names) {
    const RegisteredComponent* c = reg.find(kind::kHazardTemplate, name);
    const HazardKindInfo info = reg.create<HazardTemplate>(kind::kHazardTemplate, name, Json::object())->kind_info();
    EXPECT_EQ(info.kind, name);
    EXPECT_FALSE(info.summary.empty()) << name;
    EXPECT_FALSE(info.play_out.empty()) << name;
    EXPECT_EQ(c->info.summary, info.summary);
    EXPECT_NE(c->info.doc.find("Needs: "), std::string::npos) << name;
    // On the left a lane going the ego's way and beyond it one with oncoming traffic; one lane on the right.
    for (int64_t seed = 0; seed < 6; ++seed) {
      auto r = test::make_runner("force_kind: " + name + "\nlanes_left: 2\nlanes_right: 1\noncoming_lanes: 1\n" +
                                     "sidewalks: 'yes'\nmulti_lane: 'yes'\nseed: " + std::to_string(seed) + "\n",
                                 true, &register_overtaker);
      test::push_scene(r, 6, "city street");
      r.run();
      const auto specs = r.collect<HazardSpec>("hazard");
      ASSERT_EQ(specs.size(), 1u) << name << " seed " << seed;
      EXPECT_EQ(specs[0].kind, name);
      EXPECT_EQ(specs[0].provenance["attempts"], 1) << name << " seed " << seed;
    }
  }
}

}  // namespace
}  // namespace hf
