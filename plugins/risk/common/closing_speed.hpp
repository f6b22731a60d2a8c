// Closing speed of an estimated object, shared by the TTC and DRAC metrics.
#pragma once

#include <cmath>
#include <optional>

#include "hazardforge/types.hpp"

namespace hf::risk {

// The paper's denominator v_ego - v_obj * cos(psi) when the ego speed and the object's absolute speed and
// heading are known. Otherwise, with `relative_fallback`, the relative closing speed -v_rel.x (the same
// quantity when the ego drives along +x: v_obj * cos(psi) = v_ego + v_rel.x); else unknown.
inline std::optional<double> closing_speed(const ObjectState& s, const std::optional<double>& ego_speed,
                                           bool relative_fallback) {
  if (ego_speed && s.speed_mps && s.heading_rad) return *ego_speed - *s.speed_mps * std::cos(*s.heading_rad);
  if (relative_fallback && s.velocity_rel) return -(*s.velocity_rel)[0];
  return std::nullopt;
}

}  // namespace hf::risk
