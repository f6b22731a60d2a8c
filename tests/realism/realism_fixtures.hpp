// Synthetic pictures shared by the realism kit's tests.
#pragma once

#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

namespace hf::realism {

// Band-limited grey texture around 128 with the given contrast.
inline cv::Mat texture(cv::Size size, unsigned seed, double contrast, double sigma = 2.0) {
  cv::RNG rng(seed);
  cv::Mat n(size, CV_32F);
  rng.fill(n, cv::RNG::NORMAL, 0.0, 1.0);
  cv::GaussianBlur(n, n, cv::Size(), sigma);
  cv::Scalar m, sd;
  cv::meanStdDev(n, m, sd);
  cv::Mat out;
  n.convertTo(out, CV_8U, contrast / sd[0], 128);
  cv::Mat bgr;
  cv::cvtColor(out, bgr, cv::COLOR_GRAY2BGR);
  return bgr;
}

}  // namespace hf::realism
