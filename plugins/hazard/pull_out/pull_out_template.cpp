// pull_out: a parked vehicle drives off and steers into the ego lane in front of the ego.
#include "pull_out_template.hpp"

#include <algorithm>
#include <cmath>

#include "hazardforge/angles.hpp"
#include "hazardforge/hazard/proposal.hpp"
#include "hazardforge/number_text.hpp"

namespace hf {

namespace {
// The class's jerk limit shared between driving off and steering (as the cut-in shares it): |(0.8, 0.6)| = 1.
constexpr double kLongitudinalJerkShare = 0.8, kLateralJerkShare = 0.6;
// A pull-out drives off briskly but not at the class's limit.
constexpr double kDriveOffAccel = 2.5;
// Speed at which steering begins (a parked car rolls before it turns out), at most half its end speed.
constexpr double kSteerFromSpeed = 1.5;
// How far off the road's direction it may point while it pulls out (rad).
constexpr double kMaxPullOutHeading = 35.0 * kRadPerDeg;

const SpecField<double> kAfter("pull_out_after_s", "seconds it stands before it drives off",
                               {{"minimum", 0}, {"maximum", 30}});
const SpecField<double> kSpeed("pull_out_speed_mps", "speed it drives off to, below the ego speed",
                               {{"minimum", 0.5}, {"maximum", 20}});
}  // namespace

hazard::ObjectMotion PullOutShape::at(double tau) const {
  const auto st = profile.at(std::max(0.0, tau));
  const hazard::Shift sh = hazard::min_jerk_shift(-y0, steer_s, tau - steer_start);
  hazard::ObjectMotion m;
  m.x = st.s;
  m.y = y0 + sh.p;
  m.vx = st.v;
  m.vy = sh.v;
  m.accel = st.a;
  // Parked along the road; once rolling, pointing where it goes.
  m.heading = st.v > 0.2 ? std::atan2(sh.v, st.v) : 0.0;
  return m;
}

std::optional<double> PullOutShape::enters(double half) const {
  const double end = steer_start + steer_s;
  if (std::abs(at(end).y) >= half) return std::nullopt;
  double lo = steer_start, hi = end;
  for (int i = 0; i < 60; ++i) {
    const double mid = (lo + hi) / 2;
    (std::abs(at(mid).y) < half ? hi : lo) = mid;
  }
  return hi;
}

double PullOutShape::parking_offset(const RoadLayout& road, int side, double width) {
  return side * (road.edge(side) + width / 2.0 + 0.3);
}

std::optional<PullOutShape> PullOutShape::make(double y0, double after, double speed, const KinematicLimits& lim,
                                               std::string& why) {
  PullOutShape s;
  s.y0 = y0;
  s.after = after;
  // Steering adds to the acceleration along its path (its speed grows with the lateral speed, by up to the
  // lateral acceleration times sin 35 deg): driving off takes 70 % of the class's acceleration at most, the
  // steering's share of the rest bounds its lateral acceleration.
  const double accel = std::min(kDriveOffAccel, 0.7 * lim.max_accel_mps2);
  const double lateral_accel =
      std::min(lim.max_lateral_accel_mps2, 0.3 * lim.max_accel_mps2 / std::sin(kMaxPullOutHeading));
  s.profile = hazard::SpeedProfile(0.0).hold(after).change_speed(speed, accel,
                                                                    kLongitudinalJerkShare * lim.max_jerk_mps3);
  const double roll = std::min(kSteerFromSpeed, speed / 2.0);
  double t = after;
  while (t < s.profile.duration() && s.profile.at(t).v < roll) t += 0.01;
  s.steer_start = t;
  // Steering out of a parking place is a turn, not a lane change: its lateral speed is bounded by its heading
  // (at most kMaxPullOutHeading off the road at its end speed) rather than by the class's lane-change rate.
  const double lateral_rate = std::max(lim.max_lateral_speed_mps, speed * std::sin(kMaxPullOutHeading));
  s.steer_s = hazard::min_jerk_duration(std::abs(y0), lateral_rate, lateral_accel,
                                        kLateralJerkShare * lim.max_jerk_mps3);
  // Stretched until the turn rate (high while it is still slow) is within the class limit.
  for (int iter = 0;; ++iter) {
    double peak = 0, prev = 0;
    const int steps = 200;
    const double dt = s.steer_s / steps;
    for (int k = 0; k <= steps; ++k) {
      const double h = *s.at(s.steer_start + k * dt).heading;
      if (k > 0) peak = std::max(peak, std::abs(angle_diff(h, prev)) / dt);
      prev = h;
    }
    if (rad_to_deg(peak) <= 0.95 * lim.max_yaw_rate_dps) break;
    if (iter == 40) {
      why = "no steering within the " + lim.object_class + " turn-rate limit of " +
            num_text(lim.max_yaw_rate_dps) + " deg/s brings it " + num_text(std::abs(y0)) +
            " m across at up to " + num_text(speed) + " m/s";
      return std::nullopt;
    }
    s.steer_s *= 1.1;
  }
  return s;
}

HazardKindInfo PullOutTemplate::info() {
  HazardKindInfo k;
  k.kind = "pull_out";
  k.summary = "a vehicle parked at the roadside pulls out into the ego lane ahead";
  k.play_out =
      "a vehicle parked beside the road on the side traffic keeps to (side and lateral_offset_m: in the parking "
      "strip just beyond the outermost lane, the road edge plus half its width and 0.3 m) at "
      "initial_distance_m, standing "
      "(speed_mps 0); after extra.pull_out_after_s it drives off to extra.pull_out_speed_mps, below the ego "
      "speed, while steering into the ego lane in front of the ego.";
  k.object_classes = {"car", "truck", "bus", "motorcycle"};
  k.extra_fields = {kAfter.declaration(), kSpeed.declaration()};
  return k;
}

ComponentInfo PullOutTemplate::describe() {
  ComponentInfo i = base_info(
      info(),
      "The vehicle stands beside the road, drives off after pull_out_after_s (jerk-limited, at up to 2.5 m/s^2 "
      "or 70 % of its class's limit) to pull_out_speed_mps and, once rolling, steers into the ego lane's centre "
      "(minimum-jerk shift within the lateral acceleration that leaves and the class's jerk limit, its lateral "
      "speed up to the lane-change limit or its speed times sin 35 deg, whichever is more: a turn out of a "
      "parking place, not a lane change; stretched until its turn rate is within the limit). The ego, faster, "
      "closes in.");
  i.params.push_back(hf::ParamSpec::number("pull_out_after_s", 1.0)
                         .range(0, 30)
                         .describe("standing time before it drives off, unless extra.pull_out_after_s is given"));
  i.params.push_back(hf::ParamSpec::number("pull_out_speed_mps", 4.0)
                         .range(0.5, 20)
                         .describe("speed it drives off to, unless extra.pull_out_speed_mps is given"));
  return i;
}

hazard::Design PullOutTemplate::design(const hazard::PlanRequest& req, std::vector<Refusal>& reasons) const {
  const HazardSpec& spec = req.spec;
  const hazard::Reasons refuse{reasons, spec.kind};
  const double len = req.size_lwh[0], wid = req.size_lwh[1];
  const int side = req.side_sign();
  if (side == 0) {
    refuse(refusal::kSpec,
           "side must be 'left' or 'right' (or lateral_offset_m non-zero) for pull_out, got '" + spec.side + "'");
    return {};
  }
  const std::string side_name = side > 0 ? "left" : "right";
  const double edge = req.road.edge(side);
  const double y0 =
      std::abs(spec.lateral_offset_m) > 0.01 ? spec.lateral_offset_m : PullOutShape::parking_offset(req.road, side, wid);
  const double half = req.path_half_width(wid);
  if (std::abs(y0) < half)
    refuse(refusal::kPlacement, "the parking place y=" + num_text(y0) + " m is in the ego path (|y| < " +
                                    num_text(half) + " m)");
  if (std::abs(y0) - wid / 2 > edge + 2.0)
    refuse(refusal::kPlacement, "the parking place y=" + num_text(y0) + " m is more than 2 m beyond the road edge (" +
                                    num_text(edge) + " m on the " + side_name + ")");
  if (spec.track_id)
    refuse(refusal::kSpec, "track_id " + std::to_string(*spec.track_id) +
                               ": the pulling-out vehicle is inserted, it does not take over a tracked object");
  if (std::abs(spec.speed_mps) > 0.1)
    refuse(refusal::kSpec, "speed_mps " + num_text(spec.speed_mps) + ": a parked vehicle stands (speed_mps 0)");
  std::optional<double> after, speed;
  try {
    after = kAfter.get(spec);
    speed = kSpeed.get(spec);
  } catch (const Error& e) {
    refuse(refusal::kSpec, e.what());
  }
  if (!reasons.empty()) return {};
  const double t_go = after.value_or(req.params.get_double("pull_out_after_s"));
  const double v1 = speed.value_or(req.params.get_double("pull_out_speed_mps"));
  if (v1 > req.limits.max_speed_mps)
    refuse(refusal::kClassLimit, "pull_out_speed_mps " + num_text(v1) + " is above the " + req.limits.object_class +
                                     " limit of " + num_text(req.limits.max_speed_mps) + " m/s");
  std::string why;
  const std::optional<PullOutShape> shape = PullOutShape::make(y0, t_go, v1, req.limits, why);
  if (!shape) refuse(refusal::kClassLimit, why);
  if (!reasons.empty()) return {};
  const double x0 = spec.initial_distance_m;
  const std::optional<double> t_in = shape->enters(half);
  if (!t_in) {
    refuse(refusal::kPlacement, "it never enters the ego path");
    return {};
  }
  const double gap_in = req.gap(x0 + shape->at(*t_in).x, len, *t_in);
  if (gap_in <= 0)
    refuse(refusal::kPlacement, "it would pull out beside or behind the ego (gap " + num_text(gap_in) + " m when it enters the ego path " +
                                    num_text(*t_in) + " s in)");
  if (!reasons.empty()) return {};
  hazard::Design d;
  const PullOutShape s = *shape;
  d.motion = [s, x0](double tau) {
    hazard::ObjectMotion m = s.at(tau);
    m.x += x0;
    return m;
  };
  d.notes = {{"drives_off_s", t_go},        {"steer_start_s", s.steer_start}, {"steer_s", s.steer_s},
             {"enters_path_s", *t_in},      {"gap_entering_m", gap_in},       {"end_speed_mps", v1},
             {"parking_offset_m", y0}};
  return d;
}

HazardProposal PullOutTemplate::propose(const ProposalRequest& request, RandomDraw& d) const {
  const hazard::ProposalScene sc = hazard::ProposalScene::of(request, *this);
  // Parked at a road edge the ego lane borders: the kerb, or a one-way or divided road's far edge (a shoulder by
  // the median). Across a lane, the vehicle pulling out merges into that lane, not the ego's.
  const int sign = sc.draw_edge_side(d);
  const hazard::NoPlan refused{kind_info().kind};
  if (sign == 0)
    return refused(refusal::kSceneLacks,
                   sc.no_edge_side() + ": a vehicle pulling out merges into the lane beside the ego lane");
  // A car mostly; a truck or bus (slower to drive off) where one fits.
  return hazard::plan_some_class(kind_info().kind, sc, {{"car", 4}, {"truck", 1}, {"bus", 1}}, d,
                                 [&](const std::string& cls) { return propose_as(cls, sign, sc, request, d); });
}

HazardProposal PullOutTemplate::propose_as(const std::string& cls, int sign, const hazard::ProposalScene& sc,
                                           const ProposalRequest& request, RandomDraw& d) const {
  using hazard::round_to;
  const std::string kind = kind_info().kind;
  const hazard::NoPlan refused{kind};
  const double ttc = request.aim * sc.target;
  const KinematicLimits& lim = sc.limits.at(cls);
  const hazard::Footprint size = sc.size(cls);
  const std::string side = sign > 0 ? "left" : "right";
  const double y0 = PullOutShape::parking_offset(sc.road, sign, size.width);
  // Its end speed: a pull-out's 2-6 m/s, well below the ego's (35-60 % of it) so that the ego closes in.
  const double v1 = std::min(lim.max_speed_mps, std::clamp(d.uniform(0.35, 0.6) * sc.ego_speed, 2.0, 6.0));
  const double half = sc.path_half(size.width);
  const double front = sc.ego_front + size.length / 2.0;
  const double latest = sc.horizon - std::min(0.7, 0.3 * sc.horizon);
  // It drives off after a drawn wait; parked beside the road it may be in view from the start, as a person on
  // the pavement may, so no first-seen rule applies. A wait that leaves the ego no faster when it pulls in is
  // lengthened (the ego accelerating on its recorded track).
  double t_go = d.uniform(0.3, 1.0);
  std::string last;
  for (; t_go < latest + sc.max_under_way; t_go += 0.25) {
    std::string why;
    const std::optional<PullOutShape> s = PullOutShape::make(y0, t_go, v1, lim, why);
    if (!s) return refused(refusal::kClassLimit, why);
    const std::optional<double> t_in = s->enters(half);
    if (!t_in) return refused(refusal::kPlacement, "the steering never brings it into the ego path");
    // A pull-out that would enter the ego path after the horizon (a short clip) is already under way when the
    // hazard appears, entering the path a drawn 40-70 % into the horizon, while max_under_way_s allows.
    double under_way = 0.0;
    if (*t_in > latest) {
      under_way = round_to(*t_in - d.uniform(0.4, 0.7) * latest, 0.05);
      if (under_way > sc.max_under_way) {
        last = "it would enter the ego path " + fixed_text(*t_in, 1) + " s in, after " + fixed_text(latest, 1) +
               " s" +
               (sc.max_under_way > 0 ? ", and under way for " + fixed_text(under_way, 1) +
                                           " s when it appears (max_under_way_s " +
                                           fixed_text(sc.max_under_way, 1) + ")"
                                     : std::string());
        break;
      }
    }
    const double enter = *t_in - under_way;  // when it enters the path, from the hazard's appearing
    const double closing = sc.ego_speed_at(enter) - s->at(*t_in).vx;
    if (closing < 0.5) {
      last = "the ego (" + fixed_text(sc.ego_speed_at(enter), 1) + " m/s then) is not faster than the vehicle (" +
             fixed_text(s->at(*t_in).vx, 1) + " m/s) when it pulls into the lane";
      continue;
    }
    // Placed so that the TTC is `ttc` as it enters the ego path (the design's x counts from where the ego was
    // when the manoeuvre began).
    const double x0 = front + sc.ego_travel(-under_way, enter) + ttc * closing - s->at(*t_in).x;
    // The same in the ego's frame as the hazard appears: where it is then, and where it pulls in.
    const double shift = sc.ego_travel(-under_way, 0.0);
    const double x_now = x0 + s->at(under_way).x - shift, x_in = x0 + s->at(*t_in).x - shift;
    if (x0 > 150.0) return refused(refusal::kPlacement, "the vehicle would stand more than 150 m ahead");
    if (const auto* o = sc.in_path_before(x_in + size.length / 2.0, 5.0))
      return refused(refusal::kTraffic, "a tracked " + o->label + " (track " + std::to_string(o->track_id) +
                                            ") " + fixed_text(o->x, 1) +
                                            " m ahead in the ego lane is short of where the " + cls +
                                            " would pull in");
    const double y_now = s->at(under_way).y;
    if (!sc.visible(x_now, y_now))
      return refused(refusal::kNotInView, "the parking place (" + fixed_text(x_now, 1) + ", " + fixed_text(y_now, 1) +
                                              ") m is outside the camera view");
    if (under_way == 0)
      if (std::string p = sc.overlap_problem(x0, y0, size); !p.empty()) return refused(refusal::kTraffic, p);
    Json spec = hazard::proposal_spec(kind, cls, x0, y0, side, 0.0, 0.0,
                                      "parked on the " + side + ", pulls out into the ego lane", sc.target);
    kAfter.set(spec, round_to(t_go, 0.05));
    kSpeed.set(spec, round_to(v1, 0.1));
    spec["rationale"] = "A " + cls + " parked on the " + side + " " + fixed_text(x0, 1) + " m ahead drives off after " +
                        fixed_text(t_go, 1) + " s to " + fixed_text(v1, 1) +
                        " m/s and steers into the ego lane " + fixed_text(enter, 1) + " s in, where the ego at " +
                        fixed_text(sc.ego_speed_at(enter), 1) + " m/s closes in at a TTC near " +
                        fixed_text(ttc, 1) + " s.";
    if (under_way > 0) {
      spec["under_way_s"] = under_way;
      spec["rationale"] = "A " + cls + " that was parked on the " + side + " is already pulling out when it appears (" +
                          fixed_text(under_way, 1) + " s into its manoeuvre, having driven off after " +
                          fixed_text(t_go, 1) + " s; " + fixed_text(x_now, 1) + " m ahead) and steers into the ego lane " + fixed_text(enter, 1) + " s later, where the ego at " +
                          fixed_text(sc.ego_speed_at(enter), 1) + " m/s closes in at a TTC near " +
                          fixed_text(ttc, 1) + " s.";
    }
    return {spec, {}};
  }
  return refused(refusal::kTtcUnreachable, "no wait before it pulls out fits the horizon: " +
                                               (last.empty() ? std::string("the horizon is too short") : last));
}

}  // namespace hf
