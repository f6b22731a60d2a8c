// The camera's attitude frame by frame: how far each frame's pitch and roll deviate from the clip's (a bump,
// a braking dip, the body rolling in a bend), from the motion of the far scene between consecutive frames.
#pragma once

#include <limits>
#include <optional>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "hazardforge/footage/two_view.hpp"
#include "hazardforge/types.hpp"

namespace hf::footage {

struct AttitudeSample {
  double t = 0;
  double pitch_rad = 0;   // deviation from the clip's slow attitude, + = looking further down
  double roll_rad = 0;    // deviation, + = the horizon rises to the right (CameraModel's roll)
  bool measured = false;  // the step from the previous frame was measured (else taken as 0)
  int inliers = 0;        // far-scene features that agreed with the step
};

struct AttitudeOptions {
  int max_width = 960;       // frames are downscaled to at most this width
  double band_above = 0.15;  // the far-scene band: this share of the image height above the horizon row ...
  double band_below = 0.04;  // ... and this share below it (distant road, cars, verges)
  int max_corners = 400;
  double corner_quality = 0.01;
  double min_corner_distance_px = 8;
  double fb_max_px = 0.5;  // forward-backward tracking disagreement allowed (working size)
  double ransac_px = 1.0;  // similarity-fit inlier threshold (working size)
  int min_inliers = 30;
  double min_inlier_fraction = 0.4;
  // The clip's slow attitude (road grade, the drift of summed steps, and the horizon estimate's own mean) is
  // a Gaussian of this width over the summed steps; what is left are the frame's deviations from it.
  double slow_s = 1.0;
  double max_step_deg = 2.0;  // a step beyond this between consecutive frames is refused (a cut, a glitch)
  // Frames further apart are not compared: at keyframe rates the turn and the far scene's parallax between
  // them swamp a nod of a fraction of a degree, and a deviation from a 1 s mean spans only a few frames.
  double max_interval_s = 0.2;
  double max_deviation_deg = 3.0;  // deviations are clamped to this
  // The heading step's sigma: the fit's horizontal residuals over the inliers, and this floor per step (the
  // far scene's parallax when the ego drifts sideways, a focus of expansion off the image centre).
  double yaw_sigma_floor_deg = 0.01;
  // Column (full-size px) where the direction of travel meets the horizon (HorizonEstimate::travel_x); NaN =
  // the principal point's. The far scene expands about it, so the fit is centred there: about any other
  // column the expansion would read as a sideways shift, i.e. a turn.
  double travel_x = std::numeric_limits<double>::quiet_NaN();
};

// Between consecutive frames, KLT features in a band around the horizon row (the far scene, where the image
// motion is the camera's rotation: the translation moves far points by little) are fitted with a similarity
// about (cx, horizon row) by RANSAC: its vertical shift is the pitch step (dy = -fy * dpitch), its rotation
// the roll step. Summed over the clip and high-passed (the Gaussian above subtracted), they give each frame's
// deviation from the clip's attitude, which the horizon estimate gives. Its horizontal shift is the heading
// step (dx = fx * dyaw, the scene moving right when the ego turns left): at video rates a far more precise
// turn than the road's own, whose lever arm is a few metres of asphalt (last_turn()).
class AttitudeTracker {
 public:
  explicit AttitudeTracker(const CameraModel& camera, AttitudeOptions opt = {});
  void add(const cv::Mat& bgr, double t);
  // Per frame added, in order; empty before any frame.
  std::vector<AttitudeSample> result() const;
  // The ego's heading change between the last two frames added (left positive), when the far scene measured
  // it.
  std::optional<TwoViewMotion> last_turn() const;
  const AttitudeOptions& options() const { return opt_; }

 private:
  CameraModel cam_;
  AttitudeOptions opt_;
  double scale_ = 1.0;
  cv::Mat prev_;
  struct Step {
    double t = 0, dpitch = 0, droll = 0, dyaw = 0, dyaw_sigma = 0;
    bool measured = false;
    double inlier_fraction = 0;
    int inliers = 0;
  };
  std::vector<Step> steps_;
};

// The camera with the given pitch and roll (rad), everything else kept.
CameraModel with_pitch_roll(const CameraModel& camera, double pitch_rad, double roll_rad);
// The camera with its pitch and roll moved by a frame's deviation.
CameraModel with_attitude(const CameraModel& camera, const AttitudeSample& s);

}  // namespace hf::footage
