// Parsers for KITTI calib (P2) and tracking label files.
#include "kitti_files.hpp"

#include <fstream>
#include <sstream>

#include "hazardforge/error.hpp"

namespace hf::source::kitti {

namespace fs = std::filesystem;

cv::Vec3d Calibration::cam0_to_cam2() const {
  // P2 = K [I | t]; K is upper triangular without skew.
  const double tz = P2(2, 3);
  const double ty = (P2(1, 3) - cy() * tz) / fy();
  const double tx = (P2(0, 3) - cx() * tz - P2(0, 1) * ty) / fx();
  return {tx, ty, tz};
}

Calibration read_calibration(const fs::path& file) {
  if (!fs::exists(file)) throw Error("KITTI calibration '" + file.string() + "' does not exist");
  std::ifstream in(file);
  if (!in) throw Error("KITTI calibration '" + file.string() + "' cannot be read");
  std::string line;
  for (int n = 1; std::getline(in, line); ++n) {
    const auto colon = line.find(':');
    if (colon == std::string::npos) continue;
    const std::string key = line.substr(0, colon);
    if (key != "P2" && key != "P_rect_02") continue;
    std::istringstream ss(line.substr(colon + 1));
    std::vector<double> v;
    double x;
    while (ss >> x) v.push_back(x);
    if (v.size() != 12 || !ss.eof())
      throw Error(file.string() + ":" + std::to_string(n) + ": error: " + key + " needs 12 numbers");
    Calibration c;
    for (int i = 0; i < 12; ++i) c.P2(i / 4, i % 4) = v[static_cast<size_t>(i)];
    if (!(c.fx() > 0) || !(c.fy() > 0))
      throw Error(file.string() + ":" + std::to_string(n) + ": error: " + key +
                  " has a non-positive focal length");
    return c;
  }
  throw Error("KITTI calibration '" + file.string() + "' has no P2 (or P_rect_02) line");
}

std::map<int, std::vector<Label>> read_labels(const fs::path& file) {
  if (!fs::exists(file)) throw Error("KITTI label file '" + file.string() + "' does not exist");
  std::ifstream in(file);
  if (!in) throw Error("KITTI label file '" + file.string() + "' cannot be read");
  static const char* kFields[] = {"frame", "track_id", "type", "truncated", "occluded",  "alpha",
                                  "x1",    "y1",       "x2",   "y2",        "h",         "w",
                                  "l",     "x",        "y",    "z",         "rotation_y"};
  std::map<int, std::vector<Label>> out;
  std::string line;
  for (int n = 1; std::getline(in, line); ++n) {
    if (line.find_first_not_of(" \t\r") == std::string::npos) continue;
    std::istringstream ss(line);
    std::vector<std::string> tok;
    for (std::string t; ss >> t;) tok.push_back(t);
    // 17 fields, or 18 with a detection score (result files).
    if (tok.size() != 17 && tok.size() != 18)
      throw Error(file.string() + ":" + std::to_string(n) +
                  ": error: expected 17 fields (frame track_id type ... " + "rotation_y), got " +
                  std::to_string(tok.size()));
    auto num = [&](size_t i) {
      size_t used = 0;
      double v = 0;
      try {
        v = std::stod(tok[i], &used);
      } catch (const std::exception&) {
        used = 0;
      }
      if (used != tok[i].size())
        throw Error(file.string() + ":" + std::to_string(n) + ": error: field '" + kFields[i] +
                    "' is not a number: '" + tok[i] + "'");
      return v;
    };
    Label l;
    l.line = n;
    l.frame = static_cast<int>(num(0));
    l.track_id = static_cast<int>(num(1));
    l.type = tok[2];
    l.truncated = num(3);
    l.occluded = static_cast<int>(num(4));
    l.alpha = num(5);
    l.box2d = cv::Rect2d(num(6), num(7), num(8) - num(6), num(9) - num(7));
    l.h = num(10);
    l.w = num(11);
    l.l = num(12);
    l.location = cv::Vec3d(num(13), num(14), num(15));
    l.rotation_y = num(16);
    if (l.frame < 0) throw Error(file.string() + ":" + std::to_string(n) + ": error: negative frame number");
    out[l.frame].push_back(l);
  }
  return out;
}

}  // namespace hf::source::kitti
