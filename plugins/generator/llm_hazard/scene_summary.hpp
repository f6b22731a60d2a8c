// The scene as the LLM sees it: structured context (LlmRequest::scene), the prompt's placeholder values and
// the SceneContext hazard templates check against, all built from one frame's assessment.
#pragma once

#include <map>
#include <optional>
#include <string>
#include <vector>

#include <hazardforge/stage.hpp>

#include "feasibility.hpp"
#include "feedback.hpp"

namespace hf::llm_hazard {

// "auto" | "yes" | "no" resolved against the environment text; `why` says which word decided.
struct Resolved {
  bool value = false;
  std::string why;
};
Resolved resolve_sidewalks(const std::string& setting, const std::string& text);
Resolved resolve_intersection(const std::string& setting, const std::string& text);
Resolved resolve_multi_lane(const std::string& setting, const std::string& text);

// Whether a tracked object is a vehicle travelling the ego's way in a lane beside the ego's: a car, truck,
// bus or motorcycle 2-60 m ahead, its centre 0.6-1.6 lane widths to the side, its ground velocity
// (hazard::ground_velocity: zero when the estimator cannot tell it from standing) 3-60 m/s and within 30
// degrees of the ego's heading. Only states with a covariance count (a filtered estimator's). The side it
// travels on (+1 left, -1 right), or 0.
int travelling_beside(const ObjectState& o, double ego_speed_mps, double lane_width_m);

// Whether a tracked object is a vehicle coming towards the ego beside its lane: a car, truck, bus or
// motorcycle 5-60 m ahead, whole in the picture (no side cut by the border), its centre 0.6-4.5 lane widths
// to the side, its ground velocity 3-60 m/s, within 30 degrees of the ego's opposite heading, beyond its
// estimator's uncertainty and at least the ego's own speed. The last bound is what a monocular range error
// cannot fake: a parked vehicle whose range the class-height prior over-estimates far away and less so near
// reads as coming closer faster than the ego drives, by up to 0.8 of the ego's speed (nuScenes scene-0916: a
// parked truck tracked from 46 to 10 m read as coming at 3.3-4.5 m/s with the ego at 5.5 m/s). The side it
// passes on (+1 left, -1 right), or 0.
int travelling_towards(const ObjectState& o, double ego_speed_mps, double lane_width_m);

// Vehicles seen travelling beside the ego lane, the ego's way (travelling_beside) or towards it
// (travelling_towards), per track the longest unbroken run of frames: the evidence the multi-lane and
// driving-side auto rules read from the recording. A frame in which a track is seen but not travelling so
// ends its run, so one noisy velocity does not make a lane.
class TrafficBeside {
 public:
  enum class Flow { kWithEgo, kOncoming };
  explicit TrafficBeside(double lane_width_m = 3.5, Flow flow = Flow::kWithEgo)
      : lane_width_(lane_width_m), flow_(flow) {}
  void add(double t, const ObjectStates& states, double ego_speed_mps);
  struct Seen {
    int64_t track = -1;
    std::string label;
    int side = 0;
    double seconds = 0;
  };
  Seen longest() const;

 private:
  struct Run {
    double start = 0, last = 0;
    bool open = false;
    int side = 0;
    Seen best;
  };
  double lane_width_;
  Flow flow_;
  std::map<int64_t, Run> runs_;
};

// The road the generator plans on: the stated facts, the footage's lane markings (RoadModel::with_markings)
// and what its traffic shows. A vehicle coming towards the ego beside its lane
// (TrafficBeside::Flow::kOncoming, followed for at least seen_s without a break) decides the side traffic
// keeps to where the scene does not state it: the other side. Where oncoming_lanes is not stated either, the
// lanes on that side carry oncoming traffic (at least one lane there), all but the one next to the ego lane
// when a vehicle was also seen travelling the ego's way there. seen_s <= 0: only the stated facts and the
// markings.
struct ResolvedRoad {
  hazard::RoadModel road;        // the prompt's, the scene rules', the templates' and the export's road
  std::string driving_side_why;     // "stated", "default: ..." or "auto: the recording shows ..."
  std::string conflict;             // a stated driving side the traffic contradicts, else empty
};
ResolvedRoad resolve_road(const hazard::RoadModel& stated, const RoadMarkings* markings,
                          const TrafficBeside::Seen& oncoming, const TrafficBeside::Seen& with_ego,
                          double seen_s);

struct SceneSettings {
  std::string environment;  // param, else the dataset description, else "unknown"
  std::string road_type;    // param, else "unknown"
  std::string description;  // dataset description
  Resolved sidewalks, intersection, multi_lane;
  std::vector<std::string> allowed_kinds;
  std::vector<HazardKindInfo> kinds;  // what the allowed kinds' templates say about themselves
  SceneRules rules;                   // drawable classes, takeovers, entry into view, clearance
  Feedback feedback;                  // failed attempts of earlier runs on this recording
  double target_ttc_s = 1.0;
  double ttc_tolerance_s = 0.25;
  double threshold_s = 1.5;
  double ego_speed_mps = 0.0;
  double horizon_s = 6.0;
  double sidewalk_width_m = 3.0;
  bool pedestrians_without_sidewalks = false;  // edge-case tests: a person on the shoulder
  double max_under_way_s = 0.0;                // hazards may already be under way when they appear
  hazard::TtcConventions ttc;
  hazard::RoadModel road;
  std::string driving_side_why;  // where road.driving_side came from (resolve_road)
};

// The road these settings settle, with what each fact rests on: what the scene context, the templates, the
// planner (HazardSpec::road) and the export read.
RoadLayout road_layout(const SceneSettings& settings);

struct SceneSummary {
  Json scene;                                       // LlmRequest::scene
  std::map<std::string, std::string> placeholders;  // prompt values (all but "schema")
  SceneContext context;                             // for feasibility and template checks
};

// The feasibility configuration of the scene these settings describe (limits and sizes must outlive it).
FeasibilityConfig feasibility_config(const SceneSettings& settings, const LimitsTable& limits,
                                     const ClassPriors& sizes, double trigger_time_s,
                                     std::optional<double> ego_yaw_rate);

// What every template's proposal is asked for in this scene (the scene context must outlive it).
ProposalRequest proposal_request(const SceneSettings& settings, const SceneContext& scene);

// The prompt's list of the allowed kinds: what each is, its classes, whether it applies here and its extra
// fields (placeholder {{kinds}}).
std::string describe_kinds(const std::vector<HazardKindInfo>& kinds, const FeasibilityConfig& cfg,
                           const SceneContext& scene);

SceneSummary summarize_scene(const Frame& frame, const ObjectStates& states,
                             const std::vector<const RiskAssessment*>& risks, const SceneSettings& settings,
                             const LimitsTable& limits, const ClassPriors& sizes);

}  // namespace hf::llm_hazard
