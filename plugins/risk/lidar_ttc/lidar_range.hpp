// Lidar range of objects seen in camera boxes, and the constant-velocity TTC of a range history. Pure
// functions.
#pragma once

#include <cmath>
#include <utility>
#include <vector>

#include <opencv2/core.hpp>

#include "velodyne.hpp"

namespace hf::lidar {

enum class RangeAxis {
  kCamera,  // depth along camera 2's optical axis (the camera metrics' distance reference)
  kLidar    // Velodyne x (forward), as in the classic camera/lidar exercise
};
enum class RangeStatistic {
  kClosestMedian,  // median of the k points with the smallest range
  kPercentile      // the p-th percentile of all the box's ranges
};

struct RangeOptions {
  double box_shrink = 0.10;  // fraction of the box width and height removed, half on each side
  double ground_z = -1.5;    // Velodyne z (m, up; the sensor is ~1.73 m above the road): below = road
  RangeAxis axis = RangeAxis::kCamera;
  RangeStatistic statistic = RangeStatistic::kClosestMedian;
  int k_closest = 20;
  double percentile = 10.0;  // 0..100
  int min_points = 10;       // fewer points in a box = no range
};

// Camera depth below which a point is not projected (m): nothing of interest is that close to the camera.
inline constexpr double kMinDepth = 0.5;

// A Velodyne point above the road and in front of camera 2, with its pixel in image_02.
struct ImagePoint {
  cv::Point2d px;
  double range = 0;    // along the chosen axis, m
  double lateral = 0;  // left of camera 2 (= ego y of the kitti source's frame), m
};

std::vector<ImagePoint> project_points(const std::vector<cv::Vec4f>& scan, const LidarCalibration& cal,
                                       const RangeOptions& o);

cv::Rect2d shrink(const cv::Rect2d& box, double fraction);

struct BoxRange {
  int points = 0;        // points assigned to the box
  double range = NAN;    // the range statistic; NaN with fewer than min_points points
  double lateral = NAN;  // median lateral offset of the points, m
  double nearest = NAN;  // smallest range among the points (before the robust statistic), m
};

// Assigns every point inside exactly one shrunk box to that box (a point inside two boxes cannot be told
// apart and is dropped) and computes each box's range.
std::vector<BoxRange> box_ranges(const std::vector<ImagePoint>& pts, const std::vector<cv::Rect2d>& boxes,
                                 const RangeOptions& o);

// The range statistic over one box's point ranges; NaN with fewer than min_points.
double range_statistic(std::vector<double> ranges, const RangeOptions& o);

struct CvTtc {
  double ttc = NAN;      // s; +inf when not closing faster than min_closing; NaN with fewer than 2 ranges
  double closing = NAN;  // m/s, positive when the range shrinks
};

// Constant-velocity model on the last `window` (time s, range m) samples: closing = -(least-squares slope of
// range over time), TTC = range_now / closing. With window 2 this is TTC = d_t dt / (d_{t-1} - d_t).
CvTtc constant_velocity_ttc(const std::vector<std::pair<double, double>>& history, int window,
                            double min_closing_mps);

}  // namespace hf::lidar
