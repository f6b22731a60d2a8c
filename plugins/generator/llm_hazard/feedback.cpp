// The feedback file of failed attempts: reading it, and what it means for the prompt and the offline planner.
#include "feedback.hpp"

#include <algorithm>

#include <hazardforge/error.hpp>

#include "hazard_schema.hpp"

namespace hf::llm_hazard {

namespace {

bool mentions(const std::string& text, std::initializer_list<const char*> words) {
  return std::any_of(words.begin(), words.end(), [&](const char* w) { return text.find(w) != std::string::npos; });
}

template <class Pred>
bool any_reason(const std::vector<FailedAttempt>& attempts, Pred pred) {
  for (const FailedAttempt& a : attempts)
    for (const std::string& r : a.reasons)
      if (pred(r)) return true;
  return false;
}

}  // namespace

Feedback Feedback::load(const std::string& path) {
  return from_json(load_json_file(path, "the feedback file"), path);
}

Feedback Feedback::from_json(const Json& doc, const std::string& where) {
  auto fail = [&](const std::string& ptr, const std::string& what) { throw Error(where + ": " + ptr + " " + what); };
  if (!doc.is_object() || !doc.contains("attempts") || !doc["attempts"].is_array())
    fail("/attempts", "must be a list of failed attempts");
  Feedback f;
  for (size_t i = 0; i < doc["attempts"].size(); ++i) {
    const Json& a = doc["attempts"][i];
    const std::string at = "/attempts/" + std::to_string(i);
    if (!a.is_object()) fail(at, "must be an object");
    FailedAttempt fa;
    for (const char* key : {"kind", "object_class"}) {
      if (!a.contains(key) || !a[key].is_string()) fail(at + "/" + key, "must be a string");
    }
    fa.kind = a["kind"].get<std::string>();
    fa.object_class = a["object_class"].get<std::string>();
    if (!a.contains("reasons") || !a["reasons"].is_array()) fail(at + "/reasons", "must be a list of strings");
    for (size_t k = 0; k < a["reasons"].size(); ++k) {
      if (!a["reasons"][k].is_string()) fail(at + "/reasons/" + std::to_string(k), "must be a string");
      fa.reasons.push_back(a["reasons"][k].get<std::string>());
    }
    for (const char* key : {"trigger_frame", "seed"})
      if (a.contains(key) && !a[key].is_number_integer()) fail(at + "/" + key, "must be an integer");
    fa.trigger_frame = a.value("trigger_frame", int64_t{-1});
    fa.seed = a.value("seed", int64_t{0});
    if (a.contains("spec") && !a["spec"].is_null()) {
      const Json& s = a["spec"];
      fa.has_spec = true;
      if (!s.is_object()) fail(at + "/spec", "must be a hazard spec object or null");
      if (s.contains("side") && s["side"].is_string()) fa.side = s["side"].get<std::string>();
      try {
        fa.track_id = spec_track_id(s);
      } catch (const Error& e) {
        fail(at + "/spec/track_id", e.what());
      }
    }
    f.attempts_.push_back(std::move(fa));
  }
  return f;
}

bool Feedback::lower_ttc() const {
  return any_reason(attempts_, [](const std::string& r) {
    return mentions(r, {"never becomes Unsafe", "is never reached", "is not reached", "is the hazard's"});
  });
}

bool Feedback::more_visible() const {
  return any_reason(attempts_, [](const std::string& r) {
    return mentions(r, {"never visible", "re-detect", "never detected", "not detected"});
  });
}

std::string Feedback::prompt_text() const {
  if (attempts_.empty()) return "Earlier attempts on this recording: none.";
  std::string out = "Earlier attempts on this recording failed because:";
  for (const FailedAttempt& a : attempts_) {
    std::string why;
    for (const std::string& r : a.reasons) why += (why.empty() ? "" : "; ") + r;
    out += "\n- " + a.kind + ", " + a.object_class + (a.side.empty() ? "" : ", side " + a.side) +
           (a.track_id ? ", track " + std::to_string(*a.track_id) : "") +
           (a.trigger_frame >= 0 ? " (frame " + std::to_string(a.trigger_frame) + ")" : "") + ": " +
           (why.empty() ? "no reason given" : why);
  }
  out += "\nDo not repeat a failed design (the same kind, class, side and track); change what the reasons name";
  if (more_visible()) out += " — an object that was never re-detected should be larger or nearer when it appears";
  if (lower_ttc()) out += " — where the TTC was not reached, aim for a lower one";
  return out + ".";
}

Json Feedback::scene_json(int64_t frame_index) const {
  Json attempts = Json::array();
  for (const FailedAttempt& a : attempts_)
    attempts.push_back({{"kind", a.kind},
                        {"object_class", a.object_class},
                        {"side", a.side.empty() ? Json(nullptr) : Json(a.side)},
                        {"track_id", a.track_id ? Json(*a.track_id) : Json(nullptr)},
                        {"trigger_frame", a.trigger_frame},
                        {"seed", a.seed},
                        {"has_spec", a.has_spec},
                        {"same_frame", a.trigger_frame == frame_index},
                        {"reasons", a.reasons}});
  return {{"attempts", attempts}, {"lower_ttc", lower_ttc()}, {"more_visible", more_visible()}};
}

}  // namespace hf::llm_hazard
