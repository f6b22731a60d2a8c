// KITTI calibration (tracking format) and tracking label files, parsed with messages naming file and line.
#pragma once

#include <filesystem>
#include <map>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

namespace hf::source::kitti {

struct Calibration {
  cv::Matx34d P2;  // rectified camera-0 coordinates -> image_02 pixels
  double fx() const { return P2(0, 0); }
  double fy() const { return P2(1, 1); }
  double cx() const { return P2(0, 2); }
  double cy() const { return P2(1, 2); }
  // Translation from rectified camera-0 to camera-2 coordinates: X_cam2 = X_cam0 + t (t = K^-1 P2[:,3]).
  cv::Vec3d cam0_to_cam2() const;
};

// Reads P2 from "P2: ..." (tracking format) or "P_rect_02: ..." (raw calib_cam_to_cam). Throws hf::Error.
Calibration read_calibration(const std::filesystem::path& file);

// One line of a KITTI tracking label file.
struct Label {
  int frame = 0;
  int track_id = -1;
  std::string type;  // Car, Van, Truck, Pedestrian, Person_sitting, Cyclist, Tram, Misc, DontCare
  double truncated = 0;
  int occluded = 0;  // 0 visible, 1 partly, 2 largely occluded, 3 unknown
  double alpha = 0;
  cv::Rect2d box2d;
  double h = 0, w = 0, l = 0;  // m
  cv::Vec3d location;          // bottom centre in rectified camera-0 coordinates, m
  double rotation_y = 0;       // rad, about camera-0 y (down)
  int line = 0;
};

// Largest frame number (and track id) a label may carry: KITTI sequences have at most a few thousand frames,
// and the source makes one entry per frame up to the largest number.
inline constexpr long long kMaxFrameNumber = 1000000;

// All labels of a file, by frame. Throws hf::Error "<file>:<line>: error: ..." on a malformed line, a field
// that is not a finite decimal number (nan, inf, 0x10), or a frame number outside [0, kMaxFrameNumber].
std::map<int, std::vector<Label>> read_labels(const std::filesystem::path& file);

}  // namespace hf::source::kitti
