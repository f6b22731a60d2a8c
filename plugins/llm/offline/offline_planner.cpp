// Deterministic hazard planner behind the LLM provider interface.
#include "offline_planner.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <map>
#include <optional>
#include <random>

#include <hazardforge/corridor.hpp>
#include <hazardforge/error.hpp>

namespace hf::llm {

namespace {

constexpr double kMinEgoSpeed = 1.0;  // m/s: below it no inserted object closes in on the ego
constexpr double kMinDistance = 4.0;  // nearest start of an inserted lead vehicle
constexpr double kMaxDistance = 120.0;

// std::uniform_real_distribution differs between standard libraries; this does not.
class Draw {
 public:
  explicit Draw(uint64_t seed) : gen_(seed) {}
  double uniform(double lo, double hi) {
    return lo + (hi - lo) * static_cast<double>(gen_() >> 11) * 0x1.0p-53;
  }
  size_t index(size_t n) { return static_cast<size_t>(gen_() % n); }
  bool coin() { return (gen_() >> 63) != 0; }

 private:
  std::mt19937_64 gen_;
};

double round_to(double v, double step) {
  return std::round(v / step) * step;
}

std::string fmt(double v) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.1f", v);
  return buf;
}

const Json& field(const Json& scene, const char* name) {
  if (!scene.contains(name))
    throw Error(std::string("offline: the request's scene context lacks '") + name + "'");
  return scene[name];
}

double number(const Json& scene, const char* name) {
  const Json& v = field(scene, name);
  if (!v.is_number()) throw Error(std::string("offline: scene context '") + name + "' is not a number");
  return v.get<double>();
}

struct Size {
  double length = 4.5, width = 1.8;
};

struct Limits {
  double max_speed = 0, max_accel = 0, max_decel = 0, max_lateral_speed = 0;
};

struct Scene {
  std::vector<std::string> allowed;
  bool sidewalks = false, intersection = false, multi_lane = false;
  bool on_shoulder = false;  // edge-case tests: a person on a road without sidewalks, on its shoulder
  double max_under_way = 0;  // s a manoeuvre may already be under way when the hazard appears
  double ego_speed = 0, target = 1.0, horizon = 6, sidewalk = 3.0;
  double lane_width = 3.5, edge_left = 5.25, edge_right = 5.25, kerb = 0.5;
  Corridor corridor;  // its widths; the objects' in_path flags already say where the ego's path runs
  double ego_front = 3.4;
  std::map<std::string, Limits> limits;
  std::map<std::string, Size> sizes;
  std::optional<CameraModel> camera;
  struct Obj {
    int64_t track_id;
    std::string label;
    double x, y, length, width;
    bool in_path;
    std::optional<double> speed;  // absolute, along the ego heading when known
  };
  std::vector<Obj> objects;

  Size size(const std::string& cls) const {
    auto it = sizes.find(cls);
    if (it == sizes.end()) throw Error("offline: the scene context has no size for class '" + cls + "'");
    return it->second;
  }
  double edge(int side) const { return side > 0 ? edge_left : edge_right; }
  double path_half(double width) const { return corridor.half_width_for(width); }
};

Scene read_scene(const Json& s) {
  if (!s.is_object() || s.empty())
    throw Error(
        "offline: the request carries no scene context (the offline planner reads LlmRequest::scene)");
  Scene sc;
  try {
    for (const Json& k : field(s, "allowed_kinds")) sc.allowed.push_back(k.get<std::string>());
    sc.sidewalks = field(s, "sidewalks").get<bool>();
    sc.intersection = field(s, "intersection").get<bool>();
    sc.multi_lane = field(s, "multi_lane").get<bool>();
    sc.ego_speed = number(s, "ego_speed_mps");
    sc.target = number(s, "target_ttc_s");
    sc.horizon = number(s, "horizon_s");
    sc.sidewalk = number(s, "sidewalk_width_m");
    // Newer fields; a context without them allows neither.
    sc.on_shoulder = s.value("pedestrians_without_sidewalks", false);
    sc.max_under_way = s.value("max_under_way_s", 0.0);
    const Json& road = field(s, "road");
    sc.lane_width = road.at("lane_width_m").get<double>();
    sc.edge_left = road.at("edge_left_m").get<double>();
    sc.edge_right = road.at("edge_right_m").get<double>();
    sc.kerb = road.at("kerb_offset_m").get<double>();
    const Json& ttc = field(s, "ttc");
    sc.corridor.ego_half_width = ttc.at("corridor_half_width").get<double>();
    sc.corridor.margin = ttc.at("corridor_margin").get<double>();
    sc.ego_front = ttc.at("ego_front_m").get<double>();
    for (auto it = field(s, "limits").begin(); it != s["limits"].end(); ++it)
      sc.limits[it.key()] = {it.value().at("max_speed_mps").get<double>(),
                             it.value().at("max_accel_mps2").get<double>(),
                             it.value().at("max_decel_mps2").get<double>(),
                             it.value().at("max_lateral_speed_mps").get<double>()};
    for (auto it = field(s, "class_sizes").begin(); it != s["class_sizes"].end(); ++it)
      sc.sizes[it.key()] = {it.value().at("length").get<double>(), it.value().at("width").get<double>()};
    if (s.contains("camera") && s["camera"].is_object()) {
      CameraModel cam;
      from_json(s["camera"], cam);
      if (cam.valid()) sc.camera = cam;
    }
    for (const Json& o : field(s, "objects")) {
      if (!o.at("distance_m").is_number()) continue;
      std::string label = o.at("label").get<std::string>();
      Size prior = sc.sizes.count(label) ? sc.sizes[label] : Size{};
      double l = o.value("length_m", 0.0), w = o.value("width_m", 0.0);
      std::optional<double> speed;
      if (o.contains("velocity_rel") && o["velocity_rel"].is_array())
        speed = sc.ego_speed + o["velocity_rel"][0].get<double>();
      else if (o.contains("speed_mps") && o["speed_mps"].is_number())
        speed = o["speed_mps"].get<double>();
      sc.objects.push_back({o.at("track_id").get<int64_t>(), label, o["distance_m"].get<double>(),
                            o.at("lateral_m").get<double>(), l > 0 ? l : prior.length,
                            w > 0 ? w : prior.width, o.value("in_path", false), speed});
    }
  } catch (const Json::exception& e) {
    throw Error(std::string("offline: malformed scene context: ") + e.what());
  }
  return sc;
}

struct Plan {
  Json spec;
  std::string problem;  // why this kind could not be planned (empty = ok)
};

bool visible(const Scene& sc, double x, double y) {
  if (!sc.camera) return true;
  auto px = sc.camera->project_ego(cv::Vec3d(x, y, 0.0));
  return px && px->x >= 0 && px->y >= 0 && px->x < sc.camera->width && px->y < sc.camera->height;
}

std::string overlap_problem(const Scene& sc, double x, double y, const Size& me, int64_t except = -1) {
  for (const Scene::Obj& o : sc.objects)
    if (o.track_id != except && std::abs(o.x - x) < (o.length + me.length) / 2.0 + 1.0 &&
        std::abs(o.y - y) < (o.width + me.width) / 2.0 + 0.5)
      return "start point (" + fmt(x) + ", " + fmt(y) + ") m is next to the detected " + o.label;
  return {};
}

Json base_spec(const std::string& kind, const std::string& cls, double x, double y, const std::string& side,
               double speed, double heading, const std::string& motion, double target) {
  return {{"kind", kind},
          {"object_class", cls},
          {"initial_distance_m", round_to(x, 0.1)},
          {"lateral_offset_m", round_to(y, 0.05)},
          {"side", side},
          {"speed_mps", round_to(speed, 0.05)},
          {"heading_deg", round_to(heading, 0.5)},
          {"motion", motion},
          {"start_time_s", nullptr},
          {"deceleration_mps2", nullptr},
          {"target_ttc_s", target},
          {"extra",
           {{"crossing_from", nullptr},
            {"final_speed_mps", nullptr},
            {"brake_delay_s", nullptr},
            {"track_id", nullptr},
            {"under_way_s", nullptr}}},
          {"rationale", ""}};
}

// Time for a start from rest to cover d at walking speed v (acceleration phase plus a jerk allowance).
double walk_time(double d, double v, double accel) {
  return d / v + v / (2.0 * accel) + 0.3;
}

// pedestrian_crossing: waits on the kerb, walks across; the ego arrives `enter + target` after the start.
Plan plan_pedestrian(const Scene& sc, Draw& d, double aim) {
  if (!sc.sidewalks && !sc.on_shoulder) return {{}, "the scene has no sidewalks"};
  const std::string cls = "person";
  if (!sc.limits.count(cls)) return {{}, "the limits table has no 'person'"};
  const Limits& lim = sc.limits.at(cls);
  const Size size = sc.size(cls);
  const bool left = d.coin();
  const int sign = left ? 1 : -1;
  const double y0 = sign * (sc.edge(sign) + sc.kerb + d.uniform(0.0, std::min(0.5, sc.sidewalk)));
  const double speed = d.uniform(1.6, std::min(2.5, lim.max_speed));
  const double d_in = std::abs(y0) - sc.path_half(size.width);
  // Waits a moment before stepping off; within a short horizon only as long as still leaves time to be seen.
  const double walk = walk_time(d_in, speed, lim.max_accel);
  const double ttc = aim * sc.target;
  // The template times the walk for the spec's target (sc.target), the position is planned for `ttc`: the
  // wait must cover the difference, or the person would have to enter the path before it can.
  const double min_wait = sc.target - ttc + 0.1;
  const double enter =
      walk + std::max(min_wait, std::min(d.uniform(0.3, 1.0), std::max(0.0, sc.horizon - 0.5 - walk)));
  // A horizon too short to watch the whole walk: when allowed, the person is already on the way when the
  // hazard appears and enters the path a little into the horizon.
  double under_way = 0;
  if (enter > sc.horizon - 0.5) {
    if (sc.max_under_way <= 0) return {{}, "walking into the ego path takes longer than the horizon"};
    under_way = enter - d.uniform(0.3, 0.5) * sc.horizon;
    if (under_way > sc.max_under_way)
      return {{},
              "the walk would have to be under way for " + fmt(under_way) + " s (max_under_way_s " +
                  fmt(sc.max_under_way) + ")"};
  }
  const double x0 = sc.ego_front + size.length / 2.0 + sc.ego_speed * (enter + ttc);
  const double x_seen = x0 - sc.ego_speed * under_way;  // where it is when the hazard appears
  if (x0 > kMaxDistance) return {{}, "the crossing would be more than 120 m ahead"};
  if (!visible(sc, x_seen, y0))
    return {{}, "the kerb point (" + fmt(x_seen) + ", " + fmt(y0) + ") m is outside the camera view"};
  if (std::string p = overlap_problem(sc, x_seen, y0, size); !p.empty()) return {{}, p};
  const std::string from = left ? "left" : "right";
  Json spec =
      base_spec("pedestrian_crossing", cls, x0, y0, from, speed, -sign * 90.0,
                "steps off the " + from + " kerb and crosses to the " + (left ? "right" : "left"), sc.target);
  spec["extra"]["crossing_from"] = from;
  const std::string where =
      sc.sidewalks ? "The scene has sidewalks, so a pedestrian stepping off the " + from + " kerb "
                   : "Edge case (no sidewalks; people on the road allowed explicitly): a person who left a "
                     "broken-down vehicle on the " +
                         from + " shoulder steps into the road ";
  spec["rationale"] = where + fmt(x0) + " m ahead and crossing at " + fmt(speed) +
                      " m/s is realistic; with the ego at " + fmt(sc.ego_speed) +
                      " m/s they are in its path about " + fmt(enter) + " s later, TTC near " + fmt(ttc) +
                      " s.";
  if (under_way > 0) {
    spec["extra"]["under_way_s"] = round_to(under_way, 0.05);
    spec["rationale"] = spec["rationale"].get<std::string>() + " The hazard appears " + fmt(under_way) +
                        " s after the start, " + fmt(x_seen) + " m ahead, as the person sets off.";
  }
  return {spec, {}};
}

// cut_in: overtakes from beside/behind at v0 > ego, then brakes to v1 < ego while changing lanes.
Plan plan_cut_in(const Scene& sc, Draw& d, double aim) {
  if (!sc.multi_lane) return {{}, "the road has a single lane"};
  if (sc.ego_speed < 5.0) return {{}, "the ego is too slow (< 5 m/s) to be overtaken and cut off"};
  static const char* kClasses[] = {"car", "car", "car", "motorcycle", "truck"};
  const std::string cls = kClasses[d.index(5)];
  if (!sc.limits.count(cls)) return {{}, "the limits table has no '" + cls + "'"};
  const Limits& lim = sc.limits.at(cls);
  const Size size = sc.size(cls);
  bool left = d.coin();
  if (sc.edge(left ? 1 : -1) < sc.lane_width + size.width / 2.0) left = !left;
  const int sign = left ? 1 : -1;
  if (sc.edge(sign) < sc.lane_width + size.width / 2.0) return {{}, "there is no lane beside the ego lane"};
  const double y0 = sign * sc.lane_width;
  const double v0 = std::min(sc.ego_speed + d.uniform(3.0, 5.0), lim.max_speed);
  const double v1 = std::max(0.0, sc.ego_speed - d.uniform(2.0, 4.0));
  const double decel = std::min(d.uniform(2.5, 4.0), lim.max_decel);
  if (v0 <= sc.ego_speed + 1.0) return {{}, "a " + cls + " cannot overtake the ego here"};
  const double ttc = aim * sc.target;
  const double gap_end = ttc * (sc.ego_speed - v1);
  // Braking from v0 to v1, then the lane change must fit between the start and the end of braking.
  const double t_slow = (v0 - v1) / decel + 0.4;
  const double s_slow = (v0 + v1) / 2.0 * t_slow;
  const double lane_change = 1.15 * 1.875 * sc.lane_width / std::max(0.5, lim.max_lateral_speed);
  const double t_brake = std::max(0.5, lane_change - t_slow + 0.5) + d.uniform(0.0, 1.0);
  const double x0 =
      gap_end + sc.ego_front + size.length / 2.0 + sc.ego_speed * (t_brake + t_slow) - s_slow - v0 * t_brake;
  if (x0 < -25.0 || x0 > 3.0) return {{}, "no start beside or behind the ego fits (x " + fmt(x0) + " m)"};
  // A horizon too short for the whole manoeuvre: when allowed, it is already under way when it appears and
  // the lane change ends a little into the horizon.
  double under_way = 0;
  if (t_brake + t_slow > sc.horizon - 0.5) {
    if (sc.max_under_way <= 0) return {{}, "the cut-in takes longer than the horizon"};
    under_way = t_brake + t_slow - d.uniform(0.3, 0.5) * sc.horizon;
    if (under_way > sc.max_under_way)
      return {{},
              "the cut-in would have to be under way for " + fmt(under_way) + " s (max_under_way_s " +
                  fmt(sc.max_under_way) + ")"};
  }
  if (under_way == 0)
    if (std::string p = overlap_problem(sc, x0, y0, size); !p.empty()) return {{}, p};
  const std::string side = left ? "left" : "right";
  Json spec = base_spec("cut_in", cls, x0, y0, side, v0, 0.0,
                        "overtakes in the " + side + " lane and cuts in, braking", sc.target);
  spec["deceleration_mps2"] = round_to(decel, 0.1);
  spec["extra"]["final_speed_mps"] = round_to(v1, 0.05);
  spec["rationale"] = "On a multi-lane road a " + cls + " overtakes in the " + side + " lane at " + fmt(v0) +
                      " m/s and cuts in ahead of the ego, braking to " + fmt(v1) + " m/s; it ends about " +
                      fmt(gap_end) + " m ahead, TTC near " + fmt(ttc) + " s.";
  if (under_way > 0) {
    spec["extra"]["under_way_s"] = round_to(under_way, 0.05);
    spec["rationale"] = spec["rationale"].get<std::string>() + " It appears " + fmt(under_way) +
                        " s into the manoeuvre, already changing lanes beside-ahead of the ego.";
  }
  return {spec, {}};
}

// First time (s) the TTC to a lead braking after `delay` falls to `ttc`, by a 20 ms replay; kInf if never.
// A negative delay: braking began that long before (v0 is the speed before braking, gap0 the gap now).
double time_to_ttc(double gap0, double ego, double v0, double delay, double decel, double ttc,
                   double horizon) {
  double gap = gap0, v = delay < 0 ? std::max(0.0, v0 + decel * delay) : v0;
  for (double t = 0; t <= horizon; t += 0.02) {
    const double closing = ego - v;
    if (gap <= 0 || (closing > 0.1 && gap / closing <= ttc)) return t;
    gap += (v - ego) * 0.02;
    if (t >= delay) v = std::max(0.0, v - decel * 0.02);
  }
  return kInf;
}

// sudden_stop: a tracked lead in the ego path brakes, or an inserted one if there is room.
Plan plan_sudden_stop(const Scene& sc, Draw& d, double aim) {
  const double ttc = aim * sc.target;
  const double delay = round_to(d.uniform(0.5, 1.5), 0.1);
  const Scene::Obj* lead = nullptr;
  for (const Scene::Obj& o : sc.objects)
    if (o.in_path && o.x > 0 && (!lead || o.x < lead->x)) lead = &o;
  static const char* kVehicles[] = {"car", "truck", "bus", "motorcycle"};
  auto is_vehicle = [](const std::string& c) {
    return std::find(std::begin(kVehicles), std::end(kVehicles), c) != std::end(kVehicles);
  };
  // A moving lead vehicle that brakes is the most natural sudden stop.
  if (lead && is_vehicle(lead->label) && lead->speed && *lead->speed >= 0.5 && sc.limits.count(lead->label)) {
    const double decel = round_to(d.uniform(0.6, 0.9) * sc.limits.at(lead->label).max_decel, 0.1);
    const double gap = lead->x - sc.ego_front - lead->length / 2.0;
    if (gap > 0 &&
        time_to_ttc(gap, sc.ego_speed, *lead->speed, delay, decel, ttc, sc.horizon) < sc.horizon - 0.7) {
      Json spec = base_spec("sudden_stop", lead->label, lead->x, lead->y, "center", *lead->speed, 0.0,
                            "the tracked lead brakes hard in the ego lane", sc.target);
      spec["side"] = std::abs(lead->y) <= sc.path_half(0.0) ? "center" : (lead->y > 0 ? "left" : "right");
      spec["deceleration_mps2"] = decel;
      spec["extra"]["brake_delay_s"] = delay;
      spec["extra"]["track_id"] = lead->track_id;
      spec["rationale"] = "The " + lead->label + " (track " + std::to_string(lead->track_id) + ") " +
                          fmt(lead->x) + " m ahead in the ego lane brakes at " + fmt(decel) +
                          " m/s^2 after " + fmt(delay) + " s; the ego, keeping " + fmt(sc.ego_speed) +
                          " m/s, closes in to a TTC near " + fmt(ttc) + " s.";
      return {spec, {}};
    }
  }
  static const char* kClasses[] = {"car", "car", "car", "truck", "bus"};
  const std::string cls = kClasses[d.index(5)];
  if (!sc.limits.count(cls)) return {{}, "the limits table has no '" + cls + "'"};
  const Size size = sc.size(cls);
  const double speed = std::min(sc.ego_speed, sc.limits.at(cls).max_speed);
  const double decel = round_to(d.uniform(0.6, 0.9) * sc.limits.at(cls).max_decel, 0.1);
  if (speed < kMinEgoSpeed) return {{}, "a lead vehicle cannot brake from standstill"};
  if (sc.max_under_way > 0 && delay + 1.0 > sc.horizon - 0.7) {
    // A horizon too short to watch a lead cruise and then brake: it has been braking for `b` s when it
    // appears, following at the ego's speed until then, and the TTC reaches the target `t_hit` s in.
    const double b = std::min(sc.max_under_way, d.uniform(0.3, 0.8));
    const double t_hit = d.uniform(0.3, 0.5) * sc.horizon;
    const double gap_now = decel * (b * t_hit + t_hit * t_hit / 2.0) + ttc * decel * (b + t_hit);
    const double gap_start = gap_now + decel * b * b / 2.0;  // the closing covered while braking before
    const double x0 = sc.ego_front + size.length / 2.0 + gap_start;
    const double y0 = d.uniform(-0.3, 0.3);
    if (time_to_ttc(gap_now, sc.ego_speed, speed, -b, decel, ttc, sc.horizon) > sc.horizon - 0.7)
      return {{}, "the stop would come too late within the horizon"};
    if (lead && x0 + (size.length + lead->length) / 2.0 + 2.0 > lead->x)
      return {{},
              "no room to insert a lead vehicle before the " + lead->label + " at " + fmt(lead->x) + " m"};
    if (!visible(sc, x0, y0))
      return {{}, "the start point (" + fmt(x0) + ", " + fmt(y0) + ") m is outside the camera view"};
    Json spec = base_spec("sudden_stop", cls, x0, y0, "center", speed, 0.0,
                          "follows in the ego lane and is already braking hard when it appears", sc.target);
    spec["deceleration_mps2"] = decel;
    spec["extra"]["brake_delay_s"] = 0.0;
    spec["extra"]["under_way_s"] = round_to(b, 0.05);
    spec["rationale"] = "A " + cls + " following " + fmt(gap_start) + " m ahead of the ego at the same " +
                        fmt(speed) + " m/s has been braking at " + fmt(decel) + " m/s^2 for " + fmt(b) +
                        " s when it appears " + fmt(gap_now) + " m ahead; the TTC falls to about " +
                        fmt(ttc) + " s " + fmt(t_hit) + " s later.";
    return {spec, {}};
  }
  // Same speed as the ego: the gap holds until braking starts, then TTC = gap / closing falls.
  const double t_star = std::min(d.uniform(1.0, 2.5), 0.8 * speed / decel);
  const double gap = decel * t_star * t_star / 2.0 + decel * ttc * t_star;
  const double x0 = sc.ego_front + size.length / 2.0 + gap;
  const double y0 = d.uniform(-0.3, 0.3);
  if (x0 < kMinDistance || x0 > kMaxDistance) return {{}, "no start distance within [4, 120] m"};
  if (time_to_ttc(gap, sc.ego_speed, speed, delay, decel, ttc, sc.horizon) > sc.horizon - 0.7)
    return {{}, "the stop would come too late within the horizon"};
  if (lead && x0 + (size.length + lead->length) / 2.0 + 2.0 > lead->x)
    return {{}, "no room to insert a lead vehicle before the " + lead->label + " at " + fmt(lead->x) + " m"};
  if (!visible(sc, x0, y0))
    return {{}, "the start point (" + fmt(x0) + ", " + fmt(y0) + ") m is outside the camera view"};
  if (std::string p = overlap_problem(sc, x0, y0, size); !p.empty()) return {{}, p};
  Json spec = base_spec("sudden_stop", cls, x0, y0, "center", speed, 0.0,
                        "drives ahead in the ego lane, then brakes hard", sc.target);
  spec["deceleration_mps2"] = decel;
  spec["extra"]["brake_delay_s"] = delay;
  spec["rationale"] = "A " + cls + " driving " + fmt(gap) + " m ahead of the ego at the same " + fmt(speed) +
                      " m/s brakes at " + fmt(decel) + " m/s^2 after " + fmt(delay) +
                      " s; the TTC falls to about " + fmt(ttc) + " s.";
  return {spec, {}};
}

}  // namespace

ComponentInfo OfflinePlanner::describe() {
  ComponentInfo i;
  i.name = "offline";
  i.kind = kind::kLlmProvider;
  i.summary = "Deterministic, seeded hazard planner that answers like an LLM (no server needed)";
  i.params = {
      ParamSpec::number("aim", 0.85).range(0.3, 1.0).describe("planned TTC as a fraction of target_ttc_s"),
      ParamSpec::integer("candidates_per_kind", 12)
          .range(1, 100)
          .describe("draws tried per kind before giving up"),
  };
  return i;
}

void OfflinePlanner::open(const Params& p) {
  aim_ = p.get_double("aim");
  candidates_ = static_cast<int>(p.get_int("candidates_per_kind"));
}

std::string OfflinePlanner::describe_backend() const {
  return "offline planner";
}

LlmReply OfflinePlanner::complete(const LlmRequest& request) {
  auto t0 = std::chrono::steady_clock::now();
  const Scene sc = read_scene(request.scene);
  const auto previous = std::count_if(request.messages.begin(), request.messages.end(),
                                      [](const LlmMessage& m) { return m.role == "assistant"; });
  Draw draw(static_cast<uint64_t>(request.seed) * 0x9E3779B97F4A7C15ULL + static_cast<uint64_t>(previous));

  using Planner = Plan (*)(const Scene&, Draw&, double);
  const std::vector<std::pair<std::string, Planner>> known = {{"pedestrian_crossing", &plan_pedestrian},
                                                              {"cut_in", &plan_cut_in},
                                                              {"sudden_stop", &plan_sudden_stop}};

  std::vector<std::string> problems;
  std::vector<Json> plans;
  if (sc.ego_speed < kMinEgoSpeed) {
    problems.push_back("the ego speed " + fmt(sc.ego_speed) + " m/s is below " + fmt(kMinEgoSpeed) +
                       " m/s, so no inserted object closes in on it");
  } else {
    for (const auto& [kind, plan] : known) {
      if (std::find(sc.allowed.begin(), sc.allowed.end(), kind) == sc.allowed.end()) continue;
      std::string last;
      for (int c = 0; c < candidates_; ++c) {
        Plan p = plan(sc, draw, aim_);
        if (p.problem.empty()) {
          plans.push_back(std::move(p.spec));
          last.clear();
          break;
        }
        last = p.problem;
      }
      if (!last.empty()) problems.push_back(kind + ": " + last);
    }
  }
  if (plans.empty()) {
    std::string allowed, why;
    for (const std::string& k : sc.allowed) allowed += (allowed.empty() ? "" : ", ") + k;
    for (const std::string& p : problems) why += (why.empty() ? "" : "; ") + p;
    if (why.empty()) why = "it plans only pedestrian_crossing, cut_in and sudden_stop";
    throw Error("offline: no hazard fits this scene (allowed kinds: " + allowed + "): " + why);
  }
  Json chosen = plans[draw.index(plans.size())];
  LlmReply reply;
  reply.content = chosen.dump(2);
  reply.model = "offline-planner-1";
  reply.raw = {{"planner", "offline"}, {"candidates", plans.size()}, {"rejected", problems}};
  reply.latency_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return reply;
}

}  // namespace hf::llm
