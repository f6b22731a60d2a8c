// LLM provider "offline": a deterministic scenario planner that answers like a model, needing no server.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include <hazardforge/stage.hpp>

namespace hf::llm {

// OfflinePlanner (llm_provider "offline"). Plans with the hazard templates the generator offers
// (LlmRequest::hazards): each allowed kind's template proposes a plan for the scene, drawn from a 64-bit Mersenne
// Twister seeded with the request's seed plus the number of earlier replies in the conversation; one of the kinds
// that could propose one is drawn, and its plan is checked with the generator's own rules before it is sent (a
// rejected plan is replaced by the kind's next draw). The same request gives the same JSON on every platform,
// other seeds give other kinds and parameters, and a retry draws a new plan that repeats no earlier reply. The
// scene context (LlmRequest::scene) gives the ego speed and the failed attempts of earlier runs (`feedback`): a
// plan of the same kind, class, side and track as a failed one is not proposed again, and when an attempt never
// became critical enough or was never re-detected, a lower-TTC aim and the largest, nearest of the kind's plans are
// chosen. The reply is JSON text, so it goes through the same extraction and validation as a real model's.
// Temperature is ignored. Params: aim (0.85), candidates_per_kind (12), kind_order.
class OfflinePlanner : public LlmProvider {
 public:
  static ComponentInfo describe();
  void open(const Params& params) override;
  LlmReply complete(const LlmRequest& request) override;
  std::string describe_backend() const override;

 private:
  double aim_ = 0.85;
  int candidates_ = 12;
  std::vector<std::string> kind_order_;
};

}  // namespace hf::llm
