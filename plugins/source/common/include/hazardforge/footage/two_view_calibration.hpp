// What pairs of views about a second apart tell of the camera: its focal length (when the drive turns) and the
// direction of travel in the picture (the epipole, a point on the horizon).
#pragma once

#include <optional>
#include <string>
#include <vector>

#include <opencv2/core.hpp>
#include <opencv2/features2d.hpp>

namespace hf::footage {

struct FocalEstimate {
  double fx = 0;         // px at the size of the frames pushed, square pixels (fy = fx)
  double sigma = 0;      // px, the median's standard error from the pairs' scatter (1.25 * 1.48 MAD / sqrt(pairs))
  double spread = 0;     // the pairs' median absolute deviation relative to fx
  int pairs = 0;         // frame pairs whose geometry fixed a focal length
  int pairs_tried = 0;   // frame pairs with enough matched features to try
  std::string note;      // how it was found, for the run's provenance
};

// Self-calibration of the focal length from pairs of views (the equal-singular-value condition on the essential
// matrix, Mendonca & Cipolla): a pair's fundamental matrix F (SIFT features, RANSAC) is turned into
// E(f) = K(f)^T F K(f) for focal lengths over 0.25-4x the image width with the principal point at the image
// centre, and only the true f makes E a valid essential matrix (two equal singular values). A camera moving
// straight ahead does not fix f (pure translation makes every E(f) valid), nor does a view too flat to separate
// rotation from translation: a pair counts only when the camera turned by at least `min_rotation_deg` between
// the two views and the cost has a clear minimum inside the searched range. Ground-plane geometry cannot help
// here: lane widths, heights and box ratios are all independent of f, only depth along the road scales with it.
// A single pair is noisy (a few tenths of a pixel of feature noise move its minimum by 10-20 % when the camera
// looks down by a few degrees), and a level camera turning on a plane is degenerate (both optical axes in one
// plane): the estimate is the median of the counted pairs, kept when its standard error is small and the
// epipoles' row shows the camera pitched.
//
// The same fundamental matrix gives the pair's epipole in the later view: the image of the direction the camera
// travelled, which for a car driving on its road is a point of the horizon, whatever the focal length. Between
// views 0.5-1 s apart it is fixed by metres of travel (at video rate the frame-to-frame flow FOE has centimetres),
// so at 2 Hz keyframes it is the horizon's sharpest cue. It counts when the view expanded away from it (forward
// travel) with enough parallax, and lies in the picture.
//
// Frames are pushed in time order; each is paired with the previous `pair_depth` frames of its segment (the
// caller spaces them so that the camera has turned noticeably between them, about 0.5 s apart).
class TwoViewCalibration {
 public:
  struct Options {
    int max_width = 960;             // frames are downscaled to at most this width
    int features = 2000;             // SIFT: ORB's corner positions are too coarse (5 % low on nuScenes)
    double ratio = 0.8;              // Lowe's ratio test
    double ransac_px = 1.0;          // fundamental-matrix inlier threshold at the working size (USAC with local
                                     // optimisation: plain RANSAC's F moved the minimum by 5-15 %)
    int min_inliers = 100;           // real footage gives hundreds on a pair 0.5-1 s apart
    double min_rotation_deg = 3.0;   // less: the cost curve is flat within the feature noise
    double max_sharpness = 0.5;      // the minimum's cost against the curve's median (lower = sharper)
    double min_width_ratio = 0.25;   // searched focal lengths, as multiples of the image width: 0.25 is a
    double max_width_ratio = 4.0;    // 127 deg field of view, 4 is 14 deg
    int grid = 400;                  // log-spaced candidates (0.7 % apart)
    int pair_depth = 2;              // each frame is paired with this many previous frames of its segment
    int min_pairs = 3;               // fewer pairs give no estimate
    double max_sigma = 0.05;         // the median's standard error, relative: looser pairs need more of them
    double min_parallax_px = 2.0;    // an epipole counts when the inliers' median motion is at least this
    // A level camera (optical axes in one plane through a planar turn) is the degenerate case: no estimate when
    // the epipoles' row says the camera looks down by less than this.
    double min_pitch_deg = 0.5;
  };
  struct Epipole {
    cv::Point2d point;  // px at the size of the frames pushed
    int frame = 0;      // the later view's index as given to add()
  };
  explicit TwoViewCalibration(cv::Size image) : TwoViewCalibration(image, Options{}) {}
  TwoViewCalibration(cv::Size image, Options opt);

  // Pushes the next frame (of the size given at construction). new_segment: the frame does not follow the
  // previous one (a jump in a long clip), so it is not paired with the frames before it.
  void add(const cv::Mat& bgr, int frame, bool new_segment = false);
  std::optional<FocalEstimate> result() const;
  // Why result() has no estimate, in words for the run's provenance.
  std::string why_not() const;
  // The epipoles of the pairs of forward travel, in the order found.
  const std::vector<Epipole>& epipoles() const { return epipoles_; }
  const Options& options() const { return opt_; }

  // One pair's measurement from matched points (a: earlier view, b: later view) of an image of `image` size, with
  // the principal point at its centre: the focal length minimising the essential-matrix cost of the pair's F, the
  // rotation between the views at that focal length, the minimum's sharpness (its cost against the curve's
  // median), whether the pair fixes the focal length, and the epipole in the later view when the pair shows
  // forward travel. nullopt: too few points agree with one F.
  struct PairResult {
    double f = 0;
    double rotation_deg = 0;
    double sharpness = 1;
    bool accepted = false;
    std::optional<cv::Point2d> epipole;
  };
  // Counts one measured pair (add() does this for each pair of views it matches); `frame` names the later view.
  void add_pair(const PairResult& r, int frame, double scale = 1.0);
  static std::optional<PairResult> measure_pair(const std::vector<cv::Point2f>& a, const std::vector<cv::Point2f>& b,
                                                cv::Size image, const Options& opt);

 private:
  struct View {
    std::vector<cv::KeyPoint> keypoints;
    cv::Mat descriptors;
  };
  std::optional<PairResult> pair(const View& a, const View& b) const;
  bool looks_level(double f) const;

  cv::Size image_;
  Options opt_;
  double scale_ = 1.0;
  cv::Ptr<cv::Feature2D> sift_;
  std::vector<View> recent_;      // the previous frames of the current segment, oldest first
  std::vector<Epipole> epipoles_;
  std::vector<double> accepted_;  // per accepted pair, px at the size of the frames pushed
  int tried_ = 0;
};

}  // namespace hf::footage
