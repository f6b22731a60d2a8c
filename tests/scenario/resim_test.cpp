// Exported scenarios re-simulated from their XML (resimulation.hpp): the ego triggers and meets the hazard.
#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <filesystem>
#include <iostream>
#include <map>
#include <memory>
#include <numbers>
#include <optional>
#include <string>
#include <vector>

#include "hazardforge/angles.hpp"
#include "hazardforge/hazard/ego_path.hpp"
#include "resimulation.hpp"
#include "scenario_support.hpp"
#include "xml_files.hpp"
#include "xosc_writer.hpp"

namespace hf {
namespace {

namespace fs = std::filesystem;
using resim::resimulate;
using resim::Result;

// ---- Cases
// ---------------------------------------------------------------------------------------------------

struct Case {
  std::string name;
  HazardTrajectory traj;
  XoscOptions opt;
};

// A left turn of radius r at speed v recorded at 2 Hz (world frame: starts at (100, 50) heading 30 degrees).
std::shared_ptr<EgoTrack> arc_track(double r, double v, double t_end) {
  const double h0 = kPi / 6;
  const double cx = 100 - r * std::sin(h0), cy = 50 + r * std::cos(h0);
  auto track = std::make_shared<EgoTrack>();
  track->source = "dataset";
  for (double t = 0; t <= t_end + 1e-9; t += 0.5) {
    const double turn = v * t / r;
    track->samples.push_back(
        {t, cx + r * std::sin(h0 + turn), cy - r * std::cos(h0 + turn), h0 + turn, v, v / r});
  }
  return track;
}

XoscOptions options(int lanes_left, int lanes_right, const std::string& edge = "") {
  XoscOptions o;
  o.date = "2024-01-01T00:00:00";
  o.lanes.lanes_left = lanes_left, o.lanes.lanes_right = lanes_right, o.lanes.edge_type = edge;
  return o;
}

struct Measured {
  Result nominal, slower, faster;
  XoscSummary summary;
};

Measured run_case(const Case& c) {
  const fs::path dir = test::unique_temp_dir();
  XoscOptions opt = c.opt;
  opt.road_file = "scenario.xodr";
  const XoscExport ex = export_scenario(c.traj, opt);
  test::write_text(dir / "scenario.xosc", ex.xosc);
  test::write_text(dir / "scenario.xodr", ex.xodr);
  const test::Validation vx = test::validate_xml(dir / "scenario.xosc", test::xosc_schema());
  EXPECT_TRUE(vx.ok()) << c.name << ": " << vx.output;
  const test::Validation vr = test::validate_xml(dir / "scenario.xodr", test::xodr_schema());
  EXPECT_TRUE(vr.ok()) << c.name << ": " << vr.output;
  Measured m;
  m.summary = ex.summary;
  m.nominal = resimulate(dir / "scenario.xosc", 1.0);
  m.slower = resimulate(dir / "scenario.xosc", 0.8);
  m.faster = resimulate(dir / "scenario.xosc", 1.2);
  std::cout << c.name << ": trigger " << ex.summary.trigger << " " << ex.summary.trigger_value << " fires at "
            << m.nominal.trigger_time << " s (planned " << ex.summary.trigger_time << " s); minimum TTC "
            << m.nominal.min_ttc << " s at " << m.nominal.min_ttc_time << " s (plan "
            << c.traj.intended_min_ttc_s << " s at " << ex.summary.critical_time << " s); ego x0.8: trigger "
            << m.slower.trigger_time << " s, min TTC " << m.slower.min_ttc << " s; ego x1.2: trigger "
            << m.faster.trigger_time << " s, min TTC " << m.faster.min_ttc << " s\n";
  fs::remove_all(dir);
  return m;
}

void expect_meets(const Case& c, const Measured& m) {
  EXPECT_TRUE(m.nominal.triggered) << c.name;
  EXPECT_NEAR(m.nominal.trigger_time, m.summary.trigger_time, 0.1) << c.name;
  EXPECT_NEAR(m.nominal.min_ttc, c.traj.intended_min_ttc_s, 0.3) << c.name;
  // The plans' egos drive at a constant speed, as the re-simulated one does: the critical moment comes when
  // planned.
  EXPECT_NEAR(m.nominal.min_ttc_time, m.summary.critical_time, 0.3) << c.name;
  // An ego 20 % slower or faster still meets the hazard: it is triggered and the scene becomes Unsafe (TTC
  // below 1.5 s, the protocol's threshold).
  for (const Result* r : {&m.slower, &m.faster}) {
    EXPECT_TRUE(r->triggered) << c.name;
    EXPECT_LT(r->min_ttc, 1.5) << c.name;
  }
}

HazardTrajectory plan(const std::string& kind, const HazardSpec& spec, const SceneContext& scene) {
  return test::make_template(kind)->plan(spec, scene);
}

TEST(Resimulation, CutInFromTheLeftLane) {
  HF_REQUIRE_SHARED(test::xosc_schema());
  HazardSpec s;
  s.kind = "cut_in", s.object_class = "car", s.initial_distance_m = -3, s.side = "left", s.speed_mps = 26;
  s.target_ttc_s = 1.2;
  const Case c{"cut_in", plan("cut_in", s, test::test_scene(20.0)), options(1, 1)};
  expect_meets(c, run_case(c));
}

TEST(Resimulation, SuddenStopOfATruckAhead) {
  HF_REQUIRE_SHARED(test::xosc_schema());
  HazardSpec s;
  s.kind = "sudden_stop", s.object_class = "truck", s.initial_distance_m = 30, s.speed_mps = 15;
  s.deceleration_mps2 = 6;
  const Case c{"sudden_stop", plan("sudden_stop", s, test::test_scene(15.0)), options(1, 1)};
  expect_meets(c, run_case(c));
}

TEST(Resimulation, ParametersSweepTheStory) {
  // The declared parameters drive the story: a trigger 15 m further on starts the braking 1 s later (ego at
  // 15 m/s), a harder deceleration brings the contact earlier.
  HF_REQUIRE_SHARED(test::xosc_schema());
  HazardSpec s;
  s.kind = "sudden_stop", s.object_class = "truck", s.initial_distance_m = 30, s.speed_mps = 15;
  s.deceleration_mps2 = 6;
  XoscOptions opt = options(1, 1);
  const XoscExport ex = export_scenario(plan("sudden_stop", s, test::test_scene(15.0)), opt);
  const fs::path dir = test::unique_temp_dir();
  test::write_text(dir / "scenario.xodr", ex.xodr);
  auto with = [&](const std::string& name, const std::string& value) {
    std::string x = ex.xosc;
    const std::string key = "<ParameterDeclaration name=\"" + name + "\" parameterType=\"double\" value=\"";
    const size_t a = x.find(key) + key.size();
    x.replace(a, x.find('"', a) - a, value);
    test::write_text(dir / "scenario.xosc", x);
    return resimulate(dir / "scenario.xosc", 1.0);
  };
  const Result base = with("HazardDeceleration", "6");
  const Result later = with("TriggerValue", std::to_string(ex.summary.trigger_value + 15));
  const Result harder = with("HazardDeceleration", "9");
  EXPECT_NEAR(later.trigger_time - base.trigger_time, 1.0, 0.02);
  EXPECT_LT(harder.min_ttc_time, base.min_ttc_time - 0.1);
  std::cout << "sweep: trigger " << base.trigger_time << " -> " << later.trigger_time << " s; contact at "
            << base.min_ttc_time << " s, with 9 m/s^2 at " << harder.min_ttc_time << " s\n";
  fs::remove_all(dir);
}

TEST(Resimulation, PedestrianFromTheRightSidewalk) {
  HF_REQUIRE_SHARED(test::xosc_schema());
  HazardSpec s;
  s.kind = "pedestrian_crossing", s.object_class = "person", s.initial_distance_m = 50, s.side = "right";
  s.speed_mps = 1.5, s.target_ttc_s = 1.5;
  const Case c{"pedestrian_crossing", plan("pedestrian_crossing", s, test::test_scene(10.0)),
               options(1, 0, "sidewalk")};
  expect_meets(c, run_case(c));
}

TEST(Resimulation, PedestrianInABendOfTheRecordedPath) {
  // The road follows a recorded left turn (radius 120 m): the point-mass ego that only keeps its lane drives
  // the recorded path, and the walker still meets it.
  HF_REQUIRE_SHARED(test::xosc_schema());
  SceneContext scene = test::test_scene(8.0, 4.0);
  scene.ego_track = arc_track(120, 8, 16);
  HazardSpec s;
  s.kind = "pedestrian_crossing", s.object_class = "person", s.initial_distance_m = 45, s.side = "right";
  s.speed_mps = 1.4, s.target_ttc_s = 1.4;
  Case c{"pedestrian_crossing_bend", plan("pedestrian_crossing", s, scene), options(1, 0, "sidewalk")};
  c.opt.ego_path = hazard::EgoPath::recorded(scene.ego_track->samples, 4.0, "test");
  const Measured m = run_case(c);
  expect_meets(c, m);
  // The lane-keeping ego drives the recorded path: within a few centimetres of the plan's ego (the anchor
  // frame is the world here) while both exist.
  double worst = 0;
  for (const TrajectoryPoint& p : c.traj.ego) {
    const long k = std::lround((p.t - m.summary.start_stream_time) / 0.01);
    if (k < 0 || k >= static_cast<long>(m.nominal.ego_xy.size())) continue;
    const auto& [time, x, y] = m.nominal.ego_xy[static_cast<size_t>(k)];
    worst = std::max(worst, std::hypot(p.x - x, p.y - y));
  }
  std::cout << "ego on the road vs the recorded path: " << worst << " m\n";
  EXPECT_LT(worst, 0.1);
}

TEST(Resimulation, ReplayedEgoThatSpeedsUpMeetsThePedestrianWhenPlanned) {
  // A recording in which the ego speeds up (6 m/s + 0.5 m/s^2, straight): the controlled ego keeps its
  // initial speed and comes late; the replayed one follows the recording and meets the walker when the plan
  // says.
  HF_REQUIRE_SHARED(test::xosc_schema());
  auto track = std::make_shared<EgoTrack>();
  for (double t = 0; t <= 16 + 1e-9; t += 0.5)
    track->samples.push_back({t, 20 + 6 * t + 0.25 * t * t, -10.0, 0.0, 6 + 0.5 * t, 0.0});
  SceneContext scene = test::test_scene(8.0, 4.0);
  scene.ego_track = track;
  HazardSpec s;
  s.kind = "pedestrian_crossing", s.object_class = "person", s.initial_distance_m = 60, s.side = "right";
  s.speed_mps = 1.4, s.target_ttc_s = 1.4;
  Case c{"pedestrian_crossing_replay", plan("pedestrian_crossing", s, scene), options(1, 0, "sidewalk")};
  c.opt.ego_path = hazard::EgoPath::recorded(track->samples, 4.0, "test");
  c.opt.ego_mode = "replay";
  const fs::path dir = test::unique_temp_dir();
  const XoscExport ex = export_scenario(c.traj, c.opt);
  test::write_text(dir / "scenario.xosc", ex.xosc);
  test::write_text(dir / "scenario.xodr", ex.xodr);
  const test::Validation v = test::validate_xml(dir / "scenario.xosc", test::xosc_schema());
  EXPECT_TRUE(v.ok()) << v.output;
  const Result replayed = resimulate(dir / "scenario.xosc", 1.0);
  c.opt.ego_mode = "controlled";
  test::write_text(dir / "scenario.xosc", export_scenario(c.traj, c.opt).xosc);
  const Result constant = resimulate(dir / "scenario.xosc", 1.0);
  std::cout << "replay: trigger " << replayed.trigger_time << " s, minimum TTC " << replayed.min_ttc
            << " s at " << replayed.min_ttc_time << " s; constant speed: trigger " << constant.trigger_time
            << " s, at " << constant.min_ttc_time << " s; planned: trigger " << ex.summary.trigger_time
            << " s, critical " << ex.summary.critical_time << " s\n";
  EXPECT_NEAR(replayed.trigger_time, ex.summary.trigger_time, 0.1);
  EXPECT_NEAR(replayed.min_ttc, c.traj.intended_min_ttc_s, 0.3);
  EXPECT_NEAR(replayed.min_ttc_time, ex.summary.critical_time, 0.3);
  EXPECT_GT(constant.min_ttc_time, ex.summary.critical_time + 0.3);
  fs::remove_all(dir);
}

}  // namespace
}  // namespace hf
