// Internal: the perspective warp of the premultiplied BGRA picture onto the frame (the compositor's hot loop).
#pragma once

#include <opencv2/core.hpp>

namespace hf::render {

// dst = src warped by the homography H (src pixel -> dst pixel), bilinear, transparent (0) outside src: what
// cv::warpPerspective(src, dst, H, dst.size(), INTER_LINEAR, BORDER_CONSTANT, 0) computes, in the same 1/32 px
// steps and weights (results within one grey level of it). On CPUs with AVX2 a kernel of its own fetches the
// four neighbours of eight pixels at a time (about 0.55 of OpenCV's time for a car 8 m ahead on the AMD EPYC
// machine); elsewhere, and for other types, OpenCV's. `dst` must be allocated (CV_8UC4, any size).
void warp_bgra(const cv::Mat& src, cv::Mat& dst, const cv::Matx33d& H);

// Whether warp_bgra runs its own kernel on this CPU (for the benchmark and the tests).
bool warp_bgra_accelerated();

namespace detail {
// The AVX2 kernel (warp_avx2.cpp, compiled for AVX2 + FMA; call only when the CPU has both). Minv maps dst
// pixels to src pixels.
void warp_bgra_avx2(const cv::Mat& src, cv::Mat& dst, const cv::Matx33d& Minv);
}  // namespace detail

}  // namespace hf::render
