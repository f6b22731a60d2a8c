// The calibration file reader shared by the host and the sources.
#include "hazardforge/calibration_file.hpp"

#include <string>

#include <yaml-cpp/yaml.h>

#include "hazardforge/error.hpp"

namespace hf {

namespace fs = std::filesystem;

CalibrationFile read_calibration_file(const fs::path& yaml) {
  const std::string file = yaml.string();
  if (!fs::exists(yaml)) throw Error("calibration file '" + file + "' does not exist");
  YAML::Node root;
  try {
    root = YAML::LoadFile(file);
  } catch (const YAML::Exception& ex) {
    throw Error(file + ":" + std::to_string(ex.mark.line + 1) + ":" + std::to_string(ex.mark.column + 1) +
                ": error: " + ex.msg);
  }
  if (!root.IsMap()) throw Error(file + ": error: calibration file is not a YAML mapping");
  auto number = [&](const char* name) -> double {
    YAML::Node n = root[name];
    if (!n) throw Error(file + ": error: calibration field '" + std::string(name) + "' is missing");
    try {
      return n.as<double>();
    } catch (const YAML::Exception&) {
      throw Error(file + ":" + std::to_string(n.Mark().line + 1) + ": error: calibration field '" + name +
                  "' is not a number");
    }
  };
  CalibrationFile c;
  c.width = static_cast<int>(number("image_width"));
  c.height = static_cast<int>(number("image_height"));
  c.fx = number("fx");
  c.fy = number("fy");
  c.cx = number("cx");
  c.cy = number("cy");
  if (c.width <= 0 || c.height <= 0 || !(c.fx > 0) || !(c.fy > 0))
    throw Error(file + ": error: calibration needs positive image_width, image_height, fx and fy");
  if (YAML::Node d = root["distortion"]) {
    try {
      c.distortion = d.as<std::vector<double>>();
    } catch (const YAML::Exception&) {
      throw Error(file + ":" + std::to_string(d.Mark().line + 1) +
                  ": error: calibration field 'distortion' is not a list of numbers");
    }
    const size_t n = c.distortion.size();
    if (n != 0 && n != 4 && n != 5 && n != 8 && n != 12 && n != 14)
      throw Error(file + ": error: calibration field 'distortion' has " + std::to_string(n) +
                  " coefficients; OpenCV takes 4, 5, 8, 12 or 14");
  }
  return c;
}

}  // namespace hf
