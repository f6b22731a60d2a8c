// OpenSCENARIO export: every planned kind validates against the ASAM OpenSCENARIO 1.2 XSD with xmllint.
#include <gtest/gtest.h>
#include <sys/wait.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <regex>

#include "hazardforge/testing/stage_runner.hpp"
#include "scenario_support.hpp"
#include "test_support.hpp"
#include "xosc_sink.hpp"
#include "xosc_writer.hpp"

namespace hf {
namespace {

namespace fs = std::filesystem;

struct Validation {
  int status = -1;
  std::string output;
};

// xmllint --noout --schema OpenSCENARIOv1.2.xsd FILE
Validation validate(const fs::path& file) {
  const fs::path xsd = test::shared_dir() / "schemas" / "OpenSCENARIOv1.2.xsd";
  const fs::path log = file.string() + ".xmllint.txt";
  const std::string cmd =
      "xmllint --noout --schema '" + xsd.string() + "' '" + file.string() + "' > '" + log.string() + "' 2>&1";
  Validation v;
  const int rc = std::system(cmd.c_str());
  v.status = WIFEXITED(rc) ? WEXITSTATUS(rc) : -1;
  v.output = test::read_text(log.string());
  return v;
}

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

fs::path write_through_sink(testing::StageRunner& r, const HazardTrajectory& tr,
                            std::optional<Frame> frame = {}) {
  r.push("trajectory", tr, tr.anchor_time);
  if (frame) r.push("frames", *frame, tr.anchor_time);
  r.run();
  return r.output_dir() / "scenario.xosc";
}

TEST(Xosc, CutInScenarioValidatesAgainstTheSchema) {
  HF_REQUIRE_SHARED(test::shared_dir() / "schemas" / "OpenSCENARIOv1.2.xsd");
  const HazardTrajectory tr = planned("cut_in", cut_in_spec(), 20.0);
  auto r = testing::StageRunner::create<XoscSink>();
  const fs::path file = write_through_sink(r, tr);
  ASSERT_TRUE(fs::exists(file));
  const Validation v = validate(file);
  EXPECT_EQ(v.status, 0) << v.output;
  EXPECT_NE(v.output.find("validates"), std::string::npos) << v.output;

  const std::string x = test::read_text(file.string());
  EXPECT_EQ(count(x, "<FollowTrajectoryAction>"), 2);
  EXPECT_EQ(count(x, "<Vertex "), static_cast<int>(tr.points.size() + tr.ego.size()));
  EXPECT_EQ(count(x, "<TeleportAction>"), 2);
  EXPECT_NE(x.find("<Vehicle name=\"car\" vehicleCategory=\"car\">"), std::string::npos);
  EXPECT_NE(x.find("<Axles>"), std::string::npos);
  EXPECT_NE(x.find("maxDeceleration=\"10\""), std::string::npos);  // from share/hazard_limits.yaml
  // The rationale lands in the header, escaped.
  EXPECT_NE(x.find("overtakes &amp; cuts in &lt;close&gt; &quot;ahead&quot; of the ego&apos;s lane"),
            std::string::npos);
  EXPECT_NE(x.find("<ParameterDeclaration name=\"EgoSpeed\" parameterType=\"double\" value=\"20\"/>"),
            std::string::npos);
  // The hazard's first vertex is its rear axle: centre -3 m minus half the 0.6 x 4.5 m wheelbase.
  EXPECT_NE(x.find("<WorldPosition x=\"-4.35\" y=\"3.5\" z=\"0\" h=\"0\" p=\"0\" r=\"0\"/>"),
            std::string::npos);
}

TEST(Xosc, PedestrianScenarioValidatesAgainstTheSchema) {
  HF_REQUIRE_SHARED(test::shared_dir() / "schemas" / "OpenSCENARIOv1.2.xsd");
  const HazardTrajectory tr = planned("pedestrian_crossing", crossing_spec(), 10.0);
  auto r = testing::StageRunner::create<XoscSink>("author: \"Test & Co\"");
  const fs::path file = write_through_sink(r, tr);
  const Validation v = validate(file);
  EXPECT_EQ(v.status, 0) << v.output;
  const std::string x = test::read_text(file.string());
  EXPECT_NE(x.find("<Pedestrian name=\"person\" mass=\"75\" pedestrianCategory=\"pedestrian\">"),
            std::string::npos);
  EXPECT_NE(x.find("author=\"Test &amp; Co\""), std::string::npos);
}

TEST(Xosc, WorldCoordinatesFromTheAnchorPose) {
  HF_REQUIRE_SHARED(test::shared_dir() / "schemas" / "OpenSCENARIOv1.2.xsd");
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
  // Ego at (100, 200, 1) heading +90 degrees (north) in the world.
  f.ego.T_world_ego = cv::Matx44d(0, -1, 0, 100, 1, 0, 0, 200, 0, 0, 1, 1, 0, 0, 0, 1);
  auto r = testing::StageRunner::create<XoscSink>("coordinates: world");
  const fs::path file = write_through_sink(r, tr, f);
  const Validation v = validate(file);
  EXPECT_EQ(v.status, 0) << v.output;
  const std::string x = test::read_text(file.string());
  EXPECT_NE(x.find("<WorldPosition x=\"100\" y=\"200\" z=\"1\" h=\"1.570796\" p=\"0\" r=\"0\"/>"),
            std::string::npos);
  // Truck centre 30 m ahead, rear axle 0.3 x 8 m behind it: 27.6 m north of the ego.
  EXPECT_NE(x.find("<WorldPosition x=\"100\" y=\"227.6\" z=\"1\" h=\"1.570796\" p=\"0\" r=\"0\"/>"),
            std::string::npos);

  auto no_pose = testing::StageRunner::create<XoscSink>("coordinates: world");
  Frame bare = f;
  bare.ego.T_world_ego.reset();
  try {
    write_through_sink(no_pose, tr, bare);
    FAIL();
  } catch (const Error& e) {
    EXPECT_EQ(std::string(e.what()),
              "xosc: coordinates 'world' needs the ego pose of the anchor frame (t=2 s); frame 12 "
              "carries none");
  }
}

TEST(Xosc, ValidationCatchesABrokenFile) {
  // The check above can fail: the same file without its mandatory StopTrigger is rejected.
  HF_REQUIRE_SHARED(test::shared_dir() / "schemas" / "OpenSCENARIOv1.2.xsd");
  const HazardTrajectory tr = planned("cut_in", cut_in_spec(), 20.0);
  XoscOptions opt;
  opt.date = "2024-01-01T00:00:00";
  std::string x = write_xosc(tr, opt);
  const size_t a = x.rfind("<StopTrigger>"), b = x.rfind("</StopTrigger>");
  ASSERT_NE(a, std::string::npos);
  x.erase(a, b + std::string("</StopTrigger>").size() - a);
  const fs::path file = fs::temp_directory_path() / "hf_broken.xosc";
  std::ofstream(file) << x;
  const Validation v = validate(file);
  EXPECT_NE(v.status, 0);
  EXPECT_NE(v.output.find("fails to validate"), std::string::npos) << v.output;
  fs::remove(file);
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
