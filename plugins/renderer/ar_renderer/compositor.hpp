// Pastes one object picture into a frame: perspective warp onto the projected box, colour harmonisation,
// feathered edges, motion blur, occlusion by nearer objects and a soft contact shadow — on the ROI only.
#pragma once

#include <algorithm>
#include <array>
#include <cstdint>
#include <optional>
#include <vector>

#include <opencv2/core.hpp>

#include "hazardforge/assets/asset_library.hpp"

namespace hf::render {

struct CompositeOptions {
  bool shadow = true;
  double shadow_strength = 0.5;     // darkening at the shadow's core, 0..1
  double harmonize_luma = 0.6;      // 0 = keep the asset's lightness statistics, 1 = match the surroundings'
  double harmonize_chroma = 0.4;    // same for the a/b colour channels
  double feather_px = 0.8;          // Gaussian sigma of the alpha edge
  double exposure_s = 0.01;         // camera exposure time for motion blur (0 = none)
  double exposure_smoothing = 0.7;  // exponential smoothing of the surroundings' statistics across frames
  bool grain = true;                // add sensor noise at the level measured around the object
  // Blur the picture until its interior is no sharper than this times the frame around it (variance of the
  // Laplacian); 0 = off.
  double match_sharpness = 1.0;
  // Draw only on the object's projected box (grown by kClipMargin of its height): parts of a picture that
  // show faces the frame does not see would otherwise land beside the box.
  bool clip_to_box = true;
};

// How far beyond its projected box a silhouette may reach with `clip_to_box`: this share of the box's height,
// plus 2 px (a box leaves out mirrors; a feathered edge needs room).
constexpr double kClipMargin = 0.04;

// Where and how one object is drawn in this frame.
struct Placement {
  const LoadedAsset* asset = nullptr;
  std::array<cv::Point2d, 8> corners_px;  // the object's projected 3D box (order of box_geometry.hpp)
  cv::Point2d velocity_px_s{0, 0};        // image-plane velocity of the object, px/s
  std::vector<cv::Rect2f> occluders;      // boxes of nearer objects, drawn in front of the hazard
  // A sun's cast shadow: the footprint (corners 0..3) moved along the shadow's direction and reach on the
  // road, projected; the shadow is the footprint swept there, `cast_darkness` dark (1 - shadowed / lit).
  std::optional<std::array<cv::Point2d, 4>> cast_px;
  double cast_darkness = 0.0;
};

// What the compositor keeps from frame to frame for one hazard: the surroundings' colour statistics and
// noise, smoothed (no exposure flicker), the harmonised picture (rebuilt only when it changes), and reused
// buffers.
struct CompositorState {
  cv::Scalar mean, stddev;
  bool valid = false;
  // The colours the camera records (camera_gamut): the neutral point of Lab a and b, and the widest reach
  // from it seen so far in this hazard's frames (0 for a grayscale camera; -1 before the first frame).
  cv::Vec2d gamut_centre{128, 128}, gamut_reach{-1, -1};
  double noise_sigma = 0.0;  // sensor noise around the object (8-bit grey levels), smoothed
  int noise_frames = 0;      // frames it was measured on
  int64_t frame = 0;         // moves the grain pattern every frame
  const LoadedAsset* sprite_asset = nullptr;
  int sprite_level = -1;
  double sprite_feather = -1.0;
  cv::Mat sprite_lut, sprite;     // harmonisation LUT and premultiplied, feathered BGRA picture it produced
  double blur_sigma = 0.0;        // the recording's blur applied to the picture (smoothed), px
  double last_match_sigma = 0.0;  // the last frame's unsmoothed estimate (where the next search starts)
  int blur_frames = 0;
  double own_noise = -1.0;             // the drawn picture's own noise (grey levels; -1: not measured yet)
  cv::Mat warped, shadow, ring, clip;  // work buffers (grown, never shrunk)
  cv::Mat clip_back;                   // the kept outline on the picture's pyramid level
  std::vector<uint8_t> row;            // one row, for the motion blur
  cv::Mat grain_tile;                  // the grain at full alpha (1/64 grey levels) for the sigma below
  int grain_tile_q8 = 0;               // that sigma, 1/256 grey levels (0: not built)
  std::vector<int16_t> grain_row;      // one row of it, for the blend
};

struct CompositeResult {
  bool drawn = false;
  cv::Rect roi;                // the part of the image that was modified
  double coverage_before = 0;  // sum of alpha before occlusion
  double coverage_after = 0;   // after occlusion
  double coverage_full = 0;    // the whole silhouette's alpha sum, had the picture no borders
  cv::Mat alpha;               // final alpha over `roi` (CV_8U), for tests and debugging
  int level = 0;               // pyramid level of the asset used
  double match_sigma = 0;      // Gaussian blur applied to match the recording's sharpness, px
  double grain_sigma = 0;      // sensor noise added to the picture (8-bit grey levels)
  double occluded_fraction() const {
    return coverage_before > 1e-9 ? 1.0 - coverage_after / coverage_before : 0.0;
  }
  // Share of the silhouette inside the picture (the rest is cut off by its borders).
  double in_picture_fraction() const {
    return coverage_full > 1e-9 ? std::clamp(coverage_before / coverage_full, 0.0, 1.0) : 1.0;
  }
};

// The box corners a picture is mapped by: all faces the picture shows when it shows them in about the
// proportions the frame does (the faces' shares of the projected area, from the winding of the projected
// corners, so perspective counts), else the faces both show (the picture's own when they share none).
std::vector<int> mapping_corners(const AssetSpec& asset, const std::array<cv::Point2d, 8>& image_px);
// The homography from an asset's level-0 pixels to image pixels, fitted on those corners (4 corners: exact;
// 6: least squares).
cv::Matx33d asset_homography(const LoadedAsset& asset, const std::array<cv::Point2d, 8>& corners_px);

// The colours a camera records in one frame: the median of Lab a and b over a coarse grid of the frame
// (`centre`) and how far the 99.5th percentile of |a - median| and |b - median| reaches (`reach`). A grayscale
// camera reads a reach of 0 or 1; a colour camera on a street reads tens (signs, lights, cars, sky).
void camera_gamut(const cv::Mat& image, cv::Vec2d& centre, cv::Vec2d& reach);

// Draws the object into `image` (BGR 8-bit, modified in place).
CompositeResult composite(cv::Mat& image, const Placement& p, const CompositeOptions& o,
                          CompositorState& state);

// Motion blur of a premultiplied picture (any 8-bit type), in place: a box along `blur` (the image motion
// over the exposure, px) of length 2^k, the power of two nearest its length, built by k halving-averages with
// a copy shifted by 1, 2, 4 ... px along it (rounded up; what is shifted in from outside the picture is
// transparent). `row` is a work buffer. Returns k (0 below 1.5 px).
int motion_blur(cv::Mat& bgra, cv::Point2d blur, std::vector<uint8_t>& row);

// One row of the final blend, in place on the BGR row `d` of `n` pixels: background x (1 - alpha)(1 - shadow)
// + the premultiplied BGRA colour `s` + grain x alpha, where `shadow` (0..255, or null for none) darkens the
// road and `grain` is the noise at full alpha in 1/64 grey levels. Integer arithmetic: two rounded divisions
// by 255, the grain as alpha x g / 256 rounded; saturated to 0..255.
void blend_row(uint8_t* d, const uint8_t* s, const uint8_t* shadow, const int16_t* grain, int n);

}  // namespace hf::render
