// Building blocks for a template's proposals (HazardTemplate::propose): the scene as closed-form planning
// reads it, and the checks and JSON every kind's proposals share.
#pragma once

#include <functional>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "hazardforge/geometry.hpp"
#include "hazardforge/hazard/ego_path.hpp"
#include "hazardforge/hazard/kinematics.hpp"
#include "hazardforge/hazard/template_base.hpp"
#include "hazardforge/stage.hpp"

namespace hf::hazard {

// Footprint of a class (its size prior), for closed-form planning.
struct Footprint {
  double length = 4.5, width = 1.8;
};

// Ego-frame x (from the rear axle) of a tracked object's centre. Its distance_m reaches the face the camera
// sees from the states' origin (`distance_origin_x`: the camera, the bumper or the rear axle); the centre
// lies half its length (measured, else its class's prior, else a car's) further on. The prompt and the
// templates place objects by this one rule.
double centre_x(const ObjectState& o, double distance_origin_x, const ClassPriors& sizes);

// The scene a proposal is planned in: the request's scene and settings, the template's road, TTC conventions,
// limits and class sizes.
struct ProposalScene {
  ProposalScene(const ProposalRequest& r, const RoadModel& rd, const LimitsTable& l, const ClassPriors& s)
      : request(r), road(rd), limits(l), sizes(s) {}
  const ProposalRequest& request;
  RoadModel road;  // the template's, with the recording's lane markings (RoadModel::with_markings)
  const LimitsTable& limits;
  const ClassPriors& sizes;
  Corridor corridor;  // its widths: objects' in_path flags already say where the ego's path runs
  double ego_front = 3.4;
  double ego_speed = 0, target = 1.0, horizon = 6, sidewalk = 3.0, max_under_way = 0;
  bool sidewalks = false, on_shoulder = false, multi_lane = false, intersection = false;
  std::optional<CameraModel> camera;
  // The ego's motion the template plans against (TemplateBase::planned_ego): the recorded track when there is
  // one — a queue that comes to a stop, a bend — else straight on at ego_speed.
  EgoPath ego = EgoPath::straight(0.0);
  // The ego's speed `t` s from now along that motion.
  double ego_speed_at(double t) const { return ego.is_recorded() ? ego.at(t).speed : ego_speed; }
  // How far the ego travels between `t0` and `t1` s from now along that motion (negative times: before now,
  // where a hazard already under way starts).
  double ego_travel(double t0, double t1) const {
    return ego.is_recorded() ? ego.s_at(t1) - ego.s_at(t0) : ego_speed * (t1 - t0);
  }
  // A tracked object with a distance: position of its centre (x along ego x from the rear axle, y left),
  // footprint (measured, else its class's prior, else a car's), whether it is in the ego path and its
  // absolute speed along the ego heading if known.
  struct Obj {
    int64_t track_id;
    std::string label;
    double x, y, length, width;
    bool in_path;
    std::optional<double> speed;
  };
  std::vector<Obj> objects;

  // Throws hf::Error when the class has no size prior.
  Footprint size(const std::string& cls) const;
  double edge(int side) const { return road.edge(side); }
  double path_half(double width) const { return corridor.half_width_for(width); }
  // The point (x, y) at height z above the road projects into the image (always true without a camera).
  bool visible(double x, double y, double z = 0.0) const;
  // "" or why an object of footprint `me` at (x, y) would start next to a tracked object (except `except`).
  std::string overlap_problem(double x, double y, const Footprint& me, int64_t except = -1) const;
  // The nearest tracked object in the ego path ahead whose rear is short of `x` (+ `margin`): one that would have
  // to pass through a hazard standing there; null when none is.
  const Obj* in_path_before(double x, double margin = 0.0) const;
  // First time (s from now) at which the TTC to an object `gap0` ahead of the ego's front, moving along the road
  // at `object_speed` (negative: towards the ego), falls to `ttc` along the ego's planned motion; kInf when it
  // does not within `horizon` (the ego stops or crawls). A 20 ms replay.
  double time_ttc_falls_to(double gap0, double object_speed, double ttc, double horizon) const;
  // The sides (+1 left, -1 right) where the ego lane borders the road's edge: the kerb (the side traffic keeps
  // to) first, then the far side where no lane lies beyond the ego's (a one-way road, a divided road's median).
  // Where a parked vehicle pulls out into the ego lane, or a person at the edge walks in its path.
  std::vector<int> edge_sides() const;
  // One of edge_sides(), the kerb three times as often as the far side; 0 when there is none.
  int draw_edge_side(RandomDraw& d) const;
  // Why no side has a road edge next to the ego lane ("every side has a lane beside the ego lane (lanes_left 1,
  // lanes_right 2)").
  std::string no_edge_side() const;
  // The nearest x ahead on the ego lane's centre from which an object of this class, first seen there, looks
  // small enough (ProposalRequest::first_seen_max_height); 0 without that rule or without a camera.
  double first_seen_small_from(const std::string& cls) const;

  static ProposalScene of(const ProposalRequest& request, const TemplateBase& tpl);
};

// A class drawn for a proposal from weighted candidates ({class, weight}), among those the renderer can draw
// (ProposalRequest::class_allowed) and the limits table knows; the draw is the same for the same random bits
// and candidates. nullopt, with `why` naming what each candidate lacks, when none qualifies.
std::optional<std::string> draw_class(const ProposalScene& sc,
                                      const std::vector<std::pair<std::string, int>>& weighted, RandomDraw& d,
                                      std::string* why);

// A proposal that does not fit, with its typed reason: `const NoPlan refused{kind}; return refused(code, text);`.
struct NoPlan {
  std::string kind;
  HazardProposal operator()(const char* code, std::string text) const {
    return {nullptr, {code, std::move(text), kind}};
  }
};

// A plan for a class drawn from `weighted` (as draw_class), adapting to the scene: when the drawn class's plan is
// refused (`plan` returns no spec: a bus too slow to pull out in time, a truck first seen small too far ahead)
// another class is drawn from the rest, until one plans. When none does, the refusal is the first drawn class's,
// naming the others tried.
HazardProposal plan_some_class(const std::string& kind, const ProposalScene& sc,
                               std::vector<std::pair<std::string, int>> weighted, RandomDraw& d,
                               const std::function<HazardProposal(const std::string&)>& plan);

// Rounds to a multiple of `step` (the precision a proposal states its numbers with).
double round_to(double v, double step);

// The spec JSON every proposal starts from (the reply schema's fields, extra empty).
Json proposal_spec(const std::string& kind, const std::string& cls, double x, double y,
                   const std::string& side, double speed, double heading, const std::string& motion,
                   double target);

}  // namespace hf::hazard
