// LLM provider "offline": a deterministic scenario planner that answers like a model, needing no server.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include <hazardforge/stage.hpp>

namespace hf::llm {

// OfflinePlanner (llm_provider "offline"). Reads the structured scene context (LlmRequest::scene, written
// by the llm_hazard generator) instead of the prompt text, picks a hazard kind by the prompt's rules —
// pedestrian_crossing only with sidewalks, cut_in only on multi-lane roads, sudden_stop when there is room
// for a lead vehicle in the ego lane — and sizes it with closed-form kinematics so the TTC reaches about
// `aim` x target_ttc_s. Choices are drawn from a 64-bit Mersenne Twister seeded with the request's seed plus
// the number of earlier replies in the conversation: the same request gives the same JSON on every platform,
// other seeds give other kinds and parameters, and a retry draws a new plan. The reply is JSON text, so it
// goes through the same extraction and validation as a real model's. Temperature is ignored.
// Params: aim (0.85), candidates_per_kind (12).
class OfflinePlanner : public LlmProvider {
 public:
  static ComponentInfo describe();
  void open(const Params& params) override;
  LlmReply complete(const LlmRequest& request) override;
  std::string describe_backend() const override;

 private:
  double aim_ = 0.85;
  int candidates_ = 12;
};

}  // namespace hf::llm
