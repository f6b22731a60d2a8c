// Out-of-line pieces of the stage interfaces: key functions, lookups and the typed stage adapters.
#include <algorithm>
#include <cmath>

#include "hazardforge/geometry.hpp"
#include "hazardforge/plugin.hpp"
#include "hazardforge/stage.hpp"

namespace hf {

ComponentFactory::~ComponentFactory() = default;
StageContext::~StageContext() = default;
Inputs::~Inputs() = default;
Outputs::~Outputs() = default;
Component::~Component() = default;
Stage::~Stage() = default;
LlmProvider::~LlmProvider() = default;
NoHazardFits::~NoHazardFits() = default;

std::string refusal_text(const std::vector<Refusal>& reasons, bool with_kind) {
  std::string out;
  for (const Refusal& r : reasons)
    out += (out.empty() ? "" : "; ") + (with_kind && !r.kind.empty() ? r.kind + ": " : std::string()) + r.text;
  return out;
}

bool only_traffic(const std::vector<Refusal>& reasons) {
  return !reasons.empty() && std::all_of(reasons.begin(), reasons.end(),
                                         [](const Refusal& r) { return r.code == refusal::kTraffic; });
}

void to_json(nlohmann::json& j, const Refusal& r) {
  j = {{"code", r.code}, {"text", r.text}};
  if (!r.kind.empty()) j["kind"] = r.kind;
}

void from_json(const nlohmann::json& j, Refusal& r) {
  r.code = j.value("code", std::string());
  r.text = j.value("text", std::string());
  r.kind = j.value("kind", std::string());
}
HazardTemplate::~HazardTemplate() = default;
HazardCatalog::~HazardCatalog() = default;
RandomDraw::~RandomDraw() = default;
Registrar::~Registrar() = default;

double RandomDraw::uniform(double lo, double hi) {
  return lo + (hi - lo) * static_cast<double>(next() >> 11) * 0x1.0p-53;
}
size_t RandomDraw::index(size_t n) {
  return static_cast<size_t>(next() % n);
}
bool RandomDraw::coin() {
  return (next() >> 63) != 0;
}

bool ProposalRequest::class_allowed(const std::string& object_class) const {
  return object_classes.empty() ||
         std::find(object_classes.begin(), object_classes.end(), object_class) != object_classes.end();
}

HazardKindInfo HazardTemplate::kind_info() const {
  HazardKindInfo k;
  k.kind = hazard_kind();
  return k;
}

HazardProposal HazardTemplate::propose(const ProposalRequest&, RandomDraw&) const {
  return {nullptr, {refusal::kSpec, "hazard template '" + hazard_kind() + "' proposes no plans", hazard_kind()}};
}

std::string PortSpec::type_str() const {
  return type_name == kAnyType ? std::string("*") : type_name + " v" + std::to_string(type_version);
}

const ParamSpec* ComponentInfo::param(const std::string& n) const {
  for (const auto& p : params)
    if (p.name == n) return &p;
  return nullptr;
}
const PortSpec* ComponentInfo::input(const std::string& n) const {
  for (const auto& p : inputs)
    if (p.name == n) return &p;
  return nullptr;
}
const PortSpec* ComponentInfo::output(const std::string& n) const {
  for (const auto& p : outputs)
    if (p.name == n) return &p;
  return nullptr;
}

namespace {
ComponentInfo info_of(std::string name, const char* k, std::string summary) {
  ComponentInfo i;
  i.name = std::move(name);
  i.kind = k;
  i.summary = std::move(summary);
  return i;
}
}  // namespace

ComponentInfo SourceStage::base_info(std::string name, std::string summary) {
  ComponentInfo i = info_of(std::move(name), kind::kSource, std::move(summary));
  i.outputs = {port<Frame>("frames", "decoded frames with camera model, ego state and optional annotations")};
  return i;
}

ComponentInfo Detector::base_info(std::string name, std::string summary) {
  ComponentInfo i = info_of(std::move(name), kind::kDetector, std::move(summary));
  i.inputs = {port<Frame>("frames", "images to detect in")};
  i.outputs = {port<Detections>("detections", "boxes in the frame's pixel coordinates, one packet per frame")};
  return i;
}

void Detector::process(StageContext& ctx, const Inputs& in, Outputs& out) {
  out.emit("detections", detect(ctx, in.require<Frame>("frames")));
}

ComponentInfo Tracker::base_info(std::string name, std::string summary) {
  ComponentInfo i = info_of(std::move(name), kind::kTracker, std::move(summary));
  i.inputs = {port<Detections>("detections", "this frame's detections"),
              port<Frame>("frames", "the frame (timestamp, size)")};
  i.outputs = {port<Tracks>("tracks", "tracks alive this frame with persistent ids")};
  return i;
}

void Tracker::process(StageContext& ctx, const Inputs& in, Outputs& out) {
  out.emit("tracks", update(ctx, in.require<Detections>("detections"), in.require<Frame>("frames")));
}

ComponentInfo Estimator::base_info(std::string name, std::string summary) {
  ComponentInfo i = info_of(std::move(name), kind::kEstimator, std::move(summary));
  i.inputs = {port<Tracks>("tracks", "tracked boxes"), port<Frame>("frames", "camera model and ego state")};
  i.outputs = {port<ObjectStates>("states", "per-object distance, lateral offset, velocity, heading")};
  return i;
}

void Estimator::process(StageContext& ctx, const Inputs& in, Outputs& out) {
  out.emit("states", estimate(ctx, in.require<Tracks>("tracks"), in.require<Frame>("frames")));
}

ComponentInfo RiskMetric::base_info(std::string name, std::string summary) {
  ComponentInfo i = info_of(std::move(name), kind::kRiskMetric, std::move(summary));
  i.inputs = {port<ObjectStates>("states", "per-object states"),
              optional(port<Frame>("frames", "the frame, for metrics that need the image or annotations"))};
  i.outputs = {port<RiskAssessment>("risk", "per-object values, the scene value and the Safe/Unsafe label")};
  i.params.push_back(ParamSpec::number("threshold", 1.5)
                         .range(0, 1000)
                         .describe("Unsafe when the scene value is below (TTC-like) or above (DRAC) this"));
  i.params.push_back(
      ParamSpec::string("unsafe_when", "value")
          .one_of({"value", "riskier_bound", "safer_bound"})
          .describe("which number of an in-path object decides Unsafe when the metric gives an interval: the "
                    "value; its riskier bound (TTC low end: flags an object whose interval reaches below the "
                    "threshold, for screening); its safer bound (TTC high end: only objects below the "
                    "threshold with confidence, for verification). Objects without an interval use the value"));
  for (ParamSpec& p : Corridor::params()) i.params.push_back(std::move(p));
  return i;
}

void RiskMetric::process(StageContext& ctx, const Inputs& in, Outputs& out) {
  const ObjectStates& states = in.require<ObjectStates>("states");
  RiskAssessment r = assess(ctx, states, in.get<Frame>("frames"));
  const Corridor corridor = Corridor::from(ctx.params());
  r.frame_index = states.frame_index;
  r.metric = ctx.node_id();
  r.threshold = ctx.params().get_double("threshold");
  r.label_rule = ctx.params().get_string("unsafe_when");
  r.scene_value = r.lower_is_riskier ? kInf : 0.0;
  r.critical_track = -1;
  auto worse = [&](double a, double b) { return r.lower_is_riskier ? a < b : a > b; };
  for (ObjectRisk& o : r.objects) {
    auto it = std::find_if(states.objects.begin(), states.objects.end(),
                           [&](const ObjectState& s) { return s.track_id == o.track_id; });
    o.in_path = it != states.objects.end() && corridor.contains(states, *it);
    if (!o.in_path || std::isnan(o.value)) continue;
    if (worse(o.value, r.scene_value)) {
      r.scene_value = o.value;
      r.critical_track = o.track_id;
    }
  }
  const double deciding = deciding_value(r);
  const bool unsafe = r.lower_is_riskier ? deciding < r.threshold : deciding > r.threshold;
  r.label = unsafe ? SafetyLabel::kUnsafe : SafetyLabel::kSafe;
  out.emit("risk", std::move(r));
}

}  // namespace hf
