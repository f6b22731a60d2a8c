// Filtered monocular state estimation: fused range cues, a Kalman filter per track, keypoint scale change.
#pragma once

#include <array>
#include <map>
#include <optional>
#include <set>
#include <string>
#include <vector>

#include <hazardforge/class_groups.hpp>
#include <hazardforge/estimation/keypoint_scale.hpp>
#include <hazardforge/estimation/range_alignment.hpp>
#include <hazardforge/estimation/robust_spread.hpp>
#include <hazardforge/estimation/track_filter.hpp>
#include <hazardforge/geometry.hpp>
#include <hazardforge/road_user_limits.hpp>
#include <hazardforge/stage.hpp>

namespace hf {

// One frame's range measurement of a box: the pinhole range from the class height prior and the
// ground-contact range from the camera's height and pitch, each with its expected error, fused by inverse
// variance.
struct RangeCue {
  std::optional<double> pinhole_depth, pinhole_var;  // optical depth (m) and its variance
  std::optional<double> ground_depth, ground_var;
  double pinhole_noise_var = 0.0,
         ground_noise_var = 0.0;     // the frame-to-frame (jitter) part of each variance
  std::optional<double> depth, var;  // fused, with the cues' whole expected errors (they set the weights)
  // Variance of the fused depth from frame-to-frame noise alone (box jitter). The prior's height error and
  // the pitch / road offsets are biases that persist along a track: they scale range and closing speed alike,
  // so TTC does not see them, and feeding them to the filter as white noise would smear every velocity.
  std::optional<double> noise_var;
  std::string method;  // pinhole | ground | fused | "" (no usable cue: truncated)
};

// Stage "kalman" (estimator).
// Ports: tracks (Tracks) + frames (Frame: image, camera, ego pose/speed/yaw rate) -> states (ObjectStates),
//   one packet per frame stamped with the frame's time.
// Per track a TrackFilter (hazardforge/estimation/track_filter.hpp) over the ground point and velocity in the
//   ego frame, moved by the ego's motion between frames (dataset poses, else speed and yaw rate, else
//   relative), updated by (1) the fused range cue of the matched box — a box touching the top or bottom image
//   border gives no pinhole range, one touching the bottom no ground range — gated by the innovation and the
//   class's speed limit (share/hazard_limits.yaml), and (2) the keypoint scale change of the box
//   (hazardforge/estimation/keypoint_scale.hpp) as a measurement of closing speed / depth. A held box
//   (misses > 0) is predicted only. The state's covariance travels in ObjectState::covariance.
// Params: see describe(); docs/risk-metrics.md has the measurement model.
class KalmanEstimator : public Estimator {
 public:
  static ComponentInfo describe();
  void open(StageContext& ctx) override;
  ObjectStates estimate(StageContext& ctx, const Tracks& tracks, const Frame& frame) override;
  // Logs the noise the boxes and the ground cue taught (and from how many samples).
  void finish(StageContext& ctx, Outputs& out) override;

  struct Config {
    double height_rel_sd = 0.10;    // relative spread of the class's real height
    double box_jitter_px = 1.5;     // detector jitter of a box edge
    double pitch_sd_deg = 0.5;      // uncertainty of the camera pitch (ground range)
    double pitch_jitter_deg = 0.0;  // frame-to-frame pitch of the body (ground range noise)
    double ground_height_sd = 0.1;  // m, road surface off the ego's ground plane at the object (ground range)
    double min_horizon_gap_px = 10.0;  // ground range only for bottoms this far below the horizon
    double border_margin_px = 2.0;
    bool keypoints = true;
    double keypoint_floor = 0.003;   // minimum standard error of ln(scale ratio) per frame pair
    double keypoint_band_m = 5.0;    // keypoints only for objects this close to the ego laterally (m)
    int min_updates = 1;             // accepted measurements before velocity and TTC are reported
    bool size_from_ground = true;    // size by the class its ground range's heights allow
    double max_gap_s = 0.5;          // a track without an accepted measurement for longer is not reported
    double accel_sd_fraction = 0.5;  // process noise = this x the class's max acceleration
    std::optional<double> ego_speed_param;
    std::string origin = "bumper";
    double front_overhang = 3.4;
  };
  // Re-fuses a cue with its ground range mapped onto the pinhole range's scale by the track's fit
  // (hazardforge/estimation/range_alignment.hpp: pitch offset and height scale), so the fused range does not
  // drift when the cues' weights change with distance or when one of them comes and goes (which would read as
  // a velocity). frame_offset: the inverse-depth offset every ground cue of this frame shares (the ego's body
  // pitch).
  // Sets depth, var, noise_var and method from the cues present (see range_cue and aligned).
  static void fuse(RangeCue& r, bool by_noise);
  static RangeCue aligned(const RangeCue& cue, const estimation::RangeAlignment& fit,
                          double frame_offset = 0.0);
  // Range cue of a box (exposed for tests on synthetic geometry).
  static RangeCue range_cue(const CameraModel& cam, const cv::Rect2f& box, unsigned truncated,
                            double real_height, const Config& c);

 private:
  void drop_shadowed(ObjectStates& out) const;
  estimation::RangeAlignment new_alignment(const CameraModel& cam) const;
  double ground_offset_of_frame(const CameraModel& cam, const Tracks& tracks, const cv::Size& image_size,
                                const Config& live, double frame_t);
  double box_jitter_px() const;
  double pitch_jitter_deg(const CameraModel& cam) const;
  static constexpr double kPriorSamples = 10.0;  // weight of a stated noise against the measured samples
  struct TrackMemory {
    TrackMemory(estimation::TrackFilter f, std::string l, estimation::RangeAlignment a)
        : filter(std::move(f)), label(std::move(l)), alignment(a) {}
    estimation::TrackFilter filter;
    std::string label;
    estimation::RangeAlignment alignment;        // ground cue -> pinhole cue, fitted on this track's frames
    std::array<double, 3> height{}, height_t{};  // the last whole box heights and their times
    int heights = 0;
    std::optional<double> last_residual_rows;  // the ground/pinhole residual of its last frame (rows)
    double last_residual_t = 0.0;
    // ln of the height (m) the ground-contact range gives each whole box, and its variance (the last
    // kHeightSamples): the evidence for which class of the label's group sizes the track.
    std::vector<double> log_height, log_height_var;
  };
  static constexpr size_t kHeightSamples = 15;
  static constexpr size_t kMinHeightSamples = 2;         // whole boxes with a ground range before they count
  static constexpr double kMaxHeightSampleVar = 0.0625;  // a box's implied ln height beyond 25 % is left out
  static constexpr double kHeightRuleOut = 0.05;         // posterior below which a class is ruled out
  // The class whose size prior the track's range uses: the detector's voted label, unless the heights the
  // ground-contact range implies rule it out for another class of its group (car / truck / bus). `why` says
  // so when the answer is not the voted label.
  std::string size_class(const TrackMemory& mem, const std::string& voted, std::string* why) const;
  // Adds this frame's implied height of a whole, matched box to the track's evidence.
  void add_height_sample(TrackMemory& mem, const CameraModel& cam, const cv::Rect2f& box, unsigned truncated,
                         const Config& live, double frame_offset) const;
  void learn_jitter(TrackMemory& mem, const Track& tr, unsigned truncated, double t);
  Config cfg_;
  ClassPriors priors_;
  LimitsTable limits_;
  std::map<int64_t, TrackMemory> tracks_;
  estimation::KeypointScaleTracker keypoints_;
  estimation::RobustSpread jitter_;          // box edge jitter samples (px)
  estimation::RobustSpread pitch_rows_;      // ground-vs-pinhole residuals in image rows
  estimation::LagCorrelation lag_products_;  // their correlation from one frame to the next
  double noise_rows2_ = 0.0;                 // their mean variance explained by box noise (rows^2)
  std::optional<CameraModel> last_camera_;
  Corridor corridor_;
  std::optional<cv::Matx44d> last_pose_;
  double last_t_ = 0.0;
  bool have_last_ = false;
  std::set<std::string> warned_;
  ClassGroups groups_{default_class_groups()};
};

}  // namespace hf
