// Risk metric "lidar_ttc": the lead vehicle's range from Velodyne points inside its camera box, and its TTC.
#pragma once

#include <deque>
#include <filesystem>
#include <map>
#include <string>
#include <utility>
#include <vector>

#include "hazardforge/corridor.hpp"
#include "hazardforge/stage.hpp"
#include "lidar_range.hpp"
#include "velodyne.hpp"

namespace hf {

// Risk metric "lidar_ttc" (kind risk_metric; a reference for camera TTC on KITTI raw, not a RiskMetric
// subclass because its boxes may come from detections).
// Ports: frames (Frame; its image name, or meta.kitti_frame, names the scan <velodyne_dir>/<stem>.bin)
//   + states (ObjectStates, optional) or detections (Detections, optional): exactly one of them per frame
//   gives the boxes -> risk (RiskAssessment: one ObjectRisk per box, value = that object's lidar TTC; scene
//   value = the lead's TTC, critical track = the lead) and range (Record "lidar_range": every box's range,
//   point count and lateral offset, the lead and its TTC). Both are stamped with the frame's time.
// Method: Velodyne points above `ground_z` are projected with P2 R0_rect Tr_velo_to_cam; a point inside
//   exactly one box shrunk by `box_shrink` belongs to it; a box's range is the median of its k_closest
//   nearest points (or a percentile) when it has min_points points. The lead is the in-path box (hf::Corridor
//   on the range and the points' median lateral offset, object width 0, so the default half-width 1.0 +
//   margin 0.5 keeps boxes within 1.5 m; along the ego's arc when the frame carries speed and yaw rate) with
//   the smallest range. Each object's TTC comes from its
//   range history (track id with states; the lead with detections) under a constant closing speed, fitted
//   over the last `window` ranges: TTC = d_t / closing, infinite when closing <= min_closing_mps, unknown
//   (NaN) before two ranges. A range jump above max_range_jump_m or a gap above max_gap_s restarts the
//   history.
// Params: velodyne_dir | velodyne_archive, calib, box_shrink, ground_z, range_axis, range_statistic,
//   k_closest, percentile, min_points, corridor_half_width, corridor_margin, corridor_path, window,
//   min_closing_mps, max_range_jump_m, max_gap_s, threshold.
class LidarTtcMetric : public Stage {
 public:
  static ComponentInfo describe();
  void open(StageContext& ctx) override;
  void process(StageContext& ctx, const Inputs& in, Outputs& out) override;

 private:
  struct History {
    std::vector<std::pair<double, double>> samples;  // (time, range), oldest first, at most `window`
  };
  std::filesystem::path scan_file(const Frame& f) const;
  // Appends a range to an id's history (restarting it after a jump or gap) and returns its TTC.
  lidar::CvTtc update(std::map<int64_t, History>& hist, int64_t id, double t, double range);

  std::filesystem::path velodyne_dir_;
  lidar::LidarCalibration calib_;
  lidar::RangeOptions range_;
  Corridor corridor_;
  int window_ = 2;
  double min_closing_ = 0.1;
  double max_jump_ = 2.0;
  double max_gap_ = 0.25;
  double threshold_ = 1.5;
  std::map<int64_t, History> tracks_;  // by track id (states)
  std::map<int64_t, History> lead_;    // the single lead history (detections), key 0
};

}  // namespace hf
