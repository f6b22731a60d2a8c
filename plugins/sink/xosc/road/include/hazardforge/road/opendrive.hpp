// The scene's road as OpenDRIVE 1.6: one road on the fitted reference line with the scene's lanes.
#pragma once

#include <optional>
#include <string>
#include <vector>

#include "hazardforge/road/reference_line.hpp"

namespace hf::road {

// Lanes as the scene describes them from the ego's seat: lanes_left / lanes_right beside the ego lane. On a
// right-hand-traffic road the ego lane is the leftmost lane of its direction: the lanes on its right run the
// same way, those on its left (beyond the centre line) are oncoming; left-hand traffic mirrors that.
struct LaneLayout {
  double lane_width = 3.5;
  int lanes_left = 1, lanes_right = 1;
  bool left_hand_traffic = false;
  std::string edge_type;  // beyond both road edges: "" (nothing), "sidewalk" or "shoulder"
  double edge_width = 3.0;

  struct Lane {
    int id = 0;
    std::string type;    // OpenDRIVE lane type
    double t_inner = 0;  // lateral position of the border nearer the centre line (from the reference line)
    double t_outer = 0;
    double centre() const { return (t_inner + t_outer) / 2; }
  };
  // -1 (right-hand traffic) or +1 (left-hand traffic).
  int ego_lane() const { return left_hand_traffic ? 1 : -1; }
  // Lateral position of the centre line (lane 0) from the reference line, which runs along the ego lane's
  // centre.
  double lane_offset() const { return left_hand_traffic ? -lane_width / 2 : lane_width / 2; }
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
