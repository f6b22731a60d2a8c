// Road geometry: reference-line fits of known paths, lanes from scene facts, OpenDRIVE schema validation.
#include <gtest/gtest.h>

#include <cmath>
#include <numbers>

#include "hazardforge/angles.hpp"
#include "hazardforge/road/opendrive.hpp"
#include "hazardforge/road/reference_line.hpp"
#include "xml_files.hpp"

namespace hf {
namespace {

using road::PathPoint;
using road::ReferenceLine;

// Points every `step` metres along a path given by its curvature as a function of arc length (exact
// integration of heading, fine Euler steps for position).
std::vector<PathPoint> path_of(double length, double step, double (*curvature)(double), double x0 = 0,
                               double y0 = 0, double h0 = 0) {
  std::vector<PathPoint> out{{x0, y0}};
  double x = x0, y = y0, h = h0, next = step;
  const double ds = 0.001;
  for (double s = 0; s < length - 1e-9; s += ds) {
    const double hm = h + curvature(s + ds / 2) * ds / 2;
    x += std::cos(hm) * ds, y += std::sin(hm) * ds;
    h += curvature(s + ds / 2) * ds;
    if (s + ds >= next - 1e-9) out.push_back({x, y}), next += step;
  }
  if (std::hypot(out.back().x - x, out.back().y - y) > 1e-3) out.push_back({x, y});
  return out;
}

// Largest distance from the fitted line to the path (both ways: path points to the line, line to the path).
double max_deviation(const ReferenceLine& line, const std::vector<PathPoint>& path) {
  double worst = 0;
  for (const PathPoint& p : path) {
    const PathPoint st = line.to_st(p.x, p.y);
    const PathPoint q = line.to_xy(st.x, 0);
    worst = std::max(worst, std::hypot(p.x - q.x, p.y - q.y));
  }
  return worst;
}

TEST(RoadFit, StraightPathIsOneLine) {
  const auto path = path_of(
      120, 1.0, [](double) { return 0.0; }, 10, -5, 0.7);
  const ReferenceLine line = ReferenceLine::fit(path);
  ASSERT_EQ(line.geometries().size(), 2u);  // 120 m in pieces of at most 60 m
  for (const auto& g : line.geometries()) EXPECT_TRUE(g.line);
  EXPECT_NEAR(line.length(), 120, 0.01);
  EXPECT_LT(max_deviation(line, path), 0.005);
  const road::RoadPose end = line.at(120);
  EXPECT_NEAR(end.hdg, 0.7, 1e-6);
}

TEST(RoadFit, ConstantCurvatureArcWithinTwoCentimetres) {
  // A quarter circle of radius 40 m.
  const double r = 40;
  const auto path = path_of(r * kPi / 2, 0.5, [](double) { return 1.0 / 40; });
  const ReferenceLine line = ReferenceLine::fit(path);
  EXPECT_LT(max_deviation(line, path), 0.02);
  EXPECT_NEAR(line.length(), r * kPi / 2, 0.05);
  // Heading at the end: 90 degrees; the centre of the circle stays 40 m from every point of the line.
  EXPECT_NEAR(line.at(line.length()).hdg, kPi / 2, 0.01);
  for (double s = 0; s < line.length(); s += 1.7) {
    const PathPoint p = line.to_xy(s, 0);
    EXPECT_NEAR(std::hypot(p.x, p.y - r), r, 0.02) << "s=" << s;
  }
  // Lateral offsets are measured along the normal: t = 2 m to the left is 38 m from the centre.
  const PathPoint inner = line.to_xy(20, 2.0);
  EXPECT_NEAR(std::hypot(inner.x, inner.y - r), r - 2, 0.02);
  const PathPoint st = line.to_st(inner.x, inner.y);
  EXPECT_NEAR(st.x, 20, 0.02);
  EXPECT_NEAR(st.y, 2.0, 0.01);
}

TEST(RoadFit, SBendWithinTwoCentimetres) {
  // Straight 20 m, left arc (R 30 m) 25 m, right arc (R 30 m) 25 m, straight 20 m: heading returns to 0.
  auto kappa = [](double s) { return s < 20 ? 0.0 : s < 45 ? 1.0 / 30 : s < 70 ? -1.0 / 30 : 0.0; };
  const auto path = path_of(90, 0.5, kappa);
  const ReferenceLine line = ReferenceLine::fit(path);
  EXPECT_LT(max_deviation(line, path), 0.02);
  EXPECT_NEAR(line.length(), 90, 0.1);
  EXPECT_NEAR(line.at(line.length()).hdg, 0.0, 0.01);
  // Heading is continuous across the pieces (G1).
  for (size_t k = 1; k < line.geometries().size(); ++k) {
    const double s = line.geometries()[k].s;
    EXPECT_NEAR(angle_diff(line.at(s - 0.01).hdg, line.at(s + 0.01).hdg), 0, 0.005);
  }
  EXPECT_GE(line.geometries().size(), 3u);
}

TEST(RoadFit, RefusesADegeneratePath) {
  EXPECT_THROW(ReferenceLine::fit({{1, 1}, {1, 1}}), std::invalid_argument);
}

TEST(RoadLanes, RightHandTrafficPutsTheEgoInTheLeftmostLaneOfItsDirection) {
  road::LaneLayout l;
  l.lane_width = 3.5, l.lanes_left = 1, l.lanes_right = 2, l.edge_type = "sidewalk", l.edge_width = 3;
  EXPECT_EQ(l.ego_lane(), -1);
  EXPECT_DOUBLE_EQ(l.lane_offset(), 1.75);
  EXPECT_NEAR(l.lane(-1)->centre(), 0.0, 1e-12);
  EXPECT_NEAR(l.lane(1)->centre(), 3.5, 1e-12);  // oncoming, beyond the centre line
  EXPECT_NEAR(l.lane(-3)->centre(), -7.0, 1e-12);
  EXPECT_EQ(l.lane(-4)->type, "sidewalk");
  EXPECT_EQ(l.lane(2)->type, "sidewalk");
  EXPECT_EQ(l.lane_at(-9.0).id, -4);
  EXPECT_EQ(l.lane_at(0.3).id, -1);
  l.left_hand_traffic = true;
  EXPECT_EQ(l.ego_lane(), 1);
  EXPECT_NEAR(l.lane(2)->centre(), 3.5, 1e-12);    // same direction on the left
  EXPECT_NEAR(l.lane(-1)->centre(), -3.5, 1e-12);  // oncoming on the right
}

// With the scene's oncoming_lanes (the templates' road model), lanes beside the ego that go its way stay on
// its side of the centre line; only the outermost oncoming ones lie beyond it.
TEST(RoadLanes, OnlyTheOncomingLanesLieBeyondTheCentreLine) {
  road::LaneLayout l;
  l.lane_width = 3.5, l.lanes_left = 2, l.lanes_right = 1, l.edge_type = "sidewalk", l.edge_width = 3;
  l.oncoming_lanes = 1;  // right-hand traffic: of the two lanes on the left, the outer one is oncoming
  EXPECT_EQ(l.ego_lane(), -2);
  EXPECT_DOUBLE_EQ(l.lane_offset(), 5.25);
  EXPECT_NEAR(l.lane(-2)->centre(), 0.0, 1e-12);
  EXPECT_NEAR(l.lane(-1)->centre(), 3.5, 1e-12);  // the ego's way, left of it
  EXPECT_NEAR(l.lane(1)->centre(), 7.0, 1e-12);   // oncoming
  EXPECT_EQ(l.lane(2)->type, "sidewalk");
  EXPECT_EQ(l.lane(-4)->type, "sidewalk");
  EXPECT_EQ(l.lane_at(3.2).id, -1);
  l.oncoming_lanes = 0;  // a one-way road: no lane beyond the centre line
  EXPECT_EQ(l.ego_lane(), -3);
  EXPECT_EQ(l.lane(1)->type, "sidewalk");
  EXPECT_NEAR(l.lane(-1)->centre(), 7.0, 1e-12);
  l.left_hand_traffic = true, l.lanes_left = 1, l.lanes_right = 2, l.oncoming_lanes = 2;  // mirrored
  EXPECT_EQ(l.ego_lane(), 1);
  EXPECT_NEAR(l.lane(-1)->centre(), -3.5, 1e-12);
  l.oncoming_lanes = 1;
  EXPECT_EQ(l.ego_lane(), 2);
  EXPECT_NEAR(l.lane(1)->centre(), -3.5, 1e-12);  // the ego's way, right of it
  EXPECT_NEAR(l.lane(-1)->centre(), -7.0, 1e-12);
}

TEST(RoadOpenDrive, AOneWayRoadValidatesAgainstTheSchema) {
  HF_REQUIRE_SHARED(test::xodr_schema());
  const ReferenceLine line = ReferenceLine::fit(path_of(
      60, 0.5, [](double) { return 0.0; }, 0, 0, 0));
  road::LaneLayout l;
  l.lanes_left = 1, l.lanes_right = 1, l.oncoming_lanes = 0, l.edge_type = "sidewalk";
  const std::string text = road::write_opendrive(line, l, {"one way", "2024-01-01T00:00:00"});
  const auto dir = test::unique_temp_dir();
  test::write_text(dir / "road.xodr", text);
  const test::Validation v = test::validate_xml(dir / "road.xodr", test::xodr_schema());
  EXPECT_TRUE(v.ok()) << v.output;
  EXPECT_NE(text.find("<lane id=\"-3\" type=\"driving\""), std::string::npos) << text;
  std::filesystem::remove_all(dir);
}

TEST(RoadOpenDrive, ArcRoadValidatesAgainstTheSchema) {
  HF_REQUIRE_SHARED(test::xodr_schema());
  const auto path = path_of(
      80, 0.5, [](double s) { return s < 30 ? 0.0 : 1.0 / 50; }, 1000, 2000, 1.2);
  const ReferenceLine line = ReferenceLine::fit(path);
  road::LaneLayout l;
  l.lanes_left = 1, l.lanes_right = 0, l.edge_type = "sidewalk", l.left_hand_traffic = true;
  const std::string text = road::write_opendrive(line, l, {"scenario & road", "2024-01-01T00:00:00"});
  const auto dir = test::unique_temp_dir();
  test::write_text(dir / "road.xodr", text);
  const test::Validation v = test::validate_xml(dir / "road.xodr", test::xodr_schema());
  EXPECT_TRUE(v.ok()) << v.output;
  EXPECT_NE(text.find("rule=\"LHT\""), std::string::npos);
  EXPECT_NE(text.find("<line/>"), std::string::npos);
  EXPECT_NE(text.find("pRange=\"normalized\""), std::string::npos);
  EXPECT_NE(text.find("type=\"sidewalk\""), std::string::npos);
  EXPECT_NE(text.find("name=\"scenario &amp; road\""), std::string::npos);
  // The same text with a lane that has no id fails: the check can fail.
  std::string broken = text;
  broken.replace(broken.find("<lane id=\"1\""), std::string("<lane id=\"1\"").size(), "<lane");
  test::write_text(dir / "broken.xodr", broken);
  EXPECT_FALSE(test::validate_xml(dir / "broken.xodr", test::xodr_schema()).ok());
  std::filesystem::remove_all(dir);
}

}  // namespace
}  // namespace hf
