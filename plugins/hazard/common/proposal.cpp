// The scene a template's proposals are planned in, and the checks and JSON they share.
#include "hazardforge/hazard/proposal.hpp"
#include "hazardforge/number_text.hpp"

#include <algorithm>

#include <cmath>
#include <cstdio>

#include "hazardforge/error.hpp"

namespace hf::hazard {

double centre_x(const ObjectState& o, double distance_origin_x, const ClassPriors& sizes) {
  const double length = o.length_m > 0       ? o.length_m
                        : sizes.has(o.label) ? sizes.at(o.label).length
                                             : Footprint{}.length;
  return o.distance_m + distance_origin_x + length / 2.0;
}

Footprint ProposalScene::size(const std::string& cls) const {
  if (!sizes.has(cls)) throw Error("the class sizes have no '" + cls + "'");
  const ClassSize& s = sizes.at(cls);
  return {s.length, s.width};
}

bool ProposalScene::visible(double x, double y, double z) const {
  if (!camera) return true;
  auto px = camera->project_ego(cv::Vec3d(x, y, z));
  return px && px->x >= 0 && px->y >= 0 && px->x < camera->width && px->y < camera->height;
}

std::string ProposalScene::overlap_problem(double x, double y, const Footprint& me, int64_t except) const {
  for (const Obj& o : objects)
    if (o.track_id != except && std::abs(o.x - x) < (o.length + me.length) / 2.0 + 1.0 &&
        std::abs(o.y - y) < (o.width + me.width) / 2.0 + 0.5)
      return "start point (" + fixed_text(x, 1) + ", " + fixed_text(y, 1) + ") m is next to the detected " +
             o.label;
  return {};
}

double ProposalScene::first_seen_small_from(const std::string& cls) const {
  if (request.first_seen_max_height <= 0 || !camera || !sizes.has(cls)) return 0.0;
  const ClassSize& s = sizes.at(cls);
  const cv::Vec3d lwh(s.length, s.width, s.height);
  const double max_px = request.first_seen_max_height * camera->height;
  auto small = [&](double x) {
    const BoxView v = view_of(*camera, x, 0.0, 0.0, lwh);
    return v.in_front && v.box.height <= max_px;
  };
  double lo = camera->t_ego_cam[0] + s.length, hi = 400.0;
  if (!small(hi)) return hi;
  for (int i = 0; i < 50; ++i) {
    const double mid = (lo + hi) / 2;
    (small(mid) ? hi : lo) = mid;
  }
  return hi;
}

const ProposalScene::Obj* ProposalScene::in_path_before(double x, double margin) const {
  const Obj* nearest = nullptr;
  for (const Obj& o : objects)
    if (o.in_path && o.x > 0 && o.x - o.length / 2.0 < x + margin && (!nearest || o.x < nearest->x)) nearest = &o;
  return nearest;
}

std::vector<int> ProposalScene::edge_sides() const {
  std::vector<int> sides;
  const int kerb = -road.oncoming_side();
  for (const int side : {kerb, -kerb})
    if (road.lanes(side) == 0) sides.push_back(side);
  return sides;
}

int ProposalScene::draw_edge_side(RandomDraw& d) const {
  const std::vector<int> sides = edge_sides();
  if (sides.empty()) return 0;
  if (sides.size() == 1) return sides.front();
  return d.index(4) < 3 ? sides[0] : sides[1];
}

std::string ProposalScene::no_edge_side() const {
  return "the ego lane borders no road edge: there is a lane beside it on either side (lanes_left " +
         std::to_string(road.lanes_left) + ", lanes_right " + std::to_string(road.lanes_right) + ")";
}

double ProposalScene::time_ttc_falls_to(double gap0, double object_speed, double ttc, double horizon) const {
  for (double t = 0; t <= horizon; t += 0.02) {
    const double gap = gap0 + object_speed * t - ego_travel(0.0, t), closing = ego_speed_at(t) - object_speed;
    if (gap <= 0 || (closing > 0.1 && gap / closing <= ttc)) return t;
  }
  return kInf;
}

ProposalScene ProposalScene::of(const ProposalRequest& r, const TemplateBase& tpl) {
  ProposalScene sc(r, tpl.road_in(r.scene), tpl.limits(), tpl.class_sizes());
  const TtcConventions& ttc = tpl.ttc_conventions();
  sc.corridor.ego_half_width = ttc.corridor.ego_half_width;
  sc.corridor.margin = ttc.corridor.margin;
  sc.ego_front = ttc.ego_front;
  sc.ego_speed = r.scene.ego_speed_mps.value_or(0.0);
  sc.ego = tpl.planned_ego(r.scene);
  sc.target = r.target_ttc_s;
  sc.horizon = r.horizon_s;
  sc.sidewalk = r.sidewalk_width_m;
  sc.max_under_way = r.max_under_way_s;
  sc.sidewalks = r.sidewalks;
  sc.on_shoulder = r.pedestrians_on_shoulder;
  sc.multi_lane = r.multi_lane;
  sc.intersection = r.intersection;
  if (r.scene.camera.valid()) sc.camera = r.scene.camera;
  for (const ObjectState& o : r.scene.objects) {
    if (!std::isfinite(o.distance_m)) continue;
    const Footprint prior = sc.sizes.has(o.label) ? sc.size(o.label) : Footprint{};
    std::optional<double> speed;
    if (const auto v = ground_velocity(o, sc.ego_speed, 0.0)) speed = (*v)[0];  // the best estimate
    sc.objects.push_back({o.track_id, o.label, centre_x(o, r.scene.distance_origin_x, sc.sizes), o.lateral_m,
                          o.length_m > 0 ? o.length_m : prior.length, o.width_m > 0 ? o.width_m : prior.width,
                          o.in_path, speed});
  }
  return sc;
}

std::optional<std::string> draw_class(const ProposalScene& sc,
                                      const std::vector<std::pair<std::string, int>>& weighted, RandomDraw& d,
                                      std::string* why) {
  std::vector<std::string> pool;  // one entry per unit of weight
  std::string missing;
  for (const auto& [cls, weight] : weighted) {
    const char* lacks = !sc.limits.has(cls)              ? "no entry in the limits table"
                        : !sc.request.class_allowed(cls) ? "no appearance assets"
                                                         : nullptr;
    if (lacks) {
      missing += (missing.empty() ? "" : "; ") + ("'" + cls + "': " + lacks);
      continue;
    }
    for (int k = 0; k < weight; ++k) pool.push_back(cls);
  }
  if (pool.empty()) {
    if (why) *why = "no class it could be drawn as (" + missing + ")";
    return std::nullopt;
  }
  // One class left: nothing to draw (and no random bits taken from the plan's other choices).
  if (std::all_of(pool.begin(), pool.end(), [&](const std::string& c) { return c == pool.front(); }))
    return pool.front();
  return pool[d.index(pool.size())];
}

HazardProposal plan_some_class(const std::string& kind, const ProposalScene& sc,
                               std::vector<std::pair<std::string, int>> weighted, RandomDraw& d,
                               const std::function<HazardProposal(const std::string&)>& plan) {
  const NoPlan refused{kind};
  std::optional<HazardProposal> first;
  std::string others, why;
  while (true) {
    const std::optional<std::string> cls = draw_class(sc, weighted, d, &why);
    if (!cls) break;
    HazardProposal p = plan(*cls);
    if (!p.spec.is_null()) return p;
    if (!first) first = std::move(p);
    else others += (others.empty() ? "" : ", ") + *cls;
    std::erase_if(weighted, [&](const auto& w) { return w.first == *cls; });
    if (weighted.empty()) break;
  }
  if (!first) return refused(refusal::kObjectClass, why);  // no class could be drawn at all
  if (!others.empty()) first->problem.text += " (nor as a " + others + ")";
  return *first;
}

double round_to(double v, double step) {
  return std::round(v / step) * step;
}

Json proposal_spec(const std::string& kind, const std::string& cls, double x, double y,
                   const std::string& side, double speed, double heading, const std::string& motion,
                   double target) {
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
          {"extra", Json::object()},
          {"rationale", ""}};
}

}  // namespace hf::hazard
