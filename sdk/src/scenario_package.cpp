// The scenario package's layout and JSON forms (hazardforge/scenario_package.hpp).
#include "hazardforge/scenario_package.hpp"

#include <cmath>
#include <fstream>

#include "hazardforge/angles.hpp"
#include "hazardforge/error.hpp"

HF_SDK_BEGIN
namespace hf::scenario {

namespace fs = std::filesystem;

namespace {

Json vec3(const cv::Vec3d& v) {
  return Json::array({v[0], v[1], v[2]});
}
Json rect_json(const cv::Rect2f& r) {
  return Json::array({r.x, r.y, r.width, r.height});
}

// Field readers that name what is wrong and where.
const Json& field(const Json& j, const char* key, const std::string& where) {
  if (!j.is_object()) throw Error(where + ": expected a JSON object");
  auto it = j.find(key);
  if (it == j.end()) throw Error(where + ": field '" + key + "' is missing");
  return *it;
}
double number(const Json& j, const char* key, const std::string& where) {
  const Json& v = field(j, key, where);
  if (!v.is_number()) throw Error(where + ": field '" + key + "' is not a number");
  const double d = v.get<double>();
  if (!std::isfinite(d)) throw Error(where + ": field '" + key + "' is not finite");
  return d;
}
std::optional<double> number_or_null(const Json& j, const char* key, const std::string& where) {
  if (!j.contains(key) || j.at(key).is_null()) return std::nullopt;
  return number(j, key, where);
}
std::string text(const Json& j, const char* key, const std::string& where) {
  const Json& v = field(j, key, where);
  if (!v.is_string()) throw Error(where + ": field '" + key + "' is not a string");
  return v.get<std::string>();
}
cv::Vec3d vec3_field(const Json& j, const char* key, const std::string& where) {
  const Json& v = field(j, key, where);
  if (!v.is_array() || v.size() != 3) throw Error(where + ": field '" + key + "' is not 3 numbers");
  cv::Vec3d out;
  for (int i = 0; i < 3; ++i) {
    if (!v[i].is_number()) throw Error(where + ": field '" + key + "' is not 3 numbers");
    out[i] = v[i].get<double>();
  }
  return out;
}
cv::Rect2f rect_field(const Json& j, const char* key, const std::string& where) {
  const Json& v = field(j, key, where);
  if (!v.is_array() || v.size() != 4) throw Error(where + ": field '" + key + "' is not [x, y, w, h]");
  float r[4];
  for (int i = 0; i < 4; ++i) {
    if (!v[i].is_number()) throw Error(where + ": field '" + key + "' is not [x, y, w, h]");
    r[i] = v[i].get<float>();
  }
  if (r[2] < 0 || r[3] < 0) throw Error(where + ": field '" + key + "' has a negative width or height");
  return {r[0], r[1], r[2], r[3]};
}
std::string safe_relative(const std::string& file, const char* key, const std::string& where) {
  const fs::path p(file);
  if (file.empty() || p.is_absolute())
    throw Error(where + ": field '" + key + "' must be a file inside the package");
  for (const auto& part : p)
    if (part == "..") throw Error(where + ": field '" + key + "' must be a file inside the package");
  return file;
}

}  // namespace

Box3d box3d(const CameraModel& cam, const cv::Vec3d& bottom_centre_ego, double heading_ego,
            const cv::Vec3d& size_lwh) {
  Box3d b;
  b.centre_ego = bottom_centre_ego;
  b.heading_ego = wrap_angle(heading_ego);
  b.size_lwh = size_lwh;
  b.location_cam = cam.ego_to_cam(bottom_centre_ego);
  b.dimensions_hwl = cv::Vec3d(size_lwh[2], size_lwh[1], size_lwh[0]);
  // The heading's direction in the camera's axes; KITTI's rotation_y turns the camera's x axis about its y
  // axis (pointing down) onto it: direction (cos r, 0, -sin r).
  const cv::Vec3d d_ego(std::cos(heading_ego), std::sin(heading_ego), 0.0);
  const cv::Vec3d d_cam = cam.R_ego_cam.t() * d_ego;
  b.rotation_y = wrap_angle(std::atan2(-d_cam[2], d_cam[0]));
  return b;
}

double observation_angle(const Box3d& b) {
  return wrap_angle(b.rotation_y - std::atan2(b.location_cam[0], b.location_cam[2]));
}

Json to_json(const LabelledObject& o) {
  Json j = {{"track_id", o.track_id},  {"label", o.label},        {"inserted", o.inserted},
            {"visible", o.visible},    {"box", rect_json(o.box)}, {"truncation", o.truncation},
            {"occlusion", o.occlusion}};
  if (!o.kind.empty()) j["kind"] = o.kind;
  if (!o.instance_id.empty()) j["instance_id"] = o.instance_id;
  j["distance_m"] = finite_or_null(o.distance_m);
  j["ttc_s"] = o.ttc_s ? finite_or_null(*o.ttc_s) : Json();
  if (o.box3d) {
    const Box3d& b = *o.box3d;
    j["location_cam"] = vec3(b.location_cam);
    j["dimensions_hwl"] = vec3(b.dimensions_hwl);
    j["rotation_y"] = b.rotation_y;
    j["centre_ego"] = vec3(b.centre_ego);
    j["size_lwh"] = vec3(b.size_lwh);
    j["heading_ego"] = b.heading_ego;
  }
  return j;
}

Json to_json(const PackageFrame& f) {
  Json cam;
  hf::to_json(cam, f.camera);
  Json objects = Json::array();
  for (const auto& o : f.objects) objects.push_back(to_json(o));
  return {{"frame", f.frame},
          {"timestamp", f.timestamp},
          {"augmented", f.augmented},
          {"original", f.original},
          {"camera", cam},
          {"ego",
           {{"speed_mps", f.ego_speed_mps ? finite_or_null(*f.ego_speed_mps) : Json()},
            {"yaw_rate", f.ego_yaw_rate ? finite_or_null(*f.ego_yaw_rate) : Json()}}},
          {"hazard", f.hazard ? to_json(*f.hazard) : Json()},
          {"objects", objects}};
}

Json to_json(const PackageHeader& h) {
  Json origin;
  hf::to_json(origin, h.origin);
  return {{"schema", kSchema},
          {"kind", h.kind},
          {"object_class", h.object_class},
          {"origin", origin},
          {"image_format", h.image_format},
          {"frames", h.frames}};
}

LabelledObject labelled_object_from_json(const Json& j, const std::string& where) {
  LabelledObject o;
  const Json& id = field(j, "track_id", where);
  if (!id.is_number_integer() || id.get<int64_t>() < 0)
    throw Error(where + ": field 'track_id' is not a whole number >= 0");
  o.track_id = id.get<int64_t>();
  o.label = text(j, "label", where);
  o.inserted = j.value("inserted", false);
  o.visible = j.value("visible", false);
  o.kind = j.value("kind", "");
  o.instance_id = j.value("instance_id", "");
  o.box = rect_field(j, "box", where);
  o.truncation = number(j, "truncation", where);
  o.occlusion = number(j, "occlusion", where);
  if (o.truncation < 0 || o.truncation > 1 || o.occlusion < 0 || o.occlusion > 1)
    throw Error(where + ": fields 'truncation' and 'occlusion' must lie in [0, 1]");
  o.distance_m = number_or_null(j, "distance_m", where).value_or(kNaN);
  o.ttc_s = number_or_null(j, "ttc_s", where);
  if (j.contains("location_cam")) {
    Box3d b;
    b.location_cam = vec3_field(j, "location_cam", where);
    b.dimensions_hwl = vec3_field(j, "dimensions_hwl", where);
    b.rotation_y = number(j, "rotation_y", where);
    b.centre_ego = vec3_field(j, "centre_ego", where);
    b.size_lwh = vec3_field(j, "size_lwh", where);
    b.heading_ego = number(j, "heading_ego", where);
    o.box3d = b;
  }
  return o;
}

PackageFrame package_frame_from_json(const Json& j, const std::string& where) {
  PackageFrame f;
  const Json& fr = field(j, "frame", where);
  if (!fr.is_number_integer() || fr.get<int64_t>() < 0)
    throw Error(where + ": field 'frame' is not a whole number >= 0");
  f.frame = fr.get<int64_t>();
  f.timestamp = number(j, "timestamp", where);
  f.augmented = safe_relative(text(j, "augmented", where), "augmented", where);
  f.original = safe_relative(text(j, "original", where), "original", where);
  try {
    hf::from_json(field(j, "camera", where), f.camera);
  } catch (const nlohmann::json::exception& e) {
    throw Error(where + ": field 'camera': " + e.what());
  }
  if (!f.camera.valid()) throw Error(where + ": field 'camera' has no valid size and focal length");
  if (j.contains("ego") && j.at("ego").is_object()) {
    f.ego_speed_mps = number_or_null(j.at("ego"), "speed_mps", where + ", ego");
    f.ego_yaw_rate = number_or_null(j.at("ego"), "yaw_rate", where + ", ego");
  }
  if (j.contains("hazard") && !j.at("hazard").is_null())
    f.hazard = labelled_object_from_json(j.at("hazard"), where + ", hazard");
  if (j.contains("objects")) {
    const Json& objs = j.at("objects");
    if (!objs.is_array()) throw Error(where + ": field 'objects' is not a list");
    for (size_t i = 0; i < objs.size(); ++i)
      f.objects.push_back(labelled_object_from_json(objs[i], where + ", objects[" + std::to_string(i) + "]"));
  }
  return f;
}

std::optional<fs::path> find_package(const fs::path& dir) {
  std::error_code ec;
  if (fs::is_regular_file(dir / "scenario.json", ec)) return dir;
  if (fs::is_regular_file(dir / "scenario" / "scenario.json", ec)) return dir / "scenario";
  return std::nullopt;
}

Package read_package(const fs::path& dir) {
  const auto found = find_package(dir);
  if (!found)
    throw Error("'" + dir.string() + "' holds no scenario package (scenario.json or scenario/scenario.json)");
  Package p;
  p.dir = *found;
  const fs::path head = p.dir / "scenario.json";
  Json h;
  {
    std::ifstream in(head);
    try {
      h = Json::parse(in);
    } catch (const nlohmann::json::exception& e) {
      throw Error("'" + head.string() + "' is not JSON: " + e.what());
    }
  }
  const std::string hw = "'" + head.string() + "'";
  if (h.value("schema", "") != kSchema)
    throw Error(hw + ": field 'schema' must be \"" + std::string(kSchema) + "\"");
  p.header.kind = h.value("kind", "");
  p.header.object_class = h.value("object_class", "");
  p.header.image_format = h.value("image_format", "jpg");
  p.header.frames = h.value("frames", int64_t{0});
  if (h.contains("origin") && h["origin"].is_object()) {
    p.header.origin.dataset = h["origin"].value("dataset", "");
    p.header.origin.scene = h["origin"].value("scene", "");
    p.header.origin.description = h["origin"].value("description", "");
  }
  const fs::path lines = p.dir / "frames.jsonl";
  std::ifstream in(lines);
  if (!in) throw Error("'" + lines.string() + "' cannot be read");
  std::string line;
  int64_t n = 0;
  while (std::getline(in, line)) {
    ++n;
    if (line.empty()) continue;
    const std::string where = "'" + lines.string() + "' line " + std::to_string(n);
    Json j;
    try {
      j = Json::parse(line);
    } catch (const nlohmann::json::exception&) {
      throw Error(where + ": not a JSON object");
    }
    PackageFrame f = package_frame_from_json(j, where);
    if (!p.frames.empty() && f.frame <= p.frames.back().frame)
      throw Error(where + ": frame " + std::to_string(f.frame) + " does not follow frame " +
                  std::to_string(p.frames.back().frame));
    p.frames.push_back(std::move(f));
  }
  if (p.frames.empty()) throw Error("'" + lines.string() + "' holds no frames");
  return p;
}

}  // namespace hf::scenario
HF_SDK_END
