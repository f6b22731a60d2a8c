// Scene context for the prompt and the offline planner, from ObjectStates, RiskAssessments and Frame
// metadata.
#include "scene_summary.hpp"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <set>

#include <hazardforge/hazard/kinematics.hpp>
#include <hazardforge/hazard/proposal.hpp>
#include <hazardforge/number_text.hpp>

namespace hf::llm_hazard {

namespace {

std::set<std::string> words(const std::string& text) {
  std::set<std::string> out;
  std::string w;
  for (char c : text + " ") {
    if (std::isalnum(static_cast<unsigned char>(c)) || c == '-') {
      w.push_back(static_cast<char>(std::tolower(static_cast<unsigned char>(c))));
    } else if (!w.empty()) {
      out.insert(w);
      w.clear();
    }
  }
  return out;
}

Resolved resolve(const std::string& setting, const std::string& text, const std::set<std::string>& yes,
                 const std::set<std::string>& no, const std::string& what) {
  if (setting == "yes") return {true, "set to yes"};
  if (setting == "no") return {false, "set to no"};
  std::set<std::string> w = words(text);
  for (const std::string& n : no)
    if (w.count(n)) return {false, "auto: the scene text mentions '" + n + "'"};
  for (const std::string& y : yes)
    if (w.count(y)) return {true, "auto: the scene text mentions '" + y + "'"};
  return {false, "auto: nothing in the scene text suggests " + what};
}

Json opt(const std::optional<double>& v) {
  return v && std::isfinite(*v) ? Json(*v) : Json(nullptr);
}

// "traffic keeps right; left of the ego lane: 1 lane going the ego's way, then 1 with oncoming traffic; right
// of it: none".
std::string describe_lanes(const hazard::RoadModel& road) {
  auto side = [&](int sd) {
    const int same = road.same_direction_lanes(sd), oncoming = road.oncoming_lanes_on(sd);
    if (same + oncoming == 0) return std::string("none");
    auto count = [](int n, const std::string& what) {
      return std::to_string(n) + (n == 1 ? " lane " : " lanes ") + what;
    };
    std::string out = same > 0 ? count(same, "going the ego's way") : "";
    if (oncoming > 0) out += (out.empty() ? "" : ", then ") + count(oncoming, "with oncoming traffic");
    return out;
  };
  return "traffic keeps " + road.driving_side + "; lanes " + num_text(road.lane_width_m) +
         " m wide; left of the ego lane: " + side(1) + "; right of it: " + side(-1);
}

std::string fmt_opt(const std::optional<double>& v, const std::string& unit) {
  return v && std::isfinite(*v) ? num_text(*v) + unit : "unknown";
}

std::string yes_no(const Resolved& r) {
  return r.value ? "yes" : "no";
}

}  // namespace

Resolved resolve_sidewalks(const std::string& setting, const std::string& text) {
  return resolve(
      setting, text,
      {"sidewalk", "sidewalks", "pedestrian", "pedestrians", "ped", "peds", "crosswalk", "crosswalks",
       "urban", "city", "downtown", "residential", "parking", "shops", "school", "market", "street"},
      {"highway", "motorway", "freeway", "expressway", "interstate", "autobahn"}, "sidewalks");
}

Resolved resolve_intersection(const std::string& setting, const std::string& text) {
  return resolve(setting, text,
                 {"intersection", "intersections", "junction", "junctions", "crossroads", "roundabout",
                  "turn", "turning"},
                 {"highway", "motorway", "freeway", "expressway", "interstate", "autobahn"},
                 "an intersection");
}

Resolved resolve_multi_lane(const std::string& setting, const std::string& text) {
  return resolve(setting, text,
                 {"highway", "motorway", "freeway", "expressway", "interstate", "autobahn", "multi-lane",
                  "multilane", "lanes", "arterial", "avenue", "boulevard"},
                 {"single-lane", "one-lane", "narrow", "alley"}, "several lanes");
}

namespace {

// The ground velocity of a vehicle min_distance-60 m ahead whose centre lies 0.6 to max_lanes lane widths to
// the side, moving 3-60 m/s along the ego's path (`way` +1) or against it (-1), within 30 degrees of it; else
// nothing. A velocity without its uncertainty is no evidence: the paper's estimator reads a parked car whose
// range estimate stays put as one driving along at the ego's speed.
std::optional<cv::Vec2d> moving_beside(const ObjectState& o, double ego_speed_mps, double lane_width_m,
                                       double min_distance, double max_lanes, int way) {
  static const std::set<std::string> vehicles = {"car", "truck", "bus", "motorcycle"};
  if (!vehicles.count(o.label) || !std::isfinite(o.distance_m) || o.distance_m < min_distance ||
      o.distance_m > 60.0 || !o.covariance)
    return std::nullopt;
  const double off = std::abs(o.lateral_m);
  if (off < 0.6 * lane_width_m || off > max_lanes * lane_width_m) return std::nullopt;
  const std::optional<cv::Vec2d> v = hazard::ground_velocity(o, ego_speed_mps);
  if (!v) return std::nullopt;
  const double speed = std::hypot((*v)[0], (*v)[1]);
  if (speed < 3.0 || speed > 60.0 || way * (*v)[0] < speed * std::cos(30.0 * M_PI / 180.0))
    return std::nullopt;
  return v;
}

}  // namespace

int travelling_beside(const ObjectState& o, double ego_speed_mps, double lane_width_m) {
  if (!moving_beside(o, ego_speed_mps, lane_width_m, 2.0, 1.6, 1)) return 0;
  return o.lateral_m > 0 ? 1 : -1;
}

int travelling_towards(const ObjectState& o, double ego_speed_mps, double lane_width_m) {
  if (o.truncated != 0) return 0;
  const std::optional<cv::Vec2d> v = moving_beside(o, ego_speed_mps, lane_width_m, 5.0, 4.5, -1);
  if (!v || -(*v)[0] < ego_speed_mps) return 0;
  return o.lateral_m > 0 ? 1 : -1;
}

void TrafficBeside::add(double t, const ObjectStates& states, double ego_speed_mps) {
  for (const ObjectState& o : states.objects) {
    if (o.track_id < 0) continue;
    Run& r = runs_[o.track_id];
    const int side = flow_ == Flow::kOncoming ? travelling_towards(o, ego_speed_mps, lane_width_)
                                              : travelling_beside(o, ego_speed_mps, lane_width_);
    if (side == 0 || (r.open && side != r.side)) {
      r.open = false;
      if (side == 0) continue;
    }
    if (!r.open) {
      r.open = true;
      r.start = t;
      r.side = side;
    }
    r.last = t;
    if (r.last - r.start > r.best.seconds) r.best = {o.track_id, o.label, side, r.last - r.start};
  }
}

TrafficBeside::Seen TrafficBeside::longest() const {
  Seen best;
  for (const auto& [id, r] : runs_)
    if (r.best.seconds > best.seconds) best = r.best;
  return best;
}

namespace {

// Where a fact resolved by resolve() or resolve_road() came from, by the words its reason starts with.
RoadFactSource fact_source(const std::string& why) {
  if (why.rfind("set to", 0) == 0 || why.rfind("stated", 0) == 0) return {"stated", why};
  if (why.rfind("auto: the scene text", 0) == 0) return {"described", why};
  if (why.rfind("auto: nothing", 0) == 0 || why.rfind("default", 0) == 0) return {"default", why};
  return {"measured", why};
}

}  // namespace

RoadLayout road_layout(const SceneSettings& s) {
  RoadLayout l = s.road;
  l.sidewalks = s.sidewalks.value;
  l.sidewalk_width_m = s.sidewalk_width_m;
  l.pedestrians_without_sidewalks = s.pedestrians_without_sidewalks;
  l.intersection = s.intersection.value;
  l.multi_lane = s.multi_lane.value;
  l.road_type = s.road_type;
  l.environment = s.environment;
  l.sources.clear();
  const RoadFactSource lanes =
      s.road.lanes_from == "stated"    ? RoadFactSource{"stated", "stated"}
      : s.road.lanes_from == "default" ? RoadFactSource{"default", ""}
                                       : RoadFactSource{"measured", s.road.lanes_from};
  for (const auto& [field, stated] : {std::pair<const char*, bool>{"lanes_left", s.road.lanes_left_stated},
                                      {"lanes_right", s.road.lanes_right_stated}})
    l.sources[field] = stated && lanes.from != "measured" ? RoadFactSource{"stated", "stated"} : lanes;
  l.sources["oncoming_lanes"] = s.road.oncoming_stated ? RoadFactSource{"stated", "stated"} : lanes;
  l.sources["driving_side"] = fact_source(s.driving_side_why);
  l.sources["sidewalks"] = fact_source(s.sidewalks.why);
  l.sources["intersection"] = fact_source(s.intersection.why);
  l.sources["multi_lane"] = fact_source(s.multi_lane.why);
  return l;
}

ResolvedRoad resolve_road(const hazard::RoadModel& stated, const RoadMarkings* markings,
                          const TrafficBeside::Seen& oncoming, const TrafficBeside::Seen& with_ego,
                          double seen_s) {
  ResolvedRoad out;
  hazard::RoadModel base = stated;
  const bool seen = seen_s > 0 && oncoming.track >= 0 && oncoming.seconds >= seen_s - 1e-9;
  const std::string side_name = oncoming.side > 0 ? "left" : "right";
  const std::string evidence = seen ? "a " + oncoming.label + " coming towards the ego " + side_name +
                                          " of its lane (track " + std::to_string(oncoming.track) +
                                          ", followed for " + num_text(oncoming.seconds) + " s)"
                                    : std::string();
  if (stated.driving_side_stated) {
    out.driving_side_why = "stated";
    if (seen && oncoming.side != stated.oncoming_side())
      out.conflict = "the recording shows " + evidence + ", but driving_side is stated as " +
                     stated.driving_side + " (oncoming traffic on the " +
                     (stated.oncoming_side() > 0 ? "left" : "right") + "); the stated side is kept";
  } else if (seen) {
    base.driving_side = oncoming.side > 0 ? "right" : "left";
    out.driving_side_why = "auto: the recording shows " + evidence;
  } else {
    out.driving_side_why =
        "default: no oncoming traffic followed for " + num_text(seen_s) + " s in the recording";
  }
  out.road = base.with_markings(markings);
  const int side = out.road.oncoming_side();
  const bool side_stated = side > 0 ? stated.lanes_left_stated : stated.lanes_right_stated;
  if (seen && oncoming.side == side && !stated.oncoming_stated && !(side_stated && stated.lanes(side) == 0)) {
    hazard::RoadModel& r = out.road;
    int& lanes = side > 0 ? r.lanes_left : r.lanes_right;
    lanes = std::max(lanes, 1);
    const bool same_seen = with_ego.track >= 0 && with_ego.seconds >= seen_s - 1e-9 && with_ego.side == side;
    r.oncoming_lanes = std::max(r.oncoming_lanes, std::max(1, lanes - (same_seen ? 1 : 0)));
    r.oncoming_lanes = std::min(r.oncoming_lanes, lanes);
    r.oncoming_stated = true;
    (side > 0 ? r.lanes_left_stated : r.lanes_right_stated) = true;
    r.lanes_from += "; " + side_name + " " + std::to_string(r.oncoming_lanes) +
                    " lane(s) with oncoming traffic: the recording shows " + evidence;
  }
  return out;
}

FeasibilityConfig feasibility_config(const SceneSettings& s, const LimitsTable& limits,
                                     const ClassPriors& sizes, double trigger_time_s,
                                     std::optional<double> ego_yaw_rate) {
  FeasibilityConfig fc;
  fc.limits = &limits;
  fc.sizes = sizes;
  fc.ttc = s.ttc;
  fc.road = s.road;
  fc.sidewalk_width_m = s.sidewalk_width_m;
  fc.sidewalks = s.sidewalks.value;
  fc.pedestrians_without_sidewalks = s.pedestrians_without_sidewalks;
  fc.intersection = s.intersection.value;
  fc.multi_lane = s.multi_lane.value;
  fc.horizon_s = s.horizon_s;
  fc.ttc_tolerance_s = s.ttc_tolerance_s;
  fc.threshold_s = s.threshold_s;
  fc.trigger_time_s = trigger_time_s;
  fc.ego_speed_mps = s.ego_speed_mps;
  fc.ego_yaw_rate = ego_yaw_rate;
  for (const HazardKindInfo& k : s.kinds) fc.kind_needs[k.kind] = k.needs;
  fc.rules = s.rules;
  return fc;
}

ProposalRequest proposal_request(const SceneSettings& s, const SceneContext& scene) {
  ProposalRequest r(scene);
  r.object_classes = s.rules.asset_classes;
  r.first_seen_max_height = s.rules.entry_max_height;
  r.may_take_over = s.rules.take_over_tracks;
  r.target_ttc_s = s.target_ttc_s;
  r.horizon_s = s.horizon_s;
  r.max_under_way_s = s.max_under_way_s;
  r.sidewalks = s.sidewalks.value;
  r.pedestrians_on_shoulder = s.pedestrians_without_sidewalks;
  r.multi_lane = s.multi_lane.value;
  r.intersection = s.intersection.value;
  r.sidewalk_width_m = s.sidewalk_width_m;
  return r;
}

std::string describe_kinds(const std::vector<HazardKindInfo>& kinds, const FeasibilityConfig& cfg,
                           const SceneContext& scene) {
  std::string out;
  for (const HazardKindInfo& k : kinds) {
    std::string classes;
    for (const std::string& c : k.object_classes) classes += (classes.empty() ? "" : ", ") + c;
    out += "- " + k.kind + " (" + (classes.empty() ? "any class" : classes) + ")";
    if (!k.summary.empty()) out += ": " + k.summary + ".";
    if (!k.play_out.empty()) out += " Played out: " + k.play_out;
    if (!k.needs.empty()) {
      const std::vector<std::string> unmet = unmet_needs(k.needs, cfg, scene);
      std::string needs;
      for (const std::string& n : k.needs) needs += (needs.empty() ? "" : ", ") + condition_text(n);
      out +=
          " Needs " + needs + (unmet.empty() ? " (given here)." : " — NOT given here, so do not choose it.");
    }
    for (const HazardField& f : k.extra_fields) out += "\n  extra." + f.name + ": " + f.doc + ".";
    out += "\n";
  }
  if (!out.empty()) out.pop_back();
  return out;
}

SceneSummary summarize_scene(const Frame& frame, const ObjectStates& states,
                             const std::vector<const RiskAssessment*>& risks, const SceneSettings& s,
                             const LimitsTable& limits, const ClassPriors& sizes) {
  SceneSummary out;

  // Per-object TTC from the first seconds-valued metric, so the prompt can say which object is closest in
  // time.
  const RiskAssessment* ttc_metric = nullptr;
  for (const RiskAssessment* r : risks)
    if (r->unit == "s" && r->lower_is_riskier) {
      ttc_metric = r;
      break;
    }
  auto object_ttc = [&](int64_t id) -> std::optional<double> {
    if (!ttc_metric) return std::nullopt;
    for (const ObjectRisk& o : ttc_metric->objects)
      if (o.track_id == id) return o.value;
    return std::nullopt;
  };

  Json objects = Json::array();
  std::string object_lines;
  for (const ObjectState& o : states.objects) {
    std::optional<double> ttc = object_ttc(o.track_id);
    // Where the templates place it: its centre, from the rear axle (the frame a spec's start point is in).
    const double x = hazard::centre_x(o, states.distance_origin_x, sizes);
    Json j = {{"track_id", o.track_id},
              {"label", o.label},
              {"distance_m", finite_or_null(o.distance_m)},
              {"x_m", finite_or_null(x)},
              {"lateral_m", o.lateral_m},
              {"width_m", o.width_m},
              {"length_m", o.length_m},
              {"speed_mps", opt(o.speed_mps)},
              {"in_path", o.in_path},
              {"ttc_s", opt(ttc)}};
    if (o.velocity_rel) j["velocity_rel"] = {(*o.velocity_rel)[0], (*o.velocity_rel)[1]};
    objects.push_back(std::move(j));
    object_lines += "- track " + std::to_string(o.track_id) + ": " + o.label + ", x " + num_text(x) +
                    " m, y " + num_text(o.lateral_m) + " m, speed " + fmt_opt(o.speed_mps, " m/s") +
                    (o.in_path ? ", in the ego path" : "") +
                    (ttc && std::isfinite(*ttc) ? ", TTC " + num_text(*ttc) + " s" : "") + "\n";
  }
  if (object_lines.empty()) object_lines = "- none\n";
  if (!object_lines.empty()) object_lines.pop_back();

  Json risk = Json::array();
  std::string risk_summary;
  double scene_ttc = kInf;
  for (const RiskAssessment* r : risks) {
    risk.push_back({{"metric", r->metric},
                    {"stage", r->stage},
                    {"unit", r->unit},
                    {"scene_value", finite_or_null(r->scene_value)},
                    {"threshold", r->threshold},
                    {"label", to_string(r->label)}});
    risk_summary += (risk_summary.empty() ? "" : "; ") + r->metric + " " + num_text(r->scene_value) + " " +
                    r->unit + " (" + to_string(r->label) + ")";
    if (r->unit == "s" && r->lower_is_riskier) scene_ttc = std::min(scene_ttc, r->scene_value);
  }

  Json class_sizes = Json::object();
  for (const auto& [name, size] : sizes.all())
    class_sizes[name] = {{"length", size.length}, {"width", size.width}, {"height", size.height}};

  std::string limit_lines;
  Json limits_json = Json::object();
  for (const std::string& name : limits.classes()) {
    const KinematicLimits& c = limits.at(name);
    limits_json[name] = {{"max_speed_mps", c.max_speed_mps},
                         {"max_accel_mps2", c.max_accel_mps2},
                         {"max_decel_mps2", c.max_decel_mps2},
                         {"max_lateral_speed_mps", c.max_lateral_speed_mps}};
    limit_lines += "- " + name + ": speed <= " + num_text(c.max_speed_mps) +
                   " m/s, braking <= " + num_text(c.max_decel_mps2) + " m/s^2\n";
  }
  if (!limit_lines.empty()) limit_lines.pop_back();

  std::string kinds;
  for (const std::string& k : s.allowed_kinds) kinds += (kinds.empty() ? "" : ", ") + k;
  std::string classes;
  for (const std::string& c : s.rules.asset_classes) classes += (classes.empty() ? "" : ", ") + c;

  out.scene = {{"frame_index", frame.index},
               {"timestamp_s", frame.timestamp},
               {"ego_speed_mps", s.ego_speed_mps},
               {"scene_ttc_s", finite_or_null(scene_ttc)},
               {"threshold_s", s.threshold_s},
               {"risk", risk},
               {"objects", objects},
               {"environment", s.environment},
               {"road_type", s.road_type},
               {"description", s.description},
               {"sidewalks", s.sidewalks.value},
               {"intersection", s.intersection.value},
               {"multi_lane", s.multi_lane.value},
               {"allowed_kinds", s.allowed_kinds},
               {"object_classes", s.rules.asset_classes},
               {"take_over_tracks", s.rules.take_over_tracks},
               {"feedback", s.feedback.scene_json(frame.index)},
               {"entry_max_height", s.rules.entry_max_height},
               {"target_ttc_s", s.target_ttc_s},
               {"ttc_tolerance_s", s.ttc_tolerance_s},
               {"horizon_s", s.horizon_s},
               {"sidewalk_width_m", s.sidewalk_width_m},
               {"pedestrians_without_sidewalks", s.pedestrians_without_sidewalks},
               {"max_under_way_s", s.max_under_way_s},
               {"road",
                {{"lane_width_m", s.road.lane_width_m},
                 {"lanes_left", s.road.lanes_left},
                 {"lanes_right", s.road.lanes_right},
                 {"kerb_offset_m", s.road.kerb_offset_m},
                 {"driving_side", s.road.driving_side},
                 {"oncoming_lanes", s.road.oncoming_lanes},
                 {"edge_left_m", s.road.edge(1)},
                 {"edge_right_m", s.road.edge(-1)}}},
               {"ttc",
                {{"corridor_half_width", s.ttc.corridor.ego_half_width},
                 {"corridor_margin", s.ttc.corridor.margin},
                 {"corridor_path", s.ttc.corridor.follow_path ? "ego_path" : "straight"},
                 {"ego_front_m", s.ttc.ego_front},
                 {"min_closing_mps", s.ttc.min_closing}}},
               {"limits", limits_json},
               {"class_sizes", class_sizes},
               {"camera", frame.camera.valid() ? Json(frame.camera) : Json(nullptr)}};

  out.placeholders = {
      {"environment", s.environment},
      {"road_type", s.road_type},
      {"description", s.description.empty() ? "none" : s.description},
      {"sidewalks", !s.sidewalks.value && s.pedestrians_without_sidewalks
                        ? yes_no(s.sidewalks) + " (edge-case test: a person may nevertheless stand on the "
                                                "shoulder, e.g. after leaving a broken-down car, and walk "
                                                "into the road)"
                        : yes_no(s.sidewalks)},
      {"intersection", yes_no(s.intersection)},
      {"multi_lane", yes_no(s.multi_lane)},
      {"timestamp_s", num_text(frame.timestamp)},
      {"frame_index", std::to_string(frame.index)},
      {"ego_speed_mps", num_text(s.ego_speed_mps)},
      {"scene_ttc_s", num_text(scene_ttc)},
      {"threshold_s", num_text(s.threshold_s)},
      {"risk_summary", risk_summary.empty() ? "none" : risk_summary},
      {"objects", object_lines},
      {"limits", limit_lines},
      {"allowed_kinds", kinds},
      {"target_ttc_s", num_text(s.target_ttc_s)},
      {"ego_front_m", num_text(s.ttc.ego_front)},
      {"lane_width_m", num_text(s.road.lane_width_m)},
      {"road_edge_left_m", num_text(s.road.edge(1))},
      {"road_edge_right_m", num_text(s.road.edge(-1))},
      {"lanes", describe_lanes(s.road)},
      {"feedback", s.feedback.prompt_text()},
      {"object_classes", classes.empty() ? "any class with kinematic limits" : classes},
      {"entry_rule",
       s.rules.entry_max_height > 0
           ? "The object must come into view plausibly: from beyond the image border (beside or behind the "
             "ego), "
             "from behind a detected object, or far enough away to be small when first seen (at most " +
                 num_text(s.rules.entry_max_height * frame.camera.height) + " px of the " +
                 std::to_string(frame.camera.height) +
                 " px image height) — never popping up on the road close ahead."
           : "The object may already be in view when it appears (it appears with the first frames of the "
             "video, "
             "or the scene sets no rule on coming into view)."},
      {"take_over", s.rules.take_over_tracks ? "A detected vehicle may itself become the hazard "
                                               "(track_id): the renderer removes the real one."
                                             : "Do not make a detected object the hazard (track_id "
                                               "stays null): the real one would stay in the "
                                               "video beside it."}};

  out.context.timestamp = frame.timestamp;
  out.context.objects = states.objects;
  out.context.distance_origin_x = states.distance_origin_x;
  const FeasibilityConfig fc = feasibility_config(
      s, limits, sizes, frame.timestamp, states.ego_yaw_rate ? states.ego_yaw_rate : frame.ego.yaw_rate);
  out.placeholders["kinds"] = describe_kinds(s.kinds, fc, out.context);
  out.context.ego_speed_mps = s.ego_speed_mps;
  out.context.camera = frame.camera;
  out.context.road = road_layout(s);
  out.context.origin = frame.origin;
  // The recorded ego track (e.g. nuScenes), so the templates check a spec against where the ego really goes,
  // as the planner will: a spec planned against a straight ego can be infeasible on the recorded path.
  out.context.ego_track = frame.ego_track;
  out.context.road_markings = frame.road_markings;  // the templates read the lanes the footage shows
  return out;
}

}  // namespace hf::llm_hazard
