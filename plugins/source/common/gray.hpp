// The kit's one conversion of a frame to 8-bit grey (BGR, BGRA or grey in; any depth converted).
#pragma once

#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

namespace hf::footage::detail {

inline cv::Mat gray8(const cv::Mat& img) {
  cv::Mat g;
  if (img.channels() == 3)
    cv::cvtColor(img, g, cv::COLOR_BGR2GRAY);
  else if (img.channels() == 4)
    cv::cvtColor(img, g, cv::COLOR_BGRA2GRAY);
  else
    g = img;
  if (g.depth() != CV_8U) g.convertTo(g, CV_8U);
  return g;
}

}  // namespace hf::footage::detail
