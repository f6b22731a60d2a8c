// Scene-aware refusals every hazard kind is held to: a class the renderer can draw, no tracked object taken over
// unless it is removed, and on the planned trajectory no path through a tracked object's predicted positions,
// lanes used in their traffic's direction and a plausible entry into view.
#pragma once

#include <optional>
#include <string>
#include <vector>

#include <hazardforge/geometry.hpp>
#include <hazardforge/hazard/template_base.hpp>
#include <hazardforge/stage.hpp>

namespace hf::llm_hazard {

struct SceneRules {
  // Classes with appearance assets (empty = not checked) and where they were read, for messages.
  std::vector<std::string> asset_classes;
  std::string assets_where;
  // Classes the recording's own cut appearances show (the same camera and light): a kind that may be one of
  // them is drawn as one of them.
  std::vector<std::string> recording_classes;
  // A spec may take over a tracked object (HazardSpec::track_id) only when the renderer removes the real one.
  bool take_over_tracks = true;
  // A hazard that appears fully in view, unhidden, on the road must be at most this tall (share of the image
  // height) when first seen; 0 = no such rule.
  double entry_max_height = 0.07;
  // Room kept between the hazard and tracked objects' predicted boxes (m).
  double clearance_m = 0.3;
  // Ego x (m) the tracked objects' distances are measured from (ObjectStates::distance_origin_x).
  double distance_origin_x = 0.0;
};

// The classes the assets in `dir` (assets.yaml) and, as the renderer falls back to it, in the default set
// (share/assets) show; `dir` empty = the default set only. Sorted, unique.
std::vector<std::string> asset_classes(const std::string& dir);
// The classes the assets in `dir` alone show (no default set); `dir` empty or without assets.yaml = none.
std::vector<std::string> own_asset_classes(const std::string& dir);

// Spec-level rules: the class has appearance assets; no tracked object is taken over unless allowed.
std::vector<Refusal> check_spec_rules(const HazardSpec& spec, const SceneContext& scene, const SceneRules& rules);

// Rules on the planned trajectory (anchor frame, with the planned ego): the path keeps clear of every tracked
// object predicted at constant velocity over the plan (except one the spec takes over), a vehicle starts in a
// lane whose traffic goes its way, and the object enters the view plausibly (from beyond the image border, from
// behind a nearer tracked object, or far enough to be small) rather than popping up on the road close by.
// `sizes` gives tracked objects without a measured size their class's.
std::vector<Refusal> check_trajectory_rules(const HazardTrajectory& trajectory, const SceneContext& scene,
                                            const hazard::RoadModel& road, const ClassPriors& sizes,
                                            const SceneRules& rules);

}  // namespace hf::llm_hazard
