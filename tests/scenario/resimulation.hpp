// Re-simulation of an exported .xosc/.xodr from the XML alone, with a lane-keeping constant-speed ego.
#pragma once

#include <gtest/gtest.h>
#include <libxml/parser.h>
#include <libxml/tree.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <filesystem>
#include <map>
#include <memory>
#include <numbers>
#include <optional>
#include <string>
#include <vector>

#include "hazardforge/angles.hpp"
#include "hazardforge/types.hpp"

namespace hf::resim {

namespace fs = std::filesystem;

// ---- XML access
// ----------------------------------------------------------------------------------------------

using Doc = std::unique_ptr<xmlDoc, decltype(&xmlFreeDoc)>;

inline Doc parse(const fs::path& file) {
  return Doc(xmlReadFile(file.c_str(), nullptr, XML_PARSE_NONET), &xmlFreeDoc);
}

inline std::string attr(xmlNode* n, const char* name) {
  xmlChar* v = xmlGetProp(n, reinterpret_cast<const xmlChar*>(name));
  if (!v) return {};
  std::string s(reinterpret_cast<const char*>(v));
  xmlFree(v);
  return s;
}

inline bool is(xmlNode* n, const char* name) {
  return n && n->type == XML_ELEMENT_NODE && xmlStrcmp(n->name, reinterpret_cast<const xmlChar*>(name)) == 0;
}

inline std::vector<xmlNode*> children(xmlNode* n, const char* name = nullptr) {
  std::vector<xmlNode*> out;
  for (xmlNode* c = n ? n->children : nullptr; c; c = c->next)
    if (c->type == XML_ELEMENT_NODE && (!name || is(c, name))) out.push_back(c);
  return out;
}

inline xmlNode* child(xmlNode* n, const char* name) {
  auto c = children(n, name);
  return c.empty() ? nullptr : c.front();
}

// Every descendant with this name, in document order.
inline void find_all(xmlNode* n, const char* name, std::vector<xmlNode*>& out) {
  for (xmlNode* c = n ? n->children : nullptr; c; c = c->next) {
    if (is(c, name)) out.push_back(c);
    find_all(c, name, out);
  }
}
inline xmlNode* find(xmlNode* n, const char* name) {
  std::vector<xmlNode*> all;
  find_all(n, name, all);
  return all.empty() ? nullptr : all.front();
}

// ---- The road (OpenDRIVE): planView pieces, lane offset and widths
// -------------------------------------------

struct Road {
  struct Piece {
    double s = 0, x = 0, y = 0, hdg = 0, length = 0;
    std::string type;  // line | arc | paramPoly3
    double curvature = 0;
    double au = 0, bu = 0, cu = 0, du = 0, av = 0, bv = 0, cv = 0, dv = 0;
    bool normalized = true;
    // paramPoly3: parameter at arc lengths 0, L/n, ... (own table).
    std::vector<double> p_at;
  };
  std::vector<Piece> pieces;
  double lane_offset = 0;
  std::map<int, double> widths;  // lane id -> width

  double length() const { return pieces.back().s + pieces.back().length; }

  // Pose on the reference line at s.
  void pose(double s, double& x, double& y, double& hdg) const {
    const Piece* pc = &pieces.front();
    for (const Piece& p : pieces)
      if (s >= p.s) pc = &p;
    const double ds = std::clamp(s - pc->s, 0.0, pc->length);
    if (pc->type == "line") {
      x = pc->x + ds * std::cos(pc->hdg), y = pc->y + ds * std::sin(pc->hdg), hdg = pc->hdg;
    } else if (pc->type == "arc") {
      const double k = pc->curvature;
      x = pc->x + (std::sin(pc->hdg + k * ds) - std::sin(pc->hdg)) / k;
      y = pc->y - (std::cos(pc->hdg + k * ds) - std::cos(pc->hdg)) / k;
      hdg = pc->hdg + k * ds;
    } else {
      const int n = static_cast<int>(pc->p_at.size()) - 1;
      const double f = ds / pc->length * n;
      const int i = std::clamp(static_cast<int>(f), 0, n - 1);
      const double p = pc->p_at[i] + (f - i) * (pc->p_at[i + 1] - pc->p_at[i]);
      const double u = pc->au + p * (pc->bu + p * (pc->cu + p * pc->du));
      const double v = pc->av + p * (pc->bv + p * (pc->cv + p * pc->dv));
      const double du = pc->bu + p * (2 * pc->cu + 3 * p * pc->du),
                   dv = pc->bv + p * (2 * pc->cv + 3 * p * pc->dv);
      x = pc->x + u * std::cos(pc->hdg) - v * std::sin(pc->hdg);
      y = pc->y + u * std::sin(pc->hdg) + v * std::cos(pc->hdg);
      hdg = pc->hdg + std::atan2(dv, du);
    }
  }
  void world(double s, double t, double& x, double& y, double& hdg) const {
    pose(s, x, y, hdg);
    x -= t * std::sin(hdg), y += t * std::cos(hdg);
  }
  // Lateral position of a lane's centre: lanes stack outwards from the centre line (lane 0) at lane_offset.
  double lane_centre(int id) const {
    const int dir = id > 0 ? 1 : -1;
    double t = lane_offset;
    for (int k = dir; k != id; k += dir) t += dir * widths.at(k);
    return t + dir * widths.at(id) / 2;
  }
  int lane_at(double t) const {
    for (const auto& [id, w] : widths) {
      const double c = lane_centre(id);
      if (std::abs(t - c) <= w / 2 + 1e-9) return id;
    }
    return 0;
  }
};

inline Road read_road(const fs::path& file) {
  Doc doc = parse(file);
  EXPECT_TRUE(doc) << file;
  Road road;
  xmlNode* root = xmlDocGetRootElement(doc.get());
  for (xmlNode* g : children(find(root, "planView"), "geometry")) {
    Road::Piece p;
    p.s = std::stod(attr(g, "s")), p.x = std::stod(attr(g, "x")), p.y = std::stod(attr(g, "y"));
    p.hdg = std::stod(attr(g, "hdg")), p.length = std::stod(attr(g, "length"));
    xmlNode* shape = children(g).front();
    p.type = reinterpret_cast<const char*>(shape->name);
    if (p.type == "arc") p.curvature = std::stod(attr(shape, "curvature"));
    if (p.type == "paramPoly3") {
      p.au = std::stod(attr(shape, "aU")), p.bu = std::stod(attr(shape, "bU"));
      p.cu = std::stod(attr(shape, "cU")), p.du = std::stod(attr(shape, "dU"));
      p.av = std::stod(attr(shape, "aV")), p.bv = std::stod(attr(shape, "bV"));
      p.cv = std::stod(attr(shape, "cV")), p.dv = std::stod(attr(shape, "dV"));
      EXPECT_EQ(attr(shape, "pRange"), "normalized");
      // Arc length along p by the trapezoid rule on 2000 steps, inverted into a table of p per length step.
      const int n = 2000;
      std::vector<double> len(n + 1, 0.0);
      auto speed = [&](double q) {
        return std::hypot(p.bu + q * (2 * p.cu + 3 * q * p.du), p.bv + q * (2 * p.cv + 3 * q * p.dv));
      };
      for (int k = 1; k <= n; ++k)
        len[k] = len[k - 1] + (speed((k - 1.0) / n) + speed(1.0 * k / n)) / (2.0 * n);
      EXPECT_NEAR(len[n], p.length, 0.01 + 1e-3 * p.length) << "piece at s=" << p.s;
      const int m = 400;
      for (int j = 0, k = 0; j <= m; ++j) {
        const double target = len[n] * j / m;
        while (k < n && len[k + 1] < target) ++k;
        const double f = len[k + 1] > len[k] ? (target - len[k]) / (len[k + 1] - len[k]) : 0.0;
        p.p_at.push_back(std::min(1.0, (k + f) / n));
      }
    }
    road.pieces.push_back(p);
  }
  xmlNode* lanes = find(root, "lanes");
  road.lane_offset = std::stod(attr(child(lanes, "laneOffset"), "a"));
  std::vector<xmlNode*> ls;
  find_all(lanes, "lane", ls);
  for (xmlNode* l : ls) {
    const int id = std::stoi(attr(l, "id"));
    if (id != 0) road.widths[id] = std::stod(attr(child(l, "width"), "a"));
  }
  return road;
}

// ---- The scenario (OpenSCENARIO): what the story says, with parameters resolved
// ------------------------------

struct Scenario {
  std::map<std::string, std::string> params;
  xmlNode* root = nullptr;
  std::string value(xmlNode* n, const char* name) const {
    std::string v = attr(n, name);
    if (!v.empty() && v[0] == '$') {
      auto it = params.find(v.substr(1));
      EXPECT_NE(it, params.end()) << "undeclared parameter " << v;
      return it == params.end() ? "0" : it->second;
    }
    return v;
  }
  double num(xmlNode* n, const char* name) const { return std::stod(value(n, name)); }
};

// One moving thing on the road: road coordinates, speed along the road.
struct Body {
  double s = 0, t = 0, v = 0;
  double length = 0, width = 0, centre_x = 0;  // bounding box centre ahead of the reference point
  double heading_rel = 0;                      // to the road
  double travelled = 0;
};

struct LaneChange {
  double t0 = 0, from = 0, to = 0, duration = 1;
};
struct SpeedChange {
  double target = 0, rate = 0;
  bool step = false;
  // Continuous relative target: the entity's speed plus delta, every step.
  const Body* relative_to = nullptr;
  double delta = 0;
};
struct Walk {
  std::vector<std::pair<double, double>> points;  // (s, t)
  size_t next = 1;
};

struct Result {
  bool triggered = false;
  double trigger_time = -1;
  double min_ttc = kInf;
  double min_ttc_time = -1;
  bool collided = false;
  double end_time = 0;
  std::vector<std::array<double, 3>> ego_xy;  // (time, x, y) every step
};

// The walk action's name, for its end condition (one walk per story).
inline std::string walk_action_name_;

// Steps the story at 100 Hz: Init, the hazard's events when their conditions (and delays) are met, the stop
// trigger; the ego keeps its lane at EgoSpeed x speed_factor.
inline Result resimulate(const fs::path& xosc, double speed_factor) {
  Doc doc = parse(xosc);
  Scenario sc;
  sc.root = xmlDocGetRootElement(doc.get());
  for (xmlNode* p : children(child(sc.root, "ParameterDeclarations"), "ParameterDeclaration"))
    sc.params[attr(p, "name")] = attr(p, "value");
  const std::string road_file = attr(find(child(sc.root, "RoadNetwork"), "LogicFile"), "filepath");
  const Road road = read_road(xosc.parent_path() / road_file);

  // Entities: sizes and reference points.
  std::map<std::string, Body> bodies;
  std::map<std::string, bool> pedestrian;
  for (xmlNode* o : children(child(sc.root, "Entities"), "ScenarioObject")) {
    Body b;
    xmlNode* box = find(o, "BoundingBox");
    b.length = sc.num(child(box, "Dimensions"), "length");
    b.width = sc.num(child(box, "Dimensions"), "width");
    b.centre_x = sc.num(child(box, "Center"), "x");
    bodies[attr(o, "name")] = b;
    pedestrian[attr(o, "name")] = find(o, "Pedestrian") != nullptr;
  }
  EXPECT_EQ(bodies.size(), 2u);
  const std::string ego_name = "Ego", haz_name = "Hazard";
  Body& ego = bodies[ego_name];
  Body& haz = bodies[haz_name];

  // Init.
  xmlNode* init = find(sc.root, "Init");
  int ego_lane = 0;
  for (xmlNode* priv : children(find(init, "Actions"), "Private")) {
    Body& b = bodies[attr(priv, "entityRef")];
    if (xmlNode* lp = find(priv, "LanePosition")) {
      ego_lane = std::stoi(sc.value(lp, "laneId"));
      b.s = sc.num(lp, "s");
      b.t = road.lane_centre(ego_lane) + sc.num(lp, "offset");
    }
    if (xmlNode* rp = find(priv, "RelativeLanePosition")) {
      const Body& ref = bodies[attr(rp, "entityRef")];
      int lane = road.lane_at(ref.t);
      // dLane counts lanes to the left, skipping the centre line.
      for (int k = std::stoi(sc.value(rp, "dLane")); k != 0; k += k > 0 ? -1 : 1) {
        lane += k > 0 ? 1 : -1;
        if (lane == 0) lane += k > 0 ? 1 : -1;
      }
      b.s = ref.s + sc.num(rp, "ds");
      b.t = road.lane_centre(lane) + sc.num(rp, "offset");
      if (xmlNode* o = child(rp, "Orientation")) b.heading_rel = sc.num(o, "h");
    }
    if (xmlNode* sp = find(priv, "AbsoluteTargetSpeed")) b.v = sc.num(sp, "value");
  }
  ego.v *= speed_factor;
  EXPECT_NE(ego_lane, 0);

  // The hazard's events and their triggers.
  struct Ev {
    xmlNode* node;
    bool started = false;
    double fire_at = kInf;  // condition met + delay
  };
  std::vector<Ev> events;
  for (xmlNode* mg : children(find(sc.root, "Act"), "ManeuverGroup"))
    if (attr(find(mg, "EntityRef"), "entityRef") == haz_name)
      for (xmlNode* e : [&] {
             std::vector<xmlNode*> v;
             find_all(mg, "Event", v);
             return v;
           }())
        events.push_back({e});
  EXPECT_FALSE(events.empty());

  // ego: replay — the ego's recorded path and speed, timed WorldPosition vertices from the first step after
  // Init; its road s comes from the nearest point of the road's reference line (sampled every 0.1 m here).
  std::vector<std::array<double, 3>> replay;  // (time, x, y)
  for (xmlNode* mg : children(find(sc.root, "Act"), "ManeuverGroup"))
    if (attr(find(mg, "EntityRef"), "entityRef") == ego_name) {
      std::vector<xmlNode*> vs;
      find_all(mg, "Vertex", vs);
      for (xmlNode* v : vs) {
        xmlNode* w = find(v, "WorldPosition");
        replay.push_back({sc.num(v, "time"), sc.num(w, "x"), sc.num(w, "y")});
      }
    }
  std::vector<std::array<double, 3>> line;  // (s, x, y)
  if (!replay.empty())
    for (double s = 0; s <= road.length(); s += 0.1) {
      double x, y, h;
      road.pose(s, x, y, h);
      line.push_back({s, x, y});
    }
  // Road s and speed of the replayed ego at `time`: the vertices interpolated linearly, projected on the
  // line.
  auto replayed = [&](double time, double& s, double& v) {
    size_t k = 0;
    while (k + 2 < replay.size() && replay[k + 1][0] < time) ++k;
    const auto& a = replay[k];
    const auto& b = replay[std::min(k + 1, replay.size() - 1)];
    const double span = b[0] - a[0];
    const double u = span > 0 ? std::clamp((time - a[0]) / span, 0.0, 1.0) : 0.0;
    const double x = a[1] + u * (b[1] - a[1]), y = a[2] + u * (b[2] - a[2]);
    v = span > 0 ? std::hypot(b[1] - a[1], b[2] - a[2]) / span : 0.0;
    size_t best = 0;
    double best_d = kInf;
    for (size_t i = 0; i < line.size(); ++i)
      if (const double d = std::hypot(line[i][1] - x, line[i][2] - y); d < best_d) best_d = d, best = i;
    const size_t j = std::min(best + 1, line.size() - 1), i0 = j == best ? best - 1 : best;
    const double dx = line[j][1] - line[i0][1], dy = line[j][2] - line[i0][2];
    const double along = ((x - line[i0][1]) * dx + (y - line[i0][2]) * dy) / (dx * dx + dy * dy);
    s = line[i0][0] + along * (line[j][0] - line[i0][0]);
  };

  std::optional<LaneChange> lane_change;
  std::optional<SpeedChange> speed_change;
  std::optional<Walk> walk;
  std::map<std::string, bool> ended;  // action name -> ended

  Result r;
  const double dt = 0.01;
  const double stop_time = std::stod(sc.params.at("StopTime"));
  // The other end of the story: the ego's travelled distance (StopTrigger).
  double stop_distance = kInf;
  {
    std::vector<xmlNode*> td;
    find_all(child(find(sc.root, "Storyboard"), "StopTrigger"), "TraveledDistanceCondition", td);
    for (xmlNode* n : td) stop_distance = std::min(stop_distance, sc.num(n, "value"));
  }
  double prev_gap_x = 0;
  bool have_prev = false;
  auto world_of = [&](const Body& b, double& x, double& y, double& h) {
    double hr;
    road.world(b.s, b.t, x, y, hr);
    h = hr + b.heading_rel;
  };
  for (double time = 0; time <= stop_time + 1e-9; time += dt) {
    // Conditions of events not yet started.
    for (Ev& ev : events) {
      if (ev.started || std::isfinite(ev.fire_at)) continue;
      xmlNode* cond = find(child(ev.node, "StartTrigger"), "Condition");
      const double delay = std::stod(attr(cond, "delay"));
      bool met = false;
      if (xmlNode* c = find(cond, "TimeToCollisionCondition")) {
        xmlNode* rp = find(c, "RoadPosition");
        const double dist = sc.num(rp, "s") - ego.s;
        met = ego.v > 0.1 && dist > 0 && dist / ego.v < sc.num(c, "value");
      } else if (xmlNode* c = find(cond, "RelativeDistanceCondition")) {
        const double dist = std::abs(haz.s - ego.s);
        met = attr(c, "rule") == "greaterThan" ? dist > sc.num(c, "value") : dist < sc.num(c, "value");
      } else if (xmlNode* c = find(cond, "TraveledDistanceCondition")) {
        met = ego.travelled >= sc.num(c, "value");
      } else if (xmlNode* c = find(cond, "StoryboardElementStateCondition")) {
        met = ended[attr(c, "storyboardElementRef")];
      } else if (xmlNode* c = find(cond, "SimulationTimeCondition")) {
        EXPECT_EQ(attr(c, "rule"), "greaterThan");
        met = time > sc.num(c, "value");
      } else {
        ADD_FAILURE() << "condition not understood by the re-simulation";
      }
      if (met) {
        ev.fire_at = time + delay;
        // Only the ego's conditions start the hazard.
        if (find(cond, "ByEntityCondition") && !r.triggered) r.triggered = true, r.trigger_time = time;
      }
    }
    // Start events whose time has come.
    for (Ev& ev : events) {
      if (ev.started || time + 1e-9 < ev.fire_at) continue;
      ev.started = true;
      for (xmlNode* a : children(ev.node, "Action")) {
        if (xmlNode* sa = find(a, "SpeedAction")) {
          xmlNode* dyn = child(sa, "SpeedActionDynamics");
          SpeedChange c;
          c.step = attr(dyn, "dynamicsShape") == "step";
          c.rate = sc.num(dyn, "value");
          if (xmlNode* abs = find(sa, "AbsoluteTargetSpeed")) c.target = sc.num(abs, "value");
          if (xmlNode* rel = find(sa, "RelativeTargetSpeed")) {
            EXPECT_EQ(attr(rel, "speedTargetValueType"), "delta");
            c.target = std::max(0.0, bodies[attr(rel, "entityRef")].v + sc.num(rel, "value"));
            if (attr(rel, "continuous") == "true")
              c.relative_to = &bodies[attr(rel, "entityRef")], c.delta = sc.num(rel, "value");
          }
          // A new speed action replaces the running one.
          speed_change.reset();
          if (c.step) haz.v = c.target;
          if (!c.step || c.relative_to) speed_change = c;
        }
        if (xmlNode* lc = find(a, "LaneChangeAction")) {
          xmlNode* rt = find(lc, "RelativeTargetLane");
          int lane = road.lane_at(bodies[attr(rt, "entityRef")].t) + std::stoi(sc.value(rt, "value"));
          LaneChange c;
          c.t0 = time, c.from = haz.t;
          c.to = road.lane_centre(lane) +
                 (attr(lc, "targetLaneOffset").empty() ? 0 : sc.num(lc, "targetLaneOffset"));
          c.duration = sc.num(child(lc, "LaneChangeActionDynamics"), "value");
          EXPECT_EQ(attr(child(lc, "LaneChangeActionDynamics"), "dynamicsShape"), "sinusoidal");
          lane_change = c;
        }
        if (xmlNode* ft = find(a, "FollowTrajectoryAction")) {
          Walk w;
          std::vector<xmlNode*> rps;
          find_all(ft, "RoadPosition", rps);
          for (xmlNode* rp : rps) w.points.emplace_back(sc.num(rp, "s"), sc.num(rp, "t"));
          walk = w;
          walk->next = 1;
          ended[attr(a, "name")] = false;
          walk_action_name_ = attr(a, "name");
        }
      }
    }

    if (ego.travelled > stop_distance) break;
    // Motion: the ego keeps its lane; the hazard follows its actions.
    if (replay.empty()) {
      ego.s += ego.v * dt;
      ego.travelled += ego.v * dt;
    } else {
      double s_new, v_new;
      replayed(time + dt, s_new, v_new);
      ego.v = v_new;
      ego.travelled += s_new - ego.s;
      ego.s = s_new;
    }
    if (speed_change && speed_change->relative_to) {
      haz.v = std::max(0.0, speed_change->relative_to->v + speed_change->delta);
    } else if (speed_change) {
      const double dv = speed_change->target - haz.v;
      haz.v += std::clamp(dv, -speed_change->rate * dt, speed_change->rate * dt);
    }
    double lateral_rate = 0;
    if (lane_change) {
      const double u = std::clamp((time + dt - lane_change->t0) / lane_change->duration, 0.0, 1.0);
      const double t_new =
          lane_change->from + (lane_change->to - lane_change->from) * (1 - std::cos(kPi * u)) / 2;
      lateral_rate = (t_new - haz.t) / dt;
      haz.t = t_new;
    }
    if (walk && walk->next < walk->points.size()) {
      const auto [ts, tt] = walk->points[walk->next];
      const double ds = ts - haz.s, dd = tt - haz.t, dist = std::hypot(ds, dd);
      const double step = haz.v * dt;
      if (dist <= step) {
        haz.s = ts, haz.t = tt;
        if (++walk->next == walk->points.size()) ended[walk_action_name_] = true;
      } else {
        haz.s += step * ds / dist, haz.t += step * dd / dist;
      }
    } else if (!pedestrian[haz_name]) {
      haz.s += haz.v * dt;
    }
    if (!pedestrian[haz_name]) haz.heading_rel = std::atan2(lateral_rate, std::max(haz.v, 0.1));

    // TTC by the protocol: hazard centre in the ego frame, in path, gap from the ego's front bumper.
    double ex, ey, eh, hx, hy, hh;
    world_of(ego, ex, ey, eh);
    world_of(haz, hx, hy, hh);
    r.ego_xy.push_back({time, ex, ey});
    hx += haz.centre_x * std::cos(hh), hy += haz.centre_x * std::sin(hh);
    const double c = std::cos(eh), sn = std::sin(eh);
    const double xr = c * (hx - ex) + sn * (hy - ey), yr = -sn * (hx - ex) + c * (hy - ey);
    const double ego_front = ego.centre_x + ego.length / 2;
    const double gap = xr - ego_front - haz.length / 2;
    if (have_prev) {
      const double closing = (prev_gap_x - gap) / dt;
      const bool in_path = xr > 0 && std::abs(yr) < 1.0 + 0.5 + haz.width / 2;
      if (in_path && closing > 0.1) {
        const double ttc = std::max(gap, 0.0) / closing;
        if (ttc < r.min_ttc) r.min_ttc = ttc, r.min_ttc_time = time;
      }
      if (in_path && gap <= 0 && std::abs(yr) < (ego.width + haz.width) / 2) {
        r.min_ttc = std::min(r.min_ttc, 0.0);
        r.collided = true;
        r.end_time = time;
        break;
      }
    }
    prev_gap_x = gap;
    have_prev = true;
    r.end_time = time;
  }
  return r;
}

}  // namespace hf::resim
