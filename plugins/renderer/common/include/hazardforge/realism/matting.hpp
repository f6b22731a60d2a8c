// Cut-outs without halos: a trimap from a hard silhouette, information-flow alpha matting (OpenCV contrib
// alphamat) in its unknown band, and colour decontamination of the edge (the background's share removed).
#pragma once

#include <opencv2/core.hpp>

namespace hf::realism {

inline constexpr uint8_t kTrimapBackground = 0, kTrimapUnknown = 128, kTrimapForeground = 255;

// Trimap (CV_8U: 0 background, 128 unknown, 255 foreground) from a hard mask (>= 128 = object): the mask's
// edge grown by `band_px` to either side is unknown.
cv::Mat trimap_from_mask(const cv::Mat& mask, int band_px);

// Alpha (CV_8U) of a BGR 8-bit picture for a trimap of its size: cv::alphamat::infoFlow, with the trimap's
// definite pixels kept exactly. Throws hf::Error on mismatched sizes, types, or a trimap with no foreground
// or no background.
cv::Mat matte(const cv::Mat& bgr, const cv::Mat& trimap);

// Foreground colours (BGR 8-bit) for a picture and its alpha: where 0 < alpha < 1 the observed colour is
// I = a F + (1 - a) B; B is estimated from the nearby definite background (alpha < 0.05, normalised Gaussian
// of sigma `radius_px`) and F = (I - (1 - a) B) / a, clamped and, below a = 0.6, blended towards the nearby
// definite foreground's colour (alpha > 0.95, extrapolated the same way), which alone is used below a = 0.25
// and where no background is near.
// Opaque pixels keep their colour. The result composited on any background then carries none of the old one.
cv::Mat decontaminate(const cv::Mat& bgr, const cv::Mat& alpha, double radius_px = 4.0);

// The largest 8-connected component of a binary mask (non-zero = set) with its holes filled, 0/255 CV_8U: a
// silhouette without specks and islands.
cv::Mat largest_component(const cv::Mat& bin);

}  // namespace hf::realism
