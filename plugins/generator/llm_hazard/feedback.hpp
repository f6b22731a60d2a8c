// Failed attempts of earlier runs on the same recording (the generator's `feedback` file): what the prompt tells a
// model about them and what the scene context tells the offline planner.
#pragma once

#include <optional>
#include <string>
#include <vector>

#include <hazardforge/types.hpp>

namespace hf::llm_hazard {

struct FailedAttempt {
  std::string kind, object_class;
  bool has_spec = false;           // whether it got as far as a spec (else its side and track are unknown)
  std::string side;                // from its spec
  std::optional<int64_t> track_id;  // the tracked object it took over, from its spec
  std::vector<std::string> reasons;
  int64_t trigger_frame = -1;
  int64_t seed = 0;
};

class Feedback {
 public:
  // {"attempts": [{"kind": str, "object_class": str, "spec": {...} or null, "reasons": [str], "trigger_frame": int,
  // "seed": int}]}. Throws hf::Error naming the file and the JSON pointer of what is wrong.
  static Feedback load(const std::string& path);
  static Feedback from_json(const Json& doc, const std::string& where);

  bool empty() const { return attempts_.empty(); }
  const std::vector<FailedAttempt>& attempts() const { return attempts_; }
  // Some attempt was never critical enough (the scene never became Unsafe with it, its TTC was not reached).
  bool lower_ttc() const;
  // Some attempt's object was never seen, or re-detected too rarely.
  bool more_visible() const;
  // The prompt's {{feedback}}: the attempts with their reasons and what to change.
  std::string prompt_text() const;
  // The scene context's "feedback": the attempts (has_spec: side and track are known; same_frame: made for the
  // frame generated for now) and the two conclusions above.
  Json scene_json(int64_t frame_index) const;

 private:
  std::vector<FailedAttempt> attempts_;
};

}  // namespace hf::llm_hazard
