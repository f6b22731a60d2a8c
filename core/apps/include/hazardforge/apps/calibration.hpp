// Chessboard camera calibration and the calibration YAML file that sources read (see docs/calibration.md).
#pragma once

#include <filesystem>
#include <iosfwd>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

namespace hf {

// An image the calibration could not use, and why.
struct RejectedImage {
  std::string file;
  std::string reason;
};

struct CalibrationResult {
  int image_width = 0;
  int image_height = 0;
  double fx = 0, fy = 0, cx = 0, cy = 0;
  std::vector<double> distortion;        // OpenCV order k1 k2 p1 p2 k3
  double rms_px = 0.0;                   // RMS reprojection error over all used corners
  int board_cols = 0;                    // inner corners per row
  int board_rows = 0;                    // inner corners per column
  double square_size = 1.0;              // board square edge, in the unit the extrinsics would use
  std::vector<std::string> images_used;  // file names (not paths), sorted
  std::vector<RejectedImage> images_rejected;

  cv::Matx33d K() const { return {fx, 0, cx, 0, fy, cy, 0, 0, 1}; }
};

// Calibrates from every .jpg/.jpeg/.png/.bmp in `folder` (sorted by name) showing a chessboard with
// `inner_corners` (cols x rows). Images of a different size than the first readable one, unreadable images
// and images where the full board is not found are rejected (listed with the reason). Progress lines go to
// `log` when given. Throws hf::Error naming the folder when it is missing or fewer than 3 images are usable.
CalibrationResult calibrate_chessboard(const std::filesystem::path& folder, cv::Size inner_corners,
                                       double square_size = 1.0, std::ostream* log = nullptr);

// Writes the YAML file atomically (temporary file in the same folder, then rename). Throws hf::Error naming
// the file when it cannot be written.
void write_calibration(const CalibrationResult& result, const std::filesystem::path& yaml);

// Reads a file written by write_calibration. Throws hf::Error naming the file and the missing/bad field.
CalibrationResult read_calibration(const std::filesystem::path& yaml);

}  // namespace hf
