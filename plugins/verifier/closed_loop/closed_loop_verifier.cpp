// verifier: per-frame IoU/confidence/distance/TTC comparison of the re-assessment with the inserted hazard.
#include "closed_loop_verifier.hpp"

#include <algorithm>
#include <cmath>
#include <numeric>

#include <hazardforge/atomic_file.hpp>
#include <hazardforge/geometry.hpp>
#include <hazardforge/json_text.hpp>
#include <hazardforge/number_text.hpp>
#include <hazardforge/output_path.hpp>
#include "hazardforge/hazard/kinematics.hpp"
#include "hazardforge/realism/compare.hpp"

namespace hf {

namespace {

// Detectors confuse car/truck/bus and bicycle/motorcycle; those confusions still count as re-detections.
int class_group(const std::string& label) {
  if (label == "car" || label == "truck" || label == "bus" || label == "van") return 1;
  if (label == "bicycle" || label == "motorcycle") return 2;
  if (label == "person" || label == "pedestrian") return 3;
  return 0;
}
bool same_class(const std::string& a, const std::string& b) {
  return a == b || (class_group(a) != 0 && class_group(a) == class_group(b));
}

double median(std::vector<double> v) {
  if (v.empty()) return std::nan("");
  std::sort(v.begin(), v.end());
  const size_t n = v.size();
  return n % 2 ? v[n / 2] : (v[n / 2 - 1] + v[n / 2]) / 2;
}
double mean(const std::vector<double>& v) {
  return v.empty() ? std::nan("") : std::accumulate(v.begin(), v.end(), 0.0) / v.size();
}
Json maybe(double v) {
  return std::isfinite(v) ? Json(v) : Json();
}
Json box_json(const cv::Rect2f& r) {
  return Json::array({r.x, r.y, r.width, r.height});
}

}  // namespace

ComponentInfo ClosedLoopVerifier::describe() {
  ComponentInfo i;
  i.name = "verifier";
  i.kind = kind::kVerifier;
  i.summary = "closed-loop check: is the inserted hazard re-detected, measured and judged Unsafe?";
  i.doc =
      "Per frame with a hazard packet: best IoU of a detection with the inserted object's box (the box of "
      "its drawn silhouette where nearer objects leave it seen, as a detector would draw it; same class "
      "group when require_class_match), its confidence, the matched object's estimated distance against "
      "the intended one, the scene TTC of the TTC metric and every metric's label. At finish: minimum "
      "achieved scene TTC against the intended one, whether any frame was Unsafe while the hazard was "
      "visible, the re-detection rate over the visible frames with at least min_visible_share of the object "
      "in view, "
      "distance errors; passed = every criterion holds. Reported beside the verdict, never part of it: "
      "`realism` (the inserted object's appearance in its visible frames against the recording's real "
      "objects of its class, from the renderer's hazard packets) and `independent_redetection` (the "
      "independent_detections input: share of the same counted frames with a detection of IoU >= min_iou "
      "of the class group, and of the exact class).";
  i.inputs = {optional(port<HazardInstance>("hazard", "where the renderer put the hazard")),
              port<Detections>("detections", "detections on the augmented frames"),
              optional(multi(port<RiskAssessment>("risk", "re-assessed risk metrics"))),
              optional(port<ObjectStates>("states", "re-estimated object states")),
              sticky(port<HazardTrajectory>("trajectory", "the planned hazard")),
              optional(port<Detections>(
                  "independent_detections",
                  "an independent detector's detections on the augmented frames (reported, never "
                  "part of the verdict)"))};
  i.outputs = {port<Record>("records", "per-frame verification records and the final summary"),
               port<VerificationOutcome>("outcome", "the scenario's verdict, typed, once at finish")};
  i.params = {
      ParamSpec::number("min_iou", 0.5)
          .range(0.01, 1)
          .describe("IoU with the inserted box that counts as re-detected"),
      ParamSpec::number("min_redetection_rate", 0.5)
          .range(0, 1)
          .describe("pass: share of the counted visible frames (min_visible_share) in which the object is "
                    "re-detected"),
      ParamSpec::number("min_visible_share", 0.5)
          .range(0, 1)
          .describe(
              "re-detection (by both detectors) is counted over the visible frames in which at least this "
              "share of the object's silhouette is inside the picture and not hidden by nearer objects; "
              "frames with less say nothing either way (KITTI's hardest level still counts objects up to "
              "50 % truncated) and are reported as partly visible"),
      ParamSpec::boolean("require_unsafe", true)
          .describe("pass: some frame is Unsafe while the hazard is visible"),
      ParamSpec::boolean("require_hazard_critical", false)
          .describe(
              "pass: some visible Unsafe frame is the hazard's: the inserted object is the TTC metric's "
              "critical track AND its planned TTC there is below the threshold (+ planned_ttc_tolerance_s); "
              "every other Unsafe frame is reported as spurious and never makes a pass"),
      ParamSpec::number("planned_ttc_tolerance_s", 0.5)
          .range(0, 10)
          .describe("how far above the risk threshold the hazard's planned TTC may be in a frame that is "
                    "credited to it (the re-assessment's TTC lags and scatters around the plan)"),
      ParamSpec::boolean("require_class_match", true)
          .describe("a re-detection must have the inserted class (car/truck/bus and bicycle/motorcycle "
                    "interchangeable)"),
      ParamSpec::string("ttc_metric", "")
          .describe("risk stream (metric name or producing node) whose scene value is the TTC; empty = the "
                    "first in seconds"),
      ParamSpec::string_list("unsafe_metrics", {})
          .describe("metrics whose Unsafe label counts (empty = all)"),
      ParamSpec::number("max_ttc_error_s", -1.0)
          .range(-1, 100)
          .describe("pass: |achieved - intended minimum TTC| at most this (-1 = not checked)"),
      ParamSpec::string("intended_distance_at", "near_face")
          .one_of({"near_face", "centre"})
          .describe(
              "compare with the inserted object's near face (centre - length/2: what a camera measures) or "
              "its centre"),
      ParamSpec::number("min_iou_tracked", 0.1)
          .range(0, 1)
          .describe(
              "a track that overlapped the inserted box by min_iou in an earlier frame still counts as the "
              "inserted object's (for attribution, not for distances) while it overlaps it by this much, "
              "beside the state that overlaps it by min_iou now"),
      ParamSpec::number("max_takeover_uncovered", 0.5)
          .range(0, 1)
          .describe(
              "pass, when the hazard took over a real object (the renderer removed it): in every frame at "
              "most this share of the real object's box is left uncovered by the drawn hazard and shows "
              "the inpainted fill"),
      ParamSpec::string("file", "verification.json")
          .describe("summary written below the run's output folder"),
  };
  return i;
}

void ClosedLoopVerifier::open(StageContext& ctx) {
  const Params& p = ctx.params();
  min_iou_ = p.get_double("min_iou");
  min_rate_ = p.get_double("min_redetection_rate");
  min_visible_share_ = p.get_double("min_visible_share");
  require_unsafe_ = p.get_bool("require_unsafe");
  require_critical_ = p.get_bool("require_hazard_critical");
  planned_tolerance_ = p.get_double("planned_ttc_tolerance_s");
  max_takeover_uncovered_ = p.get_double("max_takeover_uncovered");
  min_iou_tracked_ = p.get_double("min_iou_tracked");
  require_class_match_ = p.get_bool("require_class_match");
  ttc_metric_ = p.get_string("ttc_metric");
  unsafe_metrics_ = p.get_strings("unsafe_metrics");
  max_ttc_error_ = p.get_double("max_ttc_error_s");
  near_face_ = p.get_string("intended_distance_at") == "near_face";
  file_ = output_param_path(ctx, "file");
}

void ClosedLoopVerifier::process(StageContext& ctx, const Inputs& in, Outputs& out) {
  if (const HazardTrajectory* tr = in.get<HazardTrajectory>("trajectory")) {
    trajectory_seen_ = true;
    if (tr->spec.track_id) planned_takeover_ = *tr->spec.track_id;
    intended_traj_min_ = tr->intended_min_ttc_s;
    length_ = tr->size_lwh[0];
    if (!tr->points.empty()) plan_end_t_ = tr->points.back().t;
    kind_ = tr->kind;
    object_class_ = tr->object_class;
  }
  const HazardInstance* inst = in.get<HazardInstance>("hazard");
  if (!inst) return;
  const Detections& dets = in.require<Detections>("detections");
  const ObjectStates* states = in.get<ObjectStates>("states");
  ++frames_;
  if (kind_.empty()) kind_ = inst->kind;
  if (object_class_.empty()) object_class_ = inst->object_class;
  const int64_t frame = ctx.frame_index();

  // What a detector can see of the object: its drawn silhouette's box (the projected box where the renderer
  // does not say), and whether enough of it is in view for a detection to be expected.
  const cv::Rect2f target = inst->drawn_box.area() > 0 ? inst->drawn_box : inst->box;
  const bool counted = inst->visible && inst->visible_share() >= min_visible_share_;
  Json rec = {{"frame", frame},
              {"visible", inst->visible},
              {"visible_share", inst->visible_share()},
              {"counted", counted},
              {"box", box_json(target)},
              {"intended_distance_m", maybe(inst->distance_m)},
              {"intended_ttc_s", maybe(inst->intended_ttc_s)}};
  // Past the plan's last point the renderer draws the hazard carrying on as it ended; its intended TTC there
  // is that continuation's, so the plan's own minimum is taken over the frames within the plan.
  const bool after_plan = plan_end_t_ && ctx.timestamp() > *plan_end_t_ + 1e-6;
  if (after_plan) rec["after_plan"] = true;

  // Re-detection: the best-overlapping detection of a compatible class.
  double best = 0;
  const Detection* hit = nullptr;
  for (const Detection& d : dets.items) {
    if (require_class_match_ && !same_class(d.label, inst->object_class)) continue;
    const double v = box_iou(d.box, target);
    if (v > best) best = v, hit = &d;
  }
  const bool redetected = counted && best >= min_iou_;
  rec["best_iou"] = best;
  rec["detection"] =
      hit ? Json{{"label", hit->label}, {"score", hit->score}, {"box", box_json(hit->box)}} : Json();
  rec["redetected"] = redetected;

  // Distance: the re-estimated object state on the inserted box.
  const ObjectState* match = nullptr;
  if (states) {
    double best_state = 0;
    for (const ObjectState& s : states->objects) {
      const double v = box_iou(s.box, target);
      if (v >= min_iou_ && v > best_state) best_state = v, match = &s;
    }
  }
  rec["state"] =
      match ? Json{{"track_id", match->track_id}, {"distance_m", maybe(match->distance_m)}} : Json();
  // The inserted object's tracks: the state on its box, and every track that was on it in an earlier frame
  // while it still overlaps it (min_iou_tracked). Close up a box cut by the image border and the projected 3D
  // box part ways (IoU 0.1-0.4 on the KITTI raw clip) while the tracker keeps following the object, and a
  // second track may start on it beside the first.
  std::set<int64_t> hazard_tracks;
  if (match) hazard_tracks.insert(match->track_id);
  if (states)
    for (const ObjectState& s : states->objects)
      if (hazard_tracks_seen_.count(s.track_id) && box_iou(s.box, target) >= min_iou_tracked_)
        hazard_tracks.insert(s.track_id);
  if (match) hazard_tracks_seen_.insert(match->track_id);
  if (!hazard_tracks.empty() && (!match || hazard_tracks.size() > 1))
    rec["hazard_tracks"] = Json(std::vector<int64_t>(hazard_tracks.begin(), hazard_tracks.end()));

  if (inst->taken_over) {
    const TakenOver& to = *inst->taken_over;
    taken_track_ = to.track_id;
    ++taken_frames_;
    if (!to.seen) ++taken_unseen_frames_;
    // Judged where the hazard is drawn: after a plan that ends at contact nothing is drawn in its place.
    if (inst->visible) {
      taken_uncovered_.push_back(to.uncovered_fraction);
      taken_max_shift_ = std::max(taken_max_shift_, std::abs(to.lateral_shift_m));
      if (to.uncovered_fraction > taken_worst_ || taken_worst_frame_ < 0)
        taken_worst_ = to.uncovered_fraction, taken_worst_frame_ = frame;
    }
    rec["taken_over"] = {{"track_id", to.track_id},
                         {"box", box_json(to.box)},
                         {"seen", to.seen},
                         {"uncovered_fraction", to.uncovered_fraction},
                         {"lateral_shift_m", to.lateral_shift_m}};
  }

  // Reported only: realism and the independent detector.
  for (const AppearanceStats& r : inst->references) references_.push_back(r);
  if (inst->visible && inst->appearance) {
    appearance_.push_back(*inst->appearance);
    rec["realism"] = *inst->appearance;
  }
  if (const Detections* ind = in.get<Detections>("independent_detections"); ind && counted) {
    if (independent_detector_.empty()) independent_detector_ = ind->detector;
    double best_any = 0;
    const Detection* top = nullptr;
    for (const Detection& d : ind->items) {
      const double v = box_iou(d.box, target);
      if (v > best_any) best_any = v, top = &d;
    }
    const bool found = top && best_any >= min_iou_ && same_class(top->label, inst->object_class);
    const bool exact = found && top->label == inst->object_class;
    ++independent_frames_;
    independent_ious_.push_back(best_any);
    if (found) ++independent_found_;
    if (exact) ++independent_exact_;
    ++independent_labels_[top && best_any >= min_iou_ ? top->label : "(none)"];
    rec["independent"] = {{"best_iou", best_any},
                          {"label", top ? Json(top->label) : Json()},
                          {"score", top ? Json(top->score) : Json()},
                          {"redetected", found},
                          {"right_class", exact}};
  }

  // Risk: the TTC stream and every metric's label.
  const auto risks = in.packets("risk");
  const auto producers = in.producers("risk");
  const RiskAssessment* ttc = nullptr;
  bool unsafe = false;
  Json labels = Json::object();
  std::string names;
  for (size_t k = 0; k < risks.size(); ++k) {
    const RiskAssessment& r = risks[k]->get<RiskAssessment>();
    const std::string name = r.metric.empty() ? producers.at(k) : r.metric;
    names += (names.empty() ? "" : ", ") + name;
    saw_risk_ = true;
    labels[name] = to_string(r.label);
    const bool counts =
        unsafe_metrics_.empty() ||
        std::find(unsafe_metrics_.begin(), unsafe_metrics_.end(), name) != unsafe_metrics_.end() ||
        std::find(unsafe_metrics_.begin(), unsafe_metrics_.end(), producers.at(k)) != unsafe_metrics_.end();
    if (counts && r.label == SafetyLabel::kUnsafe) {
      unsafe = true;
      if (std::find(unsafe_by_.begin(), unsafe_by_.end(), name) == unsafe_by_.end() && inst->visible)
        unsafe_by_.push_back(name);
    }
    const bool wanted =
        ttc_metric_.empty()
            ? (chosen_ttc_metric_.empty() ? r.unit == "s" && r.lower_is_riskier : name == chosen_ttc_metric_)
            : (name == ttc_metric_ || producers.at(k) == ttc_metric_);
    if (wanted && !ttc) {
      ttc = &r;
      if (chosen_ttc_metric_.empty()) chosen_ttc_metric_ = name;
    }
  }
  if (!ttc_metric_.empty() && !risks.empty() && !ttc)
    throw Error("node '" + ctx.node_id() + "': ttc_metric '" + ttc_metric_ +
                "' is none of the risk streams at frame " + std::to_string(frame) + " (" + names + ")");
  rec["ttc_metric"] = ttc ? Json(chosen_ttc_metric_) : Json();
  rec["scene_ttc_s"] = ttc ? maybe(ttc->scene_value) : Json();
  rec["labels"] = labels;
  rec["unsafe"] = unsafe;
  rec["hazard_is_critical"] = ttc && hazard_tracks.count(ttc->critical_track) > 0;
  // Attribution: an Unsafe frame is the hazard's only when the hazard is the critical object and the plan
  // also says it is critical there; otherwise it is an artefact (another road user, a tracking error) —
  // spurious.
  const double threshold = ttc ? ttc->threshold : 1.5;
  const bool planned_critical = inst->intended_ttc_s < threshold + planned_tolerance_;
  bool attributed = false;
  if (unsafe && inst->visible) {
    attributed = rec["hazard_is_critical"].get<bool>() && planned_critical;
    if (attributed)
      rec["attribution"] = "hazard";
    else if (!rec["hazard_is_critical"].get<bool>())
      rec["attribution"] = "spurious: the inserted object is not the critical track";
    else
      rec["attribution"] = "spurious: the hazard's planned TTC " + num_text(inst->intended_ttc_s) +
                           " s is not below the threshold " + num_text(threshold) + " s + " +
                           num_text(planned_tolerance_) + " s";
  }

  if (counted) {
    ++counted_;
    ious_.push_back(best);
    if (redetected) {
      ++redetected_;
      scores_.push_back(hit->score);
    }
  }
  if (inst->visible) {
    ++visible_;
    best_share_ = std::max(best_share_, inst->visible_share());
    if (match && std::isfinite(match->distance_m) && std::isfinite(inst->distance_m)) {
      // Both in rear-axle terms (the states say where their distances start); the intended one at the face a
      // camera sees unless the centre is asked for.
      const double estimated = match->distance_m + states->distance_origin_x;
      state_origin_x_ = states->distance_origin_x;
      const double intended = inst->distance_m - (near_face_ ? length_.value_or(0.0) / 2 : 0.0);
      const double err = std::abs(estimated - intended);
      dist_abs_.push_back(err);
      if (intended > 0) dist_rel_.push_back(err / intended);
      rec["distance_compared_m"] = {estimated, intended};
      rec["distance_abs_error_m"] = err;
      rec["distance_rel_error"] = intended > 0 ? Json(err / intended) : Json();
    }
    if (ttc && ttc->scene_value < achieved_min_ttc_) {
      achieved_min_ttc_ = ttc->scene_value;
      achieved_at_frame_ = frame;
    }
    if (after_plan)
      ++visible_after_plan_;
    else
      intended_visible_min_ = std::min(intended_visible_min_, inst->intended_ttc_s);
    if (unsafe) {
      ++unsafe_frames_;
      if (!first_unsafe_frame_) first_unsafe_frame_ = frame;
    }
    if (rec["hazard_is_critical"].get<bool>()) ++critical_frames_;
    if (attributed) {
      ++unsafe_critical_frames_;
      if (!first_unsafe_critical_frame_) first_unsafe_critical_frame_ = frame;
    } else if (unsafe) {
      spurious_frames_.push_back({frame, rec["attribution"].get<std::string>()});
    }
  }
  out.emit("records", Record{"verification", std::move(rec)});
}

Json ClosedLoopVerifier::spurious_json() const {
  Json a = Json::array();
  for (const auto& [f, why] : spurious_frames_) a.push_back({{"frame", f}, {"why", why}});
  return a;
}

Json ClosedLoopVerifier::realism_json() const {
  std::vector<std::string> used;
  const auto real = realism::references_for(object_class_, references_, 5, &used);
  Json sources = Json::object();
  for (const AppearanceStats& r : real) {
    const std::string s = r.source.empty() ? "unknown" : r.source;
    sources[s] = sources.value(s, 0) + 1;
  }
  return {{"inserted_frames", appearance_.size()},
          {"reference_labels", used},
          {"reference_samples", real.size()},
          {"reference_sources", sources},
          {"rule", "inserted median within the real objects' 10-90 % range (min-max below 5 samples)"},
          {"metrics", realism::compare(appearance_, real)}};
}

Json ClosedLoopVerifier::independent_json() const {
  if (independent_frames_ == 0) return Json();
  Json labels = Json::object();
  for (const auto& [l, n] : independent_labels_) labels[l] = n;
  return {{"detector", independent_detector_},
          {"counted_frames", independent_frames_},
          {"redetected_frames", independent_found_},
          {"rate", static_cast<double>(independent_found_) / independent_frames_},
          {"right_class_frames", independent_exact_},
          {"right_class_rate", static_cast<double>(independent_exact_) / independent_frames_},
          {"mean_iou", maybe(mean(independent_ious_))},
          {"labels", labels},
          {"note", "reported only: never used to plan or to pass"}};
}

Json ClosedLoopVerifier::takeover_json() const {
  if (!taken_track_) return Json();
  return {{"track_id", *taken_track_},
          {"frames", taken_frames_},
          {"frames_from_held_box", taken_unseen_frames_},
          {"median_uncovered_fraction", maybe(median(taken_uncovered_))},
          {"max_uncovered_fraction", taken_worst_},
          {"max_at_frame", taken_worst_frame_},
          {"max_allowed", max_takeover_uncovered_},
          {"max_abs_lateral_shift_m", taken_max_shift_}};
}

Json ClosedLoopVerifier::summary() const {
  VerificationOutcome o;
  std::vector<Refusal>& reasons = o.reasons;
  auto fail = [&](const char* code, std::string text) { reasons.push_back({code, std::move(text), kind_}); };
  const double rate = counted_ > 0 ? static_cast<double>(redetected_) / counted_ : 0.0;
  const int partly = visible_ - counted_;
  const double intended =
      std::isfinite(intended_visible_min_) ? intended_visible_min_ : intended_traj_min_.value_or(kInf);
  if (visible_ == 0 && !trajectory_seen_ && kind_.empty()) {
    fail(verdict::kNoHazard,
         "no hazard was inserted: no planned trajectory arrived (the generator or the planner "
        "produced none; the run's log says why)");
  } else if (visible_ == 0) {
    fail(verdict::kNeverVisible, "the inserted object is never visible (0 of " + std::to_string(frames_) + " frames)");
  } else if (counted_ == 0) {
    fail(verdict::kNeverVisible, "the inserted object is never at least " + num_text(min_visible_share_) +
                      " in view (min_visible_share): at most " + num_text(best_share_) +
                      " of it is seen in its " + std::to_string(visible_) +
                      " visible frames, too little to expect a detection");
  } else if (rate < min_rate_) {
    fail(verdict::kNotRedetected, "re-detection rate " + num_text(rate) + " is below min_redetection_rate " +
                      num_text(min_rate_) + " (" + std::to_string(redetected_) + " of " +
                      std::to_string(counted_) + " visible frames with IoU >= " + num_text(min_iou_) +
                      (partly > 0 ? "; " + std::to_string(partly) + " more with less than " +
                                        num_text(min_visible_share_) + " of it in view are not counted"
                                  : std::string()) +
                      ")");
  }
  if (require_unsafe_ && !first_unsafe_frame_ && visible_ > 0) {
    std::string why = !saw_risk_ ? "no risk assessment arrived"
                      : chosen_ttc_metric_.empty()
                          ? "no TTC metric among the risk streams"
                          : "minimum scene TTC " + num_text(achieved_min_ttc_) + " s";
    fail(verdict::kNeverUnsafe, "the scene never becomes Unsafe while the hazard is visible (" + why + ")");
  }
  if (require_critical_ && visible_ > 0 && first_unsafe_frame_ && !first_unsafe_critical_frame_) {
    int other = 0, plan = 0;
    for (const auto& [f, why] : spurious_frames_)
      (why.find("not the critical track") != std::string::npos ? other : plan)++;
    fail(verdict::kNotHazardCritical,
        "none of the " + std::to_string(unsafe_frames_) + " Unsafe visible frames is the hazard's: " +
        std::to_string(other) + " with another object critical, " + std::to_string(plan) +
        " where the plan does not make the hazard critical (spurious Unsafe frames never pass)");
  } else if (require_critical_ && visible_ > 0 && !first_unsafe_frame_ && !require_unsafe_)
    fail(verdict::kNeverUnsafe,
        "the scene never becomes Unsafe while the hazard is visible, so the inserted object is never "
        "the cause (minimum scene TTC " +
        num_text(achieved_min_ttc_) + " s)");
  if (planned_takeover_ && !taken_track_ && visible_ > 0)
    fail(verdict::kTakeover,
        "the hazard takes over track " + std::to_string(*planned_takeover_) +
        ", but the renderer never removed the real one: it stays in the video beside the hazard");
  if (taken_track_ && taken_worst_ > max_takeover_uncovered_)
    fail(verdict::kTakeover, "the taken-over real object (track " + std::to_string(*taken_track_) +
                      ") is not hidden by the hazard drawn in its place: " + num_text(taken_worst_) +
                      " of its box shows the inpainted fill at frame " + std::to_string(taken_worst_frame_) +
                      " (max_takeover_uncovered " + num_text(max_takeover_uncovered_) + ")");
  const double ttc_err = std::abs(achieved_min_ttc_ - intended);
  if (max_ttc_error_ >= 0 && visible_ > 0) {
    if (!std::isfinite(achieved_min_ttc_) || !std::isfinite(intended))
      fail(verdict::kTtcError, "cannot compare TTC: achieved minimum " + num_text(achieved_min_ttc_) +
                        " s, intended " + num_text(intended) + " s");
    else if (ttc_err > max_ttc_error_)
      fail(verdict::kTtcError, "achieved minimum TTC " + num_text(achieved_min_ttc_) + " s is " + num_text(ttc_err) +
                        " s away from the intended " + num_text(intended) + " s (max_ttc_error_s " +
                        num_text(max_ttc_error_) + ")");
  }
  o.passed = reasons.empty();
  o.kind = kind_;
  o.object_class = object_class_;
  if (std::isfinite(intended_visible_min_)) o.intended_min_ttc_s = intended_visible_min_;
  if (std::isfinite(achieved_min_ttc_)) o.achieved_min_ttc_s = achieved_min_ttc_;
  o.achieved_at_frame = achieved_at_frame_;
  o.hazard_critical_frames = unsafe_critical_frames_;
  for (const auto& [f, why] : spurious_frames_) o.spurious_frames.push_back(f);
  if (counted_ > 0) o.redetection_rate = rate;
  // The typed outcome first, then the details only this file carries.
  Json j = o;
  j["frames"] = frames_;
  j["visible_frames"] = visible_;
  j["visible_frames_after_plan"] = visible_after_plan_;
  j["ttc"] = {{"metric", chosen_ttc_metric_.empty() ? Json() : Json(chosen_ttc_metric_)},
              {"intended_min_ttc_s", intended_traj_min_ ? maybe(*intended_traj_min_) : Json()},
              {"intended_min_ttc_visible_s", maybe(intended_visible_min_)},
              {"achieved_min_ttc_s", maybe(achieved_min_ttc_)},
              {"achieved_at_frame", achieved_at_frame_ ? Json(*achieved_at_frame_) : Json()},
              {"abs_error_s", maybe(ttc_err)}};
  j["unsafe"] = {{"reached", first_unsafe_frame_.has_value()},
                 {"first_frame", first_unsafe_frame_ ? Json(*first_unsafe_frame_) : Json()},
                 {"frames", unsafe_frames_},
                 {"hazard_critical_frames", unsafe_critical_frames_},
                 {"attributed_frames", unsafe_critical_frames_},
                 {"spurious_frames", spurious_json()},
                 {"first_hazard_critical_frame",
                  first_unsafe_critical_frame_ ? Json(*first_unsafe_critical_frame_) : Json()},
                 {"metrics", unsafe_by_}};
  j["redetection"] = {{"min_iou", min_iou_},
                      {"min_visible_share", min_visible_share_},
                      {"counted_frames", counted_},
                      {"partly_visible_frames", partly},
                      {"redetected_frames", redetected_},
                      {"rate", counted_ > 0 ? Json(rate) : Json()},
                      {"mean_iou", maybe(mean(ious_))},
                      {"median_iou", maybe(median(ious_))},
                      {"mean_confidence", maybe(mean(scores_))}};
  j["distance"] = {
      {"state_origin_x_m", state_origin_x_ ? Json(*state_origin_x_) : Json()},
      {"intended_at", near_face_ ? "near_face" : "centre"},
      {"matched_frames", dist_abs_.size()},
      {"median_abs_error_m", maybe(median(dist_abs_))},
      {"median_rel_error", maybe(median(dist_rel_))},
      {"max_abs_error_m",
       dist_abs_.empty() ? Json() : Json(*std::max_element(dist_abs_.begin(), dist_abs_.end()))}};
  j["hazard_critical_frames"] = critical_frames_;
  j["criteria"] = {{"min_iou", min_iou_},
                   {"min_redetection_rate", min_rate_},
                   {"min_visible_share", min_visible_share_},
                   {"require_unsafe", require_unsafe_},
                   {"require_hazard_critical", require_critical_},
                   {"planned_ttc_tolerance_s", planned_tolerance_},
                   {"require_class_match", require_class_match_},
                   {"max_ttc_error_s", max_ttc_error_},
                   {"min_iou_tracked", min_iou_tracked_},
                   {"max_takeover_uncovered", max_takeover_uncovered_}};
  if (taken_track_) j["taken_over"] = takeover_json();
  if (!appearance_.empty() || !references_.empty()) j["realism"] = realism_json();
  if (independent_frames_ > 0) j["independent_redetection"] = independent_json();
  if (near_face_ && !length_ && !dist_abs_.empty())
    j["distance"]["note"] = "no trajectory arrived: the object's length is unknown, its centre was used";
  return j;
}

void ClosedLoopVerifier::finish(StageContext& ctx, Outputs& out) {
  if (finished_) return;
  finished_ = true;
  const Json s = summary();
  write_file_atomic(file_, json_text(s, 2) + "\n");
  ctx.log(s["passed"].get<bool>() ? LogLevel::kInfo : LogLevel::kWarning,
          std::string("scenario ") + (s["passed"].get<bool>() ? "passed" : "failed") + " verification" +
              (s["reasons"].empty() ? std::string() : ": " + s["reasons"][0].get<std::string>()));
  out.emit("records", Record{"verification_summary", s});
  out.emit("outcome", s.get<VerificationOutcome>());
}

}  // namespace hf
