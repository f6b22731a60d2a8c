// nuScenes relational tables (JSON) loaded and indexed by token, with field access that names file and token.
#pragma once

#include <filesystem>
#include <string>
#include <unordered_map>
#include <vector>

#include <opencv2/core.hpp>

#include "hazardforge/error.hpp"
#include "hazardforge/types.hpp"

namespace hf::source::nuscenes {

// One table file: its records (a JSON list) and a token index.
class Table {
 public:
  // Throws hf::Error naming the file when it is missing, is not valid JSON or is not a list of records.
  static Table load(const std::filesystem::path& file);

  const std::filesystem::path& file() const { return file_; }
  const Json& records() const { return records_; }
  bool has(const std::string& token) const { return index_.count(token) != 0; }
  // Throws hf::Error "<file>: no record with token '<t>' (referenced by <what>)".
  const Json& at(const std::string& token, const std::string& referenced_by) const;

  // Typed field of a record; throws "<file>: record '<token>': field '<name>' is missing or not a <type>".
  std::string str(const Json& rec, const char* name) const;
  double num(const Json& rec, const char* name) const;
  int64_t i64(const Json& rec, const char* name) const;
  bool boolean(const Json& rec, const char* name) const;
  std::vector<double> nums(const Json& rec, const char* name, size_t expected) const;  // 0 = any length
  // Rotation of a [w, x, y, z] field; throws naming the record when it is not a unit quaternion (a zero
  // quaternion would otherwise turn every yaw into NaN, far from where it came from).
  cv::Matx33d rotation(const Json& rec, const char* name) const;
  // Throws "<file>: record '<token>': <message>".
  [[noreturn]] void bad_record(const Json& rec, const std::string& message) const;

 private:
  [[noreturn]] void bad_field(const Json& rec, const char* name, const char* type) const;
  std::filesystem::path file_;
  Json records_;
  std::unordered_map<std::string, size_t> index_;
};

// Rotation matrix of a unit quaternion given as [w, x, y, z] (nuScenes/pyquaternion order).
cv::Matx33d quaternion_to_matrix(const std::vector<double>& wxyz);

// The tables this source needs. log, attribute, visibility and map are not read.
struct Tables {
  Table scene, sample, sample_data, sample_annotation, ego_pose, calibrated_sensor, sensor, instance,
      category;
  // Loads <dataroot>/<version>/<name>.json; `with_annotations` = false skips
  // sample_annotation/instance/category.
  static Tables load(const std::filesystem::path& table_dir, bool with_annotations);
};

}  // namespace hf::source::nuscenes
