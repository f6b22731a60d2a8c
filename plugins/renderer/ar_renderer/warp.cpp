// Internal: dispatch of the BGRA perspective warp (compiled for the baseline CPU).
#include "warp.hpp"

#include <opencv2/imgproc.hpp>

namespace hf::render {

bool warp_bgra_accelerated() {
#if defined(__x86_64__) && defined(HF_WARP_AVX2)
  static const bool ok = __builtin_cpu_supports("avx2") && __builtin_cpu_supports("fma");
  return ok;
#else
  return false;
#endif
}

void warp_bgra(const cv::Mat& src, cv::Mat& dst, const cv::Matx33d& H) {
#if defined(HF_WARP_AVX2)
  bool invertible = false;
  const cv::Matx33d Minv = H.inv(cv::DECOMP_LU, &invertible);
  if (invertible && src.type() == CV_8UC4 && dst.type() == CV_8UC4 && !src.empty() && warp_bgra_accelerated()) {
    detail::warp_bgra_avx2(src, dst, Minv);
    return;
  }
#endif
  cv::warpPerspective(src, dst, cv::Mat(H), dst.size(), cv::INTER_LINEAR, cv::BORDER_CONSTANT, cv::Scalar::all(0));
}

}  // namespace hf::render
