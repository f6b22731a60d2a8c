// Drawing of boxes, track ids, distances, per-metric values and Safe/Unsafe banners onto a frame.
#pragma once

#include <string>
#include <utility>
#include <vector>

#include <opencv2/core.hpp>

#include "hazardforge/types.hpp"

namespace hf::sink {

// BGR colour of a road-user class (grey for anything else).
cv::Scalar class_color(const std::string& label);
// Banner colours: Unsafe is red, Safe green.
inline const cv::Scalar kUnsafeColor(0, 0, 220);
inline const cv::Scalar kSafeColor(0, 150, 0);

struct OverlayInputs {
  const Tracks* tracks = nullptr;
  const ObjectStates* states = nullptr;
  const Detections* detections = nullptr;
  std::vector<std::pair<std::string, const RiskAssessment*>> risks;  // metric name -> assessment
};

// Draws on `img` (BGR 8-bit) in place. Boxes are in the frame's pixels; `box_scale` maps them onto `img` when
// it is a resized copy of the frame.
void draw_overlay(cv::Mat& img, int64_t frame_index, double timestamp, const OverlayInputs& in,
                  int thickness, double box_scale = 1.0);

// Text of a metric value: "1.23 s", "inf" when not finite.
std::string format_value(double v, const std::string& unit);

}  // namespace hf::sink
