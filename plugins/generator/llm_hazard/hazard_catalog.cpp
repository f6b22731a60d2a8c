// The generator's verdict on a reply and the catalog of hazard kinds it offers providers.
#include "hazard_catalog.hpp"

#include <algorithm>

#include <hazardforge/error.hpp>

namespace hf::llm_hazard {

ReplyChecker::ReplyChecker(const SchemaValidator& reply_schema,
                           const std::map<std::string, std::unique_ptr<HazardTemplate>>& templates,
                           const SceneContext& scene, FeasibilityConfig config)
    : reply_schema_(reply_schema), templates_(templates), scene_(scene), config_(std::move(config)) {}

CheckedReply ReplyChecker::check(const Json& reply) const {
  CheckedReply out;
  const std::string kind =
      reply.is_object() && reply.contains("kind") && reply["kind"].is_string() ? reply["kind"].get<std::string>() : "";
  try {
    for (std::string& e : reply_schema_.validate(reply)) out.errors.push_back({refusal::kSpec, std::move(e), kind});
    if (!out.errors.empty()) return out;
    out.spec = spec_from_reply(reply, config_.trigger_time_s);
    auto tmpl = templates_.find(out.spec.kind);
    const HazardTemplate* t = tmpl == templates_.end() ? nullptr : tmpl->second.get();
    config_.kinematics = t == nullptr;
    out.errors = check_feasibility(out.spec, scene_, config_, &out.skipped);
    if (t) {
      for (Refusal& e : t->check(out.spec, scene_)) {
        e.text = "hazard template '" + out.spec.kind + "': " + e.text;
        if (e.kind.empty()) e.kind = out.spec.kind;
        out.errors.push_back(std::move(e));
      }
      // The rest judge the planned motion, which exists only for a feasible spec.
      if (out.errors.empty())
        out.errors = check_trajectory_rules(t->plan(out.spec, scene_), scene_, config_.road, config_.sizes,
                                            config_.rules);
    }
  } catch (const Error& e) {
    out.errors = {{refusal::kSpec, e.what(), kind}};
  }
  return out;
}

TemplateCatalog::TemplateCatalog(const ReplyChecker& checker, std::vector<std::string> kinds,
                                 const ProposalRequest& base, std::vector<std::string> recording_classes)
    : checker_(checker), kinds_(std::move(kinds)), base_(base), recording_classes_(std::move(recording_classes)) {}

HazardKindInfo kind_info_of(const std::map<std::string, std::unique_ptr<HazardTemplate>>& templates,
                            const std::string& kind) {
  auto t = templates.find(kind);
  HazardKindInfo info = t == templates.end() ? HazardKindInfo() : t->second->kind_info();
  info.kind = kind;
  return info;
}

std::vector<HazardKindInfo> TemplateCatalog::kinds() const {
  std::vector<HazardKindInfo> out;
  for (const std::string& k : kinds_) out.push_back(kind_info_of(checker_.templates(), k));
  return out;
}

HazardProposal TemplateCatalog::propose(const std::string& kind, double aim,
                                        const std::vector<int64_t>& avoid_tracks, RandomDraw& draw) const {
  auto t = checker_.templates().find(kind);
  if (t == checker_.templates().end())
    return {nullptr, {refusal::kSpec, "no hazard_template '" + kind + "' is registered", kind}};
  ProposalRequest r = base_;
  r.aim = aim;
  r.avoid_tracks = avoid_tracks;
  auto propose_with = [&](const ProposalRequest& req) -> HazardProposal {
    HazardProposal p;
    try {
      p = t->second->propose(req, draw);
    } catch (const Error& e) {
      return {nullptr, {refusal::kSpec, e.what(), kind}};
    }
    if (!p.problem.empty() && p.problem.kind.empty()) p.problem.kind = kind;
    if (p.spec.is_object()) complete_reply(p.spec, checker_.reply_schema());
    return p;
  };
  // The camera's own appearances first: as a class the recording's cuts show, when the kind may be one.
  const HazardKindInfo info = kind_info_of(checker_.templates(), kind);
  std::vector<std::string> own;
  for (const std::string& c : recording_classes_)
    if (base_.class_allowed(c) && (info.object_classes.empty() || std::find(info.object_classes.begin(),
                                                                           info.object_classes.end(),
                                                                           c) != info.object_classes.end()))
      own.push_back(c);
  if (!own.empty()) {
    ProposalRequest preferred = r;
    preferred.object_classes = own;
    HazardProposal p = propose_with(preferred);
    if (p.spec.is_object()) return p;
  }
  return propose_with(r);
}

std::vector<Refusal> TemplateCatalog::check(const Json& reply) const {
  return checker_.check(reply).errors;
}

void complete_reply(Json& reply, const Json& schema) {
  if (!schema.contains("properties")) return;
  for (auto it = schema["properties"].begin(); it != schema["properties"].end(); ++it) {
    if (!reply.contains(it.key())) reply[it.key()] = nullptr;
    if (it.key() == "extra" && reply["extra"].is_object() && it.value().contains("properties"))
      for (auto f = it.value()["properties"].begin(); f != it.value()["properties"].end(); ++f)
        if (!reply["extra"].contains(f.key())) reply["extra"][f.key()] = nullptr;
  }
}

}  // namespace hf::llm_hazard
