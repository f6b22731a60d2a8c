// Deterministic hazard planner behind the LLM provider interface: asks the allowed kinds' templates for
// plans.
#include "offline_planner.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <optional>
#include <random>

#include <hazardforge/error.hpp>
#include "hazardforge/number_text.hpp"

namespace hf::llm {

namespace {

constexpr double kMinEgoSpeed = 1.0;  // m/s: below it no inserted object closes in on the ego

// Raw 64-bit draws for the templates' proposals (hf::RandomDraw turns them into numbers the same way
// everywhere).
class Draw : public RandomDraw {
 public:
  explicit Draw(uint64_t seed) : gen_(seed) {}
  uint64_t next() override { return gen_(); }

 private:
  std::mt19937_64 gen_;
};

std::string join(const std::vector<std::string>& v, const std::string& sep) {
  std::string out;
  for (const std::string& s : v) out += (out.empty() ? "" : sep) + s;
  return out;
}

// What makes two plans "the same design" for the feedback rule: kind, class, side and the track taken over.
struct Signature {
  std::string kind, object_class, side;
  std::optional<int64_t> track;
  bool known = true;  // side and track known (a failed attempt without a spec rules out every side and track)
  bool same_frame = true;  // from an attempt at the frame this request is for

  static Signature of(const Json& spec) {
    Signature s;
    s.kind = spec.value("kind", "");
    s.object_class = spec.value("object_class", "");
    s.side = spec.value("side", "");
    try {
      s.track = spec_track_id(spec);
    } catch (const Error&) {
    }
    return s;
  }
  bool matches(const Signature& o) const {
    return kind == o.kind && object_class == o.object_class &&
           (!known || (side == o.side && track == o.track));
  }
  std::string str() const {
    return kind + " " + object_class + (known ? " " + side : "") +
           (track ? " track " + std::to_string(*track) : "");
  }
};

// The scene context's `feedback` (written by the llm_hazard generator from its `feedback` file) and the
// replies already rejected in this conversation.
struct Feedback {
  std::vector<Signature> failed;
  bool lower_ttc = false;     // an attempt never became critical enough
  bool more_visible = false;  // an attempt's object was never (re-)detected
};

Feedback read_feedback(const LlmRequest& request) {
  Feedback f;
  const Json& s = request.scene;
  if (s.contains("feedback") && s["feedback"].is_object()) {
    const Json& fb = s["feedback"];
    f.lower_ttc = fb.value("lower_ttc", false);
    f.more_visible = fb.value("more_visible", false);
    if (fb.contains("attempts") && fb["attempts"].is_array())
      for (const Json& a : fb["attempts"]) {
        if (!a.is_object()) continue;
        Signature sig;
        sig.kind = a.value("kind", "");
        sig.object_class = a.value("object_class", "");
        sig.side = a.contains("side") && a["side"].is_string() ? a["side"].get<std::string>() : "";
        if (a.contains("track_id") && a["track_id"].is_number_integer())
          sig.track = a["track_id"].get<int64_t>();
        sig.known = a.value("has_spec", true);
        sig.same_frame = a.value("same_frame", true);
        f.failed.push_back(sig);
      }
  }
  for (const LlmMessage& m : request.messages) {
    if (m.role != "assistant") continue;
    try {
      const Json j = Json::parse(m.content);
      if (j.is_object()) f.failed.push_back(Signature::of(j));
    } catch (const Json::exception&) {
    }
  }
  return f;
}

// Size of a class for "larger is easier to detect" (length x width x height from the scene's class sizes).
double class_volume(const Json& scene, const std::string& cls) {
  if (!scene.contains("class_sizes") || !scene["class_sizes"].contains(cls)) return 0.0;
  const Json& s = scene["class_sizes"][cls];
  return s.value("length", 0.0) * s.value("width", 0.0) * s.value("height", 0.0);
}

// One selection over the offered kinds.
class Selection {
 public:
  Selection(const LlmRequest& request, const HazardCatalog& catalog, Draw& draw, int budget, double aim,
            const std::vector<Signature>& avoid, bool prefer_visible)
      : request_(request),
        catalog_(catalog),
        draw_(draw),
        budget_(budget),
        aim_(aim),
        avoid_(avoid),
        prefer_visible_(prefer_visible) {
    // A tracked object that failed as the hazard at this frame is not taken over again here; at another frame
    // it is in another state (nearer, slower), and the aim or the braking changes, so it may serve again.
    for (const Signature& s : avoid)
      if (s.track && s.same_frame) avoid_tracks_.push_back(*s.track);
  }

  // Each kind's first usable plan; then one kind is drawn, its plan checked with the generator's rules and,
  // if rejected, replaced by the kind's next plan that passes them.
  std::optional<Json> run(const std::vector<std::string>& kinds) {
    std::vector<Slot> slots;
    for (const std::string& kind : kinds) {
      Slot s{kind, nullptr, false, budget_};
      Refusal why;
      if (prefer_visible_ ? best(s, why) : next(s, false, why))
        slots.push_back(std::move(s));
      else
        problems.push_back(labelled(kind, std::move(why)));
    }
    candidates = slots.size();
    while (!slots.empty()) {
      const size_t i = draw_.index(slots.size());
      Slot& s = slots[i];
      if (s.checked) return s.spec;
      const std::vector<Refusal> errors = catalog_.check(s.spec);
      if (errors.empty()) return s.spec;
      for (const Refusal& e : errors) problems.push_back(labelled(s.kind, e));
      Refusal why;
      if (!next(s, true, why)) slots.erase(slots.begin() + static_cast<long>(i));
    }
    return std::nullopt;
  }

  std::vector<Refusal> problems;  // texts prefixed "<kind>: "
  size_t candidates = 0;
  bool skipped_repeat = false;  // a plan was passed over because it repeats a failed attempt

 private:
  struct Slot {
    std::string kind;
    Json spec;
    bool checked;
    int budget;
  };

  static Refusal labelled(const std::string& kind, Refusal r) {
    r.text = kind + ": " + r.text;
    if (r.kind.empty()) r.kind = kind;
    return r;
  }

  // The kind's next plan within its budget (checked with the generator's rules when `checked`); else why
  // not (the last reason found).
  bool next(Slot& s, bool checked, Refusal& why) {
    while (s.budget > 0) {
      --s.budget;
      HazardProposal p = catalog_.propose(s.kind, aim_, avoid_tracks_, draw_);
      if (!p.problem.empty() || p.spec.is_null()) {
        why = p.problem.empty() ? Refusal{refusal::kSpec, "no plan", s.kind} : p.problem;
        continue;
      }
      const Signature sig = Signature::of(p.spec);
      auto same =
          std::find_if(avoid_.begin(), avoid_.end(), [&](const Signature& a) { return a.matches(sig); });
      if (same != avoid_.end()) {
        why = {refusal::kRepeatsFailed, "the plan (" + sig.str() + ") repeats a failed attempt", s.kind};
        skipped_repeat = true;
        continue;
      }
      if (checked) {
        const std::vector<Refusal> errors = catalog_.check(p.spec);
        if (!errors.empty()) {
          // One reason for the kind, with every text: traffic only when every reason is traffic.
          why = errors.front();
          for (const Refusal& e : errors)
            if (e.code != refusal::kTraffic) {
              why.code = e.code;
              break;
            }
          why.text = refusal_text(errors);
          continue;
        }
      }
      s.spec = std::move(p.spec);
      s.checked = checked;
      return true;
    }
    return false;
  }

  // Of the kind's plans that pass the rules, the largest object, then the nearest start.
  bool best(Slot& s, Refusal& why) {
    std::optional<Json> chosen;
    auto score = [&](const Json& spec) {
      return std::make_pair(class_volume(request_.scene, spec.value("object_class", "")),
                            -std::abs(spec.value("initial_distance_m", 0.0)));
    };
    while (s.budget > 0) {
      Slot trial{s.kind, nullptr, false, 1};
      --s.budget;
      if (!next(trial, true, why)) continue;
      if (!chosen || score(trial.spec) > score(*chosen)) chosen = std::move(trial.spec);
    }
    if (!chosen) return false;
    s.spec = std::move(*chosen);
    s.checked = true;
    return true;
  }

  const LlmRequest& request_;
  const HazardCatalog& catalog_;
  Draw& draw_;
  int budget_;
  double aim_;
  std::vector<Signature> avoid_;
  std::vector<int64_t> avoid_tracks_;
  bool prefer_visible_;
};

}  // namespace

ComponentInfo OfflinePlanner::describe() {
  ComponentInfo i;
  i.name = "offline";
  i.kind = kind::kLlmProvider;
  i.summary = "Deterministic, seeded hazard planner that answers like an LLM (no server needed)";
  i.doc =
      "Asks the templates of the allowed kinds (LlmRequest::hazards, offered by the llm_hazard generator) "
      "for "
      "plans, draws one, and checks it with the generator's rules before answering. Failed attempts in the "
      "scene "
      "context's feedback are not repeated (same kind, class, side and track); after an attempt that never "
      "became "
      "critical enough the aim is lowered by a quarter, after one that was never re-detected the largest, "
      "nearest "
      "plan of each kind is chosen.";
  i.params = {
      ParamSpec::number("aim", 0.85).range(0.3, 1.0).describe("planned TTC as a fraction of target_ttc_s"),
      ParamSpec::integer("candidates_per_kind", 48)
          .range(1, 100)
          .describe("draws tried per kind before giving up"),
      ParamSpec::string_list("kind_order", {"pedestrian_crossing", "cut_in", "sudden_stop"})
          .describe(
              "kinds draw their plans in this order, the other allowed kinds after them in the generator's "
              "order; the order decides which random numbers each kind gets, so it is part of what a seed "
              "means"),
  };
  return i;
}

void OfflinePlanner::open(const Params& p) {
  aim_ = p.get_double("aim");
  candidates_ = static_cast<int>(p.get_int("candidates_per_kind"));
  kind_order_ = p.get_strings("kind_order");
}

std::string OfflinePlanner::describe_backend() const {
  return "offline planner";
}

LlmReply OfflinePlanner::complete(const LlmRequest& request) {
  auto t0 = std::chrono::steady_clock::now();
  const Json& scene = request.scene;
  if (!scene.is_object() || scene.empty())
    throw Error(
        "offline: the request carries no scene context (the offline planner reads LlmRequest::scene)");
  if (!request.hazards)
    throw Error(
        "offline: the request offers no hazard templates (LlmRequest::hazards): the offline planner plans "
        "with "
        "the templates of the allowed kinds, which the llm_hazard generator offers");
  if (!scene.contains("ego_speed_mps") || !scene["ego_speed_mps"].is_number())
    throw Error("offline: the request's scene context lacks 'ego_speed_mps'");
  const double ego_speed = scene["ego_speed_mps"].get<double>();
  const auto previous = std::count_if(request.messages.begin(), request.messages.end(),
                                      [](const LlmMessage& m) { return m.role == "assistant"; });
  const uint64_t seed =
      static_cast<uint64_t>(request.seed) * 0x9E3779B97F4A7C15ULL + static_cast<uint64_t>(previous);

  // The offered kinds, those named in kind_order first.
  std::vector<std::string> offered, kinds;
  for (const HazardKindInfo& k : request.hazards->kinds()) offered.push_back(k.kind);
  for (const std::string& k : kind_order_)
    if (std::find(offered.begin(), offered.end(), k) != offered.end()) kinds.push_back(k);
  for (const std::string& k : offered)
    if (std::find(kinds.begin(), kinds.end(), k) == kinds.end()) kinds.push_back(k);

  const Feedback fb = read_feedback(request);
  const double aim = fb.lower_ttc ? std::max(0.3, 0.75 * aim_) : aim_;
  std::vector<Refusal> problems;
  std::optional<Json> chosen;
  size_t candidates = 0;
  if (ego_speed < kMinEgoSpeed) {
    problems.push_back({refusal::kEgoMotion, "the ego speed " + fixed_text(ego_speed, 1) + " m/s is below " +
                                                 fixed_text(kMinEgoSpeed, 1) +
                                                 " m/s, so no inserted object closes in on it",
                        ""});
  } else {
    Draw draw(seed);
    Selection sel(request, *request.hazards, draw, candidates_, aim, fb.failed, fb.more_visible);
    chosen = sel.run(kinds);
    problems = sel.problems;
    candidates = sel.candidates;
    if (!chosen && sel.skipped_repeat) {
      // Every plan repeats a failed attempt: attempts at other frames no longer rule a design out.
      std::vector<Signature> here;
      for (const Signature& s : fb.failed)
        if (s.same_frame) here.push_back(s);
      if (here.size() < fb.failed.size()) {
        Draw again(seed);
        Selection retry(request, *request.hazards, again, candidates_, aim, here, fb.more_visible);
        chosen = retry.run(kinds);
        for (Refusal p : retry.problems) {
          p.text = "(repeats allowed from other frames) " + p.text;
          problems.push_back(std::move(p));
        }
        candidates = retry.candidates;
      }
    }
  }
  if (!chosen) {
    if (problems.empty()) problems.push_back({refusal::kSpec, "no kind was offered", ""});
    throw NoHazardFits("offline: no hazard fits this scene (allowed kinds: " + join(offered, ", ") +
                           "): " + refusal_text(problems),
                       problems);
  }
  LlmReply reply;
  reply.content = chosen->dump(2);
  reply.model = "offline-planner-1";
  Json rejected = Json::array();
  for (const Refusal& p : problems) rejected.push_back(p.text);
  reply.raw = {{"planner", "offline"}, {"candidates", candidates}, {"rejected", rejected}};
  if (fb.lower_ttc || fb.more_visible || !fb.failed.empty())
    reply.raw["feedback"] = {
        {"avoided", fb.failed.size()}, {"aim", aim}, {"prefer_visible", fb.more_visible}};
  reply.latency_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return reply;
}

}  // namespace hf::llm
