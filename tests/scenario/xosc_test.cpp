// OpenSCENARIO export: scenario, road and catalog validate against their schemas and say what they should.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <regex>

#include "hazardforge/testing/stage_runner.hpp"
#include "scenario_support.hpp"
#include "xml_files.hpp"
#include "xosc_sink.hpp"
#include "xosc_writer.hpp"

namespace hf {
namespace {

namespace fs = std::filesystem;

HazardTrajectory planned(const std::string& kind, HazardSpec spec, double ego_speed) {
  auto tpl = test::make_template(kind);
  return tpl->plan(spec, test::test_scene(ego_speed));
}

HazardSpec cut_in_spec() {
  HazardSpec s;
  s.kind = "cut_in";
  s.object_class = "car";
  s.initial_distance_m = -3;
  s.side = "left";
  s.speed_mps = 26;
  s.target_ttc_s = 1.2;
  s.rationale = "overtakes & cuts in <close> \"ahead\" of the ego's lane";
  return s;
}

HazardSpec crossing_spec() {
  HazardSpec s;
  s.kind = "pedestrian_crossing";
  s.object_class = "person";
  s.initial_distance_m = 50;
  s.side = "right";
  s.speed_mps = 1.5;
  s.target_ttc_s = 1.5;
  return s;
}

int count(const std::string& text, const std::string& what) {
  int n = 0;
  for (size_t p = text.find(what); p != std::string::npos; p = text.find(what, p + 1)) ++n;
  return n;
}

void expect_valid(const fs::path& xosc) {
  const test::Validation v = test::validate_xml(xosc, test::xosc_schema());
  EXPECT_TRUE(v.ok()) << v.output;
}

fs::path write_through_sink(testing::StageRunner& r, const HazardTrajectory& tr,
                            std::optional<Frame> frame = {}) {
  r.push("trajectory", tr, tr.anchor_time);
  if (frame) r.push("frames", *frame, tr.anchor_time);
  r.run();
  return r.output_dir() / "scenario.xosc";
}

TEST(Xosc, CutInScenarioAndRoadValidateAgainstTheSchemas) {
  HF_REQUIRE_SHARED(test::xosc_schema());
  const HazardTrajectory tr = planned("cut_in", cut_in_spec(), 20.0);
  auto r = testing::StageRunner::create<XoscSink>();
  const fs::path file = write_through_sink(r, tr);
  ASSERT_TRUE(fs::exists(file));
  expect_valid(file);
  const fs::path road = r.output_dir() / "scenario.xodr";
  ASSERT_TRUE(fs::exists(road));
  const test::Validation rv = test::validate_xml(road, test::xodr_schema());
  EXPECT_TRUE(rv.ok()) << rv.output;
  // The catalog is written once, and validates too.
  const fs::path catalog = r.output_dir() / "hazard_maneuvers.xosc";
  ASSERT_TRUE(fs::exists(catalog));
  expect_valid(catalog);

  const std::string x = test::read_text(file.string());
  EXPECT_NE(x.find("<LogicFile filepath=\"scenario.xodr\"/>"), std::string::npos);
  // Init places the ego in its lane and the hazard relative to it, one lane to the left.
  EXPECT_NE(x.find("<LanePosition roadId=\"1\" laneId=\"-1\" offset=\"0\""), std::string::npos);
  EXPECT_NE(x.find("<RelativeLanePosition entityRef=\"Ego\" dLane=\"1\" ds=\"$HazardStartGap\""),
            std::string::npos);
  EXPECT_EQ(count(x, "<FollowTrajectoryAction>"), 0);
  EXPECT_EQ(count(x, "<LaneChangeAction "), 1);
  EXPECT_NE(x.find("<RelativeTargetLane entityRef=\"Ego\" value=\"0\"/>"), std::string::npos);
  EXPECT_NE(x.find("<RelativeDistanceCondition entityRef=\"Hazard\""), std::string::npos)
      << x.substr(0, 2500);
  for (const char* p : {"EgoSpeed", "HazardSpeed", "HazardStartGap", "HazardDeceleration", "TriggerValue",
                        "LaneChangeTime", "StopTime"})
    EXPECT_NE(x.find("<ParameterDeclaration name=\"" + std::string(p) + "\""), std::string::npos) << p;
  EXPECT_NE(x.find("<ParameterDeclaration name=\"EgoSpeed\" parameterType=\"double\" value=\"20\"/>"),
            std::string::npos);
  EXPECT_NE(x.find("<ParameterDeclaration name=\"HazardSpeed\" parameterType=\"double\" value=\"26\"/>"),
            std::string::npos);
  EXPECT_NE(x.find("model3d=\"car_red.osgb\""), std::string::npos);
  EXPECT_NE(x.find("<Property name=\"type\" value=\"ego_vehicle\"/>"), std::string::npos);
  EXPECT_NE(x.find("<CollisionCondition>"), std::string::npos);
  EXPECT_NE(x.find("maxDeceleration=\"10\""), std::string::npos);  // from share/hazard_limits.yaml
  // The rationale stays in the hazard's spec property (escaped); the header carries the plan's own numbers.
  EXPECT_NE(x.find("overtakes &amp; cuts in &lt;close&gt; \\&quot;ahead\\&quot; of the ego&apos;s lane"),
            std::string::npos);
  EXPECT_EQ(x.find("overtakes", x.find("<FileHeader")),
            x.find("overtakes", x.find("<Property name=\"hazard_spec\"")));
  std::smatch mt;
  ASSERT_TRUE(std::regex_search(x, mt, std::regex("minimum TTC ([0-9.]+) s at t=([0-9.]+) s")));
  EXPECT_NEAR(std::stod(mt[1]), tr.intended_min_ttc_s, 0.01);
}

TEST(Xosc, PedestrianWaitsOnTheSidewalkAndWalksWhenTheEgoIsClose) {
  HF_REQUIRE_SHARED(test::xosc_schema());
  HazardTrajectory tr = planned("pedestrian_crossing", crossing_spec(), 10.0);
  RoadLayout layout;
  layout.driving_side = "right";
  layout.lanes_left = 1;
  layout.lanes_right = 0;
  layout.lane_width_m = 3.5;
  layout.sidewalks = true;
  layout.sidewalk_width_m = 3.0;
  tr.spec.road = layout;
  auto r = testing::StageRunner::create<XoscSink>("author: \"Test & Co\"");
  const fs::path file = write_through_sink(r, tr);
  expect_valid(file);
  const test::Validation rv = test::validate_xml(r.output_dir() / "scenario.xodr", test::xodr_schema());
  EXPECT_TRUE(rv.ok()) << rv.output;
  const std::string x = test::read_text(file.string());
  const std::string road = test::read_text((r.output_dir() / "scenario.xodr").string());
  EXPECT_EQ(count(road, "type=\"sidewalk\""), 2);
  EXPECT_NE(x.find("<Pedestrian name=\"person\" mass=\"75\" pedestrianCategory=\"pedestrian\" "
                   "model3d=\"walkman.osgb\">"),
            std::string::npos);
  EXPECT_NE(x.find("author=\"Test &amp; Co\""), std::string::npos);
  // On the right sidewalk (lane -2, one lane right of the ego's), facing left across the road.
  EXPECT_NE(x.find("<RelativeLanePosition entityRef=\"Ego\" dLane=\"-1\""), std::string::npos);
  EXPECT_NE(x.find("<Orientation type=\"relative\" h=\"1.570796\""), std::string::npos);
  EXPECT_NE(x.find("<TimeToCollisionCondition freespace=\"false\" rule=\"lessThan\" value=\"$TriggerValue\""),
            std::string::npos);
}

TEST(Xosc, WorldCoordinatesAreYawOnlyAtGroundLevel) {
  HF_REQUIRE_SHARED(test::xosc_schema());
  HazardSpec s;
  s.kind = "sudden_stop";
  s.object_class = "truck";
  s.initial_distance_m = 30;
  s.speed_mps = 15;
  s.deceleration_mps2 = 6;
  const HazardTrajectory tr = planned("sudden_stop", s, 15.0);
  Frame f;
  f.index = 12;
  f.timestamp = tr.anchor_time;
  // Ego at (100, 200, 1) heading +90 degrees (north), pitched by 0.1 rad: only x, y and the yaw count.
  const double cp = std::cos(0.1), sp = std::sin(0.1);
  f.ego.T_world_ego = cv::Matx44d(0, -1, 0, 100, cp, 0, -sp, 200, sp, 0, cp, 1, 0, 0, 0, 1);
  auto r = testing::StageRunner::create<XoscSink>("coordinates: world\nego: replay");
  const fs::path file = write_through_sink(r, tr, f);
  expect_valid(file);
  const std::string x = test::read_text(file.string());
  const std::string road = test::read_text((r.output_dir() / "scenario.xodr").string());
  // The road runs north through the ego's position; the ego replays its (constant) speed at z = 0.
  EXPECT_NE(road.find("hdg=\"1.570796327\""), std::string::npos) << road.substr(0, 800);
  EXPECT_TRUE(std::regex_search(
      x, std::regex("<WorldPosition x=\"100\" y=\"2[0-9.]+\" z=\"0\" h=\"1.570796\" p=\"0\" r=\"0\"/>")));
  EXPECT_EQ(count(x, "z=\"1\""), 0);
  EXPECT_NE(x.find("<TraveledDistanceCondition value=\"$TriggerValue\"/>"), std::string::npos);
  EXPECT_NE(
      x.find("<ParameterDeclaration name=\"HazardDeceleration\" parameterType=\"double\" value=\"6\"/>"),
      std::string::npos);
  EXPECT_NE(x.find("<ParameterDeclaration name=\"HazardEndSpeed\" parameterType=\"double\" value=\"0\"/>"),
            std::string::npos);
  // The replayed ego starts after Init, so the Init speed is not cancelled.
  EXPECT_NE(x.find("<SimulationTimeCondition value=\"0\" rule=\"greaterThan\"/>"), std::string::npos);

  auto no_pose = testing::StageRunner::create<XoscSink>("coordinates: world");
  Frame bare = f;
  bare.ego.T_world_ego.reset();
  try {
    write_through_sink(no_pose, tr, bare);
    FAIL();
  } catch (const Error& e) {
    EXPECT_EQ(
        std::string(e.what()),
        "xosc: coordinates 'world' needs the ego pose of the anchor frame (t=2 s); frame 12 carries none");
  }
}

TEST(Xosc, BadRoadFactsInASpecAreNamed) {
  // The road travels typed in the spec (HazardSpec::road); a spec file with a bad one is refused when read,
  // naming the field, before any sink sees it.
  Json spec = cut_in_spec();
  spec["road"] = {{"lanes_left", "two"}};
  try {
    (void)spec.get<HazardSpec>();
    FAIL();
  } catch (const Error& e) {
    EXPECT_EQ(std::string(e.what()), "road.lanes_left must be a whole number, got \"two\"");
  }
  spec["road"] = {{"driving_side", "middle"}};
  try {
    (void)spec.get<HazardSpec>();
    FAIL();
  } catch (const Error& e) {
    EXPECT_EQ(std::string(e.what()), "road.driving_side must be 'right' or 'left', got 'middle'");
  }
  spec["road"] = {{"lanes_left", 0}, {"oncoming_lanes", 1}};
  EXPECT_THROW((void)spec.get<HazardSpec>(), Error);  // no lane on the left to carry oncoming traffic
}

TEST(Xosc, ValidationCatchesABrokenFile) {
  // The check above can fail: the same file without its mandatory StopTrigger is rejected.
  HF_REQUIRE_SHARED(test::xosc_schema());
  const HazardTrajectory tr = planned("cut_in", cut_in_spec(), 20.0);
  XoscOptions opt;
  opt.date = "2024-01-01T00:00:00";
  std::string x = write_xosc(tr, opt);
  const size_t a = x.rfind("<StopTrigger>"), b = x.rfind("</StopTrigger>");
  ASSERT_NE(a, std::string::npos);
  x.erase(a, b + std::string("</StopTrigger>").size() - a);
  const fs::path dir = test::unique_temp_dir();
  test::write_text(dir / "broken.xosc", x);
  const test::Validation v = test::validate_xml(dir / "broken.xosc", test::xosc_schema());
  EXPECT_NE(v.status, 0);
  EXPECT_NE(v.output.find("fails to validate"), std::string::npos) << v.output;
  fs::remove_all(dir);
}

TEST(Xosc, EscapesEverythingXmlCannotCarryRaw) {
  EXPECT_EQ(xml_escape("a<b>&\"c'\x01\td"), "a&lt;b&gt;&amp;&quot;c&apos;\td");
}

TEST(Xosc, RefusesATrajectoryWithOneSample) {
  HazardTrajectory tr;
  tr.kind = "cut_in";
  tr.object_class = "car";
  tr.points.resize(1);
  tr.ego.resize(1);
  EXPECT_THROW(write_xosc(tr, XoscOptions{}), Error);
}

}  // namespace
}  // namespace hf
