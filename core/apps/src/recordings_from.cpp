// Recordings found, not listed: a nuScenes dataroot, a KITTI raw download, file patterns.
#include "hazardforge/apps/recordings_from.hpp"

#include <fnmatch.h>
#include <glob.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <cctype>
#include <fstream>
#include <map>
#include <optional>
#include <set>
#include <sstream>

#include <nlohmann/json.hpp>

#include "hazardforge/error.hpp"

namespace hf::apps {

namespace fs = std::filesystem;
using Json = nlohmann::json;

namespace {

std::string lower(std::string s) {
  std::transform(s.begin(), s.end(), s.begin(), [](unsigned char c) { return std::tolower(c); });
  return s;
}

bool is_picture(const fs::path& p) {
  const std::string e = lower(p.extension().string());
  return e == ".png" || e == ".jpg" || e == ".jpeg" || e == ".bmp" || e == ".tif" || e == ".tiff";
}

bool is_video(const fs::path& p) {
  static const std::set<std::string> kExt = {".mp4", ".mov",  ".avi", ".mkv", ".webm", ".m4v",
                                             ".mpg", ".mpeg", ".ts",  ".mts", ".h264", ".hevc"};
  return kExt.count(lower(p.extension().string())) > 0;
}

// A path as a --set value: a JSON string is a YAML scalar whatever the path holds (spaces, '#', ':', '[').
std::string quoted(const fs::path& p) {
  return Json(p.string()).dump();
}

Json read_table(const fs::path& file) {
  std::ifstream in(file);
  if (!in) throw Error(file.string() + ": cannot read");
  try {
    return Json::parse(in);
  } catch (const std::exception& e) {
    throw Error(file.string() + ": not JSON: " + e.what());
  }
}

// The side traffic keeps at a nuScenes log's location (the dataset drove in Boston and Singapore).
std::string side_of_location(const std::string& location) {
  if (location.rfind("singapore", 0) == 0) return "left";
  if (location.rfind("boston", 0) == 0) return "right";
  return "";
}

// The same from a log name's UTC offset ("n015-2018-10-08-15-36-50+0800").
std::string side_of_log_name(const std::string& name) {
  if (name.find("+0800") != std::string::npos) return "left";
  if (name.find("-0400") != std::string::npos || name.find("-0500") != std::string::npos) return "right";
  return "";
}

// KITTI's calibration: the 12 numbers after `key` in a calibration text file, if it has them.
std::optional<std::array<double, 12>> projection(const fs::path& file, const std::string& key) {
  std::ifstream in(file);
  for (std::string line; std::getline(in, line);) {
    if (line.rfind(key, 0) != 0) continue;
    std::istringstream ss(line.substr(key.size()));
    std::array<double, 12> p{};
    for (double& v : p)
      if (!(ss >> v)) return std::nullopt;
    return p;
  }
  return std::nullopt;
}

}  // namespace

std::string unique_recording_name(const std::string& text, std::vector<std::string>& taken) {
  std::string base;
  for (char c : text)
    base += std::isalnum(static_cast<unsigned char>(c)) || c == '-' || c == '_' || c == '.' ? c : '_';
  while (!base.empty() && base.front() == '.') base.erase(base.begin());  // never "." / ".." / hidden
  if (base.empty()) base = "recording";
  std::string name = base;
  for (int k = 2; std::find(taken.begin(), taken.end(), name) != taken.end(); ++k)
    name = base + "-" + std::to_string(k);
  taken.push_back(name);
  return name;
}

FoundRecordings nuscenes_recordings(const fs::path& dataroot, const std::string& version,
                                    const std::vector<std::string>& patterns) {
  FoundRecordings out;
  std::error_code ec;
  if (!fs::is_directory(dataroot, ec))
    throw Error(dataroot.string() + ": not a folder (a nuScenes dataroot)");
  std::string v = version;
  if (v.empty()) {
    std::vector<std::string> tables;
    for (const auto& e : fs::directory_iterator(dataroot, ec))
      if (e.is_directory() && fs::exists(e.path() / "scene.json"))
        tables.push_back(e.path().filename().string());
    std::sort(tables.begin(), tables.end());
    if (tables.empty()) throw Error(dataroot.string() + ": no table folder with scene.json (e.g. v1.0-mini)");
    if (tables.size() > 1) {
      std::string list;
      for (const auto& t : tables) list += (list.empty() ? "" : ", ") + t;
      throw Error(dataroot.string() + ": several table folders (" + list + "); name one with 'version'");
    }
    v = tables.front();
  }
  const fs::path tables = dataroot / v;
  const Json scenes = read_table(tables / "scene.json");
  if (!scenes.is_array()) throw Error((tables / "scene.json").string() + ": not a list of scenes");
  // Log tokens to locations, where the log table is there; else one UTC offset shared by every camera file.
  std::map<std::string, std::string> log_side;
  std::string folder_side;
  if (fs::exists(tables / "log.json")) {
    const Json logs = read_table(tables / "log.json");
    for (const Json& l : logs)
      if (l.is_object() && l.contains("token") && l.contains("location") && l["location"].is_string())
        log_side[l["token"].get<std::string>()] = side_of_location(l["location"].get<std::string>());
  } else {
    std::set<std::string> sides;
    for (const auto& e : fs::directory_iterator(dataroot / "samples" / "CAM_FRONT", ec))
      sides.insert(side_of_log_name(e.path().filename().string()));
    if (sides.size() == 1) folder_side = *sides.begin();
  }
  for (size_t i = 0; i < scenes.size(); ++i) {
    const Json& s = scenes[i];
    if (!s.is_object() || !s.contains("name") || !s["name"].is_string()) {
      out.skipped.push_back(
          {(tables / "scene.json").string() + " entry " + std::to_string(i), "has no name"});
      continue;
    }
    const std::string name = s["name"].get<std::string>();
    if (!patterns.empty() && std::none_of(patterns.begin(), patterns.end(), [&](const std::string& p) {
          return fnmatch(p.c_str(), name.c_str(), 0) == 0;
        }))
      continue;
    FoundRecording r;
    r.name = name;
    r.set = {"source.dataroot=" + quoted(dataroot), "source.version=" + Json(v).dump(),
             "source.scenes=[" + Json(name).dump() + "]"};
    std::string side = folder_side;
    if (auto it = log_side.find(s.value("log_token", "")); it != log_side.end()) side = it->second;
    if (!side.empty()) r.set.push_back("scene.road.driving_side=" + side);
    out.found.push_back(std::move(r));
  }
  return out;
}

FoundRecordings kitti_raw_recordings(const fs::path& root) {
  FoundRecordings out;
  std::error_code ec;
  if (!fs::is_directory(root, ec))
    throw Error(root.string() + ": not a folder (a KITTI raw download or drive)");
  std::vector<fs::path> drives;  // folders holding image_02/data
  fs::recursive_directory_iterator it(root, fs::directory_options::skip_permission_denied, ec), end;
  for (; it != end; it.increment(ec)) {
    if (ec) break;
    if (it.depth() > 4) {
      it.disable_recursion_pending();
      continue;
    }
    if (it->is_directory(ec) && it->path().filename() == "image_02") {
      drives.push_back(it->path().parent_path());
      it.disable_recursion_pending();
    }
  }
  std::sort(drives.begin(), drives.end());
  for (const fs::path& d : drives) {
    const fs::path data = d / "image_02" / "data";
    size_t pictures = 0;
    for (const auto& e : fs::directory_iterator(data, ec))
      if (is_picture(e.path())) ++pictures;
    if (pictures == 0) {
      out.skipped.push_back({data.string(), "no PNG frames"});
      continue;
    }
    FoundRecording r;
    r.name = (d == root ? root.filename() : d.filename()).string();
    r.set = {"source.path=" + quoted(data), "source.fps=10", "scene.camera.height_m=1.65",
             "scene.road.driving_side=right"};
    // The rectified camera 2: calib_cam_to_cam.txt's P_rect_02, or a KITTI-tracking file's P2, in the drive's
    // folder or above it.
    std::optional<std::array<double, 12>> p;
    for (fs::path at = d; !p; at = at.parent_path()) {
      if (fs::exists(at / "calib_cam_to_cam.txt")) p = projection(at / "calib_cam_to_cam.txt", "P_rect_02:");
      for (const auto& e : fs::directory_iterator(at, ec))
        if (!p && e.is_regular_file() && e.path().extension() == ".txt") p = projection(e.path(), "P2:");
      if (at == root || at == at.parent_path() || at.lexically_relative(root).string().rfind("..", 0) == 0)
        break;
    }
    if (p) {
      const auto num = [](double v) {
        std::ostringstream s;
        s.precision(10);
        s << v;
        return s.str();
      };
      r.set.push_back("scene.camera.fx=" + num((*p)[0]));
      r.set.push_back("scene.camera.fy=" + num((*p)[5]));
      r.set.push_back("scene.camera.cx=" + num((*p)[2]));
      r.set.push_back("scene.camera.cy=" + num((*p)[6]));
    }
    out.found.push_back(std::move(r));
  }
  if (drives.empty()) out.skipped.push_back({root.string(), "no image_02/data folder below it"});
  return out;
}

FoundRecordings file_recordings(const std::vector<std::string>& patterns) {
  FoundRecordings out;
  std::set<fs::path> seen;
  for (const std::string& pattern : patterns) {
    glob_t g{};
    const int rc = glob(pattern.c_str(), GLOB_BRACE | GLOB_TILDE, nullptr, &g);
    if (rc == GLOB_NOMATCH) out.skipped.push_back({pattern, "matches nothing"});
    for (size_t i = 0; rc == 0 && i < g.gl_pathc; ++i) {
      const fs::path p = fs::absolute(g.gl_pathv[i]).lexically_normal();
      if (!seen.insert(p).second) continue;
      std::error_code ec;
      const auto st = fs::status(p, ec);
      std::string why;
      if (fs::is_directory(st)) {
        bool any = false;
        for (const auto& e : fs::directory_iterator(p, ec))
          if (is_picture(e.path())) {
            any = true;
            break;
          }
        if (!any) why = "a folder without pictures (png, jpg, bmp, tif)";
      } else if (!fs::is_regular_file(st)) {
        why = "not a file or folder";
      } else if (!is_video(p)) {
        continue;  // the pattern's other files (notes, calibration, pictures of a folder) are not recordings
      } else if (fs::file_size(p, ec) == 0) {
        why = "empty";
      }
      if (why.empty() && ::access(p.c_str(), R_OK) != 0) why = "not readable";
      if (!why.empty()) {
        out.skipped.push_back({p.string(), why});
        continue;
      }
      out.found.push_back(
          {fs::is_directory(st) ? p.filename().string() : p.stem().string(), {"source.path=" + quoted(p)}});
    }
    globfree(&g);
  }
  return out;
}

}  // namespace hf::apps
