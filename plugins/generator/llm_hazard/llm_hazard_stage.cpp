// LLM-guided hazard generation: prompt, provider call, validation/retry loop and the run records.
#include "llm_hazard_stage.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <fstream>

#include <hazardforge/angles.hpp>
#include <hazardforge/atomic_file.hpp>
#include <hazardforge/error.hpp>
#include <hazardforge/json_text.hpp>
#include <hazardforge/number_text.hpp>
#include <hazardforge/output_path.hpp>
#include <hazardforge/run_signals.hpp>

#include "hazardforge/llm/hash.hpp"
#include "hazardforge/llm/json.hpp"

namespace hf::llm_hazard {

namespace {

// A hazard's horizon when none is stated: what is left of the clip after t, at least 1 s and at most 6 s.
constexpr double kMinHorizonS = 1.0, kMaxHorizonS = 6.0;
double clip_horizon(double end, double t) {
  return std::clamp(end - t, kMinHorizonS, kMaxHorizonS);
}

std::string share_file(const Params& p, const std::string& param, const std::string& rel) {
  std::filesystem::path given = p.get_path(param);
  return given.empty() ? (std::filesystem::path(share_dir()) / rel).string() : given.string();
}

std::string bullet_list(const std::vector<std::string>& items) {
  std::string out;
  for (const std::string& s : items) out += "- " + s + "\n";
  if (!out.empty()) out.pop_back();
  return out;
}

std::string join(const std::vector<std::string>& v, const std::string& sep) {
  std::string out;
  for (const std::string& s : v) out += (out.empty() ? "" : sep) + s;
  return out;
}

Json messages_json(const std::vector<LlmMessage>& messages) {
  Json j = Json::array();
  for (const LlmMessage& m : messages) j.push_back({{"role", m.role}, {"content", m.content}});
  return j;
}

}  // namespace

ComponentInfo LlmHazardGenerator::describe() {
  ComponentInfo i;
  i.name = "llm_hazard";
  i.kind = kind::kGenerator;
  i.summary = "Asks an LLM for a collision-inducing hazard (HazardSpec) when the scene is Safe";
  i.doc =
      "Emits one HazardSpec at the trigger frame (stamped with its timestamp) when every risk input labels "
      "it "
      "Safe. The reply is validated against share/schemas/hazard_spec.schema.json, the class limits in "
      "share/hazard_limits.yaml, road/camera/TTC feasibility and the kind's hazard template; invalid replies "
      "are "
      "sent back with the errors up to max_retries times. Records every call in llm/calls.jsonl and the spec "
      "in "
      "hazard_spec.json.";
  i.inputs = {port<ObjectStates>("states", "tracked objects in the ego frame"),
              multi(port<RiskAssessment>("risk", "risk verdicts; the trigger frame must be Safe for all")),
              port<Frame>("frames", "camera model, ego speed and dataset description")};
  i.outputs = {port<HazardSpec>("hazard", "the accepted hazard, once")};
  i.params = {
      ParamSpec::object("provider", Json{{"name", "offline"}})
          .describe("LLM provider: {name: offline|ollama|openai|..., <provider params>}"),
      ParamSpec::string_list("kinds", {})
          .describe("allowed hazard kinds; empty = every registered hazard_template"),
      ParamSpec::string("force_kind", "").describe("ask for exactly this kind (must be allowed)"),
      ParamSpec::integer("max_retries", 3)
          .range(0, 20)
          .describe("invalid replies sent back before giving up"),
      ParamSpec::integer("seed", 0).describe("sampling seed passed to the provider"),
      ParamSpec::number("temperature", 0.2)
          .range(0, 2)
          .describe("sampling temperature passed to the provider"),
      ParamSpec::integer("max_tokens", 1024).range(64, 32768).describe("reply length limit"),
      ParamSpec::number("target_ttc_s", 1.0).range(0.1, 10).describe("TTC the hazard should reach"),
      ParamSpec::number("ttc_tolerance_s", 0.25).range(0, 5).describe("slack when checking the reached TTC"),
      ParamSpec::string("trigger", "first_safe").one_of({"first_safe", "frame"}).describe("when to generate"),
      ParamSpec::string("road_file", "road.jsonl")
          .describe("the road as settled from the scene block and the footage, one record per frame where a "
                    "fact changes ({frame, timestamp, road: RoadLayout}); '' = none"),
      ParamSpec::integer("trigger_frame", 0)
          .range(0, std::nullopt)
          .describe("frame index for trigger: frame"),
      ParamSpec::integer("warmup_frames", 5)
          .range(0, std::nullopt)
          .describe("frames skipped by first_safe so tracks have velocities"),
      ParamSpec::number("retry_every_s", 1.0)
          .range(0, 3600)
          .describe(
              "first_safe: when no hazard fits a Safe frame (the provider finds none, or every reply stays "
              "invalid), the first Safe frame this much later is tried, while at least 1 s of the clip is "
              "left; 0 = only the first Safe frame"),
      ParamSpec::number("max_turn_deg", 20.0)
          .range(0, 360)
          .describe(
              "first_safe: a Safe frame where the recorded ego path turns by more than this over the "
              "horizon is passed over while a later frame (with at least 3 s of the clip left, or this "
              "frame's horizon if shorter) turns less; hazards are laid out along the ego's path, and in "
              "a bend they leave the view or cross kerbs; 0 = no such rule (needs the recording's ego "
              "track)"),
      ParamSpec::integer("max_trigger_attempts", 8)
          .range(1, 1000)
          .describe("first_safe: frames tried at most (each with up to 1 + max_retries provider calls)"),
      ParamSpec::string("environment", "")
          .from_scene("environment")
          .describe("scene environment for the prompt; empty = dataset description"),
      ParamSpec::string("road_type", "")
          .from_scene("road.type")
          .describe("road type for the prompt, e.g. 'urban two-lane street'"),
      ParamSpec::string("sidewalks", "auto")
          .from_scene("road.sidewalks")
          .one_of({"auto", "yes", "no"})
          .describe("pedestrians allowed"),
      ParamSpec::number("people_seen_s", 1.0)
          .range(0, 3600)
          .describe(
              "sidewalks: auto with no word for or against them in the scene text: people walk here when the "
              "recording shows a person tracked for at least this long (up to the trigger frame); 0 = only "
              "the scene text decides"),
      ParamSpec::number("traffic_seen_s", 1.0)
          .range(0, 3600)
          .describe(
              "multi_lane: auto with no word for or against it in the scene text: several lanes go the ego's "
              "way when the recording shows a vehicle travelling the ego's way in the lane beside it (2-60 m "
              "ahead, 0.6-1.6 lane widths to the side, 3-60 m/s on the ground within 30 degrees of the ego's "
              "heading, beyond its estimator's uncertainty: states without a covariance never count) for at "
              "least this long without a break (up to the trigger frame); 0 = only the scene text decides. "
              "Likewise for the side traffic keeps to, where driving_side is not stated: a whole "
              "vehicle coming towards the ego beside its lane (5-60 m ahead, 0.6-4.5 lane widths to the "
              "side, at least as fast as the ego and 3 m/s, within 30 degrees of the ego's opposite "
              "heading) followed this long puts oncoming traffic on its side (and, where oncoming_lanes "
              "is not stated, in the lanes there); without one traffic keeps right"),
      ParamSpec::string("intersection", "auto")
          .from_scene("road.intersection")
          .one_of({"auto", "yes", "no"})
          .describe("crossing vehicles allowed"),
      ParamSpec::string("multi_lane", "auto")
          .from_scene("road.multi_lane")
          .one_of({"auto", "yes", "no"})
          .describe("cut-ins allowed"),
      ParamSpec::number("sidewalk_width_m", 3.0)
          .from_scene("road.sidewalk_width_m")
          .range(0, 15)
          .describe("sidewalk width beyond the road edge"),
      ParamSpec::boolean("pedestrians_without_sidewalks", false)
          .describe("edge-case tests: a person may appear on a road without sidewalks, on the shoulder "
                    "(sidewalk_width_m beyond the road edge) — e.g. someone who left a broken-down car. "
                    "Relaxes the rule 'no pedestrians without sidewalks' explicitly; the prompt says so"),
      ParamSpec::path("assets_dir", "")
          .from_scene("assets.dir")
          .describe(
              "folder of appearance assets (assets.yaml) the renderer draws from; the hazard's class must "
              "have pictures there or in the default set (share/assets), which the renderer falls back to; "
              "empty = the default set"),
      ParamSpec::path("recording_appearances", "")
          .describe(
              "folder of appearances cut from this recording (assets.yaml; a campaign's scouting run writes "
              "one): the offline planner draws a kind that may be one of their classes as one of them, so the "
              "renderer can draw it with the camera's own picture; empty = every drawable class alike"),
      ParamSpec::path("recording_states", "")
          .describe(
              "JSON-lines file of the whole recording's object states, as the jsonl sink writes them (a "
              "campaign's scouting run): the people and the traffic beside the ego it shows count for "
              "people_seen_s and traffic_seen_s too, when this run sees only a window of the recording; a "
              "hazard made among the run's first warmup_frames frames is planned on its estimates of the "
              "objects and the ego there (the run's own tracks have no velocities yet)"),
      ParamSpec::path("feedback", "")
          .describe(
              "JSON file of failed attempts on this recording, {\"attempts\": [{\"kind\", \"object_class\", "
              "\"spec\" (or null), \"reasons\": [...], \"trigger_frame\", \"seed\"}]}: their reasons go into "
              "the prompt and into the scene context, where the offline planner avoids their designs and, "
              "after one that never became critical or was never re-detected, aims lower or picks larger, "
              "nearer objects; empty = none"),
      ParamSpec::boolean("take_over_tracks", true)
          .describe(
              "a spec may take over a tracked object (track_id, e.g. the real lead of a sudden stop): "
              "ar_renderer removes the real one and draws the hazard in its place, and the verifier fails a "
              "scenario where the drawn one does not hide it; false = such specs are refused (for a "
              "renderer that cannot remove objects)"),
      ParamSpec::number("entry_max_height", 0.07)
          .range(0, 1)
          .describe(
              "a hazard that comes into view fully in the image, on the road and not hidden by a nearer "
              "tracked object must then be at most this tall (share of the image height): far enough to be "
              "first seen small, never popping up close ahead; 0 = no such rule"),
      ParamSpec::number("entry_after_s", 0.5)
          .range(0, 3600)
          .describe("entry_max_height applies to hazards that appear this long or more after the run's first "
                    "frame; one that appears earlier is there from the start of the video, as the real objects "
                    "are"),
      ParamSpec::number("clearance_m", 0.3)
          .range(0, 5)
          .describe("room the hazard's planned path keeps from every tracked object's predicted box (m)"),
      ParamSpec::number("max_under_way_s", -1.0)
          .range(-1, 30)
          .describe("longest under_way_s a spec may give (hazards already under way when they appear, "
                    "for recordings too short to show the whole manoeuvre); passed to the templates; 0 = "
                    "every hazard starts when it appears; -1 = what the clip cannot show: 6 s minus the "
                    "horizon when the clip's end cut the horizon short, else 0"),
      ParamSpec::number("horizon_s", 0.0)
          .range(0, 60)
          .describe(
              "how long hazards are planned/replayed for the TTC check (templates' duration_s); 0 = what "
              "is left of the clip after the trigger (Frame::stream_end), at least 1 s and at most 6 s, "
              "shortened while no hazard fits (min_horizon_s)"),
      ParamSpec::number("min_horizon_s", 0.0)
          .range(0, 60)
          .describe(
              "with the automatic horizon (horizon_s 0): when no hazard fits a frame, shorter horizons "
              "are tried in 1 s steps down to this one, each with up to 1 + max_retries provider calls "
              "(a plan may fit when it ends before a bend or the ego's stop; campaigns set it); 0 = never "
              "shorten"),
      ParamSpec::number("ego_speed_mps", -1.0)
          .from_scene("ego.speed_mps")
          .range(-1, 80)
          .describe("ego speed if the data has none; negative = from ObjectStates / Frame.ego"),
      ParamSpec::path("prompt_template", "")
          .describe("prompt file; empty = share/prompts/hazard_generation.md"),
      ParamSpec::path("retry_template", "")
          .describe("retry message file; empty = share/prompts/hazard_retry.md"),
      ParamSpec::path("schema", "")
          .describe("hazard spec schema; empty = share/schemas/hazard_spec.schema.json"),
      ParamSpec::path("limits", "").describe("kinematic limits per class; empty = share/hazard_limits.yaml"),
      ParamSpec::path("class_sizes", "").describe("object sizes; empty = share/class_sizes.yaml"),
  };
  // Road and TTC conventions, passed on to the hazard templates so both judge the same road.
  for (ParamSpec& p : hazard::RoadModel::params()) i.params.push_back(std::move(p));
  for (ParamSpec& p : hazard::TtcConventions::params()) i.params.push_back(std::move(p));
  return i;
}

Json template_params(const hazard::RoadModel& road, const hazard::TtcConventions& ttc, double horizon_s,
                     double max_under_way_s, const std::string& limits_file, const std::string& sizes_file) {
  // The templates plan on the road the generator settles for each scene (SceneContext::road); their own road
  // params only serve where they are used without one. Lane counts only when stated.
  Json j = {{"limits", limits_file},
            {"class_sizes", sizes_file},
            {"lane_width_m", road.lane_width_m},
            {"kerb_offset_m", road.kerb_offset_m},
            {"driving_side", road.driving_side},
            {"corridor_half_width", ttc.corridor.ego_half_width},
            {"corridor_margin", ttc.corridor.margin},
            {"corridor_path", ttc.corridor.follow_path ? "ego_path" : "straight"},
            {"ego_front_m", ttc.ego_front},
            {"min_closing_mps", ttc.min_closing},
            {"duration_s", horizon_s},
            {"max_under_way_s", max_under_way_s}};
  if (road.lanes_left_stated) j["lanes_left"] = road.lanes_left;
  if (road.lanes_right_stated) j["lanes_right"] = road.lanes_right;
  if (road.oncoming_stated) j["oncoming_lanes"] = road.oncoming_lanes;
  return j;
}

LlmHazardGenerator::LlmHazardGenerator() = default;
LlmHazardGenerator::~LlmHazardGenerator() = default;

// The templates of the allowed kinds, configured with the generator's road, TTC conventions and horizon.
void LlmHazardGenerator::make_templates(StageContext& ctx, const std::vector<std::string>& registered) {
  const Params& p = ctx.params();
  std::string limits_file = share_file(p, "limits", "hazard_limits.yaml");
  std::string sizes_file = share_file(p, "class_sizes", "class_sizes.yaml");
  templates_.clear();
  const Json shared =
      template_params(road_, ttc_, horizon_s_, max_under_way_s_, limits_file, sizes_file);
  for (const std::string& k : allowed_kinds_)
    if (std::find(registered.begin(), registered.end(), k) == registered.end())
      ctx.log(LogLevel::kWarning,
              "no hazard_template '" + k + "' is registered: the generic kinematic checks apply");
  // Every registered kind, allowed or not: the reply's extra fields are those of all of them (a model may
  // fill another kind's field with null), and the allowed ones check and propose.
  for (const std::string& k : registered) {
    try {
      templates_[k] = ctx.components().create<HazardTemplate>(kind::kHazardTemplate, k, shared);
    } catch (const DiagnosticError&) {
      // Not built on the shared template kit: it declares its own params and keeps its own defaults.
      templates_[k] = ctx.components().create<HazardTemplate>(kind::kHazardTemplate, k, Json::object());
      ctx.log(LogLevel::kWarning, "hazard_template '" + k +
                                      "' does not take the road/TTC params; it checks with its own defaults");
    }
  }
}

namespace {

// An object state as the jsonl sink writes it (its covariance from the 1-sigma values it keeps).
ObjectState state_from_record(const Json& o) {
  ObjectState s;
  s.track_id = o["track_id"].get<int64_t>();
  s.label = o.value("label", "");
  auto number = [&](const char* key, double fallback) {
    return o.contains(key) && o[key].is_number() ? o[key].get<double>() : fallback;
  };
  s.distance_m = number("distance_m", std::nan(""));
  s.lateral_m = number("lateral_m", 0.0);
  s.width_m = number("width_m", 0.0);
  s.length_m = number("length_m", 0.0);
  s.age = static_cast<int>(number("age", 0.0));
  s.in_path = o.value("in_path", false);
  s.distance_method = o.value("distance_method", "");
  if (o.contains("speed_mps") && o["speed_mps"].is_number()) s.speed_mps = o["speed_mps"].get<double>();
  if (o.contains("heading_rad") && o["heading_rad"].is_number()) s.heading_rad = o["heading_rad"].get<double>();
  if (o.contains("scale_rate") && o["scale_rate"].is_number()) s.scale_rate = o["scale_rate"].get<double>();
  const Json b = o.value("box", Json());
  if (b.is_array() && b.size() == 4 && std::all_of(b.begin(), b.end(), [](const Json& x) { return x.is_number(); }))
    s.box = cv::Rect2f(b[0].get<float>(), b[1].get<float>(), b[2].get<float>(), b[3].get<float>());
  if (o.contains("truncated") && o["truncated"].is_number_unsigned())
    s.truncated = o["truncated"].get<unsigned>();
  const Json v = o.value("velocity_rel", Json());
  if (v.is_array() && v.size() == 2 && v[0].is_number() && v[1].is_number())
    s.velocity_rel = cv::Vec2d(v[0].get<double>(), v[1].get<double>());
  const Json sg = o.value("sigma", Json());
  if (sg.is_object() && sg.contains("velocity_rel") && sg["velocity_rel"].is_array() &&
      sg["velocity_rel"].size() == 2 && sg["velocity_rel"][0].is_number() &&
      sg["velocity_rel"][1].is_number()) {
    cv::Matx44d P = cv::Matx44d::zeros();
    const double sd = sg.value("distance_m", 0.0), sl = sg.value("lateral_m", 0.0);
    P(0, 0) = sd * sd;
    P(1, 1) = sl * sl;
    P(2, 2) = std::pow(sg["velocity_rel"][0].get<double>(), 2);
    P(3, 3) = std::pow(sg["velocity_rel"][1].get<double>(), 2);
    s.covariance = P;
  }
  return s;
}

}  // namespace

void LlmHazardGenerator::read_states_file(const std::filesystem::path& file,
                                          std::map<int64_t, std::pair<double, double>>& people,
                                          TrafficBeside& traffic, TrafficBeside& oncoming,
                                          std::map<int64_t, ObjectStates>& frames) {
  std::ifstream in(file);
  if (!in) throw Error("recording_states: cannot read " + file.string());
  std::string line;
  int64_t n = 0;
  while (std::getline(in, line)) {
    ++n;
    if (line.find_first_not_of(" \t\r") == std::string::npos) continue;
    const Json j = Json::parse(line, nullptr, false);
    if (j.is_discarded() || !j.is_object() || !j.contains("timestamp") || !j["timestamp"].is_number())
      throw Error(file.string() + ":" + std::to_string(n) +
                  ": not a record of the jsonl sink (a JSON object with a numeric 'timestamp')");
    const double t = j["timestamp"].get<double>();
    for (const auto& [key, value] : j.items()) {
      if (!value.is_object() || !value.contains("objects") || !value["objects"].is_array()) continue;
      ObjectStates states;
      for (const Json& o : value["objects"]) {
        if (!o.is_object() || !o.contains("track_id") || !o["track_id"].is_number_integer() ||
            o["track_id"].get<int64_t>() < 0)
          continue;
        if (o.value("label", "") == "person") {
          auto [it, added] = people.try_emplace(o["track_id"].get<int64_t>(), std::make_pair(t, t));
          if (!added) {
            it->second.first = std::min(it->second.first, t);
            it->second.second = std::max(it->second.second, t);
          }
        }
        states.objects.push_back(state_from_record(o));
      }
      const Json ego = value.value("ego_speed_mps", Json());
      if (ego.is_number()) {
        traffic.add(t, states, ego.get<double>());
        oncoming.add(t, states, ego.get<double>());
        states.ego_speed_mps = ego.get<double>();
      }
      if (const Json yaw = value.value("ego_yaw_rate", Json()); yaw.is_number())
        states.ego_yaw_rate = yaw.get<double>();
      states.distance_origin_x = value.value("distance_origin_x", 0.0);
      states.timestamp = t;
      if (const Json f = value.contains("frame") ? value["frame"] : j.value("frame", Json()); f.is_number_integer()) {
        states.frame_index = f.get<int64_t>();
        frames[states.frame_index] = std::move(states);
      }
    }
  }
}

void LlmHazardGenerator::open(StageContext& ctx) {
  const Params& p = ctx.params();

  // Provider: {name: ..., rest = its own params}.
  Json provider_params = p.raw("provider");
  if (!provider_params.is_object() || !provider_params.contains("name") ||
      !provider_params["name"].is_string())
    throw Error("param 'provider' needs a 'name' (e.g. {name: offline})");
  provider_name_ = provider_params["name"].get<std::string>();
  provider_params.erase("name");
  provider_ = ctx.components().create<LlmProvider>(kind::kLlmProvider, provider_name_, provider_params);

  // Allowed kinds: the param, else every registered template.
  std::vector<std::string> registered = ctx.components().component_names(kind::kHazardTemplate);
  allowed_kinds_ = p.get_strings("kinds");
  if (allowed_kinds_.empty()) allowed_kinds_ = registered;
  if (allowed_kinds_.empty())
    throw Error(
        "no hazard kinds to choose from: no hazard_template component is registered and param "
        "'kinds' is empty");
  std::string force = p.get_string("force_kind");
  if (!force.empty()) {
    if (std::find(allowed_kinds_.begin(), allowed_kinds_.end(), force) == allowed_kinds_.end())
      throw Error("force_kind '" + force + "' is not among the allowed kinds (" + join(allowed_kinds_, ", ") +
                  ")");
    allowed_kinds_ = {force};
  }
  road_ = hazard::RoadModel::from(p);
  ttc_ = hazard::TtcConventions::from(p);
  std::string limits_file = share_file(p, "limits", "hazard_limits.yaml");
  std::string sizes_file = share_file(p, "class_sizes", "class_sizes.yaml");
  horizon_s_ = p.get_double("horizon_s") > 0 ? p.get_double("horizon_s") : 6.0;
  max_under_way_s_ = std::max(0.0, p.get_double("max_under_way_s"));
  make_templates(ctx, registered);
  // What the allowed kinds say about themselves: the prompt's kind list, the reply's extra fields, the
  // conditions the scene must meet.
  kind_infos_.clear();
  for (const std::string& k : allowed_kinds_) {
    kind_infos_.push_back(kind_info_of(templates_, k));
    for (const std::string& need : kind_infos_.back().needs)
      if (!known_condition(need))
        throw Error(
            "hazard_template '" + k + "' needs the scene condition '" + need +
            "', which this generator does not know (known: sidewalks, same_direction_lane, oncoming_lane, "
            "intersection, tracked_lead)");
  }
  std::vector<HazardKindInfo> all_kinds = kind_infos_;
  for (const std::string& k : registered)
    if (std::find(allowed_kinds_.begin(), allowed_kinds_.end(), k) == allowed_kinds_.end())
      all_kinds.push_back(kind_info_of(templates_, k));
  // What the renderer can draw: a model is offered only those classes.
  const std::filesystem::path assets_dir = p.get_path("assets_dir");
  rules_ = SceneRules();
  rules_.asset_classes = asset_classes(assets_dir.string());
  rules_.assets_where = assets_dir.empty() ? "the default set, share/assets"
                                           : assets_dir.string() + " and the default set, share/assets";
  rules_.recording_classes = own_asset_classes(p.get_path("recording_appearances").string());
  if (!p.get_path("recording_appearances").empty()) ctx.record_resource(p.get_path("recording_appearances"));
  rules_.take_over_tracks = p.get_bool("take_over_tracks");
  rules_.entry_max_height = p.get_double("entry_max_height");
  rules_.clearance_m = p.get_double("clearance_m");
  recording_people_.clear();
  recording_frames_.clear();
  run_start_s_.reset();
  traffic_ = recording_traffic_ = TrafficBeside(road_.lane_width_m);
  oncoming_ = recording_oncoming_ = TrafficBeside(road_.lane_width_m, TrafficBeside::Flow::kOncoming);
  if (const std::filesystem::path rs = p.get_path("recording_states"); !rs.empty()) {
    read_states_file(rs, recording_people_, recording_traffic_, recording_oncoming_, recording_frames_);
    ctx.record_resource(rs);
  }
  const std::filesystem::path feedback_file = p.get_path("feedback");
  feedback_ = feedback_file.empty() ? Feedback() : Feedback::load(feedback_file.string());
  if (!feedback_file.empty()) ctx.record_resource(feedback_file);
  std::string schema_file = share_file(p, "schema", "schemas/hazard_spec.schema.json");
  spec_schema_ = with_kind_fields(load_schema_file(schema_file), all_kinds);
  Json replies = reply_schema(spec_schema_, allowed_kinds_);
  Json drawable = Json::array();
  for (const Json& c : replies["properties"]["object_class"]["enum"])
    if (std::find(rules_.asset_classes.begin(), rules_.asset_classes.end(), c.get<std::string>()) !=
        rules_.asset_classes.end())
      drawable.push_back(c);
  if (drawable.empty())
    throw Error("no object class of the hazard spec schema has appearance assets (" + rules_.assets_where +
                ")");
  replies["properties"]["object_class"]["enum"] = drawable;
  reply_validator_.emplace(std::move(replies));
  spec_validator_.emplace(spec_schema_);
  prompt_ = PromptTemplate::load(share_file(p, "prompt_template", "prompts/hazard_generation.md"));
  retry_prompt_ = PromptTemplate::load(share_file(p, "retry_template", "prompts/hazard_retry.md"));
  limits_ = LimitsTable::load(limits_file);
  sizes_ = ClassPriors::load(sizes_file);
  for (const std::string& f : {schema_file, prompt_->name(), retry_prompt_->name(), limits_file})
    ctx.record_resource(f);

  trigger_ = p.get_string("trigger");
  trigger_frame_ = p.get_int("trigger_frame");
  warmup_frames_ = p.get_int("warmup_frames");
  calls_ = std::make_unique<JsonLines>(resolve_output_path(
      ctx.output_dir(), "llm/calls.jsonl", "node '" + ctx.node_id() + "': the LLM call record"));
  if (!p.get_string("road_file").empty()) road_log_ = std::make_unique<JsonLines>(output_param_path(ctx, "road_file"));
  ctx.log(LogLevel::kInfo,
          "hazards from " + provider_->describe_backend() + "; kinds: " + join(allowed_kinds_, ", "));
}

namespace {

// Each retry re-sends the whole conversation: a huge reply echoed as is would be sent again with every
// attempt (and recorded with every call), so only its beginning goes back to the model.
constexpr size_t kMaxEchoedReply = 8000;

std::string echoed_reply(const std::string& reply) {
  if (reply.size() <= kMaxEchoedReply) return reply;
  return reply.substr(0, kMaxEchoedReply) + "\n[... reply cut here: " + std::to_string(reply.size()) +
         " bytes in all]";
}

}  // namespace

void LlmHazardGenerator::process(StageContext& ctx, const Inputs& in, Outputs& out) {
  const Frame& frame = in.require<Frame>("frames");
  const ObjectStates& states = in.require<ObjectStates>("states");
  std::vector<const RiskAssessment*> risks;
  for (const Packet* pk : in.packets("risk"))
    if (pk && !pk->empty()) risks.push_back(&pk->get<RiskAssessment>());
  const int64_t seen = frames_seen_++;
  if (!run_start_s_) run_start_s_ = frame.timestamp;

  for (const ObjectState& o : states.objects) {  // people the recording shows, for the sidewalks' auto rule
    if (o.label != "person" || o.track_id < 0) continue;
    auto [it, added] = people_.try_emplace(o.track_id, std::make_pair(frame.timestamp, frame.timestamp));
    if (!added) it->second.second = frame.timestamp;
  }
  if (const double ego = ego_speed(frame, states); ego >= 0) {
    traffic_.add(frame.timestamp, states, ego);
    oncoming_.add(frame.timestamp, states, ego);
  }
  record_road(ctx, frame);
  if (done_) return;
  if (trigger_ == "first_safe" && (seen < warmup_frames_ || frame.timestamp < next_try_s_ - 1e-9)) return;
  if (trigger_ == "frame" && frame.index != trigger_frame_) return;
  if (risks.empty())
    throw Error("frame " + std::to_string(frame.index) +
                " has no risk input; connect at least one risk metric to 'risk'");

  std::string unsafe;
  for (const RiskAssessment* r : risks)
    if (r->label == SafetyLabel::kUnsafe)
      unsafe += (unsafe.empty() ? "" : ", ") + r->metric + " = " + num_text(r->scene_value) + " " + r->unit +
                " (threshold " + num_text(r->threshold) + ")";
  if (!unsafe.empty()) {
    if (trigger_ == "frame") {
      ctx.log(LogLevel::kWarning, "frame " + std::to_string(frame.index) + " is Unsafe (" + unsafe +
                                      "): it is already critical, no hazard generated");
      done_ = true;
    }
    return;
  }

  if (trigger_ == "first_safe" && !tried_.empty() && frame.stream_end &&
      *frame.stream_end - frame.timestamp < kMinHorizonS) {
    done_ = true;  // less than the shortest horizon left; finish() says what was tried
    return;
  }
  if (trigger_ == "first_safe" && turns_too_much(ctx, frame)) return;
  std::optional<HazardSpec> spec;
  try {
    spec = generate_shortening(ctx, frame, planning_states(ctx, frame, states, seen), risks);
  } catch (const NoHazardFits& e) {
    if (trigger_ == "frame") throw;
    tried_.emplace_back(frame.index, e.what());
    const Params& p = ctx.params();
    const double every = p.get_double("retry_every_s");
    if (every <= 0 || static_cast<int64_t>(tried_.size()) >= p.get_int("max_trigger_attempts")) {
      done_ = true;  // finish() says what was tried
      return;
    }
    next_try_s_ = frame.timestamp + every;
    ctx.log(LogLevel::kWarning, "frame " + std::to_string(frame.index) + ": " + e.what() +
                                    "; trying a Safe frame from t = " + num_text(next_try_s_) + " s on");
    return;
  }
  done_ = true;
  if (spec) {
    emitted_ = true;
    spec->horizon_s = horizon_s_;
    spec->max_under_way_s = max_under_way_s_;
    out.emit("hazard", std::move(*spec));
  }
}

namespace {

// How far the ego's recorded heading turns from t over the hazard's horizon (what is left of the clip, at
// most 6 s, or the stated horizon), degrees.
double turn_deg(const EgoTrack& track, double t, double end, double horizon_s) {
  const double h = horizon_s > 0 ? horizon_s : clip_horizon(end, t);
  return rad_to_deg(std::abs(track.heading_change(t, std::min(t + h, end))));
}

}  // namespace

bool LlmHazardGenerator::turns_too_much(StageContext& ctx, const Frame& frame) {
  const double max_turn = ctx.params().get_double("max_turn_deg");
  if (max_turn <= 0 || !frame.ego_track || frame.ego_track->samples.size() < 2) return false;
  if (frame.timestamp < straight_from_ - 1e-9) return true;  // the straighter stretch found earlier is ahead
  const EgoTrack& track = *frame.ego_track;
  const double end = frame.stream_end ? *frame.stream_end : track.samples.back().t;
  const double horizon = ctx.params().get_double("horizon_s");
  const double here = turn_deg(track, frame.timestamp, end, horizon);
  if (here <= max_turn) return false;
  // Passed over only when a later moment of the clip is straighter over a horizon that is not much shorter
  // (at least 3 s, or this frame's if shorter): near the clip's end every short horizon looks straight.
  const double need_left = horizon > 0 ? horizon : std::min(3.0, clip_horizon(end, frame.timestamp));
  const auto later = std::upper_bound(track.samples.begin(), track.samples.end(), frame.timestamp + 1e-9,
                                      [](double t, const EgoTrackSample& s) { return t < s.t; });
  for (auto it = later; it != track.samples.end(); ++it) {
    const EgoTrackSample& s = *it;
    if (end - s.t < need_left - 1e-9) break;  // later samples leave even less
    if (turn_deg(track, s.t, end, horizon) <= max_turn) {
      if (!warned_turn_)
        ctx.log(LogLevel::kInfo,
                "frame " + std::to_string(frame.index) + ": the ego path turns " + num_text(here) +
                    " deg over the horizon (max_turn_deg " + num_text(max_turn) +
                    "); waiting for the straighter stretch from t = " + num_text(s.t) + " s");
      warned_turn_ = true;
      straight_from_ = s.t;
      return true;
    }
  }
  return false;
}

Json LlmHazardGenerator::frames_tried() const {
  Json j = Json::array();
  for (const auto& [f, why] : tried_) j.push_back({{"frame_index", f}, {"why", why}});
  return j;
}

void LlmHazardGenerator::log_nothing_fitted(StageContext& ctx) const {
  std::string frames;
  for (const auto& [f, why] : tried_) frames += (frames.empty() ? "" : ", ") + std::to_string(f);
  ctx.log(LogLevel::kWarning, "no hazard generated: none fitted the scene at frame(s) " + frames +
                                  " (the last: " + tried_.back().second + ")");
}

void LlmHazardGenerator::finish(StageContext& ctx, Outputs&) {
  if (!tried_.empty() && !emitted_) {
    log_nothing_fitted(ctx);
    return;
  }
  if (done_) return;
  if (trigger_ == "frame")
    ctx.log(LogLevel::kWarning, "no hazard generated: frame " + std::to_string(trigger_frame_) +
                                    " never arrived (" + std::to_string(frames_seen_) + " frames seen)");
  else
    ctx.log(LogLevel::kWarning, "no hazard generated: no frame after the " + std::to_string(warmup_frames_) +
                                    " warm-up frames was Safe (" + std::to_string(frames_seen_) +
                                    " frames seen)");
}

double LlmHazardGenerator::ego_speed(const Frame& frame, const ObjectStates& states) const {
  if (states.ego_speed_mps && std::isfinite(*states.ego_speed_mps)) return *states.ego_speed_mps;
  if (frame.ego.speed_mps && std::isfinite(*frame.ego.speed_mps)) return *frame.ego.speed_mps;
  return -1.0;
}

double LlmHazardGenerator::risk_threshold(const std::vector<const RiskAssessment*>& risks,
                                          int64_t frame) const {
  for (const RiskAssessment* r : risks)
    if (r->unit == "s" && r->lower_is_riskier) return r->threshold;
  throw Error("frame " + std::to_string(frame) +
              ": no time-to-collision risk input (unit 's'); the hazard's target TTC needs one");
}

// With the automatic horizon, a frame where no hazard fits is tried again with shorter horizons (1 s steps
// down to min_horizon_s; what the clip cannot show is then under way when the hazard appears): a plan that
// would run on into a bend, a junction or the ego's stop may fit when it ends before. The error is the
// longest horizon's, the one that says most about the scene; the shorter ones' are in the log.
std::optional<HazardSpec> LlmHazardGenerator::generate_shortening(
    StageContext& ctx, const Frame& frame, const ObjectStates& states,
    const std::vector<const RiskAssessment*>& risks) {
  const Params& p = ctx.params();
  const double shortest = p.get_double("min_horizon_s");
  std::optional<NoHazardFits> first;
  for (double cap = kMaxHorizonS;; cap = horizon_s_ - 1.0) {
    try {
      return generate(ctx, frame, states, risks, cap);
    } catch (const NoHazardFits& e) {
      if (!first) first = e;
      if (p.get_double("horizon_s") > 0 || shortest <= 0 || horizon_s_ - 1.0 < shortest - 1e-9) throw *first;
      ctx.log(LogLevel::kWarning, "frame " + std::to_string(frame.index) + ", horizon " +
                                      num_text(horizon_s_) + " s: " + e.what() + "; trying a horizon of " +
                                      num_text(horizon_s_ - 1.0) + " s");
    }
  }
}

// The scene's facts as stated and as the recording shows them: its words, sidewalks, intersection, the lanes
// each side, the side traffic keeps to, several lanes the ego's way. The road every check, the prompt, the
// templates and the export then share (road_layout).
SceneSettings LlmHazardGenerator::read_scene(StageContext& ctx, const Frame& frame) {
  const Params& p = ctx.params();
  SceneSettings s;
  s.description = frame.origin.description;
  s.environment = p.get_string("environment");
  if (s.environment.empty()) s.environment = s.description.empty() ? "unknown" : s.description;
  s.road_type = p.get_string("road_type");
  if (s.road_type.empty()) s.road_type = "unknown";
  const std::string text = s.environment + " " + s.road_type + " " + s.description;
  s.sidewalks = resolve_sidewalks(p.get_string("sidewalks"), text);
  if (const double seen_s = p.get_double("people_seen_s");
      seen_s > 0 && p.get_string("sidewalks") == "auto" && !s.sidewalks.value &&
      s.sidewalks.why.rfind("auto: nothing", 0) == 0) {
    int64_t longest = -1;
    double longest_s = 0;
    bool whole = false;  // found in the whole recording's states rather than in this run's frames
    for (const auto* seen : {&people_, &recording_people_})
      for (const auto& [id, span] : *seen)
        if (span.second - span.first > longest_s)
          longest = id, longest_s = span.second - span.first, whole = seen == &recording_people_;
    if (longest >= 0 && longest_s >= seen_s - 1e-9)
      s.sidewalks = {true, "auto: the recording shows people (person track " + std::to_string(longest) +
                               " followed for " + num_text(longest_s) + " s" +
                               (whole ? " in " + p.get_path("recording_states").filename().string() : "") +
                               ")"};
  }
  s.intersection = resolve_intersection(p.get_string("intersection"), text);
  // The lanes each side and the side traffic keeps to: stated, else what the footage's lane markings and
  // traffic show, else the defaults.
  const double traffic_seen_s = p.get_double("traffic_seen_s");
  auto longer = [](const TrafficBeside& a, const TrafficBeside& b) {
    const TrafficBeside::Seen x = a.longest(), y = b.longest();
    return y.seconds > x.seconds ? y : x;
  };
  const ResolvedRoad resolved =
      resolve_road(road_, frame.road_markings.get(), longer(oncoming_, recording_oncoming_),
                   longer(traffic_, recording_traffic_), traffic_seen_s);
  s.road = resolved.road;
  s.driving_side_why = resolved.driving_side_why;
  if (!resolved.conflict.empty() && !warned_side_) {
    ctx.log(LogLevel::kWarning, resolved.conflict);
    warned_side_ = true;
  }
  s.multi_lane = resolve_multi_lane(p.get_string("multi_lane"), text);
  if (p.get_string("multi_lane") == "auto" && !s.multi_lane.value &&
      s.multi_lane.why.rfind("auto: nothing", 0) == 0 && frame.road_markings) {
    // A dashed line beside the ego lane bounds a lane going its way (a yellow one parts opposing traffic),
    // where the scene states nothing about that side.
    for (const int side : {-1, 1}) {
      const LaneMarkingSide& m = side > 0 ? frame.road_markings->left : frame.road_markings->right;
      const bool stated = side > 0 ? s.road.lanes_left_stated : s.road.lanes_right_stated;
      if (!stated && m.boundary == "dashed" && s.road.same_direction_lanes(side) > 0) {
        s.multi_lane = {true, "auto: the footage shows a dashed " + m.colour + " lane line " +
                                  (side > 0 ? "left" : "right") + " of the ego lane in " +
                                  std::to_string(static_cast<int>(std::lround(100 * m.seen_share))) +
                                  " % of " + std::to_string(frame.road_markings->frames) + " frames"};
        break;
      }
    }
  }
  if (const double seen_s = traffic_seen_s; seen_s > 0 && p.get_string("multi_lane") == "auto" &&
                                            !s.multi_lane.value &&
                                            s.multi_lane.why.rfind("auto: nothing", 0) == 0) {
    const TrafficBeside::Seen here = traffic_.longest(), there = recording_traffic_.longest();
    const bool whole = there.seconds > here.seconds;
    const TrafficBeside::Seen& seen = whole ? there : here;
    if (seen.track >= 0 && seen.seconds >= seen_s - 1e-9)
      s.multi_lane = {true,
                      "auto: the recording shows a " + seen.label + " travelling the ego's way in the lane " +
                          (seen.side > 0 ? "left" : "right") + " of it (track " + std::to_string(seen.track) +
                          ", followed for " + num_text(seen.seconds) + " s" +
                          (whole ? " in " + p.get_path("recording_states").filename().string() : "") + ")"};
  }
  s.sidewalk_width_m = p.get_double("sidewalk_width_m");
  s.pedestrians_without_sidewalks = p.get_bool("pedestrians_without_sidewalks");
  return s;
}

ObjectStates LlmHazardGenerator::planning_states(StageContext& ctx, const Frame& frame, const ObjectStates& live,
                                                 int64_t seen) const {
  if (seen >= warmup_frames_) return live;
  const auto at = recording_frames_.find(frame.index);
  if (at == recording_frames_.end()) return live;
  const ObjectStates& rec = at->second;
  if (rec.distance_origin_x != live.distance_origin_x) return live;  // another estimator's frame
  ObjectStates out = live;
  if (rec.ego_speed_mps) out.ego_speed_mps = rec.ego_speed_mps;
  if (rec.ego_yaw_rate) out.ego_yaw_rate = rec.ego_yaw_rate;
  int matched = 0;
  for (ObjectState& o : out.objects) {
    // The same detection in both passes: the same label and nearly the same box.
    const ObjectState* best = nullptr;
    double best_iou = 0.7;
    for (const ObjectState& r : rec.objects) {
      if (r.label != o.label) continue;
      const double inter = (r.box & o.box).area(), uni = r.box.area() + o.box.area() - inter;
      if (uni > 0 && inter / uni > best_iou) best = &r, best_iou = inter / uni;
    }
    if (!best) continue;
    const int64_t id = o.track_id;
    const cv::Rect2f box = o.box;
    const float score = o.score;
    o = *best;  // its estimate with the track's history
    o.track_id = id, o.box = box, o.score = score;
    ++matched;
  }
  ctx.log(LogLevel::kInfo, "frame " + std::to_string(frame.index) + " is the run's frame " +
                               std::to_string(seen + 1) + ": planned on recording_states' estimates there (" +
                               std::to_string(matched) + " of " + std::to_string(out.objects.size()) +
                               " objects matched, ego speed " +
                               (out.ego_speed_mps ? num_text(*out.ego_speed_mps) + " m/s" : std::string("unknown")) +
                               ")");
  return out;
}

void LlmHazardGenerator::record_road(StageContext& ctx, const Frame& frame) {
  if (!road_log_) return;
  Json road = road_layout(read_scene(ctx, frame));
  road.erase("environment");  // the scene's words, the same on every frame
  // The facts and what each rests on; the evidence's wording (a track followed for longer) is not a change.
  Json facts = road;
  for (auto& [field, source] : facts["sources"].items()) source.erase("why");
  if (facts == last_road_) return;
  road_log_->append({{"frame", frame.index}, {"timestamp", frame.timestamp}, {"road", road}});
  last_road_ = std::move(facts);
}

std::optional<HazardSpec> LlmHazardGenerator::generate(StageContext& ctx, const Frame& frame,
                                                       const ObjectStates& states,
                                                       const std::vector<const RiskAssessment*>& risks,
                                                       double horizon_cap) {
  const Params& p = ctx.params();

  SceneSettings s = read_scene(ctx, frame);
  s.allowed_kinds = allowed_kinds_;
  s.kinds = kind_infos_;
  s.rules = rules_;
  s.rules.distance_origin_x = states.distance_origin_x;
  // Appearing with the video's first frames, the hazard is there from the start like the real objects.
  if (frame.timestamp - run_start_s_.value_or(frame.timestamp) < p.get_double("entry_after_s"))
    s.rules.entry_max_height = 0.0;
  s.feedback = feedback_;
  s.target_ttc_s = p.get_double("target_ttc_s");
  s.ttc_tolerance_s = p.get_double("ttc_tolerance_s");
  s.threshold_s = risk_threshold(risks, frame.index);
  if (s.target_ttc_s >= s.threshold_s)
    throw Error("target_ttc_s = " + num_text(s.target_ttc_s) + " is not below the risk threshold " +
                num_text(s.threshold_s) + " s, so no hazard could make the scene Unsafe");
  s.ego_speed_mps = ego_speed(frame, states);
  if (s.ego_speed_mps < 0) s.ego_speed_mps = p.get_double("ego_speed_mps");
  if (s.ego_speed_mps < 0)
    throw Error("the ego speed at frame " + std::to_string(frame.index) +
                " is unknown (neither ObjectStates nor the frame carry it); set param ego_speed_mps");
  if (p.get_double("horizon_s") <= 0) {
    // What is left of the clip: a hazard planned beyond its end could never be seen. Shorter when a longer
    // one fitted no hazard (process()).
    const double left = frame.stream_end ? clip_horizon(*frame.stream_end, frame.timestamp) : kMaxHorizonS;
    const double horizon = std::min(left, horizon_cap);
    const double under_way = p.get_double("max_under_way_s") < 0 ? kMaxHorizonS - horizon : max_under_way_s_;
    if (std::abs(horizon - horizon_s_) > 1e-9 || std::abs(under_way - max_under_way_s_) > 1e-9) {
      horizon_s_ = horizon;
      max_under_way_s_ = under_way;
      make_templates(ctx, ctx.components().component_names(kind::kHazardTemplate));
    }
    ctx.log(LogLevel::kInfo, "horizon " + num_text(horizon_s_) + " s: " +
                                 (horizon < left - 1e-9 ? "shortened from the " + num_text(left) + " s"
                                                        : std::string("what is")) +
                                 " left of the clip after frame " + std::to_string(frame.index) +
                                 " (at least 1 s, at most 6 s); hazards may be under way for up to " +
                                 num_text(max_under_way_s_) + " s when they appear");
  }
  s.horizon_s = horizon_s_;
  s.max_under_way_s = max_under_way_s_;
  s.ttc = ttc_;
  ctx.log(LogLevel::kInfo,
          "frame " + std::to_string(frame.index) + " is Safe: generating a hazard (sidewalks " +
              (s.sidewalks.value ? "yes" : "no") + ", " + s.sidewalks.why + "; intersection " +
              (s.intersection.value ? "yes" : "no") + ", " + s.intersection.why + "; multi-lane " +
              (s.multi_lane.value ? "yes" : "no") + ", " + s.multi_lane.why + "; lanes left " +
              std::to_string(s.road.lanes_left) + ", right " + std::to_string(s.road.lanes_right) + ", " +
              s.road.lanes_from + "; traffic keeps " + s.road.driving_side + ", " + s.driving_side_why + ")");

  SceneSummary scene = summarize_scene(frame, states, risks, s, limits_, sizes_);
  const FeasibilityConfig fc = feasibility_config(
      s, limits_, sizes_, frame.timestamp, states.ego_yaw_rate ? states.ego_yaw_rate : frame.ego.yaw_rate);
  std::map<std::string, std::string> values = scene.placeholders;
  values["schema"] = reply_validator_->schema().dump(2);
  const std::string prompt = prompt_->render(values);
  const std::string prompt_hash = llm::sha256_hex(prompt);

  // One verdict for the model's replies and the offline provider's plans.
  const ReplyChecker checker(*reply_validator_, templates_, scene.context, fc);
  const ProposalRequest proposal = proposal_request(s, scene.context);
  const TemplateCatalog catalog(checker, allowed_kinds_, proposal, rules_.recording_classes);

  LlmRequest req;
  req.messages = {{"user", prompt}};
  req.response_schema = reply_validator_->schema();
  req.temperature = p.get_double("temperature");
  req.seed = p.get_int("seed");
  req.max_tokens = static_cast<int>(p.get_int("max_tokens"));
  req.scene = scene.scene;
  req.hazards = &catalog;

  return ask(ctx, frame, req, checker, prompt_hash, *scene.context.road);
}

std::optional<HazardSpec> LlmHazardGenerator::ask(StageContext& ctx, const Frame& frame, LlmRequest& req,
                                                  const ReplyChecker& checker, const std::string& prompt_hash,
                                                  const RoadLayout& road) {
  const Params& p = ctx.params();
  const int max_attempts = 1 + static_cast<int>(p.get_int("max_retries"));
  const std::string backend = provider_->describe_backend();
  std::vector<Refusal> errors;
  for (int attempt = 1; attempt <= max_attempts; ++attempt) {
    Json record = {{"node", ctx.node_id()},          {"frame_index", frame.index},
                   {"timestamp_s", frame.timestamp}, {"attempt", attempt},
                   {"provider", provider_name_},     {"backend", backend},
                   {"temperature", req.temperature}, {"seed", req.seed},
                   {"prompt_sha256", prompt_hash},   {"messages", messages_json(req.messages)}};
    LlmReply reply;
    auto t0 = std::chrono::steady_clock::now();
    try {
      CancellationScope cancel([&ctx] { return ctx.stop_requested(); });
      reply = provider_->complete(req);
    } catch (const Error& e) {
      record["latency_s"] = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
      record["transport_error"] = e.what();
      record["accepted"] = false;
      if (ctx.stop_requested()) {
        // Ctrl-C, not a server fault: the run ends interrupted with the call on record.
        record["cancelled"] = true;
        calls_->append(record);
        ctx.log(LogLevel::kWarning, "no hazard generated: " + std::string(e.what()));
        return std::nullopt;
      }
      calls_->append(record);
      throw;  // the host names the node; the provider named the endpoint
    }
    const double latency = reply.latency_s > 0
                               ? reply.latency_s
                               : std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    ctx.record_timing("llm_call", latency);
    record["model"] = reply.model;
    record["latency_s"] = latency;
    record["reply"] = reply.content;
    record["response"] = reply.raw;

    errors.clear();
    HazardSpec spec;
    try {
      CheckedReply checked = checker.check(llm::extract_json_object(reply.content));
      if (!checked.skipped.empty() && !warned_skipped_) {
        for (const std::string& note : checked.skipped) ctx.log(LogLevel::kWarning, note);
        warned_skipped_ = true;
      }
      spec = std::move(checked.spec);
      errors = std::move(checked.errors);
    } catch (const Error& e) {
      errors = {{refusal::kSpec, e.what(), ""}};
    }
    record["errors"] = Json::array();
    for (const Refusal& e : errors) record["errors"].push_back(e.text);
    record["accepted"] = errors.empty();
    calls_->append(record);

    if (errors.empty()) {
      spec.schema_version = "1.1";
      spec.provenance = {{"provider", provider_name_},
                         {"backend", backend},
                         {"model", reply.model},
                         {"prompt_sha256", prompt_hash},
                         {"prompt_template", prompt_->name()},
                         {"attempts", attempt},
                         {"retries", attempt - 1},
                         {"seed", req.seed},
                         {"temperature", req.temperature},
                         {"trigger", trigger_},
                         {"frame_index", frame.index},
                         {"calls", "llm/calls.jsonl"}};
      spec.road = road;  // the road the spec was made for: the planner plans and exports lay out on it
      if (!tried_.empty()) spec.provenance["frames_without_a_fit"] = frames_tried();
      Json written = spec;
      if (std::vector<std::string> bad = spec_validator_->validate(written); !bad.empty())
        throw Error("internal error: the accepted spec does not follow the schema: " + join(bad, "; "));
      write_file_atomic(ctx.output_dir() / "hazard_spec.json", json_text(written, 2) + "\n");
      ctx.log(LogLevel::kInfo, "hazard " + spec.kind + " (" + spec.object_class + ") accepted after " +
                                   std::to_string(attempt) + " attempt(s)");
      return spec;
    }
    ctx.log(LogLevel::kWarning, "attempt " + std::to_string(attempt) + " rejected: " + refusal_text(errors));
    if (attempt < max_attempts) {
      std::vector<std::string> texts;
      for (const Refusal& e : errors) texts.push_back(e.text);
      req.messages.push_back({"assistant", echoed_reply(reply.content)});
      req.messages.push_back({"user", retry_prompt_->render({{"errors", bullet_list(texts)}})});
    }
  }
  throw NoHazardFits("no valid hazard spec after " + std::to_string(max_attempts) + " attempt(s) from " +
                         backend + "; last errors: " + refusal_text(errors),
                     errors);
}

}  // namespace hf::llm_hazard
