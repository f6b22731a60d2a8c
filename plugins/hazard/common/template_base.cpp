// Shared hazard-template pipeline: spec checks, ego plan (recorded track or constant speed), sampling in road
// coordinates, contact cut-off, TTC, limits.
#include "hazardforge/hazard/template_base.hpp"
#include "hazardforge/number_text.hpp"

#include <algorithm>
#include <cmath>

namespace hf::hazard {

std::vector<ParamSpec> RoadModel::params() {
  return {
      ParamSpec::number("lane_width_m", 3.5)
          .from_scene("road.lane_width_m")
          .range(2, 6)
          .describe("lane width (m); the ego lane is centred on y = 0"),
      ParamSpec::integer("lanes_left", 1)
          .from_scene("road.lanes_left")
          .range(0, 10)
          .describe("lanes left of the ego lane (road edge position)"),
      ParamSpec::integer("lanes_right", 1)
          .from_scene("road.lanes_right")
          .range(0, 10)
          .describe("lanes right of the ego lane (road edge position)"),
      ParamSpec::number("kerb_offset_m", 0.5)
          .range(0, 5)
          .describe("how far beyond the road edge a pedestrian waits (m)"),
      ParamSpec::string("driving_side", "right")
          .from_scene("road.driving_side")
          .one_of({"right", "left"})
          .describe("the side of the road traffic keeps to (left: e.g. Singapore, UK); oncoming lanes lie "
                    "on the other side, and exported scenarios lay out their road by it. Not stated, the "
                    "generator takes it from oncoming traffic the recording shows (traffic_seen_s)"),
      ParamSpec::integer("oncoming_lanes", 0)
          .from_scene("road.oncoming_lanes")
          .range(0, 10)
          .describe("how many of the lanes on the side away from driving_side carry oncoming traffic (the "
                    "outermost ones); 0 = every lane beside the ego lane goes its way")};
}

RoadModel RoadModel::from(const Params& p) {
  RoadModel r;
  if (p.has("lane_width_m")) r.lane_width_m = p.get_double("lane_width_m");
  if (p.has("lanes_left")) r.lanes_left = static_cast<int>(p.get_int("lanes_left"));
  if (p.has("lanes_right")) r.lanes_right = static_cast<int>(p.get_int("lanes_right"));
  if (p.has("kerb_offset_m")) r.kerb_offset_m = p.get_double("kerb_offset_m");
  if (p.has("driving_side")) r.driving_side = p.get_string("driving_side");
  if (p.has("oncoming_lanes")) r.oncoming_lanes = static_cast<int>(p.get_int("oncoming_lanes"));
  r.lanes_left_stated = p.has("lanes_left") && p.stated("lanes_left");
  r.lanes_right_stated = p.has("lanes_right") && p.stated("lanes_right");
  r.oncoming_stated = p.has("oncoming_lanes") && p.stated("oncoming_lanes");
  r.driving_side_stated = p.has("driving_side") && p.stated("driving_side");
  if (r.lanes_left_stated || r.lanes_right_stated) r.lanes_from = "stated";
  const int side = r.oncoming_side();
  if (r.oncoming_lanes > r.lanes(side))
    throw Error("oncoming_lanes " + std::to_string(r.oncoming_lanes) + " exceeds the " +
                std::to_string(r.lanes(side)) + " lane(s) on the " + (side > 0 ? "left" : "right") +
                " (lanes_" + (side > 0 ? "left" : "right") +
                "), where oncoming traffic passes when traffic keeps " + r.driving_side);
  return r;
}

RoadModel RoadModel::from(const RoadLayout& layout) {
  RoadModel r;
  static_cast<RoadLayout&>(r) = layout;
  r.lanes_left_stated = r.lanes_right_stated = r.oncoming_stated = r.driving_side_stated = true;
  const RoadFactSource left = layout.source("lanes_left"), right = layout.source("lanes_right");
  r.lanes_from = left.from == "default" && right.from == "default" ? "default"
                 : !left.why.empty()                               ? left.why
                 : !right.why.empty()                              ? right.why
                                                                   : "stated";
  return r;
}

RoadModel RoadModel::with_markings(const RoadMarkings* markings) const {
  if (!markings) return *this;
  RoadModel r = *this;
  std::string from;
  for (const int side : {1, -1}) {
    const LaneMarkingSide& m = side > 0 ? markings->left : markings->right;
    const bool stated = side > 0 ? lanes_left_stated : lanes_right_stated;
    if (stated || m.lanes < 0) continue;
    (side > 0 ? r.lanes_left : r.lanes_right) = m.lanes;
    if (side == r.oncoming_side() && !oncoming_stated) r.oncoming_lanes = m.colour == "yellow" ? m.lanes : 0;
    from += std::string(from.empty() ? "" : "; ") + (side > 0 ? "left" : "right") + " " +
            std::to_string(m.lanes) + " lane(s): a " + m.boundary + " " + m.colour + " line in " +
            std::to_string(static_cast<int>(std::lround(100 * m.seen_share))) + " % of " +
            std::to_string(markings->frames) + " frames";
  }
  if (r.oncoming_lanes > r.lanes(r.oncoming_side())) r.oncoming_lanes = r.lanes(r.oncoming_side());
  if (!from.empty()) r.lanes_from = "the footage's lane markings (" + from + ")";
  return r;
}

int PlanRequest::side_sign() const {
  if (std::abs(spec.lateral_offset_m) > 0.01) return spec.lateral_offset_m > 0 ? 1 : -1;
  if (spec.side == "left") return 1;
  if (spec.side == "right") return -1;
  return 0;
}

BoxView view_of(const CameraModel& cam, double x, double y, double heading, const cv::Vec3d& size) {
  BoxView v;
  const double c = std::cos(heading), s = std::sin(heading);
  double x0 = kInf, y0 = kInf, x1 = -kInf, y1 = -kInf;
  int ahead = 0;
  for (int i = 0; i < 8; ++i) {
    const double lx = (i & 1 ? 0.5 : -0.5) * size[0], ly = (i & 2 ? 0.5 : -0.5) * size[1];
    const double z = i & 4 ? size[2] : 0.0;
    const cv::Vec3d p(x + c * lx - s * ly, y + s * lx + c * ly, z);
    if (auto px = cam.project_ego(p)) {
      ++ahead;
      x0 = std::min(x0, px->x), y0 = std::min(y0, px->y), x1 = std::max(x1, px->x), y1 = std::max(y1, px->y);
    }
  }
  v.in_front = ahead == 8;
  if (ahead > 0) {
    v.box = cv::Rect2d(x0, y0, x1 - x0, y1 - y0);
    const cv::Rect2d img(0, 0, cam.width, cam.height);
    const double area = v.box.area();
    v.inside_fraction = area > 0 ? (v.box & img).area() / area : 0.0;
  }
  if (auto px = cam.project_ego(cv::Vec3d(x, y, size[2] / 2)))
    v.centre_inside = px->x >= 0 && px->y >= 0 && px->x < cam.width && px->y < cam.height;
  return v;
}

BoxView view_of(const CameraModel& cam, const EgoPath& ego, double s, double d, double rel_heading,
                const cv::Vec3d& size) {
  const EgoPath::Mapped m = ego.map(s, d, 0.0, 0.0, rel_heading);
  return view_of(cam, m.x, m.y, *m.heading, size);
}

BoxView view_from_anchor(const PlanRequest& req, double s, double d, double rel_heading,
                         const cv::Vec3d& size) {
  if (req.under_way <= 0 || !req.anchor_ego)
    return view_of(req.scene.camera, req.ego, s, d, rel_heading, size);
  return view_of(req.scene.camera, *req.anchor_ego, s - req.ego.s_at(req.under_way), d, rel_heading, size);
}

ComponentInfo TemplateBase::base_info(std::string name, std::string summary) {
  ComponentInfo i;
  i.name = std::move(name);
  i.kind = kind::kHazardTemplate;
  i.summary = std::move(summary);
  i.params = {
      ParamSpec::path("limits", "")
          .describe("kinematic limits per class (default: share/hazard_limits.yaml)"),
      ParamSpec::path("class_sizes", "").describe("object sizes per class (default: share/class_sizes.yaml)"),
      ParamSpec::number("sample_rate_hz", 20.0).range(1, 1000).describe("trajectory sampling rate (Hz)"),
      ParamSpec::number("duration_s", 6.0)
          .range(0.1, 120)
          .describe("planned horizon (s); the trajectory ends earlier if the object touches the ego"),
      ParamSpec::string("ego_plan", "auto")
          .one_of({"auto", "recorded", "constant_speed"})
          .describe(
              "the ego's motion the hazard is planned against: recorded = the scene's recorded ego track "
              "(SceneContext::ego_track, e.g. from the nuscenes source), the road following it; "
              "constant_speed = straight ahead at the frame's speed; auto = recorded when the scene "
              "carries a track"),
      ParamSpec::number("ego_smoothing_s", 0.25)
          .range(0, 2)
          .describe("sigma of the Gaussian (s) that smooths the recorded ego path against pose noise"),
      ParamSpec::number("max_under_way_s", 0.0)
          .range(0, 30)
          .describe(
              "longest under_way_s a spec may give: the hazard is already under way when it appears "
              "(a lead already braking, a lane change already started), for recordings too short to show "
              "the whole manoeuvre; the spec's position and speed then describe the manoeuvre's start, "
              "under_way_s before the anchor time. 0 = every hazard starts when it appears"),
  };
  for (auto& p : RoadModel::params()) i.params.push_back(p);
  for (auto& p : TtcConventions::params()) i.params.push_back(p);
  return i;
}

ComponentInfo TemplateBase::base_info(const HazardKindInfo& kind, const std::string& doc) {
  ComponentInfo i = base_info(kind.kind, kind.summary);
  auto list = [](const std::vector<std::string>& v, const std::string& none) {
    std::string out;
    for (const auto& s : v) out += (out.empty() ? "" : ", ") + s;
    return out.empty() ? none : out;
  };
  std::string fields;
  for (const HazardField& f : kind.extra_fields)
    fields += (fields.empty() ? "" : "; ") + ("extra." + f.name + ": " + f.doc);
  i.doc = (doc.empty() ? "" : doc + " ") + "Classes: " + list(kind.object_classes, "any") +
          ". Needs: " + list(kind.needs, "nothing of the scene") +
          ". Extra fields: " + (fields.empty() ? "none" : fields) +
          ". As the prompt puts it: " + kind.play_out;
  return i;
}

void TemplateBase::open(const Params& params) {
  params_ = params;
  std::string limits_path = params.get_path("limits").string();
  limits_ = LimitsTable::load(limits_path.empty() ? LimitsTable::default_path() : limits_path);
  std::string sizes_path = params.get_path("class_sizes").string();
  sizes_ = ClassPriors::load(sizes_path.empty() ? share_dir() + "/class_sizes.yaml" : sizes_path);
  road_ = RoadModel::from(params);
  ttc_ = TtcConventions::from(params);
  rate_hz_ = params.get_double("sample_rate_hz");
  duration_s_ = params.get_double("duration_s");
  ego_plan_ = params.has("ego_plan") ? params.get_string("ego_plan") : "auto";
  ego_smoothing_s_ = params.has("ego_smoothing_s") ? params.get_double("ego_smoothing_s") : 0.25;
  max_under_way_s_ = params.has("max_under_way_s") ? params.get_double("max_under_way_s") : 0.0;
}

std::vector<Refusal> TemplateBase::check(const HazardSpec& spec, const SceneContext& scene) const {
  return evaluate(spec, scene).reasons;
}

HazardTrajectory TemplateBase::plan(const HazardSpec& spec, const SceneContext& scene) const {
  PlanOutcome o = evaluate(spec, scene);
  if (!o.reasons.empty())
    throw Error("hazard '" + spec.kind + "' is infeasible: " + refusal_text(o.reasons));
  return std::move(o.trajectory);
}

RoadModel TemplateBase::road_in(const SceneContext& scene) const {
  return scene.road ? RoadModel::from(*scene.road) : road_.with_markings(scene.road_markings.get());
}

namespace {

// Standing objects keep the heading they will move off with (or last moved with).
void fill_standing_headings(std::vector<std::optional<double>>& headings) {
  std::optional<double> last;
  for (auto& h : headings) {
    if (h)
      last = h;
    else
      h = last;
  }
  last.reset();
  for (auto it = headings.rbegin(); it != headings.rend(); ++it) {
    if (*it)
      last = *it;
    else
      *it = last;
  }
}

}  // namespace

std::vector<Refusal> TemplateBase::spec_reasons(const HazardSpec& spec, const SceneContext& scene) const {
  std::vector<Refusal> reasons;
  const std::string& kind = spec.kind;
  const Reasons refuse{reasons, kind};
  const std::string& cls = spec.object_class;
  if (!scene.camera.valid())
    refuse(refusal::kSceneData, "the scene has no valid camera model (needed for the view check)");
  if (!scene.ego_speed_mps)
    refuse(refusal::kSceneData, "the scene has no ego speed");
  else if (*scene.ego_speed_mps < 0)
    refuse(refusal::kSceneData, "ego speed " + num_text(*scene.ego_speed_mps) + " m/s is negative");
  const auto allowed = allowed_classes();
  if (!allowed.empty() && std::find(allowed.begin(), allowed.end(), cls) == allowed.end()) {
    std::string list;
    for (const auto& a : allowed) list += (list.empty() ? "" : ", ") + a;
    refuse(refusal::kObjectClass,
           "object_class '" + cls + "' is not supported by " + hazard_kind() + " (supported: " + list + ")");
  } else if (!limits_.has(cls)) {
    std::string list;
    for (const auto& a : limits_.classes()) list += (list.empty() ? "" : ", ") + a;
    refuse(refusal::kObjectClass,
           "object_class '" + cls + "' has no kinematic limits in hazard_limits.yaml (known: " + list + ")");
  } else if (!sizes_.has(cls)) {
    refuse(refusal::kObjectClass, "object_class '" + cls + "' has no size in class_sizes.yaml");
  }
  if (!reasons.empty()) return reasons;

  const KinematicLimits& lim = limits_.at(cls);
  if (spec.speed_mps < 0) refuse(refusal::kSpec, "speed_mps " + num_text(spec.speed_mps) + " is negative");
  if (spec.speed_mps > lim.max_speed_mps)
    refuse(refusal::kClassLimit, "speed_mps " + num_text(spec.speed_mps) + " exceeds the " + cls +
                                     " limit of " + num_text(lim.max_speed_mps) + " m/s");
  if (spec.deceleration_mps2) {
    if (*spec.deceleration_mps2 <= 0)
      refuse(refusal::kSpec, "deceleration_mps2 " + num_text(*spec.deceleration_mps2) + " must be positive");
    else if (*spec.deceleration_mps2 > lim.max_decel_mps2)
      refuse(refusal::kClassLimit, "deceleration_mps2 " + num_text(*spec.deceleration_mps2) + " exceeds the " +
                                       cls + " limit of " + num_text(lim.max_decel_mps2) + " m/s^2");
  }
  if (spec.target_ttc_s && *spec.target_ttc_s <= 0)
    refuse(refusal::kSpec, "target_ttc_s " + num_text(*spec.target_ttc_s) + " must be positive");
  if (spec.under_way_s) {
    const double under_way = *spec.under_way_s;
    if (under_way < 0)
      refuse(refusal::kSpec, "under_way_s " + num_text(under_way) + " is negative");
    else if (under_way > max_under_way_s_ + 1e-9)
      refuse(refusal::kSpec, "under_way_s " + num_text(under_way) + " s exceeds max_under_way_s " +
                                 num_text(max_under_way_s_) +
                                 " s (raise the template param to plan hazards already under way when they "
                                 "appear)");
  }
  return reasons;
}

HazardTrajectory TemplateBase::sample(const Design& d, const HazardSpec& spec, const SceneContext& scene,
                                      const EgoPath& ego, double under_way, double ego_shift,
                                      const cv::Vec3d& size_lwh) const {
  HazardTrajectory tr;
  tr.kind = spec.kind;
  tr.object_class = spec.object_class;
  tr.size_lwh = d.size_lwh.value_or(size_lwh);
  tr.anchor_time = scene.timestamp;
  tr.spec = spec;
  const int n = static_cast<int>(std::floor(duration_s_ * rate_hz_ + 1e-9));
  std::vector<std::optional<double>> headings;
  for (int k = 0; k <= n; ++k) {
    const double tau = k / rate_hz_;
    const ObjectMotion m = d.motion(tau + under_way);
    const EgoPath::Mapped a = ego.map(m.x - ego_shift, m.y, m.vx, m.vy, m.heading);
    TrajectoryPoint p;
    p.t = scene.timestamp + tau;
    p.x = a.x;
    p.y = a.y;
    p.speed = std::hypot(a.vx, a.vy);
    p.accel = m.accel;
    headings.push_back(a.heading
                           ? a.heading
                           : (p.speed > 0.05 ? std::optional<double>(std::atan2(a.vy, a.vx)) : std::nullopt));
    tr.points.push_back(p);
    TrajectoryPoint e = ego.at(tau);
    e.t = p.t;
    tr.ego.push_back(e);
  }
  fill_standing_headings(headings);
  for (size_t k = 0; k < headings.size(); ++k) tr.points[k].heading = headings[k].value_or(0.0);
  return tr;
}

std::vector<TrajectoryPoint> TemplateBase::whole_manoeuvre(const Design& d, const HazardTrajectory& tr,
                                                          const EgoPath& design_ego, double under_way) const {
  // The limits hold for the whole manoeuvre, including its part before the anchor time: measure it from its
  // start (in the frame of the ego at the start) up to the last planned sample.
  std::vector<TrajectoryPoint> whole;
  const int m_end =
      static_cast<int>(std::floor((under_way + (tr.points.back().t - tr.anchor_time)) * rate_hz_ + 1e-9));
  for (int k = 0; k <= m_end; ++k) {
    const ObjectMotion m = d.motion(k / rate_hz_);
    const EgoPath::Mapped a = design_ego.map(m.x, m.y, m.vx, m.vy, m.heading);
    TrajectoryPoint p;
    p.t = tr.anchor_time - under_way + k / rate_hz_;
    p.x = a.x;
    p.y = a.y;
    p.speed = std::hypot(a.vx, a.vy);
    p.heading = a.heading.value_or(p.speed > 0.05 ? std::atan2(a.vy, a.vx)
                                                  : (whole.empty() ? 0.0 : whole.back().heading));
    whole.push_back(p);
  }
  return whole;
}

PlanOutcome TemplateBase::evaluate(const HazardSpec& spec, const SceneContext& scene) const {
  PlanOutcome out;
  auto& reasons = out.reasons;
  const Reasons refuse{reasons, spec.kind};
  // Spec-level checks first: a motion is only designed for a spec that is physically possible at all.
  reasons = spec_reasons(spec, scene);
  if (!reasons.empty()) return out;
  const std::string& cls = spec.object_class;
  const KinematicLimits& lim = limits_.at(cls);
  // How long the manoeuvre has been under way when the hazard appears (0 = it starts now).
  const double under_way = spec.under_way_s.value_or(0.0);

  // The ego plan: the recorded track when the scene carries one (so the hazard is planned against where the
  // ego really goes), else straight on at the frame's speed.
  const bool has_track = scene.ego_track && scene.ego_track->samples.size() >= 2;
  EgoPath ego = EgoPath::straight(*scene.ego_speed_mps);
  if (ego_plan_ == "recorded" && !has_track) {
    refuse(refusal::kSceneData,
           "ego_plan 'recorded' needs the recording's ego track (from dataset poses or estimated from the "
           "video), which this scene does not carry");
    return out;
  }
  // An under-way hazard is designed from its start, under_way s before the anchor time, against the ego's
  // path from there (`design_ego`); its samples are then taken from the anchor time on.
  EgoPath design_ego = ego;
  if (ego_plan_ != "constant_speed" && has_track) {
    ego = EgoPath::recorded(scene.ego_track->samples, scene.timestamp,
                            "scene at t=" + num_text(scene.timestamp, 3) + " s", ego_smoothing_s_);
    // The same path seen from where the ego was then — before the recording began, back along its first
    // heading at its first speed (the recording says nothing else about that time), as proposals assume.
    design_ego = under_way > 0 ? ego.seen_from(-under_way) : ego;
  }
  // Arc length the ego covers from the hazard's start to the anchor time (road x of the design -> of the
  // anchor).
  const double ego_shift = under_way > 0 ? design_ego.s_at(under_way) : 0.0;

  const ClassSize& prior = sizes_.at(cls);
  const RoadModel road = road_in(scene);
  PlanRequest req{spec,       scene, lim,        cv::Vec3d(prior.length, prior.width, prior.height),
                  *scene.ego_speed_mps, road, ttc_, duration_s_ + under_way,
                  params_,    design_ego, under_way, &ego};
  Design d = design(req, reasons);
  if (!reasons.empty()) return out;
  if (!d.motion) throw Error("hazard template '" + hazard_kind() + "' designed no motion and gave no reason");
  out.notes = d.notes;
  out.notes["ego_plan"] = ego.is_recorded() ? "recorded" : "constant_speed";
  if (under_way > 0) out.notes["under_way_s"] = under_way;

  HazardTrajectory& tr = out.trajectory;
  tr = sample(d, spec, scene, ego, under_way, ego_shift, req.size_lwh);

  // The ego plan does not react, so samples after contact would put the object inside the ego: stop there.
  out.ttc = ttc_series(tr.ego, tr.points, tr.size_lwh, ttc_);
  for (size_t k = 0; k < out.ttc.size(); ++k) {
    if (out.ttc[k].in_path && out.ttc[k].gap <= 0) {
      if (k < 2) {
        refuse(refusal::kPlacement,
               "the object touches the ego at the start (gap " + num_text(out.ttc[k].gap) + " m)");
        return out;
      }
      out.notes["contact_time_s"] = tr.points[k].t;
      tr.points.resize(k);
      tr.ego.resize(k);
      out.ttc.resize(k);
      break;
    }
  }
  tr.intended_min_ttc_s = min_ttc(out.ttc);

  out.stats = measure(under_way > 0 ? whole_manoeuvre(d, tr, design_ego, under_way) : tr.points);
  for (auto& r : exceeded_limits(out.stats, lim)) refuse(refusal::kClassLimit, r);

  if (start_must_be_visible()) {
    const TrajectoryPoint& p0 = tr.points.front();
    if (!view_of(scene.camera, p0.x, p0.y, p0.heading, tr.size_lwh).centre_inside)
      refuse(refusal::kNotInView, "the start point (x=" + num_text(p0.x) + " m, y=" + num_text(p0.y) +
                                      " m) is out of the camera's view");
  }
  if (spec.target_ttc_s && tr.intended_min_ttc_s > *spec.target_ttc_s + 0.05) {
    const double window = tr.points.back().t - tr.points.front().t;
    refuse(refusal::kTtcUnreachable,
           "target_ttc_s " + num_text(*spec.target_ttc_s) + " is not reached within the " + num_text(window) +
               " s plan (planned minimum TTC " +
               (std::isfinite(tr.intended_min_ttc_s)
                    ? num_text(tr.intended_min_ttc_s) + " s)"
                    : std::string("infinite: the object never closes in on the ego path)")));
  }
  return out;
}

EgoPath TemplateBase::planned_ego(const SceneContext& scene) const {
  const bool has_track = scene.ego_track && scene.ego_track->samples.size() >= 2;
  if (ego_plan_ != "constant_speed" && has_track && scene.timestamp >= scene.ego_track->samples.front().t &&
      scene.timestamp <= scene.ego_track->samples.back().t)
    return EgoPath::recorded(scene.ego_track->samples, scene.timestamp,
                             "scene at t=" + num_text(scene.timestamp, 3) + " s", ego_smoothing_s_);
  return EgoPath::straight(scene.ego_speed_mps.value_or(0.0));
}

}  // namespace hf::hazard
