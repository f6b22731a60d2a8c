// Scale change of tracked boxes between frames from keypoints inside them (the camera-only TTC cue).
#pragma once

#include <cmath>
#include <cstdint>
#include <limits>
#include <map>
#include <memory>
#include <vector>

#include <opencv2/core.hpp>

namespace hf::estimation {

// How an object's image grew between two frames. For a pinhole camera the distance between two points on the
// object scales with 1 / depth, so ratio = depth_before / depth_now and, at constant closing speed,
// TTC = dt / (ratio - 1) (the classic camera TTC: -dt / (1 - ratio)).
struct ScaleRatio {
  double ratio = std::numeric_limits<double>::quiet_NaN();      // median of d_now / d_before over point pairs
  double log_sigma = std::numeric_limits<double>::quiet_NaN();  // standard error of ln(ratio)
  double dt = 0.0;                                              // s between the two frames
  int points = 0;                                               // points that survived tracking
  int pairs = 0;                                                // pairs the median was taken over
  int off_box = 0;  // tracked points dropped for not moving with their box (background, swinging limbs)
  bool valid() const { return std::isfinite(ratio) && ratio > 0 && std::isfinite(log_sigma); }
  // (ratio - 1) / dt: closing speed over depth, 1/TTC (positive = approaching).
  double inverse_ttc() const { return (ratio - 1.0) / dt; }
};

// The robust estimate from matched points alone (what the tests check on known scalings): every pair whose
// distance in `before` is at least `min_pair_px` gives d_now / d_before; the median of the pairs within three
// (scaled) median absolute deviations of the first median is the ratio. Invalid with fewer than `min_points`
// points or 3 usable pairs.
ScaleRatio scale_from_matches(const std::vector<cv::Point2f>& before, const std::vector<cv::Point2f>& now,
                              double min_pair_px = 10.0, int min_points = 6);

struct KeypointScaleConfig {
  int max_points = 40;          // corners sought per box
  double quality = 0.01;        // goodFeaturesToTrack quality level (fraction of the best corner)
  double min_corner_px = 3.0;   // minimum distance between corners
  double inner_fraction = 0.1;  // each box side is trimmed by this fraction so corners sit on the object
  double min_box_px = 12.0;     // boxes narrower or shorter than this are not measured
  double min_pair_px = 10.0;    // see scale_from_matches
  int min_points = 6;
  double max_fb_error_px = 1.0;  // forward-backward tracking error above which a point is dropped
  // A point must land within this fraction of the box's larger side of where the box's own motion (its
  // translation and per-axis scaling between the two frames) carries it: background seen through or beside
  // the object (a parked car behind a crossing person) and swinging limbs move otherwise and would pull the
  // median ratio towards their own depth. Detector jitter of a few per cent of the box stays well inside.
  double max_off_box_fraction = 0.1;
  int pyramid_levels = 3;
  int window_px = 15;
  // A box missing from one or more calls (a detector's dropout) keeps its points while they are younger than
  // this: when it is back, they are tracked from the frame they were found in, and the ratio spans the gap.
  // 0.5 s is the span consecutive 2 Hz keyframes already ask of the tracking, so a 2 Hz recording bridges
  // nothing and a 10 Hz one bridges up to four missed frames.
  double max_bridge_s = 0.5;
};

// Keeps each box's corners from the previous frame and tracks them into the current one with pyramidal
// Lucas-Kanade, seeded by the box's own motion (so keyframes 0.5 s apart still converge), forward-backward
// checked, and keeps only points that move with their box (max_off_box_fraction). One call per frame, in time
// order.
class KeypointScaleTracker {
 public:
  explicit KeypointScaleTracker(KeypointScaleConfig c = {}) : cfg_(c) {}
  // `boxes`: id -> box in this image's pixels. Returns the ratio for every id also measured in the previous
  // call, or in an earlier one within max_bridge_s (its `dt` spans the gap; older points are forgotten).
  // `image` is BGR or grey 8-bit.
  std::map<int64_t, ScaleRatio> update(const cv::Mat& image, double t,
                                       const std::map<int64_t, cv::Rect2f>& boxes);

 private:
  using Pyramid = std::shared_ptr<const std::vector<cv::Mat>>;
  struct Memory {
    std::vector<cv::Point2f> points;
    cv::Rect2f box;
    Pyramid pyramid;  // of the frame the points were found in
    double t = 0.0;
    bool missed = false;  // the box was missing from a call since
  };
  KeypointScaleConfig cfg_;
  std::map<int64_t, Memory> memory_;
};

}  // namespace hf::estimation
