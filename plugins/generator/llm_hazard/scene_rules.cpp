// Scene-aware refusals: drawable class, no silent takeover of a tracked object, and the planned trajectory's
// clearance from tracked objects, lane directions and entry into view.
#include "scene_rules.hpp"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <set>

#include <hazardforge/angles.hpp>
#include <hazardforge/error.hpp>
#include <hazardforge/hazard/kinematics.hpp>
#include <hazardforge/json_text.hpp>
#include <hazardforge/number_text.hpp>

#include "feasibility.hpp"
#include "hazardforge/assets/asset_library.hpp"

namespace hf::llm_hazard {

namespace {

bool is_vehicle_or_bicycle(const std::string& cls) {
  return cls == "car" || cls == "truck" || cls == "bus" || cls == "motorcycle" || cls == "bicycle";
}

std::string join(const std::vector<std::string>& v) {
  std::string out;
  for (const std::string& s : v) out += (out.empty() ? "" : ", ") + s;
  return out;
}

// A footprint on the ground: centre, heading, half length and half width.
struct Footprint {
  double x, y, heading, half_l, half_w;
};

// Separating-axis test of two oriented rectangles.
bool overlap(const Footprint& a, const Footprint& b) {
  const Footprint* boxes[2] = {&a, &b};
  for (const Footprint* axis_box : boxes)
    for (int k = 0; k < 2; ++k) {
      const double h = axis_box->heading + k * kPi / 2;
      const double ux = std::cos(h), uy = std::sin(h);
      auto radius = [&](const Footprint& f) {
        return f.half_l * std::abs(std::cos(f.heading - h)) + f.half_w * std::abs(std::sin(f.heading - h));
      };
      const double dist = std::abs((b.x - a.x) * ux + (b.y - a.y) * uy);
      if (dist > radius(a) + radius(b)) return false;
    }
  return true;
}

// A point's offset to the left of the planned ego path and its heading relative to the path there, from the
// nearest planned ego sample (the path runs straight on beyond the plan's ends).
struct RoadPose {
  double d = 0, rel_heading = 0;
};
RoadPose road_pose(const std::vector<TrajectoryPoint>& ego, double x, double y, double heading) {
  if (ego.empty()) return {y, heading};
  const TrajectoryPoint* best = &ego.front();
  double best_d2 = kInf;
  for (const TrajectoryPoint& e : ego) {
    const double d2 = (e.x - x) * (e.x - x) + (e.y - y) * (e.y - y);
    if (d2 < best_d2) best_d2 = d2, best = &e;
  }
  RoadPose p;
  p.d = -(x - best->x) * std::sin(best->heading) + (y - best->y) * std::cos(best->heading);
  p.rel_heading = angle_diff(heading, best->heading);
  return p;
}

// Where an object at (x, y) is after driving `ds` metres along its lane, the lanes running beside the ego's
// path `ego` (straight beyond its end), and its heading there; (x, y) + ds along x without a path.
cv::Vec3d along_lane(const std::vector<TrajectoryPoint>& ego, double x, double y, double ds) {
  if (ego.size() < 2) return {x + ds, y, 0.0};
  size_t k = 0;
  double best_d2 = kInf;
  for (size_t i = 0; i < ego.size(); ++i) {
    const double d2 = (ego[i].x - x) * (ego[i].x - x) + (ego[i].y - y) * (ego[i].y - y);
    if (d2 < best_d2) best_d2 = d2, k = i;
  }
  auto dir = [](const TrajectoryPoint& e) { return cv::Vec2d(std::cos(e.heading), std::sin(e.heading)); };
  const cv::Vec2d t0 = dir(ego[k]), n0(-t0[1], t0[0]);
  const cv::Vec2d rel(x - ego[k].x, y - ego[k].y);
  const double d = rel.dot(n0);
  double left = rel.dot(t0) + ds;  // metres to go along the path from ego[k]
  size_t i = k;
  while (i + 1 < ego.size()) {
    const double seg = std::hypot(ego[i + 1].x - ego[i].x, ego[i + 1].y - ego[i].y);
    if (left < seg || seg <= 0) break;
    left -= seg;
    ++i;
  }
  const cv::Vec2d t = dir(ego[i]), n(-t[1], t[0]);
  const cv::Vec2d p = cv::Vec2d(ego[i].x, ego[i].y) + left * t + d * n;
  return {p[0], p[1], ego[i].heading};
}

// Share of `box` covered by the union of `covers` (sampled on a 12 x 12 grid).
double covered_fraction(const cv::Rect2d& box, const std::vector<cv::Rect2d>& covers) {
  if (covers.empty() || box.area() <= 0) return 0.0;
  int in = 0;
  const int n = 12;
  for (int i = 0; i < n; ++i)
    for (int j = 0; j < n; ++j) {
      const cv::Point2d p(box.x + (i + 0.5) * box.width / n, box.y + (j + 0.5) * box.height / n);
      for (const cv::Rect2d& c : covers)
        if (c.contains(p)) {
          ++in;
          break;
        }
    }
  return static_cast<double>(in) / (n * n);
}

}  // namespace

std::vector<std::string> asset_classes(const std::string& dir) {
  namespace fs = std::filesystem;
  const fs::path defaults = fs::path(share_dir()) / "assets";
  std::set<std::string> classes;
  for (const fs::path& d : {defaults, fs::path(dir)}) {
    if (d.empty() || (d != defaults && fs::exists(d) && fs::equivalent(d, defaults))) continue;
    for (const render::AssetSpec& a : render::load_asset_index(d).assets) classes.insert(a.object_class);
  }
  return {classes.begin(), classes.end()};
}

std::vector<std::string> own_asset_classes(const std::string& dir) {
  namespace fs = std::filesystem;
  std::set<std::string> classes;
  if (!dir.empty() && fs::exists(fs::path(dir) / "assets.yaml"))
    for (const render::AssetSpec& a : render::load_asset_index(dir).assets) classes.insert(a.object_class);
  return {classes.begin(), classes.end()};
}

std::vector<Refusal> check_spec_rules(const HazardSpec& spec, const SceneContext& scene,
                                      const SceneRules& rules) {
  std::vector<Refusal> errs;
  const auto& classes = rules.asset_classes;
  if (!classes.empty() && std::find(classes.begin(), classes.end(), spec.object_class) == classes.end())
    errs.push_back({refusal::kObjectClass,
                    "/object_class = \"" + spec.object_class + "\" has no appearance assets, so the renderer " +
                        "cannot draw it (classes with assets: " + join(classes) + "; " + rules.assets_where +
                        ")",
                    spec.kind});
  if (!rules.take_over_tracks && spec.track_id) {
    const int64_t id = *spec.track_id;
    std::string what = "tracked object";
    for (const ObjectState& o : scene.objects)
      if (o.track_id == id) what = "tracked " + o.label;
    errs.push_back({refusal::kSpec,
                    "/track_id = " + std::to_string(id) + " takes over the " + what +
                        ", but this scene does not allow takeovers (take_over_tracks false: the renderer "
                        "would leave the real one in the video beside the inserted one). Insert a new object "
                        "instead (track_id null)",
                    spec.kind});
  }
  return errs;
}

std::vector<Refusal> check_trajectory_rules(const HazardTrajectory& tr, const SceneContext& scene,
                                            const hazard::RoadModel& road, const ClassPriors& sizes,
                                            const SceneRules& rules) {
  std::vector<Refusal> errs;
  if (tr.points.empty()) return errs;
  const std::string& cls = tr.object_class;
  const double half_l = tr.size_lwh[0] / 2, half_w = tr.size_lwh[1] / 2, clear = rules.clearance_m / 2;
  const std::optional<int64_t> taken = tr.spec.track_id;
  auto refuse = [&](const char* code, std::string text) { errs.push_back({code, std::move(text), tr.kind}); };

  // Clear of every tracked object, each predicted at constant velocity from where it is now (standing when
  // its estimator cannot tell its motion from none).
  for (const ObjectState& o : scene.objects) {
    if (!std::isfinite(o.distance_m) || (taken && *taken == o.track_id)) continue;
    const ClassSize prior = sizes.has(o.label) ? sizes.at(o.label) : ClassSize{};
    const double ol = o.length_m > 0 ? o.length_m : prior.length,
                 ow = o.width_m > 0 ? o.width_m : prior.width;
    const double ego = scene.ego_speed_mps.value_or(0.0);
    const cv::Vec2d v = hazard::ground_velocity(o, ego).value_or(cv::Vec2d(0, 0));
    // A vehicle keeps its lane (it follows the road as the ego's path does) at its speed along it: its
    // tracked lateral speed is mostly box noise (a truck beside the ego, cut off by the image border, reads
    // 1-2.5 m/s towards the ego lane on the KITTI raw clip), which a constant-velocity prediction would turn
    // into a collision with anything planned in the next lane. People keep their velocity.
    const bool in_lane = is_vehicle_or_bicycle(o.label);
    const double oh = cv::norm(v) > 0.5 ? std::atan2(v[1], v[0]) : 0.0;
    // distance_m reaches the face the camera sees; the footprint is placed by its centre, half its length on.
    const double x0 = o.distance_m + rules.distance_origin_x + ol / 2.0, y0 = o.lateral_m;
    // A taken-over object starts where the real one is: a neighbour as close as the recording shows them is
    // not a collision; only coming closer than that is — sideways for one in the next lane (which may pass
    // it), in any direction for one in its own lane.
    std::optional<double> recorded_gap;
    bool side_by_side = false;
    for (const TrajectoryPoint& p : tr.points) {
      const double dt = p.t - tr.anchor_time;
      const cv::Vec3d at =
          in_lane ? along_lane(tr.ego, x0, y0, v[0] * dt) : cv::Vec3d(x0 + v[0] * dt, y0 + v[1] * dt, oh);
      const Footprint other{at[0], at[1], at[2], ol / 2 + clear, ow / 2 + clear};
      const bool hit = overlap({p.x, p.y, p.heading, half_l + clear, half_w + clear}, other);
      const double sideways = std::abs(p.y - other.y);
      if (taken && &p == &tr.points.front() && hit) {
        side_by_side = sideways >= half_w + ow / 2;
        recorded_gap = side_by_side ? sideways : std::hypot(p.x - other.x, p.y - other.y);
      }
      const double apart = side_by_side ? sideways : std::hypot(p.x - other.x, p.y - other.y);
      if (!hit || (recorded_gap && apart >= *recorded_gap - 0.1)) continue;
      refuse(refusal::kTraffic, "the planned path of the " + cls + " runs into the tracked " + o.label + " (track " +
                     std::to_string(o.track_id) + ", predicted at constant velocity): " + num_text(dt) +
                     " s after it appears the " + cls + " would be at (x " + num_text(p.x) + ", y " +
                     num_text(p.y) + ") m and the " + o.label + " at (x " + num_text(other.x) + ", y " +
                     num_text(other.y) + ") m. Place it where its path stays clear of the tracked objects");
      break;
    }
  }

  const TrajectoryPoint& first = tr.points.front();
  const RoadPose start = road_pose(tr.ego, first.x, first.y, first.heading);
  const int side = start.d >= 0 ? 1 : -1;

  // A vehicle starts in a lane in its traffic's direction.
  if (is_vehicle_or_bicycle(cls) && std::abs(road.lane_at(start.d)) <= road.lanes(side)) {
    const bool with_ego = std::cos(start.rel_heading) > 0;
    const bool lane_with_ego = road.same_direction_at(start.d);
    if (with_ego != lane_with_ego)
      refuse(refusal::kPlacement, "the " + cls + " starts at y " + num_text(start.d) + " m in a lane " +
                     (lane_with_ego ? "going the ego's way" : "with oncoming traffic") + " (lanes_left " +
                     std::to_string(road.lanes_left) + ", lanes_right " + std::to_string(road.lanes_right) +
                     ", oncoming_lanes " + std::to_string(road.oncoming_lanes) + ", traffic keeps " +
                     road.driving_side + ") but drives " + (with_ego ? "the ego's way" : "towards the ego") +
                     ", against that lane's traffic");
  }

  // It enters the view plausibly: the first time any of it is in the image. A taken-over object was in view
  // already: it is the real one, drawn where it is.
  const CameraModel& cam = scene.camera;
  if (cam.valid() && rules.entry_max_height > 0 && !taken) {
    const cv::Rect2d image(0, 0, cam.width, cam.height);
    for (const TrajectoryPoint& p : tr.points) {
      const hazard::BoxView view = hazard::view_of(cam, p.x, p.y, p.heading, tr.size_lwh);
      if (view.box.area() <= 0 || (view.box & image).area() <= 0) continue;
      const RoadPose at = road_pose(tr.ego, p.x, p.y, p.heading);
      const bool entering = !view.in_front || view.inside_fraction < 0.98;
      const bool off_road = std::abs(at.d) - half_w >= road.edge(at.d >= 0 ? 1 : -1);
      const double max_px = rules.entry_max_height * cam.height;
      const bool small = view.box.height <= max_px;
      std::vector<cv::Rect2d> nearer;
      for (const ObjectState& o : scene.objects)
        if (std::isfinite(o.distance_m) && o.distance_m + rules.distance_origin_x < p.x &&
            (!taken || *taken != o.track_id))
          nearer.emplace_back(o.box.x, o.box.y, o.box.width, o.box.height);
      const bool hidden = covered_fraction(view.box, nearer) >= 0.5;
      if (!entering && !off_road && !small && !hidden)
        refuse(
            refusal::kNotInView, "the " + cls + " would pop up on the road " + num_text(p.x) +
            " m ahead: when it is first seen (" + num_text(p.t - tr.anchor_time) +
            " s after it appears) its box is fully in view, " + num_text(view.box.height, 0) +
            " px tall, and no tracked object hides it. Let it enter from "
            "beyond the image border, from behind a nearer tracked object, or far enough to be first "
            "seen small (at most " +
            num_text(max_px, 0) + " px tall, " + num_text(100 * rules.entry_max_height) +
            " % of the image height)");
      break;
    }
  }
  return errs;
}

}  // namespace hf::llm_hazard
