// OpenDRIVE 1.6 text for a fitted reference line and the scene's lanes.
#include "hazardforge/road/opendrive.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

#include "hazardforge/road/xml.hpp"

namespace hf::road {

std::vector<LaneLayout::Lane> LaneLayout::lanes() const {
  std::vector<Lane> out;
  const double c = lane_offset();
  // Driving lanes per side of the centre line, nearest first; then the edge lane.
  const int beyond = same_direction_beyond();
  const int left_driving = left_hand_traffic ? 1 + lanes_left + beyond : lanes_left - beyond;
  const int right_driving = left_hand_traffic ? lanes_right - beyond : 1 + lanes_right + beyond;
  for (int side : {1, -1}) {
    const int n = side > 0 ? left_driving : right_driving;
    double t = c;
    for (int k = 1; k <= n; ++k) {
      out.push_back({side * k, "driving", t, t + side * lane_width});
      t += side * lane_width;
    }
    if (!edge_type.empty()) out.push_back({side * (n + 1), edge_type, t, t + side * edge_width});
  }
  return out;
}

std::optional<LaneLayout::Lane> LaneLayout::lane(int id) const {
  for (const Lane& l : lanes())
    if (l.id == id) return l;
  return std::nullopt;
}

LaneLayout::Lane LaneLayout::lane_at(double t) const {
  const std::vector<Lane> all = lanes();
  const Lane* best = nullptr;
  double best_d = std::numeric_limits<double>::infinity();
  for (const Lane& l : all) {
    const double lo = std::min(l.t_inner, l.t_outer), hi = std::max(l.t_inner, l.t_outer);
    const double d = t < lo ? lo - t : t > hi ? t - hi : 0.0;
    if (d < best_d) best_d = d, best = &l;
  }
  return best ? *best : Lane{};
}

namespace {

void road_mark(XmlWriter& x, const std::string& type) {
  x.empty("roadMark", {{"sOffset", "0"},
                       {"type", type},
                       {"weight", "standard"},
                       {"color", "standard"},
                       {"width", "0.12"},
                       {"laneChange", type == "broken" ? "both" : "none"}});
}

void lane_element(XmlWriter& x, const LaneLayout::Lane& l, int driving_on_side) {
  x.open("lane", {{"id", std::to_string(l.id)}, {"type", l.type}, {"level", "false"}});
  x.empty("link");
  x.empty("width", {{"sOffset", "0"},
                    {"a", xml_num(std::abs(l.t_outer - l.t_inner), 4)},
                    {"b", "0"},
                    {"c", "0"},
                    {"d", "0"}});
  // The mark on the lane's outer border: broken between lanes of one direction, solid at the road edge.
  const bool last_driving = std::abs(l.id) == driving_on_side;
  road_mark(x, l.type != "driving" ? "none" : last_driving ? "solid" : "broken");
  x.close();
}

}  // namespace

std::string write_opendrive(const ReferenceLine& line, const LaneLayout& layout, const OpenDriveInfo& info) {
  double x0 = std::numeric_limits<double>::infinity(), y0 = x0, x1 = -x0, y1 = -x0;
  const std::vector<LaneLayout::Lane> lanes = layout.lanes();
  double reach = 0;
  for (const auto& l : lanes) reach = std::max({reach, std::abs(l.t_inner), std::abs(l.t_outer)});
  for (double s = 0; s <= line.length() + 1e-9; s += std::max(1.0, line.length() / 200)) {
    for (double t : {-reach, reach}) {
      const PathPoint p = line.to_xy(s, t);
      x0 = std::min(x0, p.x), x1 = std::max(x1, p.x), y0 = std::min(y0, p.y), y1 = std::max(y1, p.y);
    }
  }
  XmlWriter x;
  x.open("OpenDRIVE");
  XmlAttrs header = {{"revMajor", "1"}, {"revMinor", "6"}, {"name", info.name}, {"version", "1"}};
  if (!info.date.empty()) header.push_back({"date", info.date});
  header.insert(header.end(), {{"north", xml_num(y1, 3)},
                               {"south", xml_num(y0, 3)},
                               {"east", xml_num(x1, 3)},
                               {"west", xml_num(x0, 3)},
                               {"vendor", info.vendor}});
  x.empty("header", header);
  x.open("road", {{"name", info.name},
                  {"length", xml_num(line.length(), 6)},
                  {"id", "1"},
                  {"junction", "-1"},
                  {"rule", layout.left_hand_traffic ? "LHT" : "RHT"}});
  x.empty("link");
  x.open("planView");
  for (const Geometry& g : line.geometries()) {
    x.open("geometry", {{"s", xml_num(g.s, 6)},
                        {"x", xml_num(g.x, 6)},
                        {"y", xml_num(g.y, 6)},
                        {"hdg", xml_num(g.hdg, 9)},
                        {"length", xml_num(g.length, 6)}});
    if (g.line)
      x.empty("line");
    else
      x.empty("paramPoly3", {{"aU", "0"},
                             {"bU", xml_num(g.bu, 9)},
                             {"cU", xml_num(g.cu, 9)},
                             {"dU", xml_num(g.du, 9)},
                             {"aV", "0"},
                             {"bV", xml_num(g.bv, 9)},
                             {"cV", xml_num(g.cv, 9)},
                             {"dV", xml_num(g.dv, 9)},
                             {"pRange", "normalized"}});
    x.close();
  }
  x.close();  // planView
  x.open("elevationProfile");
  x.empty("elevation", {{"s", "0"}, {"a", "0"}, {"b", "0"}, {"c", "0"}, {"d", "0"}});
  x.close();
  x.open("lanes");
  x.empty("laneOffset",
          {{"s", "0"}, {"a", xml_num(layout.lane_offset(), 4)}, {"b", "0"}, {"c", "0"}, {"d", "0"}});
  x.open("laneSection", {{"s", "0"}});
  int driving_left = 0, driving_right = 0;
  for (const auto& l : lanes) {
    int& n = l.id > 0 ? driving_left : driving_right;
    if (l.type == "driving") n = std::max(n, std::abs(l.id));
  }
  std::vector<LaneLayout::Lane> left, right;
  for (const auto& l : lanes) (l.id > 0 ? left : right).push_back(l);
  std::sort(left.begin(), left.end(), [](const auto& a, const auto& b) { return a.id > b.id; });
  std::sort(right.begin(), right.end(), [](const auto& a, const auto& b) { return a.id > b.id; });
  if (!left.empty()) {
    x.open("left");
    for (const auto& l : left) lane_element(x, l, driving_left);
    x.close();
  }
  x.open("center");
  x.open("lane", {{"id", "0"}, {"type", "none"}, {"level", "false"}});
  x.empty("link");
  // Between the two directions when both exist, else the edge of the only one.
  road_mark(x, "solid");
  x.close();
  x.close();
  if (!right.empty()) {
    x.open("right");
    for (const auto& l : right) lane_element(x, l, driving_right);
    x.close();
  }
  x.close();  // laneSection
  x.close();  // lanes
  x.close();  // road
  x.close();  // OpenDRIVE
  return x.str();
}

}  // namespace hf::road
