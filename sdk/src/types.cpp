// Camera geometry and the JSON forms of the SDK payload types.
#include "hazardforge/types.hpp"

#include "hazardforge/angles.hpp"
#include "hazardforge/error.hpp"
#include "hazardforge/number_text.hpp"

#include <algorithm>
#include <cmath>
#include <type_traits>

namespace hf {

// ---- CameraModel
// -------------------------------------------------------------------------------------------------

double CameraModel::pitch() const {
  // Optical axis (camera z) in ego axes; pitch is its downward angle.
  const cv::Vec3d axis = R_ego_cam * cv::Vec3d(0, 0, 1);
  return std::atan2(-axis[2], std::hypot(axis[0], axis[1]));
}

double CameraModel::roll() const {
  // Heights (ego z) of the camera's right and down axes: a camera turned clockwise by r, pitched by p, has
  // right_z = -cos p sin r and down_z = -cos p cos r.
  const cv::Vec3d right = R_ego_cam * cv::Vec3d(1, 0, 0);
  const cv::Vec3d down = R_ego_cam * cv::Vec3d(0, 1, 0);
  return std::atan2(-right[2], -down[2]);
}

std::optional<double> CameraModel::horizon_y(double x) const {
  // Points at infinity on the ground plane: directions d = (cos a, sin a, 0) in ego axes. The vanishing line
  // is the set of pixels whose viewing ray has zero ego z: n . K^-1 (x, y, 1) = 0 with n = R^T e_z.
  const cv::Vec3d n = R_ego_cam.t() * cv::Vec3d(0, 0, 1);  // ego up in camera axes
  // ray_cam = ((x - cx)/fx, (y - cy)/fy, 1); n0*(x-cx)/fx + n1*(y-cy)/fy + n2 = 0
  if (std::abs(n[1]) < 1e-12) return std::nullopt;
  return cy - fy * (n[0] * (x - cx) / fx + n[2]) / n[1];
}

cv::Vec3d CameraModel::ego_to_cam(const cv::Vec3d& p_ego) const {
  return R_ego_cam.t() * (p_ego - t_ego_cam);
}
cv::Vec3d CameraModel::cam_to_ego(const cv::Vec3d& p_cam) const {
  return R_ego_cam * p_cam + t_ego_cam;
}

std::optional<cv::Point2d> CameraModel::project_cam(const cv::Vec3d& p) const {
  if (p[2] <= 0.01) return std::nullopt;
  return cv::Point2d(fx * p[0] / p[2] + cx, fy * p[1] / p[2] + cy);
}

std::optional<cv::Point2d> CameraModel::project_ego(const cv::Vec3d& p_ego) const {
  return project_cam(ego_to_cam(p_ego));
}

std::optional<cv::Vec3d> CameraModel::pixel_to_ground(const cv::Point2d& px) const {
  const cv::Vec3d ray_cam((px.x - cx) / fx, (px.y - cy) / fy, 1.0);
  const cv::Vec3d ray = R_ego_cam * ray_cam;
  if (ray[2] >= -1e-9) return std::nullopt;  // at or above the horizon
  const double s = -t_ego_cam[2] / ray[2];
  return t_ego_cam + s * ray;
}

CameraModel CameraModel::scaled_to(int w, int h) const {
  CameraModel c = *this;
  const double sx = static_cast<double>(w) / width, sy = static_cast<double>(h) / height;
  c.width = w;
  c.height = h;
  c.fx *= sx;
  c.cx *= sx;
  c.fy *= sy;
  c.cy *= sy;
  return c;
}

CameraModel CameraModel::pinhole(int w, int h, double fx, double fy, double cx, double cy, double height,
                                 double pitch_rad, double forward, double roll_rad) {
  CameraModel c;
  c.width = w;
  c.height = h;
  c.fx = fx;
  c.fy = fy;
  c.cx = cx;
  c.cy = cy;
  // Level optical frame in ego axes, then pitched down about the camera's x axis.
  const cv::Matx33d level(0, 0, 1, -1, 0, 0, 0, -1, 0);
  const double cp = std::cos(pitch_rad), sp = std::sin(pitch_rad);
  const cv::Matx33d pitch_cam(1, 0, 0, 0, cp, sp, 0, -sp, cp);  // rotates the optical axis downwards
  const double cr = std::cos(roll_rad), sr = std::sin(roll_rad);
  const cv::Matx33d roll_cam(cr, -sr, 0, sr, cr, 0, 0, 0, 1);  // rotates the camera about its optical axis
  c.R_ego_cam = level * pitch_cam * roll_cam;
  c.t_ego_cam = cv::Vec3d(forward, 0.0, height);
  return c;
}

// ---- EgoTrack
// ---------------------------------------------------------------------------------------------------

void EgoTrack::validate(const std::string& where) const {
  for (size_t k = 0; k < samples.size(); ++k) {
    const EgoTrackSample& s = samples[k];
    const std::string at = where + ": ego track sample " + std::to_string(k);
    for (double v : {s.t, s.x, s.y, s.yaw, s.speed_mps, s.yaw_rate})
      if (!std::isfinite(v)) throw Error(at + " has a value that is not finite");
    if (k > 0 && !(s.t > samples[k - 1].t))
      throw Error(at + ": t=" + std::to_string(s.t) + " s does not come after the previous sample's t=" +
                  std::to_string(samples[k - 1].t) + " s");
  }
}

EgoTrackSample EgoTrack::at(double t) const {
  if (samples.empty()) return {};
  if (t <= samples.front().t) return samples.front();
  if (t >= samples.back().t) return samples.back();
  auto it = std::upper_bound(samples.begin(), samples.end(), t,
                             [](double tt, const EgoTrackSample& s) { return tt < s.t; });
  const EgoTrackSample& b = *it;
  const EgoTrackSample& a = *(it - 1);
  const double u = (t - a.t) / (b.t - a.t);
  double dyaw = angle_diff(b.yaw, a.yaw);
  EgoTrackSample r;
  r.t = t;
  r.x = a.x + u * (b.x - a.x);
  r.y = a.y + u * (b.y - a.y);
  r.yaw = a.yaw + u * dyaw;
  r.speed_mps = a.speed_mps + u * (b.speed_mps - a.speed_mps);
  r.yaw_rate = a.yaw_rate + u * (b.yaw_rate - a.yaw_rate);
  return r;
}

double EgoTrack::heading_change(double t0, double t1) const {
  if (samples.size() < 2) return 0.0;
  if (t1 < t0) return -heading_change(t1, t0);
  // The generator asks this for every later sample of the clip on every frame before its trigger: start at
  // the first sample after t0 rather than walking the track from its beginning.
  double turn = 0.0, yaw = at(t0).yaw;
  auto it = std::upper_bound(samples.begin(), samples.end(), t0,
                             [](double t, const EgoTrackSample& s) { return t < s.t; });
  for (; it != samples.end() && it->t < t1; ++it) {
    turn += angle_diff(it->yaw, yaw);
    yaw = it->yaw;
  }
  return turn + angle_diff(at(t1).yaw, yaw);
}

const char* to_string(SafetyLabel l) {
  return l == SafetyLabel::kUnsafe ? "Unsafe" : "Safe";
}

std::optional<TrajectoryPoint> HazardTrajectory::at(double t) const {
  if (points.empty() || t < points.front().t - 1e-9 || t > points.back().t + 1e-9) return std::nullopt;
  auto it = std::lower_bound(points.begin(), points.end(), t,
                             [](const TrajectoryPoint& p, double tt) { return p.t < tt; });
  if (it == points.begin()) return points.front();
  if (it == points.end()) return points.back();
  const TrajectoryPoint& b = *it;
  const TrajectoryPoint& a = *(it - 1);
  const double u = (b.t - a.t) > 1e-12 ? (t - a.t) / (b.t - a.t) : 0.0;
  TrajectoryPoint p;
  p.t = t;
  p.x = a.x + u * (b.x - a.x);
  p.y = a.y + u * (b.y - a.y);
  double dh = angle_diff(b.heading, a.heading);
  p.heading = a.heading + u * dh;
  p.speed = a.speed + u * (b.speed - a.speed);
  p.accel = a.accel + u * (b.accel - a.accel);
  return p;
}

std::optional<TrajectoryPoint> HazardTrajectory::continued_at(double t) const {
  if (points.empty() || t < points.front().t - 1e-9) return std::nullopt;
  const TrajectoryPoint& last = points.back();
  if (t <= last.t + 1e-9) return at(t);
  // Curvature of the last second of travel: heading change over the distance covered.
  double turn = 0, dist = 0;
  for (size_t k = points.size() - 1; k > 0 && last.t - points[k - 1].t <= 1.0 + 1e-9; --k) {
    const TrajectoryPoint& a = points[k - 1];
    const TrajectoryPoint& b = points[k];
    turn += angle_diff(b.heading, a.heading);
    dist += std::hypot(b.x - a.x, b.y - a.y);
  }
  const double curvature = dist >= 0.5 ? turn / dist : 0.0;
  const double v0 = std::max(last.speed, 0.0);
  const double decel = std::min(last.accel, 0.0);  // braking goes on; speeding up does not
  double dt = t - last.t;
  if (decel < 0 && v0 > 0) dt = std::min(dt, v0 / -decel);
  const double s = v0 * dt + 0.5 * decel * dt * dt;
  TrajectoryPoint p = last;
  p.t = t;
  p.speed = std::max(v0 + decel * (t - last.t), 0.0);
  p.accel = p.speed > 0 ? decel : 0.0;
  const double dh = curvature * s;
  p.heading = last.heading + dh;
  if (std::abs(dh) > 1e-9) {
    p.x = last.x + (std::sin(p.heading) - std::sin(last.heading)) / curvature;
    p.y = last.y - (std::cos(p.heading) - std::cos(last.heading)) / curvature;
  } else {
    p.x = last.x + s * std::cos(last.heading);
    p.y = last.y + s * std::sin(last.heading);
  }
  return p;
}

// ---- JSON
// ----------------------------------------------------------------------------------------------------------

Json finite_or_null(double v) {
  return std::isfinite(v) ? Json(v) : Json();
}

namespace {
Json rect(const cv::Rect2f& r) {
  return Json::array({r.x, r.y, r.width, r.height});
}
template <class T>
Json opt(const std::optional<T>& v) {
  return v ? Json(*v) : Json();
}
Json optd(const std::optional<double>& v) {
  return v ? finite_or_null(*v) : Json();
}
}  // namespace

void to_json(Json& j, const CameraModel& v) {
  j = {{"width", v.width}, {"height", v.height},        {"fx", v.fx}, {"fy", v.fy}, {"cx", v.cx},
       {"cy", v.cy},       {"distortion", v.distortion}};
  Json R = Json::array();
  for (int r = 0; r < 3; ++r) R.push_back({v.R_ego_cam(r, 0), v.R_ego_cam(r, 1), v.R_ego_cam(r, 2)});
  j["R_ego_cam"] = R;
  j["t_ego_cam"] = {v.t_ego_cam[0], v.t_ego_cam[1], v.t_ego_cam[2]};
}

void from_json(const Json& j, CameraModel& v) {
  v.width = j.at("width").get<int>();
  v.height = j.at("height").get<int>();
  v.fx = j.at("fx").get<double>();
  v.fy = j.at("fy").get<double>();
  v.cx = j.at("cx").get<double>();
  v.cy = j.at("cy").get<double>();
  v.distortion = j.value("distortion", std::vector<double>{});
  if (j.contains("R_ego_cam"))
    for (int r = 0; r < 3; ++r)
      for (int c = 0; c < 3; ++c) v.R_ego_cam(r, c) = j["R_ego_cam"][r][c].get<double>();
  if (j.contains("t_ego_cam"))
    for (int i = 0; i < 3; ++i) v.t_ego_cam[i] = j["t_ego_cam"][i].get<double>();
}

void to_json(Json& j, const Detection& v) {
  j = {{"box", rect(v.box)}, {"class_id", v.class_id}, {"label", v.label}, {"score", v.score}};
  if (v.annotation_index >= 0) j["annotation_index"] = v.annotation_index;
  if (v.truncated) j["truncated"] = v.truncated;
}
void to_json(Json& j, const Detections& v) {
  j = {{"frame", v.frame_index}, {"detector", v.detector}, {"items", v.items}};
}
void from_json(const Json& j, Detection& v) {
  auto bad = [&](const char* what) { return Error(std::string("a detection's ") + what + ": " + j.dump()); };
  if (!j.is_object()) throw bad("record is not an object");
  const Json& b = j.contains("box") ? j["box"] : Json();
  if (!b.is_array() || b.size() != 4 || !std::all_of(b.begin(), b.end(), [](const Json& x) { return x.is_number(); }))
    throw bad("'box' is not [x, y, width, height]");
  v.box = {b[0].get<float>(), b[1].get<float>(), b[2].get<float>(), b[3].get<float>()};
  if (!j.contains("class_id") || !j["class_id"].is_number_integer()) throw bad("'class_id' is not an integer");
  if (!j.contains("label") || !j["label"].is_string()) throw bad("'label' is not a text");
  if (!j.contains("score") || !j["score"].is_number()) throw bad("'score' is not a number");
  v.class_id = j["class_id"].get<int>();
  v.label = j["label"].get<std::string>();
  v.score = j["score"].get<float>();
  v.annotation_index = j.value("annotation_index", -1);
  v.truncated = j.value("truncated", 0u);
}
void from_json(const Json& j, Detections& v) {
  if (!j.is_object() || !j.contains("items") || !j["items"].is_array())
    throw Error("a detections record needs 'items', a list: " + j.dump().substr(0, 200));
  v.frame_index = j.value("frame", int64_t{0});
  v.detector = j.value("detector", "");
  v.items = j["items"].get<std::vector<Detection>>();
}
void to_json(Json& j, const Track& v) {
  j = {{"id", v.id},         {"box", rect(v.box)},
       {"label", v.label},   {"score", v.score},
       {"age", v.age},       {"hits", v.hits},
       {"misses", v.misses}, {"velocity_px", {v.velocity_px.x, v.velocity_px.y}}};
  if (v.truncated) j["truncated"] = v.truncated;
}
void to_json(Json& j, const Tracks& v) {
  j = {{"frame", v.frame_index}, {"tracker", v.tracker}, {"items", v.items}};
}
void to_json(Json& j, const ObjectState& v) {
  j = {{"track_id", v.track_id},
       {"label", v.label},
       {"score", v.score},
       {"box", rect(v.box)},
       {"distance_m", finite_or_null(v.distance_m)},
       {"lateral_m", v.lateral_m},
       {"width_m", v.width_m},
       {"speed_mps", optd(v.speed_mps)},
       {"heading_rad", optd(v.heading_rad)},
       {"scale_rate", optd(v.scale_rate)},
       {"in_path", v.in_path},
       {"distance_method", v.distance_method},
       {"age", v.age},
       {"misses", v.misses}};
  j["velocity_rel"] = v.velocity_rel ? Json::array({(*v.velocity_rel)[0], (*v.velocity_rel)[1]}) : Json();
  if (v.truncated) j["truncated"] = v.truncated;
  if (v.covariance) {
    // 1-sigma of each component; the full matrix is rarely what a reader of the stream wants.
    const cv::Matx44d& P = *v.covariance;
    j["sigma"] = {{"distance_m", std::sqrt(std::max(P(0, 0), 0.0))},
                  {"lateral_m", std::sqrt(std::max(P(1, 1), 0.0))},
                  {"velocity_rel", {std::sqrt(std::max(P(2, 2), 0.0)), std::sqrt(std::max(P(3, 3), 0.0))}}};
  }
}
void to_json(Json& j, const ObjectStates& v) {
  j = {{"frame", v.frame_index},
       {"timestamp", v.timestamp},
       {"ego_speed_mps", optd(v.ego_speed_mps)},
       {"ego_yaw_rate", optd(v.ego_yaw_rate)},
       {"distance_origin_x", v.distance_origin_x},
       {"objects", v.objects}};
}
double deciding_value(const RiskAssessment& r) {
  auto worse = [&](double a, double b) { return r.lower_is_riskier ? a < b : a > b; };
  double deciding = r.lower_is_riskier ? kInf : 0.0;
  for (const ObjectRisk& o : r.objects) {
    if (!o.in_path || std::isnan(o.value)) continue;
    // The bound on the risky side is the low end for TTC-like metrics and the high end for DRAC-like ones.
    const double risky = r.lower_is_riskier ? o.low : o.high;
    const double safe = r.lower_is_riskier ? o.high : o.low;
    double d = o.value;
    if (r.label_rule == "riskier_bound" && !std::isnan(risky)) d = risky;
    if (r.label_rule == "safer_bound" && !std::isnan(safe)) d = safe;
    if (worse(d, deciding)) deciding = d;
  }
  return deciding;
}

void to_json(Json& j, const RiskAssessment& v) {
  Json objs = Json::array();
  for (const ObjectRisk& o : v.objects) {
    Json jo = {{"track_id", o.track_id}, {"value", finite_or_null(o.value)}, {"in_path", o.in_path}};
    // An interval's open end is infinite: written as null like every non-finite number, so "low" and
    // "high" appear only when the metric gives an interval.
    if (!std::isnan(o.low) || !std::isnan(o.high)) {
      jo["low"] = finite_or_null(o.low);
      jo["high"] = finite_or_null(o.high);
    }
    objs.push_back(std::move(jo));
  }
  j = {{"frame", v.frame_index},
       {"metric", v.metric},
       {"stage", v.stage},
       {"unit", v.unit},
       {"threshold", v.threshold},
       {"scene_value", finite_or_null(v.scene_value)},
       {"critical_track", v.critical_track},
       {"label", to_string(v.label)},
       {"label_rule", v.label_rule},
       {"objects", objs}};
}
void to_json(Json& j, const HazardSpec& v) {
  j = {{"schema_version", v.schema_version},
       {"kind", v.kind},
       {"object_class", v.object_class},
       {"initial_distance_m", v.initial_distance_m},
       {"lateral_offset_m", v.lateral_offset_m},
       {"side", v.side},
       {"speed_mps", v.speed_mps},
       {"heading_deg", v.heading_deg},
       {"motion", v.motion},
       {"start_time_s", v.start_time_s},
       {"rationale", v.rationale}};
  if (v.deceleration_mps2) j["deceleration_mps2"] = *v.deceleration_mps2;
  if (v.target_ttc_s) j["target_ttc_s"] = *v.target_ttc_s;
  if (v.track_id) j["track_id"] = *v.track_id;
  if (v.under_way_s) j["under_way_s"] = *v.under_way_s;
  if (!v.extra.empty()) j["extra"] = v.extra;
  if (v.road) j["road"] = *v.road;
  if (!v.provenance.empty()) j["provenance"] = v.provenance;
}
void from_json(const Json& j, HazardSpec& v) {
  v.schema_version = j.value("schema_version", std::string("1.0"));
  v.kind = j.at("kind").get<std::string>();
  v.object_class = j.at("object_class").get<std::string>();
  v.initial_distance_m = j.at("initial_distance_m").get<double>();
  v.lateral_offset_m = j.value("lateral_offset_m", 0.0);
  v.side = j.value("side", std::string());
  v.speed_mps = j.at("speed_mps").get<double>();
  v.heading_deg = j.value("heading_deg", 0.0);
  v.motion = j.value("motion", std::string());
  v.start_time_s = j.value("start_time_s", 0.0);
  auto number = [&j](const char* key) -> std::optional<double> {
    if (!j.contains(key) || j[key].is_null()) return std::nullopt;
    if (!j[key].is_number()) throw Error(std::string(key) + " must be a number or null, got " + j[key].dump());
    return j[key].get<double>();
  };
  v.deceleration_mps2 = number("deceleration_mps2");
  v.target_ttc_s = number("target_ttc_s");
  v.extra = j.value("extra", Json::object());
  if (!v.extra.is_object()) throw Error("extra must be an object, got " + v.extra.dump());
  // Specs of schema 1.0 carried track_id and under_way_s among the kind's fields.
  v.track_id = spec_track_id(j);
  const Json* under_way = j.contains("under_way_s") ? &j["under_way_s"]
                          : v.extra.contains("under_way_s") ? &v.extra["under_way_s"]
                                                            : nullptr;
  if (under_way && !under_way->is_null()) {
    if (!under_way->is_number()) throw Error("under_way_s must be a number or null, got " + under_way->dump());
    v.under_way_s = under_way->get<double>();
  }
  v.extra.erase("track_id");
  v.extra.erase("under_way_s");
  v.rationale = j.value("rationale", std::string());
  if (j.contains("road") && !j["road"].is_null()) {
    RoadLayout road;
    try {
      from_json(j["road"], road);
    } catch (const Error& e) {
      throw Error(std::string("road.") + e.what());
    }
    road.validate("road");
    v.road = std::move(road);
  }
  v.provenance = j.value("provenance", Json::object());
}
std::optional<int64_t> spec_track_id(const Json& spec) {
  if (!spec.is_object()) return std::nullopt;
  const Json* t = spec.contains("track_id") ? &spec["track_id"] : nullptr;
  if (!t && spec.contains("extra") && spec["extra"].is_object() && spec["extra"].contains("track_id"))
    t = &spec["extra"]["track_id"];
  if (!t || t->is_null()) return std::nullopt;
  if (!t->is_number() || t->get<double>() != std::floor(t->get<double>()) || t->get<double>() < 0)
    throw Error("track_id must be a non-negative whole number or null, got " + t->dump());
  return static_cast<int64_t>(t->get<double>());
}

void to_json(Json& j, const TrajectoryPoint& v) {
  j = {{"t", v.t}, {"x", v.x}, {"y", v.y}, {"heading", v.heading}, {"speed", v.speed}, {"accel", v.accel}};
}
void to_json(Json& j, const HazardTrajectory& v) {
  j = {{"kind", v.kind},
       {"object_class", v.object_class},
       {"size_lwh", {v.size_lwh[0], v.size_lwh[1], v.size_lwh[2]}},
       {"anchor_time", v.anchor_time},
       {"intended_min_ttc_s", finite_or_null(v.intended_min_ttc_s)},
       {"points", v.points},
       {"ego", v.ego},
       {"spec", v.spec}};
}
void to_json(Json& j, const HazardInstance& v) {
  j = {{"frame", v.frame_index},
       {"visible", v.visible},
       {"kind", v.kind},
       {"object_class", v.object_class},
       {"box", rect(v.box)},
       {"distance_m", finite_or_null(v.distance_m)},
       {"lateral_m", v.lateral_m},
       {"intended_ttc_s", finite_or_null(v.intended_ttc_s)},
       {"occluded_fraction", v.occluded_fraction},
       {"in_picture_fraction", v.in_picture_fraction},
       {"visible_share", v.visible_share()}};
  if (v.drawn_box.area() > 0) j["drawn_box"] = rect(v.drawn_box);
  if (std::isfinite(v.heading_ego)) {
    j["centre_ego"] = {v.centre_ego[0], v.centre_ego[1], v.centre_ego[2]};
    j["heading_ego"] = v.heading_ego;
    j["size_lwh"] = {v.size_lwh[0], v.size_lwh[1], v.size_lwh[2]};
  }
  if (!v.picture_file.empty()) j["picture"] = {{"file", v.picture_file}, {"source", v.picture_source}};
  if (v.appearance) j["appearance"] = *v.appearance;
  if (!v.references.empty()) j["references"] = v.references;
  if (v.taken_over)
    j["taken_over"] = {{"track_id", v.taken_over->track_id},
                       {"box", rect(v.taken_over->box)},
                       {"seen", v.taken_over->seen},
                       {"uncovered_fraction", v.taken_over->uncovered_fraction},
                       {"lateral_shift_m", v.taken_over->lateral_shift_m}};
}
void to_json(Json& j, const AppearanceStats& v) {
  auto vec = [](const cv::Vec3d& x) {
    return Json::array({finite_or_null(x[0]), finite_or_null(x[1]), finite_or_null(x[2])});
  };
  j = {{"label", v.label},
       {"box", rect(v.box)},
       {"edge_contrast", finite_or_null(v.edge_contrast)},
       {"halo", finite_or_null(v.halo)},
       {"sharpness", finite_or_null(v.sharpness)},
       {"noise_sigma", finite_or_null(v.noise_sigma)},
       {"noise_ratio", finite_or_null(v.noise_ratio)},
       {"lab_mean", vec(v.lab_mean)},
       {"lab_std", vec(v.lab_std)},
       {"ground_depth_m", finite_or_null(v.ground_depth_m)},
       {"height_m", finite_or_null(v.height_m)},
       {"width_m", finite_or_null(v.width_m)},
       {"aspect", finite_or_null(v.aspect)}};
  if (!v.source.empty()) j["source"] = v.source;
}
void to_json(Json& j, const Record& v) {
  j = {{"kind", v.kind}, {"data", v.data}};
}
void to_json(Json& j, const SystemResponse& v) {
  Json dets = Json::array();
  for (const Detection& d : v.detections)
    dets.push_back({{"box", rect(d.box)}, {"label", d.label}, {"score", d.score}});
  j = {{"frame", v.frame_index},
       {"detections", std::move(dets)},
       {"ttc_s", v.ttc_s ? finite_or_null(*v.ttc_s) : Json(nullptr)},
       {"warning", v.warning},
       {"brake", v.brake}};
}
void to_json(Json& j, const AnnotatedObject& v) {
  j = {{"instance", v.instance_id},
       {"category", v.category},
       {"label", v.label},
       {"center_ego", {v.center_ego[0], v.center_ego[1], v.center_ego[2]}},
       {"size_lwh", {v.size_lwh[0], v.size_lwh[1], v.size_lwh[2]}},
       {"yaw_ego", v.yaw_ego},
       {"num_points", v.num_points}};
  if (v.velocity_ego) j["velocity_ego"] = {(*v.velocity_ego)[0], (*v.velocity_ego)[1], (*v.velocity_ego)[2]};
}
void to_json(Json& j, const Annotations& v) {
  j = {{"objects", v.objects}};
  if (v.ego_velocity_ego)
    j["ego_velocity_ego"] = {(*v.ego_velocity_ego)[0], (*v.ego_velocity_ego)[1], (*v.ego_velocity_ego)[2]};
}
void to_json(Json& j, const LaneMarkingSide& v) {
  j = {{"line", v.boundary}, {"colour", v.colour}, {"lanes_beyond", v.lanes}, {"seen_share", v.seen_share}};
}
void to_json(Json& j, const RoadMarkings& v) {
  j = {{"source", v.source}, {"frames", v.frames}, {"left", v.left}, {"right", v.right}, {"note", v.note}};
}
void to_json(Json& j, const RoadFactSource& v) {
  j = {{"from", v.from}, {"why", v.why}};
}
void to_json(Json& j, const RoadLayout& v) {
  Json sources = Json::object();
  for (const auto& [field, src] : v.sources) sources[field] = src;
  j = {{"lane_width_m", v.lane_width_m},
       {"lanes_left", v.lanes_left},
       {"lanes_right", v.lanes_right},
       {"oncoming_lanes", v.oncoming_lanes},
       {"driving_side", v.driving_side},
       {"kerb_offset_m", v.kerb_offset_m},
       {"sidewalks", v.sidewalks},
       {"sidewalk_width_m", v.sidewalk_width_m},
       {"pedestrians_without_sidewalks", v.pedestrians_without_sidewalks},
       {"intersection", v.intersection},
       {"multi_lane", v.multi_lane},
       {"road_type", v.road_type},
       {"environment", v.environment},
       {"sources", sources}};
}
void from_json(const Json& j, RoadLayout& v) {
  if (!j.is_object()) throw Error("a road layout must be an object, got " + j.dump());
  auto field = [&j](const char* key, auto& out) {
    using T = std::decay_t<decltype(out)>;
    if (!j.contains(key)) return;
    const Json& x = j[key];
    const bool ok = std::is_same_v<T, bool>          ? x.is_boolean()
                    : std::is_same_v<T, std::string> ? x.is_string()
                    : std::is_same_v<T, int>         ? x.is_number_integer()
                                                     : x.is_number();
    if (!ok)
      throw Error(std::string(key) + " must be " +
                  (std::is_same_v<T, bool>          ? "true or false"
                   : std::is_same_v<T, std::string> ? "a string"
                   : std::is_same_v<T, int>         ? "a whole number"
                                                    : "a number") +
                  ", got " + x.dump());
    out = x.get<T>();
  };
  v = RoadLayout{};
  field("lane_width_m", v.lane_width_m);
  field("lanes_left", v.lanes_left);
  field("lanes_right", v.lanes_right);
  field("oncoming_lanes", v.oncoming_lanes);
  field("driving_side", v.driving_side);
  field("kerb_offset_m", v.kerb_offset_m);
  field("sidewalks", v.sidewalks);
  field("sidewalk_width_m", v.sidewalk_width_m);
  field("pedestrians_without_sidewalks", v.pedestrians_without_sidewalks);
  field("intersection", v.intersection);
  field("multi_lane", v.multi_lane);
  field("road_type", v.road_type);
  field("environment", v.environment);
  if (j.contains("sources") && j["sources"].is_object())
    for (auto it = j["sources"].begin(); it != j["sources"].end(); ++it)
      if (it.value().is_object())
        v.sources[it.key()] = {it.value().value("from", std::string("default")),
                               it.value().value("why", std::string())};
}
void to_json(Json& j, const FrameOrigin& v) {
  j = {{"dataset", v.dataset}, {"scene", v.scene}, {"description", v.description}};
  j["dataset_frame"] = v.dataset_frame ? Json(*v.dataset_frame) : Json();
}
void to_json(Json& j, const Frame& v) {
  j = {{"index", v.index},      {"timestamp", v.timestamp}, {"source_id", v.source_id},
       {"width", v.image.cols}, {"height", v.image.rows},   {"ego_speed_mps", optd(v.ego.speed_mps)},
       {"origin", v.origin},    {"meta", v.meta}};
}

void to_json(Json& j, const VerificationOutcome& v) {
  auto opt = [](const auto& x) { return x ? Json(*x) : Json(); };
  Json texts = Json::array(), codes = Json::array(), spurious = Json::array();
  for (const Refusal& r : v.reasons) {
    texts.push_back(r.text);
    codes.push_back(r.code);
  }
  for (int64_t f : v.spurious_frames) spurious.push_back({{"frame", f}});
  j = {{"passed", v.passed},
       {"reasons", texts},
       {"reason_codes", codes},
       {"kind", v.kind},
       {"object_class", v.object_class},
       {"ttc",
        {{"intended_min_ttc_visible_s", opt(v.intended_min_ttc_s)},
         {"achieved_min_ttc_s", opt(v.achieved_min_ttc_s)},
         {"achieved_at_frame", opt(v.achieved_at_frame)}}},
       {"unsafe", {{"attributed_frames", v.hazard_critical_frames}, {"spurious_frames", spurious}}},
       {"redetection", {{"rate", opt(v.redetection_rate)}}}};
}

void from_json(const Json& j, VerificationOutcome& v) {
  if (!j.is_object()) throw Error("a verification outcome must be an object, got " + j.dump());
  v = VerificationOutcome{};
  auto number = [](const Json& o, const char* key, const std::string& where) -> std::optional<double> {
    if (!o.is_object() || !o.contains(key) || o[key].is_null()) return std::nullopt;
    if (!o[key].is_number()) throw Error(where + key + " must be a number or null, got " + o[key].dump());
    return o[key].get<double>();
  };
  if (!j.contains("passed") || !j["passed"].is_boolean()) throw Error("passed must be true or false");
  v.passed = j["passed"].get<bool>();
  const Json texts = j.value("reasons", Json::array()), codes = j.value("reason_codes", Json::array());
  for (size_t k = 0; k < texts.size(); ++k) {
    if (!texts[k].is_string()) throw Error("reasons[" + std::to_string(k) + "] must be a string");
    v.reasons.push_back({k < codes.size() && codes[k].is_string() ? codes[k].get<std::string>() : std::string(),
                         texts[k].get<std::string>(), j.value("kind", std::string())});
  }
  v.kind = j.value("kind", std::string());
  v.object_class = j.value("object_class", std::string());
  const Json ttc = j.value("ttc", Json::object()), unsafe = j.value("unsafe", Json::object());
  v.intended_min_ttc_s = number(ttc, "intended_min_ttc_visible_s", "ttc.");
  v.achieved_min_ttc_s = number(ttc, "achieved_min_ttc_s", "ttc.");
  if (const auto f = number(ttc, "achieved_at_frame", "ttc.")) v.achieved_at_frame = static_cast<int64_t>(*f);
  v.hazard_critical_frames = static_cast<int>(number(unsafe, "attributed_frames", "unsafe.").value_or(0));
  for (const Json& s : unsafe.value("spurious_frames", Json::array()))
    if (s.is_object() && s.contains("frame") && s["frame"].is_number_integer())
      v.spurious_frames.push_back(s["frame"].get<int64_t>());
  v.redetection_rate = number(j.value("redetection", Json::object()), "rate", "redetection.");
}

int RoadLayout::lane_at(double y) const {
  const int side = y >= 0 ? 1 : -1;
  const double from_centre = std::abs(y) - lane_width_m / 2;
  if (from_centre < 0) return 0;
  const int k = std::min(lanes(side) + 1, 1 + static_cast<int>(std::floor(from_centre / lane_width_m)));
  return side * k;
}

bool RoadLayout::same_direction_at(double y) const {
  const int lane = lane_at(y);
  const int side = lane >= 0 ? 1 : -1;
  const int k = std::abs(lane);
  return k == 0 || k > lanes(side) || k <= same_direction_lanes(side);
}

RoadFactSource RoadLayout::source(const std::string& field) const {
  auto it = sources.find(field);
  return it == sources.end() ? RoadFactSource{} : it->second;
}

void RoadLayout::validate(const std::string& where) const {
  auto range = [&](const char* field, double v, double lo, double hi) {
    if (!(v >= lo && v <= hi))
      throw Error(where + "." + field + " must be in [" + num_text(lo) + ", " + num_text(hi) + "], got " +
                  num_text(v));
  };
  range("lane_width_m", lane_width_m, 2, 6);
  range("lanes_left", lanes_left, 0, 10);
  range("lanes_right", lanes_right, 0, 10);
  range("oncoming_lanes", oncoming_lanes, 0, 10);
  range("kerb_offset_m", kerb_offset_m, 0, 5);
  range("sidewalk_width_m", sidewalk_width_m, 0, 15);
  if (driving_side != "right" && driving_side != "left")
    throw Error(where + ".driving_side must be 'right' or 'left', got '" + driving_side + "'");
  const int side = oncoming_side();
  if (oncoming_lanes > lanes(side))
    throw Error(where + ".oncoming_lanes " + std::to_string(oncoming_lanes) + " exceeds the " +
                std::to_string(lanes(side)) + " lane(s) on the " + (side > 0 ? "left" : "right") +
                ", where oncoming traffic passes when traffic keeps " + driving_side);
}

std::string frame_name(const Frame& f) {
  return "frame " + std::to_string(f.index) + " (t=" + std::to_string(f.timestamp) + " s)";
}

}  // namespace hf
