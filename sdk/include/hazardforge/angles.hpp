// Angle helpers: the one place headings are wrapped, differenced and converted between radians and degrees.
#pragma once

#include <cmath>
#include <numbers>

#include "hazardforge/abi.hpp"

HF_SDK_BEGIN
namespace hf {

inline constexpr double kPi = std::numbers::pi;
inline constexpr double kRadPerDeg = kPi / 180.0;  // degrees * kRadPerDeg = radians
inline constexpr double kDegPerRad = 180.0 / kPi;  // radians * kDegPerRad = degrees

constexpr double deg_to_rad(double deg) {
  return deg * kPi / 180.0;
}
constexpr double rad_to_deg(double rad) {
  return rad * 180.0 / kPi;
}

// An angle (rad) brought into [-pi, pi].
inline double wrap_angle(double rad) {
  return std::remainder(rad, 2.0 * kPi);
}

// The signed turn (rad, in [-pi, pi]) from heading `from` to heading `to`: the shorter way round, so a
// heading of 179 deg followed by -179 deg is a 2 deg turn, not 358.
inline double angle_diff(double to, double from) {
  return wrap_angle(to - from);
}

// An angle (deg) brought into (-180, 180].
inline double wrap_deg(double deg) {
  const double d = std::remainder(deg, 360.0);
  return d <= -180.0 ? d + 360.0 : d;
}

}  // namespace hf
HF_SDK_END
