// What the generator checks a reply against for one scene, and the hazard kinds it offers providers
// (LlmRequest::hazards) so a provider without a model plans with the same templates and the same rules.
#pragma once

#include <map>
#include <memory>
#include <string>
#include <vector>

#include <hazardforge/stage.hpp>

#include "feasibility.hpp"
#include "hazard_schema.hpp"

namespace hf::llm_hazard {

struct CheckedReply {
  HazardSpec spec;                    // valid when the reply passed the schema
  std::vector<Refusal> errors;        // empty = accepted
  std::vector<std::string> skipped;   // checks that could not run (no camera model ...)
};

// The generator's whole verdict on a reply: the reply schema, the feasibility and scene rules, and the kind's
// template. Holds references: everything must outlive it.
class ReplyChecker {
 public:
  ReplyChecker(const SchemaValidator& reply_schema,
               const std::map<std::string, std::unique_ptr<HazardTemplate>>& templates, const SceneContext& scene,
               FeasibilityConfig config);
  CheckedReply check(const Json& reply) const;
  const SceneContext& scene() const { return scene_; }
  const std::map<std::string, std::unique_ptr<HazardTemplate>>& templates() const { return templates_; }
  const Json& reply_schema() const { return reply_schema_.schema(); }

 private:
  const SchemaValidator& reply_schema_;
  const std::map<std::string, std::unique_ptr<HazardTemplate>>& templates_;
  const SceneContext& scene_;
  mutable FeasibilityConfig config_;
};

// The allowed kinds' templates, offered to a provider for one request.
class TemplateCatalog : public HazardCatalog {
 public:
  // `kinds`: the allowed kinds in the generator's order; `base`: the scene and settings every proposal gets
  // (aim and avoid_tracks are set per call). `recording_classes`: classes the recording's own cut appearances
  // show; a kind that may be one of them is proposed as one of them first, and as any of its classes only
  // when no such plan fits.
  TemplateCatalog(const ReplyChecker& checker, std::vector<std::string> kinds, const ProposalRequest& base,
                  std::vector<std::string> recording_classes = {});
  std::vector<HazardKindInfo> kinds() const override;
  HazardProposal propose(const std::string& kind, double aim, const std::vector<int64_t>& avoid_tracks,
                         RandomDraw& draw) const override;
  std::vector<Refusal> check(const Json& reply) const override;

 private:
  const ReplyChecker& checker_;
  std::vector<std::string> kinds_;
  const ProposalRequest& base_;
  std::vector<std::string> recording_classes_;
};

// What the kind's template says about it, under the kind's name; the name only when no template is registered.
HazardKindInfo kind_info_of(const std::map<std::string, std::unique_ptr<HazardTemplate>>& templates,
                            const std::string& kind);

// Fills what a reply must state and a proposal left out with null (top level and `extra`), as the reply
// schema lists them.
void complete_reply(Json& reply, const Json& reply_schema);

}  // namespace hf::llm_hazard
