// Stage and component interfaces: what a plugin implements, and what the host hands it while running.
#pragma once

#include "hazardforge/abi.hpp"

#include <cstdint>
#include <filesystem>
#include <functional>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <type_traits>
#include <vector>

#include "hazardforge/packet.hpp"
#include "hazardforge/params.hpp"
#include "hazardforge/refusal.hpp"
#include "hazardforge/types.hpp"

HF_SDK_BEGIN
namespace hf {

// ---- Ports ---------------------------------------------------------------------------------------------------

inline constexpr const char* kAnyType = "*";

struct PortSpec {
  std::string name;
  std::string type_name;  // payload kTypeName, or "*" for any
  int type_version = 0;   // 0 with "*"
  std::string doc;
  bool optional = false;  // input: the stage runs even when this stream has no packet this frame
  bool sticky = false;    // input: the latest packet is kept and offered on later frames (sparse streams)
  bool multi = false;     // input: accepts a list of streams (e.g. several risk metrics)

  std::string type_str() const;  // "Frame v1" / "*"
};

template <PayloadType T>
PortSpec port(std::string name, std::string doc = {}) {
  return PortSpec{std::move(name), T::kTypeName, T::kTypeVersion, std::move(doc)};
}
inline PortSpec any_port(std::string name, std::string doc = {}) {
  return PortSpec{std::move(name), kAnyType, 0, std::move(doc)};
}
inline PortSpec optional(PortSpec p) {
  p.optional = true;
  return p;
}
inline PortSpec sticky(PortSpec p) {
  p.sticky = true;
  p.optional = true;
  return p;
}
inline PortSpec multi(PortSpec p) {
  p.multi = true;
  return p;
}

// ---- Component description ------------------------------------------------------------------------------------

// Kinds the host knows. Graph nodes are stages (all kinds but the last two); llm_provider and
// hazard_template are components that stages create by name (see ComponentFactory).
namespace kind {
inline constexpr const char* kSource = "source";
inline constexpr const char* kDetector = "detector";
inline constexpr const char* kTracker = "tracker";
inline constexpr const char* kEstimator = "estimator";
inline constexpr const char* kRiskMetric = "risk_metric";
inline constexpr const char* kGenerator = "generator";
inline constexpr const char* kPlanner = "planner";
inline constexpr const char* kRenderer = "renderer";
inline constexpr const char* kVerifier = "verifier";
inline constexpr const char* kSink = "sink";
inline constexpr const char* kFilter = "filter";
inline constexpr const char* kLlmProvider = "llm_provider";
inline constexpr const char* kHazardTemplate = "hazard_template";
inline constexpr const char* kSystem = "system";  // a system under test (hazardforge test)
}  // namespace kind

struct ComponentInfo {
  std::string name;     // lower_snake, unique within its kind
  std::string kind;     // one of hf::kind
  std::string summary;  // one line
  std::string doc;      // longer text: timestamp behaviour, method, references
  std::vector<ParamSpec> params;
  std::vector<PortSpec> inputs;   // stages only
  std::vector<PortSpec> outputs;  // stages only
  bool is_stage = false;          // set by the registrar
  bool is_source = false;         // set by the registrar

  const ParamSpec* param(const std::string& n) const;
  const PortSpec* input(const std::string& n) const;
  const PortSpec* output(const std::string& n) const;
};

// ---- Runtime context ------------------------------------------------------------------------------------------

class Component;

// Lets a stage create components (LLM providers, hazard templates) by kind and name.
class ComponentFactory {
 public:
  virtual ~ComponentFactory();
  // Throws hf::Error naming the kind/name (with a suggestion) or the invalid parameters.
  virtual std::unique_ptr<Component> create_component(const std::string& kind, const std::string& name,
                                                      const Json& params) const = 0;
  virtual std::vector<std::string> component_names(const std::string& kind) const = 0;

  template <class T>
  std::unique_ptr<T> create(const std::string& kind_name, const std::string& name, const Json& params) const;
};

enum class LogLevel { kDebug, kInfo, kWarning, kError };

class StageContext {
 public:
  virtual ~StageContext();
  virtual const std::string& node_id() const = 0;
  virtual const Params& params() const = 0;
  // The run's output folder (created by the host); stages write their artefacts below it.
  virtual const std::filesystem::path& output_dir() const = 0;
  virtual const ComponentFactory& components() const = 0;
  virtual void log(LogLevel level, const std::string& message) const = 0;
  // Index and timestamp of the frame being processed (valid during process/next).
  virtual int64_t frame_index() const = 0;
  virtual double timestamp() const = 0;
  // Records an input file (model, calibration) in the run manifest with its content hash.
  virtual void record_resource(const std::filesystem::path& file) const = 0;
  // Cooperative cancellation (Ctrl-C): long-running stages should check it.
  virtual bool stop_requested() const = 0;
  // Reports the duration of an inner step (e.g. "forward" = bare network inference) for the per-stage
  // latency table and `hazardforge bench`.
  virtual void record_timing(const std::string& label, double seconds) const = 0;
};

// Inputs of one frame. Ports absent this frame return nullptr / empty.
class Inputs {
 public:
  virtual ~Inputs();
  virtual const Packet* packet(const std::string& port) const = 0;
  virtual std::vector<const Packet*> packets(const std::string& port) const = 0;  // multi ports
  // Which upstream node produced each packet of a multi port (same order as packets()).
  virtual std::vector<std::string> producers(const std::string& port) const = 0;

  template <PayloadType T>
  const T* get(const std::string& port) const {
    const Packet* p = packet(port);
    return (p && !p->empty()) ? &p->get<T>() : nullptr;
  }
  template <PayloadType T>
  const T& require(const std::string& port) const {
    const T* v = get<T>(port);
    if (!v) throw Error("input '" + port + "' has no packet for this frame");
    return *v;
  }
};

class Outputs {
 public:
  virtual ~Outputs();
  virtual void emit_packet(const std::string& port, Packet p) = 0;
  virtual double timestamp() const = 0;

  template <PayloadType T>
  void emit(const std::string& port, T value) {
    emit_packet(port, Packet::make<T>(std::move(value), timestamp()));
  }
};

// ---- Components and stages -------------------------------------------------------------------------------------

class Component {
 public:
  virtual ~Component();
};

// A graph node. Lifecycle: open() once (params validated), process() once per frame in timestamp order,
// finish() once at end of stream (may emit final packets stamped with the last frame's time).
// Each instance is called from one thread at a time; different nodes run concurrently.
class Stage : public Component {
 public:
  ~Stage() override;
  virtual void open(StageContext& /*ctx*/) {}
  virtual void process(StageContext& ctx, const Inputs& in, Outputs& out) = 0;
  virtual void finish(StageContext& /*ctx*/, Outputs& /*out*/) {}
};

// Produces the frame stream. The host calls next() until it returns false; each call emits one frame.
class SourceStage : public Stage {
 public:
  virtual bool next(StageContext& ctx, Outputs& out) = 0;
  // Number of frames if known (drives the progress bar's ETA).
  virtual std::optional<int64_t> frame_count() const { return std::nullopt; }
  void process(StageContext&, const Inputs&, Outputs&) final {}
  static ComponentInfo base_info(std::string name, std::string summary);
};

// Typed conveniences for the common stage shapes. Each fixes the port names, so graphs stay uniform.
class Detector : public Stage {
 public:
  virtual Detections detect(StageContext& ctx, const Frame& frame) = 0;
  void process(StageContext& ctx, const Inputs& in, Outputs& out) override;
  static ComponentInfo base_info(std::string name, std::string summary);  // frames -> detections
};

class Tracker : public Stage {
 public:
  virtual Tracks update(StageContext& ctx, const Detections& dets, const Frame& frame) = 0;
  void process(StageContext& ctx, const Inputs& in, Outputs& out) override;
  static ComponentInfo base_info(std::string name, std::string summary);  // detections, frames -> tracks
};

class Estimator : public Stage {
 public:
  virtual ObjectStates estimate(StageContext& ctx, const Tracks& tracks, const Frame& frame) = 0;
  void process(StageContext& ctx, const Inputs& in, Outputs& out) override;
  static ComponentInfo base_info(std::string name, std::string summary);  // tracks, frames -> states
};

class RiskMetric : public Stage {
 public:
  virtual RiskAssessment assess(StageContext& ctx, const ObjectStates& states, const Frame* frame) = 0;
  void process(StageContext& ctx, const Inputs& in, Outputs& out) override;
  // states (+ optional frames) -> risk. Adds the shared corridor and threshold params.
  static ComponentInfo base_info(std::string name, std::string summary);
};

// ---- LLM providers ---------------------------------------------------------------------------------------------

struct LlmMessage {
  std::string role;  // system / user / assistant
  std::string content;
};

class HazardCatalog;

struct LlmRequest {
  std::vector<LlmMessage> messages;
  Json response_schema;      // JSON Schema the reply must follow
  double temperature = 0.2;
  int64_t seed = 0;
  int max_tokens = 1024;
  Json scene = Json::object();  // the structured scene context the prompt was filled from
  // The allowed hazard kinds' templates, as the generator configured them for this scene (valid during
  // complete()): a provider that plans without a model (offline) asks them for proposals and checks its
  // answer with the generator's own rules. nullptr when the caller offers none.
  const HazardCatalog* hazards = nullptr;
};

struct LlmReply {
  std::string content;  // raw text of the model's answer
  std::string model;
  double latency_s = 0.0;
  Json raw = Json::object();  // the full response body, for the run record
};

// Thrown by a provider (and by the generator after its retries) when no hazard fits the scene at this frame:
// a verdict about the scene, not a fault. A generator that triggers on the first Safe frame tries a later
// frame.
class NoHazardFits : public Error {
 public:
  NoHazardFits(const std::string& message, std::vector<Refusal> reasons)
      : Error(message), reasons_(std::move(reasons)) {}
  ~NoHazardFits() override;
  // Why, typed (the host records them in the run's manifest, the campaign counts them).
  const std::vector<Refusal>& reasons() const { return reasons_; }

 private:
  std::vector<Refusal> reasons_;
};

// A text-generation backend. Throws hf::Error (with the endpoint and cause) on transport failures,
// NoHazardFits when it knows that no hazard fits the scene (a planner without a model).
class LlmProvider : public Component {
 public:
  ~LlmProvider() override;
  virtual void open(const Params& params) = 0;
  virtual LlmReply complete(const LlmRequest& request) = 0;
  virtual std::string describe_backend() const = 0;  // e.g. "ollama llama3 @ http://127.0.0.1:11434"
};

// ---- Hazard templates ------------------------------------------------------------------------------------------

struct SceneContext {
  double timestamp = 0.0;
  std::optional<double> ego_speed_mps;
  CameraModel camera;
  std::vector<ObjectState> objects;
  // Ego x (m, from the rear axle) that the objects' distance_m is measured from (ObjectStates::
  // distance_origin_x: the camera, the bumper or the rear axle); distance_m reaches the face the camera sees.
  double distance_origin_x = 0.0;
  std::shared_ptr<const EgoTrack> ego_track;  // the recording's ego motion, when known (Frame::ego_track)
  std::shared_ptr<const RoadMarkings> road_markings;  // the recording's lane markings (Frame::road_markings)
  FrameOrigin origin;                                 // the frame's (Frame::origin)
  // The road settled for this scene (the generator's, or the spec's HazardSpec::road at the planner); absent:
  // the templates' own road, from their params and the lane markings.
  std::optional<RoadLayout> road;
};

// Scene conditions a hazard kind may need (HazardKindInfo::needs). The generator evaluates each on the scene,
// tells the model whether it holds, and refuses a kind whose conditions do not all hold.
namespace scene_condition {
inline constexpr const char* kSidewalks = "sidewalks";  // sidewalks, or people on the shoulder allowed explicitly
inline constexpr const char* kSameDirectionLane = "same_direction_lane";  // a lane beside the ego's, going its way
inline constexpr const char* kOncomingLane = "oncoming_lane";  // a lane beside the ego's with oncoming traffic
inline constexpr const char* kIntersection = "intersection";   // vehicles may cross the ego path
inline constexpr const char* kTrackedLead = "tracked_lead";    // a tracked vehicle ahead in the ego path
}  // namespace scene_condition

// A kind-specific field of HazardSpec::extra (declared by SpecField::declaration()).
struct HazardField {
  std::string name;                // extra.<name>
  Json schema = Json::object();    // JSON Schema of its value, null included ({"type": ["number", "null"]})
  std::string doc;                 // what it means, for the prompt and the reply schema
};

// A field of HazardSpec::extra with its type, declared once by the kind that reads it (api2-style handle): its
// declaration() goes into HazardKindInfo::extra_fields (the prompt, the reply schema), get() reads it from a
// spec and set() writes it into a proposal's JSON. T is double, int64_t, bool or std::string.
template <class T>
class SpecField {
 public:
  // `constraints`: JSON Schema keywords of the value beyond its type ({"minimum": 0}, {"enum": [...]}).
  SpecField(std::string name, std::string doc, Json constraints = Json::object())
      : name_(std::move(name)), doc_(std::move(doc)), constraints_(std::move(constraints)) {}
  const std::string& name() const { return name_; }
  HazardField declaration() const {
    Json schema = constraints_;
    schema["type"] = Json::array({type_name(), "null"});
    if (schema.contains("enum")) schema["enum"].push_back(nullptr);
    return {name_, schema, doc_};
  }
  // The value in spec.extra; nullopt when absent or null. Throws hf::Error naming extra.<name> when it has
  // another type.
  std::optional<T> get(const HazardSpec& spec) const {
    if (!spec.extra.is_object() || !spec.extra.contains(name_) || spec.extra[name_].is_null())
      return std::nullopt;
    const Json& v = spec.extra[name_];
    const bool ok = std::is_same_v<T, bool>          ? v.is_boolean()
                    : std::is_same_v<T, std::string> ? v.is_string()
                    : std::is_same_v<T, int64_t>     ? v.is_number_integer()
                                                     : v.is_number();
    if (!ok) throw Error("extra." + name_ + " must be " + type_name() + " or null, got " + v.dump());
    return v.get<T>();
  }
  // Writes the value into a spec's (or a proposal's) JSON object under extra.<name>.
  void set(Json& spec_json, const T& value) const { spec_json["extra"][name_] = value; }

 private:
  static std::string type_name() {
    if constexpr (std::is_same_v<T, bool>) return "boolean";
    else if constexpr (std::is_same_v<T, std::string>) return "string";
    else if constexpr (std::is_same_v<T, int64_t>) return "integer";
    else return "number";
  }
  std::string name_, doc_;
  Json constraints_;
};

// What a hazard kind is and when it applies. The generator builds the prompt's kind list, the reply schema's
// `extra` fields and its scene checks from it; the offline provider and `hazardforge inspect` show it.
struct HazardKindInfo {
  std::string kind;                         // = hazard_kind()
  std::string summary;                      // what happens, one sentence
  std::string play_out;                     // how the spec's fields are read, for a model (a few sentences)
  std::vector<std::string> object_classes;  // classes the motion makes sense for; empty = any
  std::vector<std::string> needs;           // scene_condition names that must all hold
  std::vector<HazardField> extra_fields;    // extra.* fields the kind reads
};

// Uniform random numbers for proposals. The caller owns the generator; the helpers are defined once in the SDK,
// so the same raw numbers give the same plans with every standard library.
class RandomDraw {
 public:
  virtual ~RandomDraw();
  virtual uint64_t next() = 0;         // 64 uniformly random bits
  double uniform(double lo, double hi);  // [lo, hi), from the top 53 bits
  size_t index(size_t n);              // [0, n), next() % n
  bool coin();                         // the top bit
};

// What a template is asked to propose a hazard for: the scene as the generator sees it and what the hazard
// must achieve. The template's own params (road, TTC conventions, limits, horizon) were set by the generator.
struct ProposalRequest {
  explicit ProposalRequest(const SceneContext& s) : scene(s) {}
  const SceneContext& scene;
  double target_ttc_s = 1.0;
  double aim = 0.85;  // plan for a TTC of aim x target_ttc_s (a margin below the target)
  double horizon_s = 6.0;
  double max_under_way_s = 0.0;  // how long the manoeuvre may already be under way when it appears
  bool sidewalks = false;
  bool pedestrians_on_shoulder = false;  // people allowed beyond the road edge without sidewalks
  bool multi_lane = false;
  bool intersection = false;
  double sidewalk_width_m = 3.0;
  std::vector<std::string> object_classes;  // classes the hazard may have here (appearance assets); empty = any
  // A hazard that appears fully in view on the road, not hidden by a nearer object, must be at most this tall
  // (share of the image height) when first seen; 0 = no such rule.
  double first_seen_max_height = 0.0;
  // Whether a hazard may take over a tracked object (HazardSpec::track_id): only when the renderer removes the
  // real one.
  bool may_take_over = false;
  std::vector<int64_t> avoid_tracks;  // tracked objects not to take over (earlier attempts failed with them)

  bool class_allowed(const std::string& object_class) const;
};

// One drawn plan: the spec as a model would answer it (the reply schema's fields; fields the kind does not use
// may be left out), or why none fits this draw.
struct HazardProposal {
  Json spec;        // null when `problem` says why not
  Refusal problem;  // empty with a spec
};

// Turns a hazard spec into a kinematically plausible trajectory for one hazard kind.
class HazardTemplate : public Component {
 public:
  ~HazardTemplate() override;
  virtual void open(const Params& params) = 0;
  virtual std::string hazard_kind() const = 0;
  // Physical feasibility of the spec (speeds, decelerations, visibility ...), typed reasons. Empty = feasible.
  virtual std::vector<Refusal> check(const HazardSpec& spec, const SceneContext& scene) const = 0;
  virtual HazardTrajectory plan(const HazardSpec& spec, const SceneContext& scene) const = 0;
  // What the kind is and when it applies. Default: the kind's name only.
  virtual HazardKindInfo kind_info() const;
  // A plan for this scene drawn from `draw`, for a provider without a model. Default: none ("proposes no plans").
  virtual HazardProposal propose(const ProposalRequest& request, RandomDraw& draw) const;
};

// The hazard kinds a generator offers a provider (LlmRequest::hazards), configured for the request's scene.
class HazardCatalog {
 public:
  virtual ~HazardCatalog();
  // The allowed kinds, in the generator's order.
  virtual std::vector<HazardKindInfo> kinds() const = 0;
  // The kind's proposal for the scene, with its JSON completed to the reply schema (unused fields null).
  // `aim` and `avoid_tracks` as in ProposalRequest.
  virtual HazardProposal propose(const std::string& kind, double aim, const std::vector<int64_t>& avoid_tracks,
                                 RandomDraw& draw) const = 0;
  // Every reason the generator would reject this reply for (schema, scene rules, the kind's template); empty =
  // it would be accepted.
  virtual std::vector<Refusal> check(const Json& reply) const = 0;
};

// ---- inline template ---------------------------------------------------------------------------------------------

template <class T>
std::unique_ptr<T> ComponentFactory::create(const std::string& kind_name, const std::string& name,
                                            const Json& params) const {
  std::unique_ptr<Component> c = create_component(kind_name, name, params);
  T* t = dynamic_cast<T*>(c.get());
  if (!t) throw Error(kind_name + " '" + name + "' does not implement the requested interface");
  c.release();
  return std::unique_ptr<T>(t);
}

}  // namespace hf
HF_SDK_END
