// The scene's road as OpenDRIVE 1.6: one road on the fitted reference line with the scene's lanes.
#pragma once

#include <algorithm>
#include <optional>
#include <string>
#include <vector>

#include "hazardforge/road/reference_line.hpp"

namespace hf::road {

// Lanes as the scene describes them from the ego's seat: lanes_left / lanes_right beside the ego lane, of
// which the outermost oncoming_lanes on the side away from the driving side carry oncoming traffic (the road
// model of the hazard templates, hazard::RoadModel). On a right-hand-traffic road the centre line runs
// between the lanes going the ego's way and the oncoming ones on its left; left-hand traffic mirrors that.
// oncoming_lanes < 0: every lane on that side is oncoming (the ego in the leftmost lane of its direction;
// specs that do not say).
struct LaneLayout {
  double lane_width = 3.5;
  int lanes_left = 1, lanes_right = 1;
  bool left_hand_traffic = false;
  int oncoming_lanes = -1;
  std::string edge_type;  // beyond both road edges: "" (nothing), "sidewalk" or "shoulder"
  double edge_width = 3.0;

  struct Lane {
    int id = 0;
    std::string type;    // OpenDRIVE lane type
    double t_inner = 0;  // lateral position of the border nearer the centre line (from the reference line)
    double t_outer = 0;
    double centre() const { return (t_inner + t_outer) / 2; }
  };
  // Lanes between the ego lane and the centre line: those on the oncoming side that go the ego's way.
  int same_direction_beyond() const {
    const int side = left_hand_traffic ? lanes_right : lanes_left;
    return oncoming_lanes < 0 ? 0 : std::max(0, side - oncoming_lanes);
  }
  // The ego lane's id: -1 - same_direction_beyond() (right-hand traffic) or its mirror (left-hand traffic).
  int ego_lane() const { return (left_hand_traffic ? 1 : -1) * (1 + same_direction_beyond()); }
  // Lateral position of the centre line (lane 0) from the reference line, which runs along the ego lane's
  // centre.
  double lane_offset() const {
    return (left_hand_traffic ? -1 : 1) * lane_width * (0.5 + same_direction_beyond());
  }
  std::vector<Lane> lanes() const;
  std::optional<Lane> lane(int id) const;
  // The lane holding lateral position t (the outermost lane when t is beyond the road).
  Lane lane_at(double t) const;
};

struct OpenDriveInfo {
  std::string name = "road";
  std::string date;  // free text in OpenDRIVE; the xosc's date
  std::string vendor = "HazardForge";
};

// The .xodr text: header (bounding box of the road), road 1 (planView = the reference line's pieces, flat
// elevation), one lane section.
std::string write_opendrive(const ReferenceLine& line, const LaneLayout& lanes, const OpenDriveInfo& info);

}  // namespace hf::road
