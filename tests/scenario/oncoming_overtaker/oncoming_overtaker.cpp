// oncoming_overtaker hazard template (a test plugin): an oncoming vehicle swerves into the ego lane to
// overtake. One file, built like a third party's plugin, that takes part in the prompt, the offline planner,
// the docs and the tests without a line elsewhere.
#include <algorithm>
#include <cmath>
#include <numbers>

#include "hazardforge/hazard/proposal.hpp"
#include "hazardforge/hazard/template_base.hpp"
#include "hazardforge/number_text.hpp"
#include "hazardforge/plugin.hpp"

namespace example {

using hf::num_text;

// Kind hazard_template, name oncoming_overtaker. The vehicle drives towards the ego in the oncoming lane next
// to the ego's traffic (on `side`, which must be where oncoming traffic passes) at speed_mps, first seen far
// ahead; after extra.swerve_after_s it changes into the ego lane (minimum-jerk shift within the class's
// lateral limits) and keeps coming, so the gap closes at the ego's speed plus its own. Params: the shared
// template params.
class OncomingOvertaker : public hf::hazard::KindTemplate<OncomingOvertaker> {
 public:
  // Its own field of the spec, typed: declared once, read and written through it.
  static const hf::SpecField<double>& swerve_after() {
    static const hf::SpecField<double> f(
        "swerve_after_s", "seconds it drives on in its own lane before it swerves into the ego lane",
        {{"minimum", 0}, {"maximum", 30}});
    return f;
  }
  // It comes from far ahead, where a recorded path's turns, a lane to the side, are tighter than a vehicle
  // may take at its speed: it is planned against a straight ego by default.
  static hf::ComponentInfo describe() {
    hf::ComponentInfo i = base_info(info());
    for (hf::ParamSpec& p : i.params)
      if (p.name == "ego_plan") p.default_value = "constant_speed";
    return i;
  }

  static hf::HazardKindInfo info() {
    hf::HazardKindInfo k;
    k.kind = "oncoming_overtaker";
    k.summary = "an oncoming vehicle swerves into the ego lane to overtake, head-on";
    k.play_out =
        "drives towards the ego (heading_deg 180) at speed_mps in the oncoming lane next to the ego's "
        "traffic "
        "(side and lateral_offset_m on the side oncoming traffic passes, about one lane width), first seen "
        "far "
        "ahead (initial_distance_m 40-110 m); after extra.swerve_after_s seconds it changes into the ego "
        "lane and "
        "keeps coming, so the gap closes at the ego speed plus speed_mps.";
    k.object_classes = {"car", "truck", "bus"};
    k.needs = {hf::scene_condition::kOncomingLane};
    k.extra_fields = {swerve_after().declaration()};
    return k;
  }

  // A car (2 in 4 draws), truck or bus at least 40 m ahead in the oncoming lane (up to 20 m beyond the
  // nearest start that leaves it time to swerve) at 5-10 m/s, an urban overtaking speed, swerving so that it
  // enters the ego path when the TTC is 1.1-1.5 x the target.
  hf::HazardProposal propose(const hf::ProposalRequest& req, hf::RandomDraw& d) const override {
    const auto sc = hf::hazard::ProposalScene::of(req, *this);
    const int side = sc.road.oncoming_side();
    if (sc.road.oncoming_lanes_on(side) == 0)
      return {nullptr, {hf::refusal::kSceneLacks, "no lane carries oncoming traffic", "oncoming_overtaker"}};
    static const char* kClasses[] = {"car", "car", "truck", "bus"};
    const std::string cls = kClasses[d.index(4)];
    if (!req.class_allowed(cls) || !sc.limits.has(cls))
      return {nullptr, {hf::refusal::kObjectClass, "no '" + cls + "' here", "oncoming_overtaker"}};
    const hf::KinematicLimits& lim = sc.limits.at(cls);
    const hf::hazard::Footprint size = sc.size(cls);
    const double v = d.uniform(5.0, std::min(10.0, lim.max_speed_mps));
    const double closing = sc.ego_speed + v;
    const double y0 = side * sc.road.lane_width_m * (sc.road.same_direction_lanes(side) + 1);
    const double lane = lane_change(std::abs(y0), v, lim);
    // The share of the lane change after which it is in the ego path.
    const double inside = 1.0 - sc.path_half(size.width) / std::abs(y0);
    double lo = 0, hi = 1;
    for (int i = 0; i < 50; ++i)
      (hf::hazard::min_jerk_shift(1.0, 1.0, (lo + hi) / 2).p < inside ? lo : hi) = (lo + hi) / 2;
    const double to_path = hi * lane;
    const double ttc_in = d.uniform(1.1, 1.5) * sc.target;  // the TTC when it enters the ego path
    const double front = sc.ego_front + size.length / 2.0;
    // First seen at 40 m or more; driving on for a moment before it swerves; the TTC at aim x target before
    // the horizon's end.
    const double near = std::max(40.0, front + closing * (0.2 + ttc_in + to_path));
    const double far =
        std::min({110.0, near + 20.0, front + closing * (sc.horizon - 0.5 + req.aim * sc.target)});
    if (near > far)
      return {nullptr,
              {hf::refusal::kTtcUnreachable,
               "it cannot come from " + hf::fixed_text(near, 1) + " m within the horizon", "oncoming_overtaker"}};
    const double x0 = d.uniform(near, far);
    const double swerve = (x0 - front) / closing - ttc_in - to_path;
    const std::string side_name = side > 0 ? "left" : "right";
    hf::Json spec = hf::hazard::proposal_spec(
        "oncoming_overtaker", cls, x0, y0, side_name, v, 180.0,
        "comes towards the ego in the oncoming lane and swerves into the ego lane to overtake", sc.target);
    swerve_after().set(spec, hf::hazard::round_to(swerve, 0.05));
    spec["rationale"] = "An oncoming " + cls + " " + hf::fixed_text(x0, 1) + " m ahead at " +
                        hf::fixed_text(v, 1) + " m/s pulls out to overtake into the ego lane; closing at " +
                        hf::fixed_text(closing, 1) + " m/s the TTC falls below the target.";
    return {spec, {}};
  }

 protected:
  hf::hazard::Design design(const hf::hazard::PlanRequest& req,
                            std::vector<hf::Refusal>& reasons) const override {
    const hf::HazardSpec& spec = req.spec;
    auto refuse = [&](const char* code, std::string text) {
      reasons.push_back({code, std::move(text), "oncoming_overtaker"});
    };
    const int side = req.side_sign();
    const int oncoming = req.road.oncoming_side();
    if (side != oncoming || req.road.oncoming_lanes_on(oncoming) == 0) {
      refuse(hf::refusal::kSceneLacks, "side '" + spec.side + "' carries no oncoming traffic (oncoming_lanes " +
                        std::to_string(req.road.oncoming_lanes) + ", traffic keeps " + req.road.driving_side +
                        ")");
      return {};
    }
    const double y0 = spec.lateral_offset_m;
    if (req.road.same_direction_at(y0) || req.road.lane_at(y0) == 0)
      refuse(hf::refusal::kPlacement, "the start y=" + num_text(y0) + " m is not in an oncoming lane");
    const double v = spec.speed_mps;
    if (v < 1.0) refuse(hf::refusal::kSpec, "speed_mps " + num_text(v) + " is too slow to overtake (at least 1 m/s)");
    if (std::abs(std::abs(spec.heading_deg) - 180.0) > 10.0)
      refuse(hf::refusal::kSpec, "heading_deg " + num_text(spec.heading_deg) +
                        " does not come towards the ego (about 180)");
    double swerve = 0;
    try {
      swerve = swerve_after().get(spec).value_or(0.0);
    } catch (const hf::Error& e) {
      refuse(hf::refusal::kSpec, e.what());
      return {};
    }
    if (swerve < 0) refuse(hf::refusal::kSpec, "extra.swerve_after_s " + num_text(swerve) + " is negative");
    if (req.gap(spec.initial_distance_m, req.size_lwh[0], 0.0) <= 0)
      refuse(hf::refusal::kPlacement, "initial_distance_m " + num_text(spec.initial_distance_m) +
                        " is not ahead of the ego");
    if (!reasons.empty()) return {};
    const double lane = lane_change(std::abs(y0), v, req.limits);
    const double x0 = spec.initial_distance_m;
    hf::hazard::Design d;
    d.motion = [=](double tau) {
      const hf::hazard::Shift sh = hf::hazard::min_jerk_shift(-y0, lane, tau - swerve);
      hf::hazard::ObjectMotion m;
      m.x = x0 - v * tau;
      m.y = y0 + sh.p;
      m.vx = -v;
      m.vy = sh.v;
      return m;
    };
    d.notes = {{"swerve_after_s", swerve}, {"lane_change_s", lane}};
    return d;
  }

 private:
  // The shortest lane change within the lateral limits, stretched until the turn rate is within its limit
  // too.
  static double lane_change(double width, double v, const hf::KinematicLimits& lim) {
    double dur = hf::hazard::min_jerk_duration(width, lim.max_lateral_speed_mps, lim.max_lateral_accel_mps2,
                                               0.6 * lim.max_jerk_mps3);
    for (int i = 0; i < 40; ++i) {
      double peak = 0, prev = 0;
      for (int k = 0; k <= 200; ++k) {
        const double h = std::atan2(hf::hazard::min_jerk_shift(width, dur, k * dur / 200).v, v);
        if (k > 0) peak = std::max(peak, std::abs(h - prev) / (dur / 200));
        prev = h;
      }
      if (peak * 180 / std::numbers::pi <= 0.9 * lim.max_yaw_rate_dps) break;
      dur *= 1.1;
    }
    return dur;
  }
};

}  // namespace example

HAZARDFORGE_PLUGIN("oncoming_overtaker", "0.1.0", "Apache-2.0",
                   "hazard template (test plugin): an oncoming vehicle overtakes into the ego lane") {
  reg.add<example::OncomingOvertaker>();
}
