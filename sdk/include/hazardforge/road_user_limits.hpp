// What each road-user class can physically do: the limits table that hazard planning, trajectory checks and
// state estimation all read (share/hazard_limits.yaml).
#pragma once

#include <map>
#include <string>
#include <vector>

#include "hazardforge/abi.hpp"

HF_SDK_BEGIN
namespace hf {

// What a road-user class can physically do (share/hazard_limits.yaml). Decelerations are positive numbers.
struct KinematicLimits {
  std::string object_class;
  double max_speed_mps = 0;
  double max_accel_mps2 = 0;          // speeding up along the path
  double max_decel_mps2 = 0;          // braking along the path
  double max_jerk_mps3 = 0;           // |da/dt| of the acceleration vector
  double max_lateral_accel_mps2 = 0;  // across the path (turning, lane change)
  double max_lateral_speed_mps = 0;   // sideways speed during a lane change
  double max_yaw_rate_dps = 0;        // heading change, deg/s
};

// The limits table, read once; the same file drives planning and check() so both agree.
class LimitsTable {
 public:
  // YAML mapping class -> limits. Throws hf::Error "file:line:col: error: ..." naming the class and field.
  static LimitsTable load(const std::string& path);
  // share_dir()/hazard_limits.yaml
  static std::string default_path();

  bool has(const std::string& object_class) const { return limits_.count(object_class) != 0; }
  // Throws hf::Error naming the class, the file and the known classes.
  const KinematicLimits& at(const std::string& object_class) const;
  std::vector<std::string> classes() const;
  const std::string& file() const { return file_; }
  void set(const KinematicLimits& l) { limits_[l.object_class] = l; }

 private:
  std::map<std::string, KinematicLimits> limits_;
  std::string file_;
};

}  // namespace hf
HF_SDK_END
