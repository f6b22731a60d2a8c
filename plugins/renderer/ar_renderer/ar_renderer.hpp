// The ar_renderer stage: composites a planned hazard (HazardTrajectory) into the original video so that it
// stays fixed in the world while the ego moves, with perspective, occlusion, shadow and harmonised colour.
#pragma once

#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "compositor.hpp"
#include "ego_motion.hpp"
#include "hazardforge/assets/asset_library.hpp"
#include "hazardforge/assets/footage_harvest.hpp"
#include "hazardforge/geometry.hpp"
#include "hazardforge/stage.hpp"
#include "scene_light.hpp"

namespace hf::render {

// A detected object that may stand in front of the hazard.
struct OccluderCandidate {
  cv::Rect2f box;
  float score = 1.f;
  std::optional<double> distance_m;  // ego x (from the rear axle) of its near face, if an estimator gave one
  std::string label;                 // detector's class (realism references), empty = unknown
  unsigned truncated = 0;            // hf::truncation flags of the box
  int misses = 0;                    // frames the track has not been seen (its box is predicted)
  int64_t track_id = -1;             // the recording's track, -1 for a bare detection
  std::optional<double> lateral_m;   // its ego-frame lateral offset if an estimator gave one
};

// Every object the renderer's inputs know of, once: the states' objects (with their distances) first, then
// the tracks and detections that no state stands for (same track, or a box overlapping a state's by IoU >=
// 0.5). An estimator keeps no state for an object whose distance it cannot measure (a car beside the ego, cut
// by the picture's left and bottom edges), but that object still hides what is behind it.
std::vector<OccluderCandidate> merge_occluders(const ObjectStates* states, const Tracks* tracks,
                                               const Detections* detections);

// Realism measurement: the inserted object's appearance in every frame it is drawn, and the recording's own
// road users measured the same way on the original picture (hazardforge/realism/metrics.hpp).
struct RealismOptions {
  bool enabled = true;
  int references = 1;       // real objects measured per class group (vehicles, people) and frame; 0 = none
  int reference_every = 3;  // ... on every n-th frame (grabCut is the cost)
  double min_score = 0.5;   // weakest detection measured
  double min_height_px = 24.0;  // smallest box measured
  // Also the dataset's annotated road users (Frame::annotations: 3D boxes projected into the picture), up to
  // `references` per group and frame besides the detections' (an object both give is measured once): objects
  // the detector misses or mislabels count too, and they are never a false detection.
  bool annotations = true;
  // An annotated object is measured only when at most this share of it is hidden: by the dataset's own hint
  // (AnnotatedObject::occlusion) and by the boxes of nearer annotated objects over its box in this picture.
  double max_occlusion = 0.2;
};

struct RendererOptions {
  CompositeOptions composite;
  EgoTrajectory::Options ego;
  double max_view_error_deg = 30.0;
  bool occlusion = true;
  double occluder_min_score = 0.3;
  double ego_front_m = 3.4;  // ego origin to front bumper, for the intended TTC (GUIDE protocol)
  Corridor corridor;
  RealismOptions realism;
  // The hazard casts a shadow like the recording's vehicles do (direction, reach, darkness read from the road
  // beside them, SceneLightEstimator); without a consistent one only the contact shadow is drawn.
  bool scene_light = true;
  ClassPriors vehicle_sizes;  // share/class_sizes.yaml: the real vehicles' footprints (defaults when absent)
  int scene_light_max_samples = 300;  // vehicle views measured, then the estimate is kept
  // Appearances cut from the recording itself (hazardforge/assets/footage_harvest.hpp) until the hazard is
  // first drawn, preferred over the asset folders when one shows the needed view sharply enough: the camera's
  // own look. `footage_dir` is where they are written (the run's bank) and named from.
  bool footage = true;
  FootageHarvestOptions footage_harvest;
  double footage_max_upscale = 3.0;  // a cut drawn larger than this times its height is not used
  double footage_harmonize = 0.2;    // share of the colour harmonisation applied to such a cut
  std::filesystem::path footage_dir;
  // Cuts from this recording made by an earlier pass over all of it (a campaign's scouting pass, the
  // footage_harvester sink), chosen among like the run's own; empty = none.
  std::filesystem::path footage_bank;
};

// Everything the stage does for one frame, without the graph plumbing (used by the stage and the benchmark).
class HazardRenderer {
 public:
  HazardRenderer(RendererOptions o, std::shared_ptr<const AssetLibrary> assets);

  struct Result {
    Frame frame;            // the augmented frame (the input's image when nothing was drawn)
    HazardInstance hazard;  // where the hazard is in this frame
    CompositeResult composite;
    std::string asset_file;        // the picture used, empty when nothing was drawn
    double prepare_seconds = 0;    // time spent preparing a new hazard's pictures (once per hazard)
    double ego_seconds = 0;        // time spent on ego motion
    double composite_seconds = 0;  // time spent placing and drawing
    double realism_seconds = 0;    // time spent measuring appearances (not part of drawing)
    double takeover_seconds = 0;   // time spent removing a taken-over real object (part of composite_seconds)
    double light_seconds = 0;      // time spent reading the scene's light off the real vehicles' shadows
  };
  // Call once per frame, in order. `trajectory` may be null (no hazard yet).
  Result render(const Frame& frame, const std::shared_ptr<const HazardTrajectory>& trajectory,
                const std::vector<OccluderCandidate>& occluders);

  // Shows the harvest one frame's tracked objects (before the hazard is first drawn; a no-op after, or with
  // the footage harvest off). Returns the seconds it took.
  double observe(const Frame& frame, const ObjectStates* states, const Tracks* tracks);
  // The footage harvest, null when off.
  const FootageHarvest* harvest() const { return harvest_.get(); }

  const EgoTrajectory& ego() const { return ego_; }
  // The scene's light as measured so far on the recording's vehicles.
  SceneLight light() const { return light_.estimate(); }
  std::vector<std::string> take_warnings();
  std::vector<std::string> take_notes();  // what the log should say at info level (the appearance chosen)

 private:
  // The picture for the hazard's first drawn frame: a cut from this footage (the taken-over object's own
  // first) when one shows the view within max_view_error_deg and the hazard is drawn at most
  // footage_max_upscale times its height; else the asset folders'. Says which and why.
  const LoadedAsset* first_pick(const HazardTrajectory& T, double azimuth_deg, double drawn_height_px);
  void start_hazard(const HazardTrajectory& t);
  void measure_realism(const Frame& original, const std::vector<OccluderCandidate>& objects,
                       Result& res) const;
  // The frame's annotated objects of a class group measured as references, tallest first, except those
  // overlapping a box in `measured` (IoU >= 0.5: already measured from the detections).
  std::vector<AppearanceStats> annotated_references(const Frame& original, const std::string& group,
                                                    const std::vector<cv::Rect2f>& measured) const;
  // The taken-over real object in this frame (its track, else the box that best continues its last one),
  // removed from `image` by inpainting; nullopt when it is not in view.
  std::optional<TakenOver> remove_taken_over(cv::Mat& image, const std::vector<OccluderCandidate>& objects);

  RendererOptions opt_;
  std::shared_ptr<const AssetLibrary> assets_;
  EgoTrajectory ego_;
  std::shared_ptr<const HazardTrajectory> traj_;
  std::string identity_;  // asset instance kept through one hazard
  CompositorState compositor_;
  std::optional<cv::Point2d> prev_center_px_;
  double prev_t_ = 0;
  bool warned_future_anchor_ = false;
  std::optional<int64_t> taken_id_;      // the hazard's track_id: a real object it replaces
  bool reached_ = false;                 // past its plan, the ego has reached the hazard: no longer drawn
  std::optional<cv::Rect2f> taken_box_;  // that object's latest box
  int taken_unseen_ = 0;                 // frames since its track last had it
  std::optional<double> taken_lateral_;  // its latest measured lateral offset (m)
  std::optional<double> lane_shift_;     // smoothed sideways correction keeping the hazard in its lane (m)
  bool warned_taken_missing_ = false;
  std::vector<std::string> warnings_;
  std::vector<std::string> notes_;
  SceneLightEstimator light_;
  std::unique_ptr<FootageHarvest> harvest_;
  std::vector<FootageCut> bank_;  // opt_.footage_bank's cuts
  bool saw_states_ = false;       // observe() was given tracked objects
  std::unique_ptr<AssetLibrary> footage_lib_;  // the harvest's cuts of the hazard's class, once picked
  const AssetLibrary* drawn_from_ = nullptr;  // the library the hazard's pictures come from
};

// The run folder's sub-folder the footage harvest's cuts are written to (an asset folder).
inline constexpr const char* kFootageFolder = "appearances";

// Stage "ar_renderer" (kind renderer).
//  inputs:  frames (Frame); trajectory (HazardTrajectory, sticky: the latest plan is used until a new one
//  comes);
//           tracks (Tracks), states (ObjectStates), detections (Detections) — optional, for occlusion by
//           nearer objects.
//  outputs: frames (Frame: same index, timestamp, camera, ego and meta; new image), hazard (HazardInstance),
//           one of each per input frame, stamped with the frame's time; visible_frames (Frame): the same
//           augmented frame, only when the hazard is visible in it (param visible_frames). Frames outside the
//           trajectory's time span pass through unchanged (hazard.visible = false).
//  params:  assets_dir, fallback_assets, ego_motion (auto|poses|track|constant_speed),
//           ego_speed_mps, max_view_error_deg, shadow, shadow_strength, scene_light,
//           harmonize_luma, harmonize_chroma, exposure_smoothing, grain, feather_px, match_sharpness,
//           exposure_s, occlusion, occluder_min_score, ego_front_m, realism, realism_references,
//           realism_reference_every, realism_min_score, visible_frames, corridor_half_width, corridor_margin,
//           corridor_path (see describe()).
//  With `realism` (default) the hazard packet carries the inserted object's appearance as drawn
//  (HazardInstance::appearance) and that of up to `realism_references` real road users per class group
//  measured on the original picture (HazardInstance::references), for the verifier's comparison.
class ArRenderer : public Stage {
 public:
  static ComponentInfo describe();
  void open(StageContext& ctx) override;
  void process(StageContext& ctx, const Inputs& in, Outputs& out) override;
  void finish(StageContext& ctx, Outputs& out) override;

 private:
  std::unique_ptr<HazardRenderer> renderer_;
  bool emit_visible_ = true;
  bool light_logged_ = false;
};

// One line on the scene's light for the run log.
std::string describe_light(const SceneLight& light);
// Reads the renderer's options from validated params (shared by the stage and the benchmark).
RendererOptions renderer_options(const Params& p);
// The photographic default set cut out at set-up (tools/CMakeLists.txt), empty when it was not built.
std::filesystem::path photo_assets_dir();
// assets_dir resolved (empty = the photographic default set, else share_dir()/assets) and the library loaded
// with the default sets as fallbacks (the photographic one, then the generated one).
std::shared_ptr<const AssetLibrary> load_assets(const Params& p);

}  // namespace hf::render
