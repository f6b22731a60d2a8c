// The scene description a config states once, in its `scene:` block: the camera, the ego vehicle and the road.
// Stage and component parameters bound to a scene key (ParamSpec::from_scene) take their value from it, so a
// fact such as the number of lanes or the camera height is written in one place and every stage that needs it
// reads the same value.
#pragma once

#include "hazardforge/abi.hpp"

#include <functional>
#include <string>
#include <vector>

#include "hazardforge/params.hpp"

HF_SDK_BEGIN
namespace hf {

// One fact a scene block may state. Its type, range and choices are those of every parameter bound to it.
struct SceneKey {
  std::string key;  // "road.lanes_left"
  ParamSpec spec;   // type, range, choices, doc (spec.name == key)
};

// Every key a `scene:` block may hold (camera.*, ego.*, road.*, assets.*, environment).
const std::vector<SceneKey>& scene_keys();

// The value `scene` states for a dotted key, or nullptr.
const Json* scene_value(const Json& scene, const std::string& key);

// Checks a `scene:` mapping: unknown sections and keys (with the nearest name), wrong types, out-of-range values.
// `where(pointer)` gives the source location of a JSON pointer below the block ("/road/lanes_left").
// Appends one diagnostic per problem.
void validate_scene(const Json& scene, const std::function<SourceLocation(const std::string&)>& where,
                    std::vector<Diagnostic>& diags);

// Fills the parameters of `specs` that are bound to a key the scene states into `given` (an object). A bound
// parameter that `given` already holds is left as is and its name is returned, so the caller can say the fact
// was given twice (graph nodes) or accept the caller's value (components a stage creates).
std::vector<std::string> fill_from_scene(const std::vector<ParamSpec>& specs, const Json& scene, Json& given);

}  // namespace hf
HF_SDK_END
