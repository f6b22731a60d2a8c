// Parsers for KITTI calib (P2) and tracking label files.
#include "kitti_files.hpp"

#include <cctype>
#include <cmath>
#include <cstdlib>
#include <fstream>
#include <optional>
#include <sstream>

#include "hazardforge/error.hpp"

namespace hf::source::kitti {

namespace fs = std::filesystem;

namespace {

// KITTI files hold plain decimals. std::stod would also take "nan", "inf" and hex ("0x10" = 16), none of
// which a KITTI tool writes: they mean a corrupt or hand-edited file, so they are refused, not read.
std::optional<double> strict_decimal(const std::string& t) {
  size_t i = 0, digits = 0;
  if (i < t.size() && (t[i] == '+' || t[i] == '-')) ++i;
  for (; i < t.size() && std::isdigit(static_cast<unsigned char>(t[i])); ++i) ++digits;
  if (i < t.size() && t[i] == '.')
    for (++i; i < t.size() && std::isdigit(static_cast<unsigned char>(t[i])); ++i) ++digits;
  if (digits == 0) return std::nullopt;
  if (i < t.size() && (t[i] == 'e' || t[i] == 'E')) {
    size_t exp_digits = 0;
    ++i;
    if (i < t.size() && (t[i] == '+' || t[i] == '-')) ++i;
    for (; i < t.size() && std::isdigit(static_cast<unsigned char>(t[i])); ++i) ++exp_digits;
    if (exp_digits == 0) return std::nullopt;
  }
  if (i != t.size()) return std::nullopt;
  const double v = std::strtod(t.c_str(), nullptr);
  if (!std::isfinite(v)) return std::nullopt;
  return v;
}

}  // namespace

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
    for (std::string t; ss >> t;) {
      const std::optional<double> x = strict_decimal(t);
      if (!x)
        throw Error(file.string() + ":" + std::to_string(n) + ": error: " + key + " value " +
                    std::to_string(v.size() + 1) + " is not a finite decimal number: '" + t + "'");
      v.push_back(*x);
    }
    if (v.size() != 12)
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
      const std::optional<double> v = strict_decimal(tok[i]);
      if (!v)
        throw Error(file.string() + ":" + std::to_string(n) + ": error: field '" + kFields[i] +
                    "' is not a finite decimal number: '" + tok[i] + "'");
      return *v;
    };
    // Frame numbers index arrays of frames: a corrupt one (2e9) must not become an allocation of that size.
    auto integer = [&](size_t i, long long lo, long long hi) {
      const double v = num(i);
      if (v != std::floor(v) || v < static_cast<double>(lo) || v > static_cast<double>(hi))
        throw Error(file.string() + ":" + std::to_string(n) + ": error: field '" + kFields[i] +
                    "' = " + tok[i] + " is not an integer in [" + std::to_string(lo) + ", " +
                    std::to_string(hi) + "]");
      return static_cast<int>(v);
    };
    Label l;
    l.line = n;
    l.frame = integer(0, 0, kMaxFrameNumber);
    l.track_id = integer(1, -1, kMaxFrameNumber);
    l.type = tok[2];
    l.truncated = num(3);
    l.occluded = integer(4, -1, 3);  // KITTI: 0 visible .. 3 unknown, -1 for DontCare
    l.alpha = num(5);
    l.box2d = cv::Rect2d(num(6), num(7), num(8) - num(6), num(9) - num(7));
    l.h = num(10);
    l.w = num(11);
    l.l = num(12);
    l.location = cv::Vec3d(num(13), num(14), num(15));
    l.rotation_y = num(16);
    out[l.frame].push_back(l);
  }
  return out;
}

}  // namespace hf::source::kitti
