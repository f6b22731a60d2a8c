// verifier stage: checks that an inserted hazard is re-detected, measured and judged Unsafe by the same
// pipeline.
#pragma once

#include <map>
#include <optional>
#include <set>
#include <string>
#include <vector>

#include "hazardforge/stage.hpp"

namespace hf {

// Stage verifier (kind verifier): the closed loop. The graph re-runs detection, tracking, estimation and risk
// on the augmented frames; this stage compares that re-assessment with what the renderer inserted. Inputs:
// `hazard` (HazardInstance: where the object was drawn, per frame), `detections` (re-detections on the
// augmented frames), `risk` (RiskAssessment, multi: the re-assessed metrics), `states` (ObjectStates,
// optional: for the distance check), `trajectory` (HazardTrajectory, sticky: the intended minimum TTC and the
// object's length); the states' distances are taken from where they say they start (distance_origin_x).
// Output: `records` (Record "verification" per frame with a hazard packet, stamped with that frame; and one
// "verification_summary" at finish, stamped with the last frame) and `outcome` (VerificationOutcome, the
// typed verdict, at finish). Writes <output>/verification.json at finish (atomic). A scenario counts as
// generated only when `passed` is true; `reasons` says why not, `reason_codes` how (verdict::k*).
// `independent_detections` (Detections, optional): an independent detector's detections on the augmented
// frames (never used to plan or to pass), reported as `independent_redetection`. The hazard packets'
// appearances (HazardInstance::appearance / references) are compared in `realism`; neither changes `passed`.
// Params: min_iou, min_redetection_rate, min_visible_share, require_unsafe, require_hazard_critical,
// require_class_match, ttc_metric, unsafe_metrics, max_ttc_error_s, intended_distance_at, file.
class ClosedLoopVerifier : public Stage {
 public:
  static ComponentInfo describe();
  void open(StageContext& ctx) override;
  void process(StageContext& ctx, const Inputs& in, Outputs& out) override;
  void finish(StageContext& ctx, Outputs& out) override;

  // The summary as written to verification.json (also usable before finish, e.g. by tests).
  Json summary() const;

 private:
  // Params
  double min_iou_ = 0.5, min_rate_ = 0.5, max_ttc_error_ = -1, min_visible_share_ = 0.5;
  bool require_unsafe_ = true, require_class_match_ = true, require_critical_ = false;
  std::string ttc_metric_;
  std::vector<std::string> unsafe_metrics_;
  std::string file_;
  std::optional<double> state_origin_x_;  // the matched states' distance_origin_x (m from the rear axle)
  bool near_face_ = true;
  // Accumulated over the run
  int frames_ = 0, visible_ = 0, redetected_ = 0, unsafe_frames_ = 0, critical_frames_ = 0;
  int visible_after_plan_ = 0;        // visible frames past the plan's last point (the hazard carrying on)
  int counted_ = 0;                   // visible frames with at least min_visible_share of it seen
  double best_share_ = 0;             // the largest share of it seen in any visible frame
  std::optional<double> plan_end_t_;  // stream time of the plan's last point
  int unsafe_critical_frames_ = 0;  // visible, Unsafe, and the inserted object is the TTC's critical track
  std::optional<int64_t> first_unsafe_critical_frame_;
  std::vector<double> ious_, scores_, dist_abs_, dist_rel_;
  double achieved_min_ttc_ = kInf, intended_visible_min_ = kInf;
  std::optional<int64_t> achieved_at_frame_, first_unsafe_frame_;
  std::optional<double> intended_traj_min_, length_;
  std::string kind_, object_class_, chosen_ttc_metric_;
  bool saw_risk_ = false;
  std::vector<std::string> unsafe_by_;
  bool finished_ = false;
  bool trajectory_seen_ = false;  // a planned trajectory arrived
  double planned_tolerance_ = 0.5;
  std::vector<std::pair<int64_t, std::string>> spurious_frames_;  // Unsafe visible frames not the hazard's, why
  Json spurious_json() const;
  // Realism (reported only): the inserted object's appearance per visible frame, the real objects' per frame.
  std::vector<AppearanceStats> appearance_, references_;
  // Independent detector on the augmented frames (reported only).
  std::string independent_detector_;
  int independent_frames_ = 0, independent_found_ = 0, independent_exact_ = 0;
  std::vector<double> independent_ious_;
  std::map<std::string, int> independent_labels_;
  Json realism_json() const;
  Json independent_json() const;
  // A real object the hazard took over: how much of it the drawn hazard left to inpainting, per frame.
  double max_takeover_uncovered_ = 0.5;
  double min_iou_tracked_ = 0.1;
  std::set<int64_t> hazard_tracks_seen_;  // tracks that were on the inserted box (IoU >= min_iou) in some frame
  std::optional<int64_t> taken_track_;
  std::optional<int64_t> planned_takeover_;  // the trajectory's spec names a real object to take over
  int taken_frames_ = 0, taken_unseen_frames_ = 0;
  std::vector<double> taken_uncovered_;
  double taken_worst_ = 0, taken_max_shift_ = 0;
  int64_t taken_worst_frame_ = -1;
  Json takeover_json() const;
};

}  // namespace hf
