// Base class for hazard templates: a kind only designs the object's motion; sampling, ego plan, TTC, limits
// and visibility checks are shared so every kind is judged by the same rules.
#pragma once

#include <functional>
#include <optional>
#include <string>
#include <vector>

#include "hazardforge/geometry.hpp"
#include "hazardforge/hazard/ego_path.hpp"
#include "hazardforge/hazard/kinematics.hpp"
#include "hazardforge/stage.hpp"

namespace hf::hazard {

// The road a template plans on: the scene's settled RoadLayout (SceneContext::road), else the template's own
// params (scene-bound: road.lanes_left ...) with the recording's lane markings. Road coordinates (EgoPath): the
// ego lane is centred on the ego's path (d = 0), lanes and kerbs run parallel to it.
struct RoadModel : RoadLayout {
  static std::vector<ParamSpec> params();
  static RoadModel from(const Params& p);
  // A settled road: every fact as the layout says (nothing is applied to it further).
  static RoadModel from(const RoadLayout& layout);
  // Which of lanes_left, lanes_right, oncoming_lanes and driving_side were stated (params, scene block)
  // rather than defaults.
  bool lanes_left_stated = false, lanes_right_stated = false, oncoming_stated = false;
  bool driving_side_stated = false;
  // What the lane counts rest on, for logs and the prompt: "stated", "default", or what the markings showed.
  std::string lanes_from = "default";
  // The road with what the recording's lane markings show for each side whose lane count was not stated: a
  // solid line leaves no lane beyond it, a dashed one one lane (two when a further dashed line follows); a
  // yellow line on the oncoming side parts opposing traffic, so the lanes beyond it are oncoming. A side the
  // markings do not show keeps its value. The one place the markings become lanes; null = unchanged.
  RoadModel with_markings(const RoadMarkings* markings) const;
};

// The object's state `tau` seconds after the anchor time, in road coordinates: x = arc length along the ego's
// path from the ego's position at the anchor time, y = offset to the left of that path (on a straight ego
// path these are the anchor frame's x and y). The base maps it into the anchor frame.
struct ObjectMotion {
  double x = 0, y = 0;    // ground-contact centre (m)
  double vx = 0, vy = 0;  // dx/dt, dy/dt (m/s)
  double accel = 0;       // along the path (m/s^2), for the record
  std::optional<double>
      heading;  // rad, relative to the road; default: direction of motion (held while standing)
};
using MotionFn = std::function<ObjectMotion(double tau)>;

// What a kind designs.
struct Design {
  MotionFn motion;
  std::optional<cv::Vec3d> size_lwh;  // default: the class prior
  Json notes = Json::object();        // design values worth recording (brake time, lane-change duration ...)
};

// A design's (or check's) reasons against one spec: refuse(code, text) appends {code, text, kind}.
struct Reasons {
  std::vector<Refusal>& out;
  const std::string& kind;
  void operator()(const char* code, std::string text) const { out.push_back({code, std::move(text), kind}); }
};

// Everything a kind needs to design a motion.
struct PlanRequest {
  const HazardSpec& spec;
  const SceneContext& scene;
  const KinematicLimits& limits;  // of spec.object_class
  cv::Vec3d size_lwh;             // class prior (length, width, height)
  double ego_speed = 0;           // m/s at the anchor time (the frame's)
  const RoadModel& road;
  const TtcConventions& ttc;
  double duration = 0;   // s
  const Params& params;  // the template's validated params
  const EgoPath& ego;    // where the ego goes: the recorded track, or straight at ego_speed
  // A hazard already under way (HazardSpec::under_way_s): the design starts under_way s before the anchor time and
  // `ego` is the ego's path from there; `anchor_ego` is its path from the anchor time, where the recording
  // (and the camera's view of the hazard) begins. Without: under_way 0 and anchor_ego = &ego.
  double under_way = 0;
  const EgoPath* anchor_ego = nullptr;

  // |y| below which an object of this width is in the ego path.
  double path_half_width(double object_width) const { return ttc.corridor.half_width_for(object_width); }
  // Gap along the path (protocol convention) of an object centred at road x with length l to the ego at tau.
  double gap(double x, double length, double tau) const {
    return x - ego.s_at(tau) - ttc.ego_front - length / 2;
  }
  // When the ego's front bumper reaches road x (nullopt: it never does).
  std::optional<double> ego_front_reaches(double x) const { return ego.time_at(x - ttc.ego_front); }
  // +1 left / -1 right from lateral_offset_m's sign, else from `side`; 0 when neither says.
  int side_sign() const;
};

// Projection of an object's 3D box into the camera.
struct BoxView {
  bool in_front = false;       // every corner ahead of the camera
  bool centre_inside = false;  // the box centre projects inside the image
  cv::Rect2d box;              // bounds of the projected corners that are ahead of the camera
  double inside_fraction = 0;  // share of `box` inside the image
};
BoxView view_of(const CameraModel& cam, double x, double y, double heading, const cv::Vec3d& size_lwh);
// The same for an object given in road coordinates (heading relative to the road) at the anchor time.
BoxView view_of(const CameraModel& cam, const EgoPath& ego, double s, double d, double rel_heading,
                const cv::Vec3d& size_lwh);
// Projection of an object given in the design's road coordinates (PlanRequest::ego), seen from the camera at
// the anchor time: for a hazard already under way the design's road x is shifted by the ego's travel up to
// then.
BoxView view_from_anchor(const PlanRequest& req, double s, double d, double rel_heading,
                         const cv::Vec3d& size_lwh);

// The planned hazard and, when infeasible, why.
struct PlanOutcome {
  HazardTrajectory trajectory;
  std::vector<Refusal> reasons;
  std::vector<TtcSample> ttc;  // per sample
  MotionStats stats;
  Json notes = Json::object();
};

class TemplateBase : public HazardTemplate {
 public:
  // kind hazard_template plus the shared params (limits file, sampling, road, TTC conventions).
  static ComponentInfo base_info(std::string name, std::string summary);
  // The same for a kind that describes itself: name and summary from `kind`, and the doc (what `hazardforge
  // inspect` shows) says when the kind applies, its classes and its extra fields, before `doc`.
  static ComponentInfo base_info(const HazardKindInfo& kind, const std::string& doc = {});

  void open(const Params& params) override;
  std::vector<Refusal> check(const HazardSpec& spec, const SceneContext& scene) const override;
  // Throws hf::Error listing the reasons when the spec is infeasible.
  HazardTrajectory plan(const HazardSpec& spec, const SceneContext& scene) const override;
  // Both at once, with the TTC series and peak stats (for reports and tests).
  PlanOutcome evaluate(const HazardSpec& spec, const SceneContext& scene) const;

  const LimitsTable& limits() const { return limits_; }
  const ClassPriors& class_sizes() const { return sizes_; }
  const RoadModel& road() const { return road_; }
  // The road this template plans on in a scene: the scene's settled road, else its own with the scene's lane
  // markings.
  RoadModel road_in(const SceneContext& scene) const;
  const TtcConventions& ttc_conventions() const { return ttc_; }
  // The ego's motion this template plans against from the scene's time on: the recorded track when the scene
  // carries one (and ego_plan allows it), else straight on at the scene's ego speed (0 when unknown).
  EgoPath planned_ego(const SceneContext& scene) const;

 protected:
  // Classes this kind accepts (empty = any class in the limits table).
  virtual std::vector<std::string> allowed_classes() const { return {}; }
  // Most hazards must be in view when they start; a cut-in starts beside or behind the ego instead.
  virtual bool start_must_be_visible() const { return true; }
  // Designs the motion, or appends typed reasons (and returns an empty motion) when it cannot.
  virtual Design design(const PlanRequest& req, std::vector<Refusal>& reasons) const = 0;

 private:
  // The spec's own checks (scene data, class, limits of its numbers, under_way_s).
  std::vector<Refusal> spec_reasons(const HazardSpec& spec, const SceneContext& scene) const;
  // The design sampled from the anchor time on, mapped into the anchor frame, with the ego's plan.
  HazardTrajectory sample(const Design& d, const HazardSpec& spec, const SceneContext& scene, const EgoPath& ego,
                          double under_way, double ego_shift, const cv::Vec3d& size_lwh) const;
  // An under-way design from its start to the plan's last sample, in the frame of the ego at its start.
  std::vector<TrajectoryPoint> whole_manoeuvre(const Design& d, const HazardTrajectory& tr,
                                               const EgoPath& design_ego, double under_way) const;

  Params params_;
  LimitsTable limits_;
  ClassPriors sizes_;
  RoadModel road_;
  TtcConventions ttc_;
  double rate_hz_ = 20;
  double duration_s_ = 6;
  std::string ego_plan_ = "auto";
  double ego_smoothing_s_ = 0.25;
  double max_under_way_s_ = 0;
};

// A kind described in one place: `Kind::info()` (static, returning HazardKindInfo) gives the name, summary,
// classes, scene conditions and extra fields; describe(), hazard_kind(), kind_info() and allowed_classes() follow
// from it. A kind with params of its own defines its own static describe() from base_info(info(), doc).
template <class Kind>
class KindTemplate : public TemplateBase {
 public:
  static ComponentInfo describe() { return base_info(Kind::info()); }
  std::string hazard_kind() const override { return Kind::info().kind; }
  HazardKindInfo kind_info() const override { return Kind::info(); }

 protected:
  std::vector<std::string> allowed_classes() const override { return Kind::info().object_classes; }
};

}  // namespace hf::hazard
