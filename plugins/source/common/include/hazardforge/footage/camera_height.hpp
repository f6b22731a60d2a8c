// Camera height above the road (the metric scale of a monocular clip) from the spacing of the lane lines, and
// the lane markings those lines are.
#pragma once

#include <memory>
#include <optional>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "hazardforge/types.hpp"

namespace hf::footage {

struct HeightEstimate {
  double height_m = 0;      // camera height that makes the ego lane lane_width_m wide
  double sigma_m = 0;       // 1-sigma: the spread of real lane widths and of the per-frame measurements
  double confidence = 0;    // 0..1: min(1, frames_used / full_confidence_frames) x agreement of the frames
  int frames_used = 0;      // frames in which both lines of the ego lane were found
  int frames_seen = 0;
  double lane_width_at_assumed_height_m = 0;  // median ego-lane width measured with the camera's stated height
  double frame_spread = 0;  // relative spread (scaled MAD / median) of the per-frame lane widths
  std::string note;         // how it was obtained (assumed lane width, frames)
};

struct HeightOptions {
  // Centre-to-centre spacing of the lane lines assumed for the ego lane. Motorway and trunk-road lanes are
  // 3.5-3.75 m in most countries (US interstate 12 ft = 3.66 m, EU motorways 3.5-3.75 m), urban lanes 3.0-3.5 m;
  // the spacing measured between line centres adds a line width (0.10-0.15 m) to the kerb-to-kerb lane width.
  double lane_width_m = 3.6;
  double lane_width_sigma_m = 0.2;  // the spread of that assumption (enters sigma_m, not the estimate)
  // Bird's-eye view of the road searched for lines (metres ahead of the camera and to each side).
  double near_m = 4.0;
  double far_m = 20.0;
  double half_width_m = 6.0;
  double resolution_m = 0.05;
  double horizon_margin_deg = 2.0;
  double bonnet_fraction = 0.12;       // bottom fraction of the image never used (bonnet, dashboard reflections)
  // A lane line is a ridge: brighter than the road ridge_offset_m to both sides by min_contrast grey levels.
  double ridge_offset_m = 0.25;
  double min_contrast = 12.0;
  // A line must cover this fraction of the searched length (a 3 m dash in 12 m of cycle covers 25 %).
  double min_line_fill = 0.12;
  // A vehicle ahead leaves bright streaks in the view that start at its wheels; a line counts only if at least
  // min_near_support_m of it shows in the nearest near_support_m of the visible road (a dash or a piece of one).
  double near_support_m = 4.5;
  double min_near_support_m = 0.5;
  double max_heading_deg = 12.0;      // lines are searched at headings within +- this of the ego's axis
  // The ego lane's measured width may be at most this factor away from lane_width_m (camera height within
  // 1/max_ratio .. max_ratio times the stated one).
  double max_ratio = 2.0;
  int min_frames = 5;
  int full_confidence_frames = 15;
  double max_frame_spread = 0.15;     // per-frame widths scattering more than this (relative) give no estimate
  // Lane markings (markings()): the ego lane's line on a side is solid when it fills at least min_solid_fill
  // of the visible view's rows in the median frame, dashed when at most max_dashed_fill (a 3 m dash in a 12 m
  // cycle fills a quarter, 3 m in 6 m a half); a side says nothing unless its line was found in min_frames
  // frames and min_marking_share of the frames (a further dashed line beyond counts in that share of those
  // frames).
  double min_solid_fill = 0.75;
  double max_dashed_fill = 0.6;
  double min_marking_share = 0.2;
};

// Accumulates lane-line spacings over a clip. `camera` carries K, pitch and roll (e.g. from HorizonEstimator) and
// a stated or default height; distances in its bird's-eye view scale with that height, so the ego lane's measured
// width w gives height = stated_height * lane_width_m / w. Frames must be undistorted.
class CameraHeightEstimator {
 public:
  explicit CameraHeightEstimator(const CameraModel& camera, HeightOptions opt = {});
  void add(const cv::Mat& bgr);
  // Ego-lane width (at the camera's stated height) measured in the last frame added, if both lines were found.
  std::optional<double> last_lane_width() const;
  // nullopt when fewer than min_frames frames showed both lines of the ego lane or they disagreed.
  std::optional<HeightEstimate> result() const;
  // The lane markings the frames showed beside the ego lane: each side's line (solid or dashed, white or
  // yellow) and the lanes beyond it (0 beyond a solid line; 1 beyond a dashed one, 2 when a further dashed
  // line follows a lane width on). nullopt before any frame.
  std::optional<RoadMarkings> markings() const;
  ~CameraHeightEstimator();
  CameraHeightEstimator(CameraHeightEstimator&&) noexcept;
  CameraHeightEstimator& operator=(CameraHeightEstimator&&) noexcept;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

// Convenience: all frames at once.
std::optional<HeightEstimate> estimate_camera_height(const std::vector<cv::Mat>& frames, const CameraModel& camera,
                                                     HeightOptions opt = {});

// The camera with its height replaced (K, pitch, roll and forward offset kept).
CameraModel with_height(const CameraModel& camera, double height_m);

}  // namespace hf::footage
