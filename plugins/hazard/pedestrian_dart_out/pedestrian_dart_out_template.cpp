// pedestrian_dart_out: a person waits hidden behind a parked vehicle, then runs across into the ego path.
#include "pedestrian_dart_out_template.hpp"

#include <algorithm>
#include <cmath>

#include "hazardforge/angles.hpp"
#include "hazardforge/number_text.hpp"

namespace hf {

namespace {

// The run from standstill at up to `v` within the person's limits.
hazard::SpeedProfile run(double wait, double v, const KinematicLimits& lim) {
  return hazard::SpeedProfile(0.0).hold(wait).change_speed(v, lim.max_accel_mps2, lim.max_jerk_mps3);
}

// Share of `box` inside `cover`.
double covered(const cv::Rect2d& box, const cv::Rect2d& cover) {
  return box.area() > 0 ? (box & cover).area() / box.area() : 0.0;
}

}  // namespace

HazardKindInfo PedestrianDartOutTemplate::info() {
  HazardKindInfo k;
  k.kind = "pedestrian_dart_out";
  k.summary = "a person hidden behind a parked vehicle runs out into the ego path";
  k.play_out =
      "a person standing just beyond the front end of a parked vehicle the recording tracks beside the ego path "
      "(initial_distance_m and lateral_offset_m on its centre line, side towards it), hidden behind it; it waits, "
      "then runs straight across the road at speed_mps (2-3.5 m/s), timed to enter the ego path when the TTC "
      "equals target_ttc_s.";
  k.object_classes = {"person"};
  return k;
}

hazard::Design PedestrianDartOutTemplate::design(const hazard::PlanRequest& req,
                                                 std::vector<Refusal>& reasons) const {
  const HazardSpec& spec = req.spec;
  const hazard::Reasons refuse{reasons, spec.kind};
  const double x0 = spec.initial_distance_m, y0 = spec.lateral_offset_m, v = spec.speed_mps;
  const int side = y0 > 0 ? 1 : y0 < 0 ? -1 : 0;
  if (side == 0) {
    refuse(refusal::kSpec, "lateral_offset_m 0: a dart-out starts beside the ego path, left or right of it");
    return {};
  }
  const double half = req.path_half_width(req.size_lwh[1]);
  if (std::abs(y0) < half + 0.2)
    refuse(refusal::kPlacement, "the start y=" + num_text(y0) + " m is in or at the ego path (|y| must be at least " +
                                    num_text(half + 0.2) + " m)");
  if (v < 0.5) refuse(refusal::kSpec, "speed_mps " + num_text(v) + " is too slow to run out (at least 0.5 m/s)");
  if (spec.track_id)
    refuse(refusal::kSpec, "track_id " + std::to_string(*spec.track_id) +
                               ": the person is inserted, it does not take over a tracked object");
  const double gap0 = req.gap(x0, req.size_lwh[0], 0.0);
  if (gap0 <= 0)
    refuse(refusal::kPlacement, "the start x=" + num_text(x0) + " m is not ahead of the ego's front bumper (gap " +
                                    num_text(gap0) + " m)");
  if (!reasons.empty()) return {};
  const std::optional<double> arrive = req.ego.time_at(gap0);
  if (!arrive) {
    refuse(refusal::kEgoMotion, "the ego never reaches the person's line " + num_text(gap0) +
                                    " m ahead of its front bumper (its planned motion stops before)");
    return {};
  }
  const hazard::SpeedProfile from_rest = run(0.0, v, req.limits);
  const double d_in = std::abs(y0) - half;
  const double t_in = *from_rest.time_at_distance(d_in);
  // Enters the path when the TTC (time until the ego's front reaches the line) equals the target, or reaches
  // the path's centre as the ego arrives.
  const double enter_at = spec.target_ttc_s
                              ? *arrive - *spec.target_ttc_s
                              : *arrive - *from_rest.time_at_distance(std::abs(y0)) + t_in;
  const double wait = enter_at - t_in;
  if (wait < 0) {
    refuse(refusal::kTtcUnreachable, "the person needs " + num_text(t_in) +
                                         " s to run into the ego path but would have to be in it after " +
                                         num_text(enter_at) + " s (the ego reaches its line in " +
                                         num_text(*arrive) + " s)");
    return {};
  }
  const hazard::SpeedProfile profile = run(wait, v, req.limits);
  const int dir = -side;
  hazard::Design d;
  d.motion = [profile, x0, y0, dir](double tau) {
    const auto st = profile.at(tau);
    hazard::ObjectMotion m;
    m.x = x0;
    m.y = y0 + dir * st.s;
    m.vy = dir * st.v;
    m.accel = st.a;
    m.heading = dir * kPi / 2;
    return m;
  };
  d.notes = {{"wait_s", wait}, {"enters_path_s", enter_at}, {"ego_arrives_s", *arrive}};
  return d;
}

HazardProposal PedestrianDartOutTemplate::propose(const ProposalRequest& request, RandomDraw& d) const {
  const hazard::ProposalScene sc = hazard::ProposalScene::of(request, *this);
  const std::string kind = kind_info().kind;
  const hazard::NoPlan refused{kind};
  std::string no_class;
  const std::optional<std::string> drawn = hazard::draw_class(sc, {{"person", 1}}, d, &no_class);
  if (!drawn) return refused(refusal::kObjectClass, no_class);
  if (!sc.camera) return refused(refusal::kSceneData, "the scene has no camera to tell what a parked vehicle hides");
  const std::string cls = *drawn;
  const KinematicLimits& lim = sc.limits.at(cls);
  const hazard::Footprint size = sc.size(cls);
  const ClassSize& tall = sc.sizes.at(cls);
  const double half = sc.path_half(size.width);
  // Parked vehicles: tracked, standing (ground speed known and under 1 m/s), beside the path, 8-60 m ahead.
  struct Parked {
    const hazard::ProposalScene::Obj* obj;
    cv::Rect2d box;
  };
  std::vector<Parked> parked;
  for (const auto& o : sc.objects) {
    if (o.label != "car" && o.label != "truck" && o.label != "bus") continue;
    if (o.in_path || !o.speed || std::abs(*o.speed) >= 1.0 || o.x < 8.0 || o.x > 60.0) continue;
    if (std::abs(o.y) < half + 0.5) continue;
    for (const ObjectState& s : request.scene.objects)
      if (s.track_id == o.track_id)
        parked.push_back({&o, cv::Rect2d(s.box.x, s.box.y, s.box.width, s.box.height)});
  }
  if (parked.empty())
    return refused(refusal::kTraffic,
                   "no parked vehicle is tracked beside the ego path 8-60 m ahead to hide a person");
  const double ttc = sc.target;  // the design times the run for the spec's target
  const double latest = sc.horizon - std::min(0.7, 0.3 * sc.horizon);
  std::string last;
  const char* last_code = refusal::kTtcUnreachable;
  // From a drawn parked vehicle on, each in turn until one hides a person who can come out in time.
  const size_t first = d.index(parked.size());
  for (size_t k = 0; k < parked.size(); ++k) {
    const auto& [o, box] = parked[(first + k) % parked.size()];
    const double x0 = o->x + o->length / 2.0 + 0.4, y0 = o->y;
    const int side = y0 > 0 ? 1 : -1, dir = -side;
    const std::string who = "the parked " + o->label + " (track " + std::to_string(o->track_id) + ")";
    const hazard::BoxView view =
        hazard::view_of(*sc.camera, x0, y0, dir * kPi / 2, {size.length, size.width, tall.height});
    if (covered(view.box, box) < 0.5) {
      last = who + " hides " + fixed_text(100 * covered(view.box, box), 0) + " % of a person beyond its front end";
      last_code = refusal::kPlacement;
      continue;
    }
    const double gap0 = x0 - sc.ego_front - size.length / 2.0;
    const std::optional<double> arrive = sc.ego.time_at(gap0);
    if (!arrive || *arrive - ttc > latest) {
      last = "the ego does not reach " + who + " within the horizon";
      last_code = refusal::kTtcUnreachable;
      continue;
    }
    const double enter_at = *arrive - ttc;
    // A drawn running speed, or the fastest (3.5 m/s) when only that comes out in time; it stands at least
    // 0.3 s before it runs.
    double v = std::min(lim.max_speed_mps, d.uniform(2.0, 3.5));
    auto time_in = [&](double speed) { return *run(0.0, speed, lim).time_at_distance(std::abs(y0) - half); };
    if (enter_at - time_in(v) < 0.3) v = std::min(lim.max_speed_mps, 3.5);
    const double t_in = time_in(v);
    if (enter_at - t_in < 0.3) {
      last = "the ego is too near " + who + ": a person running out at " + fixed_text(v, 1) + " m/s needs " +
             fixed_text(t_in, 1) + " s to reach its path, in which it must be after " + fixed_text(enter_at, 1) +
             " s";
      last_code = refusal::kTtcUnreachable;
      continue;
    }
    if (!sc.visible(x0 - sc.ego_travel(0.0, enter_at), dir * -half, tall.height / 2.0)) {
      last = "a person coming out from behind " + who + " would enter the ego path out of view";
      last_code = refusal::kNotInView;
      continue;
    }
    const std::string from = side > 0 ? "left" : "right";
    Json spec = hazard::proposal_spec(kind, cls, x0, y0, from, v, dir * 90.0,
                                      "runs out from behind the parked " + o->label + " on the " + from,
                                      sc.target);
    spec["rationale"] = "A person hidden beyond the front of " + who + " " + fixed_text(o->x, 1) +
                        " m ahead on the " + from + " runs out at " + fixed_text(v, 1) + " m/s after " +
                        fixed_text(enter_at - t_in, 1) + " s and enters the ego path at a TTC near " +
                        fixed_text(ttc, 1) + " s.";
    return {spec, {}};
  }
  return refused(last_code, "no parked vehicle fits a dart-out: " + last);
}

}  // namespace hf
