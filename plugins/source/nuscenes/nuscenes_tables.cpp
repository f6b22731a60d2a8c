// Loading and token-indexing of the nuScenes JSON tables, with messages naming the file, token and field.
#include "nuscenes_tables.hpp"

#include <cmath>
#include <fstream>
#include <sstream>

namespace hf::source::nuscenes {

namespace fs = std::filesystem;

Table Table::load(const fs::path& file) {
  Table t;
  t.file_ = file;
  if (!fs::exists(file)) throw Error("nuScenes table '" + file.string() + "' does not exist");
  std::ifstream in(file, std::ios::binary);
  if (!in) throw Error("nuScenes table '" + file.string() + "' cannot be read");
  try {
    t.records_ = Json::parse(in);
  } catch (const Json::exception& e) {  // parse errors and numbers too large for a double
    // nlohmann's message carries the line and column; keep it, prefixed by the file.
    std::string what = e.what();
    const std::string tag = "] ";
    if (auto p = what.find(tag); p != std::string::npos) what = what.substr(p + tag.size());
    throw Error("nuScenes table '" + file.string() + "': invalid JSON: " + what);
  }
  if (!t.records_.is_array())
    throw Error("nuScenes table '" + file.string() + "': expected a JSON list of records");
  for (size_t i = 0; i < t.records_.size(); ++i) {
    const Json& r = t.records_[i];
    if (!r.is_object() || !r.contains("token") || !r["token"].is_string())
      throw Error("nuScenes table '" + file.string() + "': record " + std::to_string(i) +
                  " has no string 'token'");
    t.index_.emplace(r["token"].get<std::string>(), i);
  }
  return t;
}

const Json& Table::at(const std::string& token, const std::string& referenced_by) const {
  auto it = index_.find(token);
  if (it == index_.end())
    throw Error("nuScenes table '" + file_.string() + "': no record with token '" + token +
                "' (referenced by " + referenced_by + ")");
  return records_[it->second];
}

void Table::bad_record(const Json& rec, const std::string& message) const {
  const std::string token =
      rec.contains("token") && rec["token"].is_string() ? rec["token"].get<std::string>() : "?";
  throw Error("nuScenes table '" + file_.string() + "': record '" + token + "': " + message);
}

void Table::bad_field(const Json& rec, const char* name, const char* type) const {
  bad_record(rec, std::string("field '") + name + "' is missing or not " + type);
}

std::string Table::str(const Json& rec, const char* name) const {
  auto it = rec.find(name);
  if (it == rec.end() || !it->is_string()) bad_field(rec, name, "a string");
  return it->get<std::string>();
}
double Table::num(const Json& rec, const char* name) const {
  auto it = rec.find(name);
  if (it == rec.end() || !it->is_number() || !std::isfinite(it->get<double>()))
    bad_field(rec, name, "a finite number");
  return it->get<double>();
}
int64_t Table::i64(const Json& rec, const char* name) const {
  auto it = rec.find(name);
  if (it == rec.end() || !it->is_number_integer()) bad_field(rec, name, "an integer");
  return it->get<int64_t>();
}
bool Table::boolean(const Json& rec, const char* name) const {
  auto it = rec.find(name);
  if (it == rec.end() || !it->is_boolean()) bad_field(rec, name, "a boolean");
  return it->get<bool>();
}
std::vector<double> Table::nums(const Json& rec, const char* name, size_t expected) const {
  auto it = rec.find(name);
  const std::string type =
      expected ? "a list of " + std::to_string(expected) + " finite numbers" : "a list of finite numbers";
  if (it == rec.end() || !it->is_array() || (expected && it->size() != expected))
    bad_field(rec, name, type.c_str());
  std::vector<double> v;
  for (const Json& x : *it) {
    if (!x.is_number() || !std::isfinite(x.get<double>())) bad_field(rec, name, type.c_str());
    v.push_back(x.get<double>());
  }
  return v;
}

cv::Matx33d Table::rotation(const Json& rec, const char* name) const {
  const std::vector<double> q = nums(rec, name, 4);
  const double norm = std::sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3]);
  // nuScenes stores normalised quaternions; 1e-3 allows for the printed digits, not for a wrong value.
  if (!(std::abs(norm - 1.0) <= 1e-3)) {
    std::ostringstream os;
    os << "field '" << name << "' = [" << q[0] << ", " << q[1] << ", " << q[2] << ", " << q[3]
       << "] is not a unit quaternion (norm " << norm << ")";
    bad_record(rec, os.str());
  }
  return quaternion_to_matrix(q);
}

cv::Matx33d quaternion_to_matrix(const std::vector<double>& q) {
  double w = q[0], x = q[1], y = q[2], z = q[3];
  const double n = std::sqrt(w * w + x * x + y * y + z * z);
  w /= n, x /= n, y /= n, z /= n;
  return {1 - 2 * (y * y + z * z), 2 * (x * y - z * w),     2 * (x * z + y * w),
          2 * (x * y + z * w),     1 - 2 * (x * x + z * z), 2 * (y * z - x * w),
          2 * (x * z - y * w),     2 * (y * z + x * w),     1 - 2 * (x * x + y * y)};
}

Tables Tables::load(const fs::path& dir, bool with_annotations) {
  if (!fs::is_directory(dir)) throw Error("nuScenes table folder '" + dir.string() + "' does not exist");
  Tables t;
  t.scene = Table::load(dir / "scene.json");
  t.sample = Table::load(dir / "sample.json");
  t.sample_data = Table::load(dir / "sample_data.json");
  t.ego_pose = Table::load(dir / "ego_pose.json");
  t.calibrated_sensor = Table::load(dir / "calibrated_sensor.json");
  t.sensor = Table::load(dir / "sensor.json");
  if (with_annotations) {
    t.sample_annotation = Table::load(dir / "sample_annotation.json");
    t.instance = Table::load(dir / "instance.json");
    t.category = Table::load(dir / "category.json");
  }
  return t;
}

}  // namespace hf::source::nuscenes
