// Deterministic hazard planner behind the LLM provider interface.
#include "offline_planner.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <map>
#include <optional>
#include <random>

#include <hazardforge/error.hpp>

namespace hf::llm {

namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr double kMinEgoSpeed = 1.0;  // m/s: below it no inserted object closes in on the ego
constexpr double kLaneWidth = 3.5;
constexpr double kMinDistance = 4.0;   // schema bounds of initial_distance_m
constexpr double kMaxDistance = 120.0;

// std::uniform_real_distribution differs between standard libraries; this does not.
class Draw {
 public:
  explicit Draw(uint64_t seed) : gen_(seed) {}
  double uniform(double lo, double hi) { return lo + (hi - lo) * static_cast<double>(gen_() >> 11) * 0x1.0p-53; }
  size_t index(size_t n) { return static_cast<size_t>(gen_() % n); }
  bool coin() { return (gen_() >> 63) != 0; }

 private:
  std::mt19937_64 gen_;
};

double round_to(double v, double step) { return std::round(v / step) * step; }

std::string fmt(double v) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.1f", v);
  return buf;
}

const Json& field(const Json& scene, const char* name) {
  if (!scene.contains(name)) throw Error(std::string("offline: the request's scene context lacks '") + name + "'");
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

struct Scene {
  std::vector<std::string> allowed;
  bool sidewalks = false, intersection = false, multi_lane = false;
  double ego_speed = 0, target = 1.0, tolerance = 0.25, horizon = 8, ego_front = 3.4;
  double road_half = 5.25, sidewalk = 3.0, ego_half = 1.0, margin = 0.5, timestamp = 0;
  std::map<std::string, std::pair<double, double>> limits;  // class -> (max speed, max decel)
  std::map<std::string, Size> sizes;
  std::optional<CameraModel> camera;
  struct Obj {
    std::string label;
    double x, y, length, width;
    bool in_path;
  };
  std::vector<Obj> objects;

  Size size(const std::string& cls) const {
    auto it = sizes.find(cls);
    if (it == sizes.end()) throw Error("offline: the scene context has no size for class '" + cls + "'");
    return it->second;
  }
  double max_speed(const std::string& cls) const { return limits.count(cls) ? limits.at(cls).first : 0.0; }
  double max_decel(const std::string& cls) const { return limits.count(cls) ? limits.at(cls).second : 0.0; }
};

Scene read_scene(const Json& s) {
  if (!s.is_object() || s.empty())
    throw Error("offline: the request carries no scene context (the offline planner reads LlmRequest::scene)");
  Scene sc;
  for (const Json& k : field(s, "allowed_kinds")) sc.allowed.push_back(k.get<std::string>());
  sc.sidewalks = field(s, "sidewalks").get<bool>();
  sc.intersection = field(s, "intersection").get<bool>();
  sc.multi_lane = field(s, "multi_lane").get<bool>();
  sc.ego_speed = number(s, "ego_speed_mps");
  sc.target = number(s, "target_ttc_s");
  sc.tolerance = number(s, "ttc_tolerance_s");
  sc.horizon = number(s, "horizon_s");
  sc.ego_front = number(s, "ego_front_m");
  sc.road_half = number(s, "road_half_width_m");
  sc.sidewalk = number(s, "sidewalk_width_m");
  sc.timestamp = number(s, "timestamp_s");
  const Json& corridor = field(s, "corridor");
  sc.ego_half = corridor.at("ego_half_width").get<double>();
  sc.margin = corridor.at("margin").get<double>();
  for (auto it = field(s, "limits").at("classes").begin(); it != s["limits"]["classes"].end(); ++it)
    sc.limits[it.key()] = {it.value().at("max_speed_mps").get<double>(), it.value().at("max_decel_mps2").get<double>()};
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
    sc.objects.push_back({label, o["distance_m"].get<double>(), o.at("lateral_m").get<double>(),
                          l > 0 ? l : prior.length, w > 0 ? w : prior.width, o.value("in_path", false)});
  }
  return sc;
}

struct Plan {
  Json spec;
  std::string problem;  // why this kind could not be planned (empty = ok)
};

// x0 so that the object, entering the ego corridor after t_in seconds, does so with TTC = ttc.
double start_distance(const Scene& sc, double long_half, double closing, double t_in, double ttc) {
  return sc.ego_front + long_half + closing * (t_in + ttc);
}

std::string visibility_problem(const Scene& sc, double x, double y) {
  if (!sc.camera) return {};
  auto px = sc.camera->project_ego(cv::Vec3d(x, y, 0.0));
  if (!px || px->x < 0 || px->y < 0 || px->x >= sc.camera->width || px->y >= sc.camera->height)
    return "start point (" + fmt(x) + ", " + fmt(y) + ") m is outside the camera view";
  return {};
}

std::string overlap_problem(const Scene& sc, double x, double y, const Size& me) {
  for (const Scene::Obj& o : sc.objects)
    if (std::abs(o.x - x) < (o.length + me.length) / 2.0 + 1.0 && std::abs(o.y - y) < (o.width + me.width) / 2.0 + 0.5)
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
          {"extra", {{"crossing_from", nullptr}}},
          {"rationale", ""}};
}

Plan plan_pedestrian(const Scene& sc, Draw& d, double aim) {
  if (!sc.sidewalks) return {{}, "the scene has no sidewalks"};
  const std::string cls = "person";
  if (!sc.limits.count(cls)) return {{}, "the limits table has no 'person'"};
  const Size size = sc.size(cls);
  const bool left = d.coin();
  const double sign = left ? 1.0 : -1.0;
  const double lane_half = sc.ego_half + sc.margin;
  const double max_y = std::min(sc.road_half + sc.sidewalk, lane_half + 3.5);
  const double speed = d.uniform(1.2, std::min(2.5, sc.max_speed(cls)));
  const double heading = -sign * d.uniform(80.0, 100.0);
  const double h = heading * kPi / 180.0;
  const double y0 = sign * std::min(max_y, d.uniform(lane_half + 1.0, lane_half + 3.0));
  const double lat_half = (size.length * std::abs(std::sin(h)) + size.width * std::abs(std::cos(h))) / 2.0;
  const double long_half = (size.length * std::abs(std::cos(h)) + size.width * std::abs(std::sin(h))) / 2.0;
  const double t_in = (std::abs(y0) - (lane_half + lat_half)) / (speed * std::abs(std::sin(h)));
  const double closing = sc.ego_speed - speed * std::cos(h);
  if (closing < 0.5) return {{}, "the ego is too slow for a crossing pedestrian to matter"};
  const double ttc = aim * sc.target;
  const double x0 = start_distance(sc, long_half, closing, t_in, ttc);
  if (x0 < kMinDistance || x0 > kMaxDistance) return {{}, "no start distance within [4, 120] m"};
  if (t_in + ttc > sc.horizon) return {{}, "the crossing takes longer than the horizon"};
  if (std::string p = visibility_problem(sc, x0, y0); !p.empty()) return {{}, p};
  if (std::string p = overlap_problem(sc, x0, y0, size); !p.empty()) return {{}, p};
  const std::string from = left ? "left" : "right";
  Json spec = base_spec("pedestrian_crossing", cls, x0, y0, from, speed, heading,
                        std::string("crossing from ") + from + " to " + (left ? "right" : "left"), sc.target);
  spec["extra"]["crossing_from"] = from;
  spec["rationale"] = "The scene has sidewalks, so a pedestrian stepping off the " + from + " curb " + fmt(x0) +
                      " m ahead at " + fmt(speed) + " m/s is realistic; with the ego at " + fmt(sc.ego_speed) +
                      " m/s they enter its path about " + fmt(t_in) + " s later with a TTC near " + fmt(ttc) + " s.";
  return {spec, {}};
}

Plan plan_cut_in(const Scene& sc, Draw& d, double aim) {
  if (!sc.multi_lane) return {{}, "the road has a single lane"};
  static const char* kClasses[] = {"car", "car", "car", "truck", "motorcycle"};
  const std::string cls = kClasses[d.index(5)];
  if (!sc.limits.count(cls)) return {{}, "the limits table has no '" + cls + "'"};
  if (kLaneWidth > sc.road_half) return {{}, "the road is too narrow for an adjacent lane"};
  const Size size = sc.size(cls);
  const bool left = d.coin();
  const double sign = left ? 1.0 : -1.0;
  const double y0 = sign * kLaneWidth;
  const double heading = -sign * d.uniform(6.0, 14.0);
  const double h = heading * kPi / 180.0;
  const double speed = std::clamp(sc.ego_speed - d.uniform(2.0, 5.0), 2.0, sc.max_speed(cls));
  const double closing = sc.ego_speed - speed * std::cos(h);
  if (closing < 0.5) return {{}, "the ego is too slow to close in on a cut-in"};
  const double lane_half = sc.ego_half + sc.margin;
  const double lat_half = (size.length * std::abs(std::sin(h)) + size.width * std::abs(std::cos(h))) / 2.0;
  const double long_half = (size.length * std::abs(std::cos(h)) + size.width * std::abs(std::sin(h))) / 2.0;
  const double t_in = std::max(0.0, (std::abs(y0) - (lane_half + lat_half)) / (speed * std::abs(std::sin(h))));
  const double ttc = aim * sc.target;
  const double x0 = start_distance(sc, long_half, closing, t_in, ttc);
  if (x0 < kMinDistance || x0 > kMaxDistance) return {{}, "no start distance within [4, 120] m"};
  if (std::string p = visibility_problem(sc, x0, y0); !p.empty()) return {{}, p};
  if (std::string p = overlap_problem(sc, x0, y0, size); !p.empty()) return {{}, p};
  const std::string side = left ? "left" : "right";
  Json spec = base_spec("cut_in", cls, x0, y0, side, speed, heading,
                        "changes from the " + side + " lane into the ego lane", sc.target);
  spec["rationale"] = "On a multi-lane road a " + cls + " in the " + side + " lane, " + fmt(sc.ego_speed - speed) +
                      " m/s slower than the ego, cuts in " + fmt(x0) + " m ahead; it enters the ego lane after " +
                      fmt(t_in) + " s with a TTC near " + fmt(ttc) + " s.";
  return {spec, {}};
}

Plan plan_sudden_stop(const Scene& sc, Draw& d, double aim) {
  static const char* kClasses[] = {"car", "car", "car", "truck", "bus"};
  const std::string cls = kClasses[d.index(5)];
  if (!sc.limits.count(cls)) return {{}, "the limits table has no '" + cls + "'"};
  const Size size = sc.size(cls);
  const double speed = std::min(sc.ego_speed, sc.max_speed(cls));
  const double decel = d.uniform(0.6, 0.9) * sc.max_decel(cls);
  if (speed < kMinEgoSpeed || decel <= 0) return {{}, "a lead vehicle cannot brake from standstill"};
  // TTC = gap / closing reaches `ttc` at t_star while the lead vehicle is still braking.
  const double ttc = aim * sc.target;
  const double t_star = std::min(d.uniform(1.0, 2.5), 0.8 * speed / decel);
  const double gap = decel * t_star * t_star / 2.0 + decel * ttc * t_star;
  const double x0 = sc.ego_front + size.length / 2.0 + gap;
  const double y0 = d.uniform(-0.3, 0.3);
  if (x0 < kMinDistance || x0 > kMaxDistance) return {{}, "no start distance within [4, 120] m"};
  double lead = kInf;
  std::string lead_label;
  for (const Scene::Obj& o : sc.objects)
    if (o.in_path && o.x > 0 && o.x < lead) {
      lead = o.x;
      lead_label = o.label;
    }
  if (std::isfinite(lead) && x0 + size.length + 2.0 > lead)
    return {{}, "no room to insert a lead vehicle before the " + lead_label + " at " + fmt(lead) + " m"};
  if (std::string p = visibility_problem(sc, x0, y0); !p.empty()) return {{}, p};
  if (std::string p = overlap_problem(sc, x0, y0, size); !p.empty()) return {{}, p};
  Json spec = base_spec("sudden_stop", cls, x0, y0, "center", speed, 0.0, "drives ahead in the ego lane, then brakes hard",
                        sc.target);
  spec["deceleration_mps2"] = round_to(decel, 0.1);
  spec["rationale"] = "A " + cls + " driving " + fmt(gap) + " m ahead of the ego at the same " + fmt(speed) +
                      " m/s brakes at " + fmt(decel) + " m/s^2" +
                      (std::isfinite(lead) ? " (traffic continues with the " + lead_label + " at " + fmt(lead) + " m)" : "") +
                      "; the TTC falls to about " + fmt(ttc) + " s after " + fmt(t_star) + " s.";
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
      ParamSpec::integer("candidates_per_kind", 12).range(1, 100).describe("draws tried per kind before giving up"),
  };
  return i;
}

void OfflinePlanner::open(const Params& p) {
  aim_ = p.get_double("aim");
  candidates_ = static_cast<int>(p.get_int("candidates_per_kind"));
}

std::string OfflinePlanner::describe_backend() const { return "offline planner"; }

LlmReply OfflinePlanner::complete(const LlmRequest& request) {
  auto t0 = std::chrono::steady_clock::now();
  const Scene sc = read_scene(request.scene);
  const auto previous = std::count_if(request.messages.begin(), request.messages.end(),
                                      [](const LlmMessage& m) { return m.role == "assistant"; });
  Draw draw(static_cast<uint64_t>(request.seed) * 0x9E3779B97F4A7C15ULL + static_cast<uint64_t>(previous));

  using Planner = Plan (*)(const Scene&, Draw&, double);
  const std::vector<std::pair<std::string, Planner>> known = {
      {"pedestrian_crossing", &plan_pedestrian}, {"cut_in", &plan_cut_in}, {"sudden_stop", &plan_sudden_stop}};

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
