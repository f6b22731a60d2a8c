// KITTI Velodyne scans and the camera/lidar calibration needed to project them (P2, R0_rect, Tr_velo_to_cam).
#pragma once

#include <filesystem>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

namespace hf::lidar {

// Lidar -> image: X_rect = R0_rect * Tr_velo_to_cam * X_velo, pixel = P2 * X_rect (homogeneous).
struct LidarCalibration {
  cv::Matx34d P2;
  cv::Matx33d R0_rect = cv::Matx33d::eye();
  cv::Matx34d Tr_velo_to_cam;

  // Rectified camera-0 coordinates of a Velodyne point.
  cv::Vec3d velo_to_rect(const cv::Vec3d& p) const;
  // Translation t with X_cam2 = X_rect + t (P2 = K [I | K^-1 p4]).
  cv::Vec3d rect_to_cam2() const;
};

// Reads P2, R0_rect and Tr_velo_to_cam from a KITTI tracking-format calibration ("KEY: v1 v2 ..."); the raw
// names P_rect_02 and R_rect_00 are accepted too. Throws hf::Error naming the file, line or missing key.
LidarCalibration read_lidar_calibration(const std::filesystem::path& file);

// One scan: float32 x, y, z, reflectance per point (Velodyne frame: x forward, y left, z up).
std::vector<cv::Vec4f> read_scan(const std::filesystem::path& file);

// Extracts a .tar.xz / .tar archive into `dest` with `tar -xf` once (a marker file records which archive, so
// later calls and concurrent callers in other nodes reuse it; an exclusive lock serialises them), then
// returns the one folder below `dest` that holds .bin files. Throws hf::Error on failure with tar's message.
std::filesystem::path extract_scans(const std::filesystem::path& archive, const std::filesystem::path& dest);

// The one folder at or below `root` holding *.bin files; throws hf::Error when there is none or several.
std::filesystem::path find_scan_folder(const std::filesystem::path& root);

}  // namespace hf::lidar
