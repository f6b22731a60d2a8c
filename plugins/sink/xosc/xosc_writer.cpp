// OpenSCENARIO 1.2 story and OpenDRIVE road for a planned hazard, and the hazard maneuver catalog.
#include "xosc_writer.hpp"

#include <algorithm>
#include <cmath>
#include <ctime>
#include <numbers>
#include <utility>
#include <vector>

#include "hazardforge/angles.hpp"
#include "hazardforge/number_text.hpp"
#include "hazardforge/road/reference_line.hpp"

namespace hf {

namespace {

using road::XmlAttrs;
using road::XmlWriter;

std::string d(double v, int decimals = 4) {
  return road::xml_num(v, decimals);
}

std::string now_utc() {
  const std::time_t t = std::time(nullptr);
  std::tm tm{};
  gmtime_r(&t, &tm);
  char buf[32];
  std::strftime(buf, sizeof buf, "%Y-%m-%dT%H:%M:%S", &tm);
  return buf;
}

struct EntityShape {
  bool pedestrian = false;
  std::string category;  // vehicleCategory / pedestrianCategory
  std::string model3d;   // esmini's model names, which other players map or ignore
  double wheelbase = 0;  // vehicles: rear axle (reference point) to front axle
};

EntityShape shape_for(const std::string& object_class, const cv::Vec3d& size) {
  EntityShape s;
  if (object_class == "person" || object_class == "pedestrian") {
    s.pedestrian = true;
    s.category = "pedestrian";
    s.model3d = "walkman.osgb";
    return s;
  }
  static const std::tuple<const char*, const char*, const char*> kVehicles[] = {
      {"car", "car", "car_red.osgb"},
      {"truck", "truck", "truck_yellow.osgb"},
      {"bus", "bus", "bus_blue.osgb"},
      {"van", "van", "van_red.osgb"},
      {"motorcycle", "motorbike", "motorcyclist.osgb"},
      {"bicycle", "bicycle", "cyclist.osgb"}};
  for (const auto& [cls, cat, model] : kVehicles)
    if (object_class == cls) s.category = cat, s.model3d = model;
  if (s.category.empty())
    throw Error("xosc: object_class '" + object_class + "' has no OpenSCENARIO entity type");
  s.wheelbase = 0.6 * size[0];
  return s;
}

// ---- The plan in road coordinates
// ---------------------------------------------------------------------------

// Minimum-jerk progress (the templates' lane-change shape) and its inverse on [0, 1].
double min_jerk(double x) {
  return x * x * x * (10 - 15 * x + 6 * x * x);
}
double min_jerk_inverse(double u) {
  double lo = 0, hi = 1;
  for (int i = 0; i < 60; ++i) {
    const double mid = (lo + hi) / 2;
    (min_jerk(mid) < u ? lo : hi) = mid;
  }
  return (lo + hi) / 2;
}

struct RoadSample {
  double t = 0;  // stream time
  double s = 0;  // along the reference line (the ego lane's centre)
  double d = 0;  // to its left
  double v = 0;  // speed
  double a = 0;  // acceleration
};

// What the story needs from the plan.
struct Manoeuvre {
  bool pedestrian = false;
  // Lateral: vehicles change lane from d_from to d_to over lane_change_time starting at t_lateral;
  // pedestrians walk from d_from to d_to at speed.
  bool lateral = false;
  double d_from = 0, d_to = 0, t_lateral = 0, lane_change_time = 0;
  // Longitudinal (vehicles): cruise at speed until t_speed, then change to end_speed at `rate`.
  bool speed_change = false;
  double speed = 0, end_speed = 0, rate = 0, t_speed = 0;
  double t_start = 0;  // the earliest of the above: what the ego triggers
  double s_ped = 0;    // pedestrians: where they cross
};

class Plan {
 public:
  Plan(const HazardTrajectory& traj, const XoscOptions& opt, const EntityShape& shape)
      : traj_(traj), opt_(opt), shape_(shape) {
    const cv::Matx44d T = opt.T_world_anchor.value_or(cv::Matx44d::eye());
    yaw_ = std::atan2(T(1, 0), T(0, 0));
    tx_ = T(0, 3), ty_ = T(1, 3);
  }

  // The ego's planned pose at stream time t (anchor frame).
  TrajectoryPoint ego_at(double t) const {
    if (opt_.ego_path) {
      TrajectoryPoint p = opt_.ego_path->at(t - traj_.anchor_time);
      p.t = t;
      return p;
    }
    const auto& e = traj_.ego;
    if (t <= e.front().t || t >= e.back().t) {
      TrajectoryPoint p = t <= e.front().t ? e.front() : e.back();
      const double dt = t - p.t;
      p.x += p.speed * dt * std::cos(p.heading);
      p.y += p.speed * dt * std::sin(p.heading);
      p.t = t;
      p.accel = 0;
      return p;
    }
    const auto it =
        std::upper_bound(e.begin(), e.end(), t, [](double v, const TrajectoryPoint& q) { return v < q.t; });
    const TrajectoryPoint& b = *it;
    const TrajectoryPoint& a = *(it - 1);
    const double u = (t - a.t) / (b.t - a.t);
    TrajectoryPoint p = a;
    p.t = t;
    p.x += u * (b.x - a.x), p.y += u * (b.y - a.y);
    p.heading += u * angle_diff(b.heading, a.heading);
    p.speed += u * (b.speed - a.speed);
    return p;
  }

  road::PathPoint world(double x, double y) const {
    const double c = std::cos(yaw_), s = std::sin(yaw_);
    return {tx_ + c * x - s * y, ty_ + s * x + c * y};
  }
  double world_heading(double h) const { return wrap_angle(h + yaw_); }

  // Fits the road to the ego's path over [t0, t1] (stream time), continued straight beyond both ends so that
  // a slower or faster ego, and the hazard before its start, still find road.
  void fit_road(double t0, double t1) {
    std::vector<road::PathPoint> pts;
    auto add = [&](const road::PathPoint& p) {
      // Points closer than this add only pose noise, and a standing ego would add nothing else.
      if (pts.empty() || std::hypot(p.x - pts.back().x, p.y - pts.back().y) >= 0.25) pts.push_back(p);
    };
    const TrajectoryPoint first = ego_at(t0), last = ego_at(t1);
    const double back = 40, ahead = std::max(120.0, 3 * last.speed * (opt_.after_s + opt_.lead_in_s));
    for (double k = back; k > 0; k -= 1.0)
      add(world(first.x - k * std::cos(first.heading), first.y - k * std::sin(first.heading)));
    for (double t = t0; t <= t1 + 1e-9; t += 0.05) {
      const TrajectoryPoint p = ego_at(t);
      add(world(p.x, p.y));
    }
    for (double k = 1.0; k <= ahead; k += 1.0)
      add(world(last.x + k * std::cos(last.heading), last.y + k * std::sin(last.heading)));
    if (pts.size() < 2) throw Error("xosc: the ego's path is too short to lay a road along it");
    line_ = road::ReferenceLine::fit(pts);
  }
  const road::ReferenceLine& line() const { return line_; }

  // Road coordinates of an anchor-frame point.
  road::PathPoint st(double x, double y) const {
    const road::PathPoint w = world(x, y);
    return line_.to_st(w.x, w.y);
  }
  double ego_s(double t) const {
    const TrajectoryPoint p = ego_at(t);
    return st(p.x, p.y).x;
  }

  // The hazard's reference point (vehicles: rear axle; pedestrians: centre) in road coordinates.
  std::vector<RoadSample> hazard_road() const {
    std::vector<RoadSample> out;
    const double back = shape_.pedestrian ? 0.0 : shape_.wheelbase / 2;
    for (const TrajectoryPoint& p : traj_.points) {
      const road::PathPoint q = st(p.x - back * std::cos(p.heading), p.y - back * std::sin(p.heading));
      out.push_back({p.t, q.x, q.y, p.speed, p.accel});
    }
    return out;
  }

 private:
  const HazardTrajectory& traj_;
  const XoscOptions& opt_;
  const EntityShape& shape_;
  double yaw_ = 0, tx_ = 0, ty_ = 0;
  road::ReferenceLine line_;
};

// Recovers the manoeuvre from the plan's samples in road coordinates. A hazard already under way when the
// plan starts had begun its manoeuvre earlier: its start is extrapolated back along the manoeuvre's shape.
Manoeuvre recover(const std::vector<RoadSample>& h, const HazardTrajectory& traj, const XoscOptions& opt,
                  bool pedestrian) {
  Manoeuvre m;
  m.pedestrian = pedestrian;
  const size_t n = h.size();
  const double t0 = h.front().t;
  auto lateral_rate = [&](size_t k) {
    const size_t a = k == 0 ? 0 : k - 1, b = std::min(n - 1, k + 1);
    return (h[b].d - h[a].d) / (h[b].t - h[a].t);
  };
  const std::vector<road::LaneLayout::Lane> lanes = opt.lanes.lanes();
  if (pedestrian) {
    m.lateral = true;
    m.s_ped = h.front().s;
    double vmax = 0;
    for (const auto& p : h) vmax = std::max(vmax, p.v);
    m.speed = traj.spec.speed_mps > 0 ? traj.spec.speed_mps : std::max(vmax, 0.5);
    const double d_end = h.back().d;
    const int from = (h.front().d - d_end) >= 0 ? 1 : -1;  // the side it comes from (+1 left)
    // The road edge on that side: the outer border of its outermost driving lane.
    double edge = opt.lanes.lane_width / 2;
    for (const auto& l : lanes)
      if (l.type == "driving" && (l.t_outer - l.t_inner) * from > 0)
        edge = std::max(edge, std::abs(l.t_outer));
    const double rate0 = std::abs(lateral_rate(0));
    if (rate0 > 0.05) {
      m.d_from = from * (edge + opt.kerb_offset);
      m.t_lateral = t0 - std::abs(h.front().d - m.d_from) / rate0;
    } else {
      m.d_from = h.front().d;
      m.t_lateral = h.back().t;
      for (const auto& p : h)
        if (std::abs(p.d - m.d_from) > 0.02) {
          m.t_lateral = p.t - 0.02 / m.speed;
          break;
        }
    }
    if (h.back().v < 0.05) {
      m.d_to = d_end;  // stops in the lane
    } else {
      double far = opt.lanes.lane_width / 2;
      for (const auto& l : lanes)
        if (l.type == "driving" && (l.t_outer - l.t_inner) * from < 0)
          far = std::max(far, std::abs(l.t_outer));
      m.d_to = -from * (far + opt.kerb_offset);
    }
    m.t_start = m.t_lateral;
    return m;
  }

  // Lateral: a lane change when the plan ends in another lane than it started, or than the spec started it in
  // (a hazard that appears near the end of its lane change; the spec's offset is in road coordinates).
  const double d0 = h.front().d, d1 = h.back().d;
  const double spec_d = traj.spec.lateral_offset_m;
  const bool from_spec = std::abs(d1 - d0) <= 0.5 && std::abs(spec_d) > 0.01 && std::abs(spec_d - d1) > 0.5;
  if (std::abs(d1 - d0) > 0.5 || from_spec) {
    const double origin = from_spec ? spec_d : d0;
    m.lateral = true;
    m.d_to = d1;
    m.d_from = origin;
    double best = kInf;
    for (const auto& l : lanes) {
      const double c = l.centre();
      if (l.type == "driving" && (c - d1) * (origin - d1) > 0 &&
          std::abs(c - d1) >= std::abs(d0 - d1) - 0.1 && std::abs(c - origin) < best)
        best = std::abs(c - origin), m.d_from = c;
    }
    const double span = m.d_to - m.d_from;
    double peak = 0;
    for (size_t k = 0; k < n; ++k) peak = std::max(peak, std::abs(lateral_rate(k)));
    const double u0 = std::clamp((d0 - m.d_from) / span, 0.0, 1.0);
    double D = peak > 1e-3 ? 1.875 * std::abs(span) / peak : 3.0;
    if (u0 < 0.02) {
      // Not begun yet: centre the min-jerk shape on the plan's mid-crossing.
      double t_mid = -1;
      for (size_t k = 1; k < n; ++k) {
        const double ua = (h[k - 1].d - m.d_from) / span, ub = (h[k].d - m.d_from) / span;
        if (ua < 0.5 && ub >= 0.5) {
          t_mid = h[k - 1].t + (0.5 - ua) / (ub - ua) * (h[k].t - h[k - 1].t);
          break;
        }
      }
      if (t_mid < 0) t_mid = h.back().t;
      m.t_lateral = t_mid - D / 2;
    } else {
      const double x0 = min_jerk_inverse(u0);
      const double rate0 = std::abs(lateral_rate(0));
      if (rate0 > 0.05 && x0 > 0.02 && x0 < 0.98)
        D = std::abs(span) * 30 * x0 * x0 * (1 - x0) * (1 - x0) / rate0;
      m.t_lateral = t0 - x0 * D;
    }
    m.lane_change_time = std::clamp(D, 0.5, 15.0);
  }

  // Longitudinal: cruise, then one speed change (braking, mostly) to the speed the plan ends with, or to a
  // stop when the plan ends still braking.
  m.speed = traj.spec.speed_mps > 0 ? traj.spec.speed_mps : h.front().v;
  m.end_speed = h.back().a < -0.5 ? 0.0 : h.back().v;
  if (std::abs(m.speed - m.end_speed) > 0.3) {
    m.speed_change = true;
    const double dir = m.end_speed < m.speed ? -1.0 : 1.0;
    double rate = traj.spec.deceleration_mps2.value_or(0.0);
    if (rate <= 0) {
      // Mean rate over the plan's change.
      double t_a = -1, t_b = -1;
      for (const auto& p : h) {
        if (t_a < 0 && (p.v - m.speed) * dir > 0.2) t_a = p.t;
        if (t_a >= 0 && std::abs(p.v - h.back().v) < 0.2) {
          t_b = p.t;
          break;
        }
      }
      rate = (t_a >= 0 && t_b > t_a) ? std::abs(h.back().v - h.front().v) / (t_b - t_a) : 3.0;
      rate = std::max(rate, 0.5);
    }
    m.rate = rate;
    if ((h.front().v - m.speed) * dir > 0.2) {
      m.t_speed = t0 - std::abs(m.speed - h.front().v) / rate;
    } else {
      m.t_speed = h.back().t;
      for (const auto& p : h)
        if ((p.v - m.speed) * dir > 0.2) {
          m.t_speed = p.t - 0.2 / rate;
          break;
        }
    }
  }
  m.t_start = t0;
  if (m.lateral || m.speed_change)
    m.t_start = std::min(m.lateral ? m.t_lateral : kInf, m.speed_change ? m.t_speed : kInf);
  return m;
}

// The hazard's road s at stream time t: the plan's samples, and before them the recovered cruise and speed
// change run backwards.
double hazard_s(const std::vector<RoadSample>& h, const Manoeuvre& m, double t) {
  if (t >= h.front().t) {
    if (t >= h.back().t) return h.back().s + h.back().v * (t - h.back().t);
    const auto it =
        std::upper_bound(h.begin(), h.end(), t, [](double v, const RoadSample& q) { return v < q.t; });
    const double u = (t - (it - 1)->t) / (it->t - (it - 1)->t);
    return (it - 1)->s + u * (it->s - (it - 1)->s);
  }
  if (m.pedestrian) return h.front().s;
  auto v_at = [&](double tau) {
    if (!m.speed_change || tau < m.t_speed) return m.speed;
    const double dir = m.end_speed < m.speed ? -1.0 : 1.0;
    const double v = m.speed + dir * m.rate * (tau - m.t_speed);
    return dir < 0 ? std::max(v, m.end_speed) : std::min(v, m.end_speed);
  };
  double s = h.front().s;
  const double step = 0.01;
  for (double tau = h.front().t; tau > t + 1e-12; tau -= step) {
    const double dt = std::min(step, tau - t);
    s -= v_at(tau - dt / 2) * dt;
  }
  return s;
}

// Lanes are counted to the left, skipping the centre line (lane 0).
int lanes_between(int from, int to) {
  int n = to - from;
  if (from < 0 && to > 0) n -= 1;
  if (from > 0 && to < 0) n += 1;
  return n;
}

// ---- XML pieces
// ----------------------------------------------------------------------------------------------

void vehicle(XmlWriter& x, const std::string& name, const std::string& category, const std::string& model3d,
             const cv::Vec3d& size, double bbox_center_x, double wheelbase, const KinematicLimits& lim,
             const std::vector<std::pair<std::string, std::string>>& properties) {
  x.open("Vehicle", {{"name", name}, {"vehicleCategory", category}, {"model3d", model3d}});
  x.open("BoundingBox");
  x.empty("Center", {{"x", d(bbox_center_x)}, {"y", "0"}, {"z", d(size[2] / 2)}});
  x.empty("Dimensions", {{"width", d(size[1])}, {"length", d(size[0])}, {"height", d(size[2])}});
  x.close();
  x.empty("Performance", {{"maxSpeed", d(lim.max_speed_mps)},
                          {"maxAcceleration", d(lim.max_accel_mps2)},
                          {"maxDeceleration", d(lim.max_decel_mps2)},
                          {"maxAccelerationRate", d(lim.max_jerk_mps3)},
                          {"maxDecelerationRate", d(lim.max_jerk_mps3)}});
  const double wheel = category == "truck" || category == "bus" ? 1.0 : category == "bicycle" ? 0.7 : 0.65;
  const double track = std::max(0.1, size[1] - 0.25);
  x.open("Axles");
  x.empty("FrontAxle", {{"maxSteering", "0.5"},
                        {"wheelDiameter", d(wheel)},
                        {"trackWidth", d(track)},
                        {"positionX", d(wheelbase)},
                        {"positionZ", d(wheel / 2)}});
  x.empty("RearAxle", {{"maxSteering", "0"},
                       {"wheelDiameter", d(wheel)},
                       {"trackWidth", d(track)},
                       {"positionX", "0"},
                       {"positionZ", d(wheel / 2)}});
  x.close();
  x.open("Properties");
  for (const auto& [k, v] : properties) x.empty("Property", {{"name", k}, {"value", v}});
  x.close();
  x.close();
}

void condition_open(XmlWriter& x, const std::string& name, const std::string& delay,
                    const std::string& edge) {
  x.open("Condition", {{"name", name}, {"delay", delay}, {"conditionEdge", edge}});
}

void sim_time_condition(XmlWriter& x, const std::string& name, const std::string& value,
                        const std::string& rule) {
  condition_open(x, name, "0", rule == "greaterOrEqual" ? "none" : "rising");
  x.open("ByValueCondition");
  x.empty("SimulationTimeCondition", {{"value", value}, {"rule", rule}});
  x.close();
  x.close();
}

void sim_time_trigger(XmlWriter& x, const std::string& tag, const std::string& name, const std::string& value,
                      const std::string& rule) {
  x.open(tag);
  x.open("ConditionGroup");
  sim_time_condition(x, name, value, rule);
  x.close();
  x.close();
}

// How the ego starts the hazard's manoeuvre; `ego`/`hazard` may be parameter references (catalog).
struct EgoTrigger {
  std::string kind;  // TimeToCollisionCondition | RelativeDistanceCondition | TraveledDistanceCondition
  std::string rule = "lessThan";
  // TimeToCollisionCondition: the conflict point (road 1, s, t).
  double s = 0, t = 0;
};

void ego_condition(XmlWriter& x, const EgoTrigger& tr, const std::string& name, double delay,
                   const std::string& ego, const std::string& hazard, bool catalog) {
  condition_open(x, name, d(std::max(0.0, delay), 3), "rising");
  x.open("ByEntityCondition");
  x.open("TriggeringEntities", {{"triggeringEntitiesRule", "any"}});
  x.empty("EntityRef", {{"entityRef", ego}});
  x.close();
  x.open("EntityCondition");
  if (tr.kind == "TimeToCollisionCondition") {
    x.open("TimeToCollisionCondition", {{"freespace", "false"},
                                        {"rule", "lessThan"},
                                        {"value", "$TriggerValue"},
                                        {"relativeDistanceType", "longitudinal"},
                                        {"coordinateSystem", "road"}});
    x.open("TimeToCollisionConditionTarget");
    x.open("Position");
    if (catalog)
      // The crossing point: where the walker is, on the ego's lane centre.
      x.empty("RelativeRoadPosition", {{"entityRef", hazard}, {"ds", "0"}, {"dt", "$CrossingOffset"}});
    else
      x.empty("RoadPosition", {{"roadId", "1"}, {"s", d(tr.s, 3)}, {"t", d(tr.t, 3)}});
    x.close();
    x.close();
    x.close();
  } else if (tr.kind == "RelativeDistanceCondition") {
    x.empty("RelativeDistanceCondition", {{"entityRef", hazard},
                                          {"freespace", "false"},
                                          {"relativeDistanceType", "longitudinal"},
                                          {"coordinateSystem", "road"},
                                          {"rule", tr.rule},
                                          {"value", "$TriggerValue"}});
  } else {
    x.empty("TraveledDistanceCondition", {{"value", "$TriggerValue"}});
  }
  x.close();  // EntityCondition
  x.close();  // ByEntityCondition
  x.close();  // Condition
}

void start_trigger(XmlWriter& x, const EgoTrigger& tr, const std::string& name, double delay,
                   const std::string& ego, const std::string& hazard, bool catalog) {
  x.open("StartTrigger");
  x.open("ConditionGroup");
  ego_condition(x, tr, name, delay, ego, hazard, catalog);
  x.close();
  x.close();
}

void speed_action(XmlWriter& x, const std::string& name, const std::string& shape,
                  const std::string& dimension, const std::string& dyn_value, const std::string& target) {
  x.open("Action", {{"name", name}});
  x.open("PrivateAction");
  x.open("LongitudinalAction");
  x.open("SpeedAction");
  x.empty("SpeedActionDynamics",
          {{"dynamicsShape", shape}, {"value", dyn_value}, {"dynamicsDimension", dimension}});
  x.open("SpeedActionTarget");
  x.empty("AbsoluteTargetSpeed", {{"value", target}});
  x.close();
  x.close();
  x.close();
  x.close();
  x.close();
}

// The hazard's events, shared by the scenario (numbers) and the catalog (parameters only).
struct HazardEvents {
  bool pedestrian = false, lateral = false, speed_change = false;
  bool relative_end_speed = false;   // the end speed is the ego's plus HazardEndSpeedDelta
  bool hold_relative_speed = false;  // before the manoeuvre: the ego's speed plus HazardRelativeSpeed
  double lane_change_delay = 0, speed_delay = 0;  // after the trigger
  EgoTrigger trigger;
  // Pedestrian walk (scenario): from (s, t_from) to (s, t_to).
  double s_ped = 0, t_from = 0, t_to = 0;
};

void hazard_events(XmlWriter& x, const HazardEvents& ev, const std::string& ego, const std::string& hazard,
                   bool catalog) {
  const std::string trig_name = "EgoStartsHazard";
  if (ev.pedestrian) {
    x.open("Event", {{"name", "HazardWalks"}, {"priority", "override"}, {"maximumExecutionCount", "1"}});
    speed_action(x, "HazardWalkSpeed", "step", "time", "0", "$HazardSpeed");
    x.open("Action", {{"name", "HazardWalkAction"}});
    x.open("PrivateAction");
    x.open("RoutingAction");
    x.open("FollowTrajectoryAction");
    x.open("TrajectoryRef");
    x.open("Trajectory", {{"name", "HazardWalkPath"}, {"closed", "false"}});
    x.open("Shape");
    x.open("Polyline");
    for (int k = 0; k < 2; ++k) {
      x.open("Vertex");
      x.open("Position");
      if (catalog)
        x.empty("RelativeRoadPosition",
                {{"entityRef", hazard}, {"ds", "0"}, {"dt", k == 0 ? "0" : "$WalkDistance"}});
      else
        x.empty("RoadPosition",
                {{"roadId", "1"}, {"s", d(ev.s_ped, 3)}, {"t", d(k == 0 ? ev.t_from : ev.t_to, 3)}});
      x.close();
      x.close();
    }
    x.close();  // Polyline
    x.close();  // Shape
    x.close();  // Trajectory
    x.close();  // TrajectoryRef
    x.open("TimeReference");
    x.empty("None");
    x.close();
    x.empty("TrajectoryFollowingMode", {{"followingMode", "follow"}});
    x.close();  // FollowTrajectoryAction
    x.close();  // RoutingAction
    x.close();  // PrivateAction
    x.close();  // Action
    start_trigger(x, ev.trigger, trig_name, 0, ego, hazard, catalog);
    x.close();  // Event

    x.open("Event", {{"name", "HazardStops"}, {"priority", "parallel"}, {"maximumExecutionCount", "1"}});
    speed_action(x, "HazardStopAction", "step", "time", "0", "0");
    x.open("StartTrigger");
    x.open("ConditionGroup");
    condition_open(x, "WalkEnded", "0", "rising");
    x.open("ByValueCondition");
    x.empty("StoryboardElementStateCondition", {{"storyboardElementType", "action"},
                                                {"storyboardElementRef", "HazardWalkAction"},
                                                {"state", "endTransition"}});
    x.close();
    x.close();
    x.close();
    x.close();
    x.close();  // Event
    return;
  }
  if (ev.hold_relative_speed) {
    // Until its manoeuvre the vehicle keeps its speed relative to the ego, so it overtakes (or leads) any ego
    // as planned; the manoeuvre's speed action replaces this one.
    x.open("Event",
           {{"name", "HazardHoldsRelativeSpeed"}, {"priority", "parallel"}, {"maximumExecutionCount", "1"}});
    x.open("Action", {{"name", "HazardRelativeSpeedAction"}});
    x.open("PrivateAction");
    x.open("LongitudinalAction");
    x.open("SpeedAction");
    x.empty("SpeedActionDynamics",
            {{"dynamicsShape", "step"}, {"value", "0"}, {"dynamicsDimension", "time"}});
    x.open("SpeedActionTarget");
    x.empty("RelativeTargetSpeed", {{"entityRef", ego},
                                    {"value", "$HazardRelativeSpeed"},
                                    {"speedTargetValueType", "delta"},
                                    {"continuous", "true"}});
    x.close();
    x.close();
    x.close();
    x.close();
    x.close();  // Action
    // After Init has set its speed, not in the same step.
    sim_time_trigger(x, "StartTrigger", "AfterInit", "0", "greaterThan");
    x.close();  // Event
  }
  if (ev.lateral) {
    x.open("Event",
           {{"name", "HazardChangesLane"}, {"priority", "parallel"}, {"maximumExecutionCount", "1"}});
    x.open("Action", {{"name", "HazardLaneChangeAction"}});
    x.open("PrivateAction");
    x.open("LateralAction");
    x.open("LaneChangeAction", {{"targetLaneOffset", "$TargetLaneOffset"}});
    x.empty("LaneChangeActionDynamics",
            {{"dynamicsShape", "sinusoidal"}, {"value", "$LaneChangeTime"}, {"dynamicsDimension", "time"}});
    x.open("LaneChangeTarget");
    // Into the ego's lane, wherever the ego is.
    x.empty("RelativeTargetLane", {{"entityRef", ego}, {"value", "0"}});
    x.close();
    x.close();
    x.close();
    x.close();
    x.close();  // Action
    start_trigger(x, ev.trigger, trig_name, ev.lane_change_delay, ego, hazard, catalog);
    x.close();  // Event
  }
  if (ev.speed_change) {
    x.open("Event",
           {{"name", "HazardChangesSpeed"}, {"priority", "parallel"}, {"maximumExecutionCount", "1"}});
    if (ev.relative_end_speed) {
      // Slower than the ego by a set margin, whatever the ego's speed then: the cut-in closes in on any ego.
      x.open("Action", {{"name", "HazardSpeedAction"}});
      x.open("PrivateAction");
      x.open("LongitudinalAction");
      x.open("SpeedAction");
      x.empty("SpeedActionDynamics",
              {{"dynamicsShape", "linear"}, {"value", "$HazardDeceleration"}, {"dynamicsDimension", "rate"}});
      x.open("SpeedActionTarget");
      x.empty("RelativeTargetSpeed", {{"entityRef", ego},
                                      {"value", "$HazardEndSpeedDelta"},
                                      {"speedTargetValueType", "delta"},
                                      {"continuous", "false"}});
      x.close();
      x.close();
      x.close();
      x.close();
      x.close();
    } else {
      speed_action(x, "HazardSpeedAction", "linear", "rate", "$HazardDeceleration", "$HazardEndSpeed");
    }
    start_trigger(x, ev.trigger, trig_name, catalog ? 0.0 : ev.speed_delay, ego, hazard, catalog);
    x.close();
  }
}

void declare(XmlWriter& x, const std::string& name, const std::string& type, const std::string& value) {
  x.empty("ParameterDeclaration", {{"name", name}, {"parameterType", type}, {"value", value}});
}

}  // namespace

XoscExport export_scenario(const HazardTrajectory& traj, const XoscOptions& opt) {
  if (traj.points.size() < 2 || traj.ego.size() < 2)
    throw Error("xosc: the trajectory needs at least two samples for the hazard and the ego (has " +
                std::to_string(traj.points.size()) + " and " + std::to_string(traj.ego.size()) + ")");
  if (opt.ego_mode != "controlled" && opt.ego_mode != "replay")
    throw Error("xosc: ego mode '" + opt.ego_mode + "' is neither 'controlled' nor 'replay'");
  const EntityShape shape = shape_for(traj.object_class, traj.size_lwh);

  // The critical moment: the plan's minimum TTC (its end when the series cannot be paired).
  double t_crit = traj.points.back().t;
  double plan_min = traj.intended_min_ttc_s;
  try {
    hazard::TtcConventions conv;
    conv.ego_front = opt.ego_front;
    const auto series = hazard::ttc_series(traj.ego, traj.points, traj.size_lwh, conv);
    double best = kInf;
    for (const auto& s : series)
      if (s.ttc < best) best = s.ttc, t_crit = s.t;
  } catch (const Error&) {
  }

  Plan plan(traj, opt, shape);
  // A first road over the plan gives the manoeuvre's start; the final one also covers the lead-in.
  plan.fit_road(traj.points.front().t, traj.points.back().t);
  Manoeuvre m = recover(plan.hazard_road(), traj, opt, shape.pedestrian);
  const double stop_stream = std::max(t_crit, traj.points.back().t) + opt.after_s;
  plan.fit_road(m.t_start - opt.lead_in_s, stop_stream);
  const std::vector<RoadSample> h = plan.hazard_road();
  m = recover(h, traj, opt, shape.pedestrian);

  const road::LaneLayout& lanes = opt.lanes;
  const int ego_lane = lanes.ego_lane();
  double T0 = m.t_start - opt.lead_in_s;

  // The ego's condition that starts the manoeuvre at the planned moment.
  HazardEvents ev;
  ev.pedestrian = shape.pedestrian;
  ev.lateral = m.lateral && !shape.pedestrian;
  ev.speed_change = m.speed_change && !shape.pedestrian;
  ev.relative_end_speed = ev.speed_change && m.end_speed > 0.5;
  ev.hold_relative_speed = !shape.pedestrian;
  ev.lane_change_delay = m.lateral ? m.t_lateral - m.t_start : 0;
  ev.speed_delay = m.speed_change ? m.t_speed - m.t_start : 0;
  double trigger_value = 0;
  if (shape.pedestrian) {
    // Walkers start when the ego is a given time away from where they cross: the same TTC whatever its speed.
    ev.trigger.kind = "TimeToCollisionCondition";
    ev.trigger.s = m.s_ped, ev.trigger.t = 0;
    ev.s_ped = m.s_ped, ev.t_from = m.d_from, ev.t_to = m.d_to;
    trigger_value = (m.s_ped - plan.ego_s(m.t_start)) / std::max(plan.ego_at(m.t_start).speed, 0.1);
  } else {
    // Vehicles start at a longitudinal distance from the ego when it changes while the ego approaches (or is
    // overtaken); a vehicle holding the ego's speed keeps its distance, so there the ego's travelled distance
    // (the lead-in) decides.
    auto rel = [&](double t) { return hazard_s(h, m, t) - plan.ego_s(t); };
    const double target = std::abs(rel(m.t_start));
    bool use_distance = std::abs(std::abs(rel(T0)) - target) > 1.0;
    const std::string rule = std::abs(rel(T0)) < target ? "greaterThan" : "lessThan";
    if (use_distance && rel(m.t_start) * rel(T0) < 0 && rule == "lessThan") {
      // The distance is unsigned: a vehicle overtaking from further back than it ends up ahead would meet the
      // condition while still behind. It starts the lead-in at most that far back instead.
      double t = m.t_start;
      while (t - 0.05 > T0 && std::abs(rel(t - 0.05)) <= target) t -= 0.05;
      T0 = t;
    }
    if (use_distance) {
      // The condition must first hold at the planned moment, not earlier on the way there.
      const std::string r = std::abs(rel(T0)) < target ? "greaterThan" : "lessThan";
      for (double t = T0; t < m.t_start - 0.1; t += 0.05) {
        const double v = std::abs(rel(t));
        if (r == "greaterThan" ? v > target : v < target) {
          use_distance = false;
          break;
        }
      }
      ev.trigger.rule = r;
    }
    if (use_distance) {
      ev.trigger.kind = "RelativeDistanceCondition";
      trigger_value = target;
    } else {
      ev.trigger.kind = "TraveledDistanceCondition";
      trigger_value = plan.ego_s(m.t_start) - plan.ego_s(T0);
    }
  }
  const double ego_s0 = plan.ego_s(T0);
  const TrajectoryPoint ego0 = plan.ego_at(T0);
  const double haz_s0 = hazard_s(h, m, T0);
  const double end_delta = m.end_speed - plan.ego_at(m.speed_change ? m.t_speed : m.t_start).speed;

  XoscSummary sum;
  sum.trigger_value = trigger_value;
  sum.start_stream_time = T0;
  sum.trigger_time = m.t_start - T0;
  sum.critical_time = t_crit - T0;
  // The story ends when the ego has driven after_s past the critical moment at its planned speed (an ego
  // slower or faster than planned reaches that point later or earlier), at a collision, or at the latest at
  // twice the critical moment plus after_s (an ego that stops).
  sum.stop_distance = plan.ego_s(t_crit) - ego_s0 + opt.after_s * std::max(plan.ego_at(t_crit).speed, 0.5);
  sum.stop_time = 2 * (t_crit - T0) + opt.after_s;
  sum.plan_min_ttc = plan_min;
  sum.ego_speed = ego0.speed;
  sum.hazard_speed = m.speed;
  sum.hazard_end_speed = m.end_speed;
  sum.deceleration = m.rate;
  sum.lane_change_time = m.lane_change_time;
  sum.start_gap = haz_s0 - ego_s0;
  sum.trigger = ev.trigger.kind;

  // Where the hazard starts, relative to the ego's lane.
  const double haz_t0 = m.lateral ? m.d_from : h.front().d;
  const road::LaneLayout::Lane haz_lane = lanes.lane_at(haz_t0);
  const int d_lane = lanes_between(ego_lane, haz_lane.id);
  const double haz_offset = haz_t0 - haz_lane.centre();
  const road::LaneLayout::Lane end_lane = lanes.lane_at(m.d_to);
  const double target_offset = m.d_to - end_lane.centre();

  std::string description = opt.description;
  if (description.empty()) {
    // The spec's rationale stays in the hazard's hazard_spec property: its numbers are the generator's
    // intent, the header's are the plan's.
    description = "HazardForge " + traj.kind + " (" + traj.object_class + ")";
    description +=
        ". Plan: minimum TTC " + num_text(plan_min, 2) + " s at t=" + num_text(sum.critical_time, 2) +
        " s; the ego starts the hazard at t=" + num_text(sum.trigger_time, 2) + " s by " + sum.trigger + " " +
        num_text(sum.trigger_value, 2) + " (TriggerValue) after a " + num_text(sum.trigger_time, 1) +
        " s lead-in; ends when the ego has driven " + num_text(sum.stop_distance, 1) +
        " m (StopDistance), at a collision, or at t=" + num_text(sum.stop_time, 2) + " s.";
  }

  XmlWriter x;
  x.open("OpenSCENARIO");
  x.empty("FileHeader", {{"revMajor", "1"},
                         {"revMinor", "2"},
                         {"date", opt.date.empty() ? now_utc() : opt.date},
                         {"description", description},
                         {"author", opt.author}});
  x.open("ParameterDeclarations");
  declare(x, "HazardKind", "string", traj.kind);
  declare(x, "EgoSpeed", "double", d(sum.ego_speed, 3));
  declare(x, "HazardSpeed", "double", d(m.speed, 3));
  declare(x, "HazardStartGap", "double", d(sum.start_gap, 3));
  if (ev.hold_relative_speed) declare(x, "HazardRelativeSpeed", "double", d(m.speed - sum.ego_speed, 3));
  if (ev.speed_change) {
    declare(x, "HazardDeceleration", "double", d(m.rate, 3));
    if (ev.relative_end_speed)
      declare(x, "HazardEndSpeedDelta", "double", d(end_delta, 3));
    else
      declare(x, "HazardEndSpeed", "double", d(m.end_speed, 3));
  }
  if (ev.lateral) {
    declare(x, "LaneChangeTime", "double", d(m.lane_change_time, 3));
    declare(x, "TargetLaneOffset", "double", d(target_offset, 3));
  }
  declare(x, "TriggerValue", "double", d(sum.trigger_value, 3));
  declare(x, "IntendedMinTtc", "double", d(plan_min, 3));
  declare(x, "AnchorTime", "double", d(traj.anchor_time, 3));
  declare(x, "StopDistance", "double", d(sum.stop_distance, 3));
  declare(x, "StopTime", "double", d(sum.stop_time, 3));
  x.close();
  x.empty("CatalogLocations");
  x.open("RoadNetwork");
  x.empty("LogicFile", {{"filepath", opt.road_file}});
  x.close();

  x.open("Entities");
  x.open("ScenarioObject", {{"name", opt.ego_name}});
  vehicle(x, "ego_vehicle", "car", "car_white.osgb", opt.ego_size_lwh,
          opt.ego_front - opt.ego_size_lwh[0] / 2, 0.6 * opt.ego_size_lwh[0], opt.ego_limits,
          {{"role", "ego"}, {"type", "ego_vehicle"}, {"ego_mode", opt.ego_mode}});
  x.close();
  x.open("ScenarioObject", {{"name", opt.hazard_name}});
  const std::string spec_json = Json(traj.spec).dump();
  if (shape.pedestrian) {
    x.open("Pedestrian", {{"name", traj.object_class},
                          {"mass", "75"},
                          {"pedestrianCategory", shape.category},
                          {"model3d", shape.model3d}});
    x.open("BoundingBox");
    x.empty("Center", {{"x", "0"}, {"y", "0"}, {"z", d(traj.size_lwh[2] / 2)}});
    x.empty(
        "Dimensions",
        {{"width", d(traj.size_lwh[1])}, {"length", d(traj.size_lwh[0])}, {"height", d(traj.size_lwh[2])}});
    x.close();
    x.open("Properties");
    x.empty("Property", {{"name", "role"}, {"value", "hazard"}});
    x.empty("Property", {{"name", "hazard_spec"}, {"value", spec_json}});
    x.close();
    x.close();
  } else {
    vehicle(x, traj.object_class, shape.category, shape.model3d, traj.size_lwh, shape.wheelbase / 2,
            shape.wheelbase, opt.hazard_limits, {{"role", "hazard"}, {"hazard_spec", spec_json}});
  }
  x.close();
  x.close();  // Entities

  x.open("Storyboard");
  x.open("Init");
  x.open("Actions");
  x.open("Private", {{"entityRef", opt.ego_name}});
  x.open("PrivateAction");
  x.open("TeleportAction");
  x.open("Position");
  x.empty("LanePosition",
          {{"roadId", "1"}, {"laneId", std::to_string(ego_lane)}, {"offset", "0"}, {"s", d(ego_s0, 3)}});
  x.close();
  x.close();
  x.close();
  x.open("PrivateAction");
  x.open("LongitudinalAction");
  x.open("SpeedAction");
  x.empty("SpeedActionDynamics", {{"dynamicsShape", "step"}, {"value", "0"}, {"dynamicsDimension", "time"}});
  x.open("SpeedActionTarget");
  x.empty("AbsoluteTargetSpeed", {{"value", "$EgoSpeed"}});
  x.close();
  x.close();
  x.close();
  x.close();
  x.close();  // Private
  x.open("Private", {{"entityRef", opt.hazard_name}});
  x.open("PrivateAction");
  x.open("TeleportAction");
  x.open("Position");
  x.open("RelativeLanePosition", {{"entityRef", opt.ego_name},
                                  {"dLane", std::to_string(d_lane)},
                                  {"ds", "$HazardStartGap"},
                                  {"offset", d(haz_offset, 3)}});
  // Walkers face across the road, towards where they go.
  const double rel_h = shape.pedestrian ? (m.d_to > m.d_from ? kPi / 2 : -kPi / 2) : 0.0;
  x.empty("Orientation", {{"type", "relative"}, {"h", d(rel_h, 6)}, {"p", "0"}, {"r", "0"}});
  x.close();
  x.close();
  x.close();
  x.close();
  x.open("PrivateAction");
  x.open("LongitudinalAction");
  x.open("SpeedAction");
  x.empty("SpeedActionDynamics", {{"dynamicsShape", "step"}, {"value", "0"}, {"dynamicsDimension", "time"}});
  x.open("SpeedActionTarget");
  x.empty("AbsoluteTargetSpeed", {{"value", shape.pedestrian ? "0" : "$HazardSpeed"}});
  x.close();
  x.close();
  x.close();
  x.close();
  x.close();  // Private
  x.close();  // Actions
  x.close();  // Init

  x.open("Story", {{"name", traj.kind + "Story"}});
  x.open("Act", {{"name", traj.kind + "Act"}});
  x.open("ManeuverGroup", {{"maximumExecutionCount", "1"}, {"name", "HazardManeuverGroup"}});
  x.open("Actors", {{"selectTriggeringEntities", "false"}});
  x.empty("EntityRef", {{"entityRef", opt.hazard_name}});
  x.close();
  x.open("Maneuver", {{"name", traj.kind}});
  hazard_events(x, ev, opt.ego_name, opt.hazard_name, false);
  x.close();  // Maneuver
  x.close();  // ManeuverGroup
  if (opt.ego_mode == "replay") {
    x.open("ManeuverGroup", {{"maximumExecutionCount", "1"}, {"name", "EgoReplayGroup"}});
    x.open("Actors", {{"selectTriggeringEntities", "false"}});
    x.empty("EntityRef", {{"entityRef", opt.ego_name}});
    x.close();
    x.open("Maneuver", {{"name", "EgoReplay"}});
    x.open("Event",
           {{"name", "EgoFollowsRecording"}, {"priority", "override"}, {"maximumExecutionCount", "1"}});
    x.open("Action", {{"name", "EgoReplayAction"}});
    x.open("PrivateAction");
    x.open("RoutingAction");
    x.open("FollowTrajectoryAction");
    x.open("TrajectoryRef");
    x.open("Trajectory", {{"name", "EgoRecording"}, {"closed", "false"}});
    x.open("Shape");
    x.open("Polyline");
    for (double t = T0; t <= stop_stream + 1e-9; t += 0.1) {
      const TrajectoryPoint p = plan.ego_at(t);
      const road::PathPoint w = plan.world(p.x, p.y);
      x.open("Vertex", {{"time", d(t - T0, 3)}});
      x.open("Position");
      x.empty("WorldPosition", {{"x", d(w.x)},
                                {"y", d(w.y)},
                                {"z", "0"},
                                {"h", d(plan.world_heading(p.heading), 6)},
                                {"p", "0"},
                                {"r", "0"}});
      x.close();
      x.close();
    }
    x.close();  // Polyline
    x.close();  // Shape
    x.close();  // Trajectory
    x.close();  // TrajectoryRef
    x.open("TimeReference");
    x.empty("Timing", {{"domainAbsoluteRelative", "relative"}, {"scale", "1"}, {"offset", "0"}});
    x.close();
    x.empty("TrajectoryFollowingMode", {{"followingMode", "position"}});
    x.close();  // FollowTrajectoryAction
    x.close();  // RoutingAction
    x.close();  // PrivateAction
    x.close();  // Action
    // After Init has set the ego's speed, not in the same step (an action on the same domain would cancel
    // it).
    sim_time_trigger(x, "StartTrigger", "AfterInit", "0", "greaterThan");
    x.close();  // Event
    x.close();  // Maneuver
    x.close();  // ManeuverGroup
  }
  sim_time_trigger(x, "StartTrigger", "ActStarts", "0", "greaterOrEqual");
  x.close();  // Act
  x.close();  // Story
  x.open("StopTrigger");
  x.open("ConditionGroup");
  condition_open(x, "EgoDrovePastTheHazard", "0", "rising");
  x.open("ByEntityCondition");
  x.open("TriggeringEntities", {{"triggeringEntitiesRule", "any"}});
  x.empty("EntityRef", {{"entityRef", opt.ego_name}});
  x.close();
  x.open("EntityCondition");
  x.empty("TraveledDistanceCondition", {{"value", "$StopDistance"}});
  x.close();
  x.close();
  x.close();
  x.close();
  x.open("ConditionGroup");
  sim_time_condition(x, "ScenarioEnds", "$StopTime", "greaterThan");
  x.close();
  x.open("ConditionGroup");
  condition_open(x, "EgoHitsHazard", "0", "rising");
  x.open("ByEntityCondition");
  x.open("TriggeringEntities", {{"triggeringEntitiesRule", "any"}});
  x.empty("EntityRef", {{"entityRef", opt.ego_name}});
  x.close();
  x.open("EntityCondition");
  x.open("CollisionCondition");
  x.empty("EntityRef", {{"entityRef", opt.hazard_name}});
  x.close();
  x.close();
  x.close();
  x.close();
  x.close();  // ConditionGroup
  x.close();  // StopTrigger
  x.close();  // Storyboard
  x.close();  // OpenSCENARIO

  XoscExport out;
  out.xosc = x.str();
  road::OpenDriveInfo info;
  info.name = traj.kind + " road";
  info.date = opt.date.empty() ? now_utc() : opt.date;
  out.xodr = road::write_opendrive(plan.line(), lanes, info);
  out.summary = sum;
  return out;
}

std::string write_xosc(const HazardTrajectory& traj, const XoscOptions& opt) {
  return export_scenario(traj, opt).xosc;
}

std::string write_hazard_catalog(const std::string& date) {
  XmlWriter x;
  x.open("OpenSCENARIO");
  x.empty("FileHeader",
          {{"revMajor", "1"},
           {"revMinor", "2"},
           {"date", date.empty() ? now_utc() : date},
           {"description",
            "HazardForge hazard maneuvers: one parameterised Maneuver per kind, started by a condition "
            "on the ego; assign them to the hazard's ManeuverGroup"},
           {"author", "HazardForge"}});
  x.open("Catalog", {{"name", "HazardManeuvers"}});
  struct Kind {
    const char* name;
    HazardEvents ev;
    std::vector<std::tuple<const char*, const char*, const char*>> params;
  };
  std::vector<Kind> kinds;
  {
    Kind k{"sudden_stop", {}, {}};
    k.ev.speed_change = k.ev.hold_relative_speed = true;
    k.ev.trigger.kind = "TraveledDistanceCondition";
    k.params = {{"HazardRelativeSpeed", "double", "0"},
                {"HazardDeceleration", "double", "6"},
                {"HazardEndSpeed", "double", "0"},
                {"TriggerValue", "double", "30"}};
    kinds.push_back(k);
  }
  {
    Kind k{"cut_in", {}, {}};
    k.ev.lateral = k.ev.speed_change = k.ev.relative_end_speed = k.ev.hold_relative_speed = true;
    k.ev.trigger.kind = "RelativeDistanceCondition";
    k.ev.trigger.rule = "greaterThan";
    k.params = {{"HazardRelativeSpeed", "double", "5"},  {"LaneChangeTime", "double", "3"},
                {"TargetLaneOffset", "double", "0"},     {"HazardDeceleration", "double", "3"},
                {"HazardEndSpeedDelta", "double", "-3"}, {"TriggerValue", "double", "5"}};
    kinds.push_back(k);
  }
  {
    Kind k{"pedestrian_crossing", {}, {}};
    k.ev.pedestrian = true;
    k.ev.trigger.kind = "TimeToCollisionCondition";
    k.params = {{"HazardSpeed", "double", "1.5"},
                {"WalkDistance", "double", "6"},
                {"CrossingOffset", "double", "4"},
                {"TriggerValue", "double", "3"}};
    kinds.push_back(k);
  }
  for (const Kind& k : kinds) {
    x.open("Maneuver", {{"name", k.name}});
    x.open("ParameterDeclarations");
    declare(x, "EgoEntity", "string", "Ego");
    declare(x, "HazardEntity", "string", "Hazard");
    for (const auto& [name, type, value] : k.params) declare(x, name, type, value);
    x.close();
    hazard_events(x, k.ev, "$EgoEntity", "$HazardEntity", true);
    x.close();
  }
  x.close();  // Catalog
  x.close();  // OpenSCENARIO
  return x.str();
}

}  // namespace hf
