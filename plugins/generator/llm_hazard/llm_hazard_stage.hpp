// The llm_hazard generator: asks an LLM provider for a collision-inducing hazard when the scene is Safe.
#pragma once

#include <filesystem>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include <hazardforge/geometry.hpp>
#include <hazardforge/stage.hpp>

#include "feasibility.hpp"
#include "hazard_catalog.hpp"
#include "hazard_schema.hpp"
#include "prompt.hpp"
#include "run_files.hpp"
#include "scene_summary.hpp"

namespace hf::llm_hazard {

// The params the generator creates hazard templates with: its road, TTC conventions, horizon and bound on
// hazards already under way, so templates judge the same road and times as its own checks.
Json template_params(const hazard::RoadModel& road, const hazard::TtcConventions& ttc, double horizon_s,
                     double max_under_way_s, const std::string& limits_file, const std::string& sizes_file);

// LlmHazardGenerator (stage "llm_hazard", kind generator).
// Inputs: states (ObjectStates), risk (RiskAssessment, multi), frames (Frame).
// Output: hazard (HazardSpec), emitted once, stamped with the trigger frame's timestamp.
// Trigger: `first_safe` = the first frame after `warmup_frames` frames that every risk input labels Safe,
// where the recorded ego path turns at most `max_turn_deg` over the horizon (unless no later frame turns
// less), and at which a hazard fits: when none fits there (NoHazardFits), a Safe frame `retry_every_s` later
// is tried, at most `max_trigger_attempts` frames and only while at least 1 s of the clip is left; `frame` =
// the frame whose index is `trigger_frame` (if it is Unsafe nothing is generated, logged; if no hazard fits,
// the stage fails). At the trigger the scene is summarised into the prompt
// (share/prompts/hazard_generation.md), the provider
// (`provider: {name: ..., <its params>}`) answers, and the reply is extracted, validated against the hazard
// spec schema, checked for physical feasibility and by the kind's hazard template. Invalid replies go back to
// the model with the errors (share/prompts/hazard_retry.md), up to `max_retries` times; then the stage fails
// with the last errors (NoHazardFits, see Trigger). Transport failures fail at once. Every call is appended
// to llm/calls.jsonl and the accepted spec is written to hazard_spec.json in the run folder.
class LlmHazardGenerator : public Stage {
 public:
  static ComponentInfo describe();
  LlmHazardGenerator();
  ~LlmHazardGenerator() override;
  void open(StageContext& ctx) override;
  void process(StageContext& ctx, const Inputs& in, Outputs& out) override;
  void finish(StageContext& ctx, Outputs& out) override;

  // The allowed kinds after open(): param `kinds` (or every registered template), narrowed by `force_kind`.
  const std::vector<std::string>& allowed_kinds() const { return allowed_kinds_; }

 private:
  // nullopt when the run is stopping (Ctrl-C) during a model call.
  std::optional<HazardSpec> generate(StageContext& ctx, const Frame& frame, const ObjectStates& states,
                                     const std::vector<const RiskAssessment*>& risks, double horizon_cap);
  // generate(), with shorter automatic horizons while none fits (param min_horizon_s).
  std::optional<HazardSpec> generate_shortening(StageContext& ctx, const Frame& frame,
                                                const ObjectStates& states,
                                                const std::vector<const RiskAssessment*>& risks);
  double ego_speed(const Frame& frame, const ObjectStates& states) const;
  SceneSettings read_scene(StageContext& ctx, const Frame& frame);
  // Appends the frame's settled road to road_file when a fact differs from the last record's.
  void record_road(StageContext& ctx, const Frame& frame);
  std::optional<HazardSpec> ask(StageContext& ctx, const Frame& frame, LlmRequest& req, const ReplyChecker& checker,
                                const std::string& prompt_hash, const RoadLayout& road);
  double risk_threshold(const std::vector<const RiskAssessment*>& risks, int64_t frame) const;
  // first_safe: whether this frame's ego path turns more than max_turn_deg while a later one turns less.
  bool turns_too_much(StageContext& ctx, const Frame& frame);
  Json frames_tried() const;  // the first_safe frames where no hazard fitted, and why
  void log_nothing_fitted(StageContext& ctx) const;

  std::unique_ptr<LlmProvider> provider_;
  std::string provider_name_;
  std::map<std::string, std::unique_ptr<HazardTemplate>> templates_;
  double horizon_s_ = 6.0;
  double max_under_way_s_ = 0.0;  // the param, or what the clip cannot show (-1)  // templates' duration_s:
                                  // the param, or what is left of the clip at the trigger
  void make_templates(StageContext& ctx, const std::vector<std::string>& registered);
  std::vector<std::string> allowed_kinds_;
  std::vector<HazardKindInfo> kind_infos_;  // of the allowed kinds, in their order
  SceneRules rules_;                        // drawable classes, takeovers, entry, clearance (params)
  Feedback feedback_;                       // failed attempts of earlier runs (param feedback)
  Json spec_schema_;
  std::optional<SchemaValidator> reply_validator_;
  std::optional<SchemaValidator> spec_validator_;
  std::optional<PromptTemplate> prompt_;
  std::optional<PromptTemplate> retry_prompt_;
  LimitsTable limits_;
  ClassPriors sizes_;
  hazard::RoadModel road_;  // as stated (params, scene block)
  bool warned_side_ = false;
  hazard::TtcConventions ttc_;
  std::unique_ptr<JsonLines> calls_;
  std::unique_ptr<JsonLines> road_log_;  // road_file
  Json last_road_;  // its last record's facts and their sources, without the evidence's wording

  std::string trigger_;
  int64_t trigger_frame_ = 0;
  int64_t warmup_frames_ = 5;
  int64_t frames_seen_ = 0;
  bool done_ = false;
  // first_safe: frames tried where no hazard fitted, why, and when the next try may come.
  std::vector<std::pair<int64_t, std::string>> tried_;
  double next_try_s_ = -1e300;
  bool emitted_ = false;
  bool warned_turn_ = false;
  double straight_from_ = -1e300;  // first_safe: where the straighter stretch found by turns_too_much begins
  std::map<int64_t, std::pair<double, double>> people_;  // person tracks seen so far: first and last time
  std::map<int64_t, std::pair<double, double>> recording_people_;  // the same from recording_states
  TrafficBeside traffic_,
      recording_traffic_;  // vehicles travelling the ego's way beside it: so far / recording
  TrafficBeside oncoming_, recording_oncoming_;  // vehicles coming towards the ego beside its lane
  // recording_states by frame index: the whole recording's perception, tracks with their history.
  std::map<int64_t, ObjectStates> recording_frames_;
  std::optional<double> run_start_s_;  // the timestamp of the first frame this run sees
  // Person tracks (first and last time seen), vehicles travelling beside the ego, either way, and each frame's
  // states, in a jsonl sink's file of object states.
  static void read_states_file(const std::filesystem::path& file,
                               std::map<int64_t, std::pair<double, double>>& people, TrafficBeside& traffic,
                               TrafficBeside& oncoming, std::map<int64_t, ObjectStates>& frames);
  // The states a hazard is planned on. Among the run's first frames (fewer than warmup_frames: its own tracks
  // have no velocities yet) each object takes the recording's estimate of it at this frame (recording_states,
  // matched by its box), and the ego its speed and yaw rate; otherwise the run's own.
  ObjectStates planning_states(StageContext& ctx, const Frame& frame, const ObjectStates& live,
                               int64_t seen) const;
  bool warned_skipped_ = false;
};

}  // namespace hf::llm_hazard
