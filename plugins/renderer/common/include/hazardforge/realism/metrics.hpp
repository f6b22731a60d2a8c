// Appearance metrics of one object in one picture (hf::AppearanceStats): measured the same way on an inserted
// object (its alpha) and on the recording's real objects (a grabCut silhouette in their detection box), so
// the two can be compared.
#pragma once

#include <optional>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "hazardforge/types.hpp"

namespace hf::realism {

struct MeasureOptions {
  int band_px = 2;       // width of the bands on either side of the silhouette (edge contrast)
  int halo_gap_px = 5;   // the halo's reference band starts this far outside the silhouette ...
  int halo_width_px = 4;  // ... and is this wide
  // Background ring for sharpness and noise: this share of the object's height, clamped to [6, 40] px.
  double ring_fraction = 0.25;
  int min_object_px = 64;  // fewer interior pixels: the quantities that need them stay NaN
};

// Measures an object in a BGR 8-bit picture. `mask` (CV_8U, object where >= 128, e.g. an alpha) covers the
// rectangle of its size at `offset` in the picture; `box` is the object's box (its size for the distance
// quantities); `camera`, when given, places the road point under the box's bottom centre (ground_depth_m,
// height_m, width_m stay NaN without it, above the horizon, or when the box touches the picture's bottom).
// Throws hf::Error when the picture is not BGR 8-bit or the mask not 8-bit.
AppearanceStats measure(const cv::Mat& bgr, const cv::Mat& mask, cv::Point offset, const cv::Rect2f& box,
                        const std::string& label, const CameraModel* camera, const MeasureOptions& o = {});

// The silhouette of a real object from its detection box: grabCut on a copy scaled to at most `max_height_px`
// tall, seeded with the box (outside: background, a margin of `margin` of its size; inside: probably the
// object; its central ellipse surely), the mask scaled back. Returns the mask (CV_8U 0/255) over `*crop` (the
// box plus margin, clipped to the picture); an empty mask when the box is under 8 px, grabCut fails, or the
// silhouette fills less than `min_fill` of the box (grabCut lost the object).
cv::Mat object_mask(const cv::Mat& bgr, const cv::Rect2f& box, cv::Rect* crop, double margin = 0.2,
                    int max_height_px = 48, int iterations = 2, double min_fill = 0.35);

// Sensor noise of a grey picture (any depth, grey levels of 8 bits) over a mask (CV_8U, empty = all): Immerkaer's
// estimator (the 3x3 second-difference kernel cancels planar shading; sigma = sqrt(pi/2) / 6 * mean |response|)
// on the flattest half of the masked pixels, flatness judged on a blurred copy so it does not select the noise
// itself. NaN when fewer than 16 pixels are left.
double noise_sigma(const cv::Mat& grey, const cv::Mat& mask = {});
// The same over several grey patches taken together (their pixels pooled before the flattest half is chosen):
// a ring around an object read as a few strips, without filtering the area it encloses.
double noise_sigma(const std::vector<cv::Mat>& grey_patches);

// Variance of the 3x3 Laplacian of a grey picture (any depth) over a mask (CV_8U, empty = all); NaN below 16
// pixels.
double laplacian_variance(const cv::Mat& grey, const cv::Mat& mask = {});

// Matching the recording's blur: the Gaussian sigma, from `sigmas` (ascending), whose blur brings the
// variance of the Laplacian of `grey` over `mask` nearest `target_variance` (on a log scale; the largest
// sigma when none reaches it) — the blur that makes an inserted picture as sharp as the frame around it. 0
// when the picture is already no sharper (it is never sharpened). `hint` (e.g. the previous frame's answer)
// is where the search starts: since blur only lowers the variance, the answer is the same from any hint, with
// fewer blurs near it.
double blur_to_match(const cv::Mat& grey, const cv::Mat& mask, double target_variance, double hint = 0.0,
                     const std::vector<double>& sigmas = {0.5, 0.8, 1.1, 1.5, 2.0, 2.6});

// Road point under pixel column x, row y: camera depth (m), or nullopt above the horizon.
std::optional<double> ground_depth(const CameraModel& camera, double x, double y);

}  // namespace hf::realism
