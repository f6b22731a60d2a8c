// Reading frame images: one decoder entry for every source, and the check for files that are cut off
// (decoders fill the missing part with grey and only print a warning).
#pragma once

#include "hazardforge/abi.hpp"

#include <filesystem>
#include <string>

#include <opencv2/core.hpp>

HF_SDK_BEGIN
namespace hf {

// Throws hf::Error "<what> is truncated: <why>" when `file` is a JPEG without its end-of-image marker or a
// PNG without its IEND chunk near the end of the file. Other formats pass unchecked. `what` names the file
// and the frame, e.g. "nuScenes image 'x.jpg' (frame 3)".
void require_complete_image(const std::filesystem::path& file, const std::string& what);

// The file as an 8-bit, 3-channel BGR image, pixel for pixel what cv::imread(file, cv::IMREAD_COLOR) gives
// (EXIF orientation applied), after require_complete_image's check. Baseline and progressive colour JPEGs
// without an EXIF block are decoded by libjpeg straight into BGR rows, which takes under 60 % of
// OpenCV's time for a 1600x900 frame; every other file goes through OpenCV's decoders. Throws hf::Error
// "<what> cannot be read" (missing, unreadable) or "<what> cannot be decoded".
cv::Mat read_color_image(const std::filesystem::path& file, const std::string& what);

}  // namespace hf
HF_SDK_END
