// Why a hazard does not fit a scene, typed: a code the campaign and the reports count without reading text, and
// the text a person (or a model asked to try again) reads.
#pragma once

#include "hazardforge/abi.hpp"

#include <string>
#include <vector>

#include <nlohmann/json.hpp>

HF_SDK_BEGIN
namespace hf {

struct Refusal {
  std::string code;  // one of refusal::k*, or a code of the kind's own (snake_case)
  std::string text;  // with the numbers, for people and for a model's next try
  std::string kind;  // the hazard kind it concerns; "" = the scene, or every kind
  bool empty() const { return code.empty() && text.empty(); }
};

// The SDK's codes, by what another attempt could change.
namespace refusal {
// A road user of this moment is in the way (the plan runs into a tracked object, starts on a detected one):
// another moment of the recording may fit.
inline constexpr const char* kTraffic = "traffic";
// The scene lacks what the kind needs (sidewalks, a lane beside the ego's, an oncoming lane, an intersection,
// a lead to follow): no moment of this scene fits as it is read.
inline constexpr const char* kSceneLacks = "scene_lacks";
// The motion would exceed its class's limits (speed, acceleration, deceleration, jerk, turn rate).
inline constexpr const char* kClassLimit = "class_limit";
// The target TTC is not reached within the plan (too far, too slow, never closing in), or is reached at once.
inline constexpr const char* kTtcUnreachable = "ttc_unreachable";
// Out of the camera's view when it starts, or coming into view too large, too close.
inline constexpr const char* kNotInView = "not_in_view";
// The ego's motion does not allow it (standing, too slow, turning away, stopping before the hazard).
inline constexpr const char* kEgoMotion = "ego_motion";
// The placement contradicts the road (off the road, already in the ego path, a side the kind cannot use).
inline constexpr const char* kPlacement = "placement";
// The class cannot be drawn here or the kind does not support it.
inline constexpr const char* kObjectClass = "object_class";
// The spec is malformed or contradicts itself (a model's reply: schema, sides, fields).
inline constexpr const char* kSpec = "spec";
// The scene lacks data a check needs (a camera model, the ego's speed).
inline constexpr const char* kSceneData = "scene_data";
// Every plan left repeats an earlier failed attempt.
inline constexpr const char* kRepeatsFailed = "repeats_failed";
}  // namespace refusal

// Texts joined by "; " (each prefixed "<kind>: " when it names a kind and `with_kind`).
std::string refusal_text(const std::vector<Refusal>& reasons, bool with_kind = false);
// Whether there is a reason and every one is refusal::kTraffic: another moment may fit.
bool only_traffic(const std::vector<Refusal>& reasons);

void to_json(nlohmann::json& j, const Refusal& r);
void from_json(const nlohmann::json& j, Refusal& r);

}  // namespace hf
HF_SDK_END
