// The `scene:` block: its keys, validation, and filling the parameters bound to them.
#include "hazardforge/scene.hpp"

#include <algorithm>

namespace hf {

namespace {

SceneKey key(ParamSpec s) {
  SceneKey k;
  k.key = s.name;
  k.spec = std::move(s);
  return k;
}

std::vector<SceneKey> make_keys() {
  using P = ParamSpec;
  const std::vector<std::string> yes_no = {"auto", "yes", "no"};
  return {
      key(P::string("environment", "").describe("free text for the prompt: place, time of day, weather")),
      key(P::path("assets.dir", "")
              .describe("folder of appearance assets (assets.yaml) for the inserted objects, e.g. cut from this "
                        "recording; empty = the default set")),
      key(P::path("camera.calibration", "").describe("calibration YAML (`hazardforge calibrate`)")),
      key(P::number("camera.fx", 0.0).range(0, 1e6).describe("focal length x, px at camera.intrinsics_size")),
      key(P::number("camera.fy", 0.0).range(0, 1e6).describe("focal length y, px (0 = fx)")),
      key(P::number("camera.cx", 0.0).range(0, 1e6).describe("principal point x, px (0 = image centre)")),
      key(P::number("camera.cy", 0.0).range(0, 1e6).describe("principal point y, px (0 = image centre)")),
      key(P::int_list("camera.intrinsics_size", {})
              .describe("[width, height] of the images fx/fy/cx/cy refer to (empty = the video's own size)")),
      key(P::number("camera.hfov_deg", 0.0).range(0, 179).describe("horizontal field of view, deg")),
      key(P::number("camera.height_m", 1.5).range(0.1, 10).describe("camera height above the road, m")),
      key(P::number("camera.pitch_deg", 0.0).range(-45, 45).describe("downward pitch, deg (else estimated)")),
      key(P::number("camera.roll_deg", 0.0).range(-30, 30).describe("roll, deg, + = horizon rises to the right")),
      key(P::number("camera.forward_m", 1.5).range(-10, 10).describe("camera position ahead of the rear axle, m")),
      key(P::number("ego.speed_mps", 0.0).range(0, 100).describe("constant ego speed, m/s (else estimated)")),
      key(P::string("road.type", "").describe("road type for the prompt, e.g. 'urban two-lane street'")),
      key(P::string("road.driving_side", "right").one_of({"left", "right"}).describe("side traffic keeps to")),
      key(P::integer("road.lanes_left", 1).range(0, 10).describe("lanes left of the ego lane")),
      key(P::integer("road.lanes_right", 1).range(0, 10).describe("lanes right of the ego lane")),
      key(P::integer("road.oncoming_lanes", 0)
              .range(0, 10)
              .describe("of the lanes on the side away from driving_side, how many carry oncoming traffic (the "
                        "outermost); 0 = all go the ego's way")),
      key(P::number("road.lane_width_m", 3.5).range(2, 6).describe("lane width, m")),
      key(P::string("road.sidewalks", "auto").one_of(yes_no).describe("sidewalks (pedestrians allowed)")),
      key(P::number("road.sidewalk_width_m", 3.0).range(0, 15).describe("sidewalk width beyond the road edge")),
      key(P::string("road.intersection", "auto").one_of(yes_no).describe("an intersection in view")),
      key(P::string("road.multi_lane", "auto").one_of(yes_no).describe("lanes in the ego's direction > 1")),
  };
}

std::string ptr_token(const std::string& s) {
  std::string out;
  for (char c : s) out += c == '~' ? std::string("~0") : c == '/' ? std::string("~1") : std::string(1, c);
  return out;
}

}  // namespace

const std::vector<SceneKey>& scene_keys() {
  static const std::vector<SceneKey> keys = make_keys();
  return keys;
}

const Json* scene_value(const Json& scene, const std::string& dotted) {
  const Json* at = &scene;
  size_t start = 0;
  while (true) {
    if (!at->is_object()) return nullptr;
    const size_t dot = dotted.find('.', start);
    const std::string part = dotted.substr(start, dot == std::string::npos ? std::string::npos : dot - start);
    auto it = at->find(part);
    if (it == at->end() || it->is_null()) return nullptr;
    at = &*it;
    if (dot == std::string::npos) return at;
    start = dot + 1;
  }
}

void validate_scene(const Json& scene, const std::function<SourceLocation(const std::string&)>& where,
                    std::vector<Diagnostic>& diags) {
  auto error = [&](const std::string& ptr, std::string msg) {
    diags.push_back({Diagnostic::Severity::kError, where(ptr), std::move(msg)});
  };
  if (scene.is_null()) return;
  if (!scene.is_object()) {
    error("", "'scene' is a mapping with camera, ego, road, assets and environment");
    return;
  }
  std::vector<std::string> sections, all;
  for (const SceneKey& k : scene_keys()) {
    all.push_back(k.key);
    const auto dot = k.key.find('.');
    const std::string sec = dot == std::string::npos ? k.key : k.key.substr(0, dot);
    if (std::find(sections.begin(), sections.end(), sec) == sections.end()) sections.push_back(sec);
  }
  auto check = [&](const SceneKey& k, const Json& v, const std::string& ptr) {
    ParamLocations locs{{k.key, where(ptr)}};
    validate_params({k.spec}, Json{{k.key, v}}, "scene", where(ptr), locs, diags);
  };
  for (auto it = scene.begin(); it != scene.end(); ++it) {
    const std::string ptr = "/" + ptr_token(it.key());
    if (std::find(sections.begin(), sections.end(), it.key()) == sections.end()) {
      const std::string near = nearest_name(it.key(), sections);
      error(ptr + "#key", "unknown scene section '" + it.key() + "'" +
                              (near.empty() ? "" : "; did you mean '" + near + "'?"));
      continue;
    }
    auto direct = std::find_if(scene_keys().begin(), scene_keys().end(),
                               [&](const SceneKey& k) { return k.key == it.key(); });
    if (direct != scene_keys().end()) {
      check(*direct, it.value(), ptr);
      continue;
    }
    if (!it->is_object()) {
      error(ptr, "scene." + it.key() + " is a mapping");
      continue;
    }
    for (auto jt = it->begin(); jt != it->end(); ++jt) {
      const std::string dotted = it.key() + "." + jt.key();
      const std::string p = ptr + "/" + ptr_token(jt.key());
      auto k = std::find_if(scene_keys().begin(), scene_keys().end(),
                            [&](const SceneKey& s) { return s.key == dotted; });
      if (k == scene_keys().end()) {
        std::vector<std::string> in_section;
        for (const std::string& a : all)
          if (a.rfind(it.key() + ".", 0) == 0) in_section.push_back(a.substr(it.key().size() + 1));
        const std::string near = nearest_name(jt.key(), in_section);
        error(p + "#key", "unknown key 'scene." + dotted + "'" +
                              (near.empty() ? "" : "; did you mean '" + near + "'?"));
        continue;
      }
      check(*k, jt.value(), p);
    }
  }
}

std::vector<std::string> fill_from_scene(const std::vector<ParamSpec>& specs, const Json& scene, Json& given) {
  std::vector<std::string> twice;
  if (!given.is_object()) return twice;
  for (const ParamSpec& s : specs) {
    if (s.scene_key.empty()) continue;
    const Json* v = scene_value(scene, s.scene_key);
    if (!v) continue;
    if (given.contains(s.name) && !given[s.name].is_null()) {
      twice.push_back(s.name);
      continue;
    }
    given[s.name] = *v;
  }
  return twice;
}

}  // namespace hf
