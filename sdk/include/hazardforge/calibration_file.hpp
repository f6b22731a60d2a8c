// The camera calibration file: written by `hazardforge calibrate`, read by any source that takes a
// `calibration` param (see docs/calibration.md for the format).
#pragma once

#include <filesystem>
#include <vector>

namespace hf {

// Intrinsics at the native image size the calibration was made at, and OpenCV distortion coefficients.
struct CalibrationFile {
  int width = 0;
  int height = 0;
  double fx = 0, fy = 0, cx = 0, cy = 0;
  std::vector<double> distortion;  // OpenCV order k1 k2 p1 p2 [k3 ...]; empty = none
};

// Reads the fields above; other fields of the file (board, RMS, images) are ignored. Throws hf::Error naming
// the file (and line) of a missing, ill-typed or impossible field.
CalibrationFile read_calibration_file(const std::filesystem::path& yaml);

}  // namespace hf
