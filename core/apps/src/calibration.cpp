// Chessboard calibration (OpenCV findChessboardCorners + cornerSubPix + calibrateCamera) and its YAML file.
#include "hazardforge/apps/calibration.hpp"

#include "hazardforge/atomic_file.hpp"

#include "hazardforge/calibration_file.hpp"

#include <unistd.h>

#include <algorithm>
#include <cstdio>
#include <fstream>
#include <ostream>
#include <sstream>

#include <yaml-cpp/yaml.h>
#include <opencv2/calib3d.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "hazardforge/error.hpp"

namespace hf {

namespace fs = std::filesystem;

namespace {

bool is_image(const fs::path& p) {
  std::string ext = p.extension().string();
  std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char c) { return std::tolower(c); });
  return ext == ".jpg" || ext == ".jpeg" || ext == ".png" || ext == ".bmp";
}

std::string size_str(cv::Size s) {
  return std::to_string(s.width) + "x" + std::to_string(s.height);
}

}  // namespace

CalibrationResult calibrate_chessboard(const fs::path& folder, cv::Size inner_corners, double square_size,
                                       std::ostream* log) {
  if (!fs::is_directory(folder)) throw Error("calibration folder '" + folder.string() + "' does not exist");
  if (inner_corners.width < 2 || inner_corners.height < 2)
    throw Error("chessboard needs at least 2x2 inner corners, got " + size_str(inner_corners));
  if (!(square_size > 0)) throw Error("chessboard square size must be positive");

  std::vector<fs::path> files;
  for (const auto& e : fs::directory_iterator(folder))
    if (e.is_regular_file() && is_image(e.path())) files.push_back(e.path());
  std::sort(files.begin(), files.end());

  CalibrationResult r;
  r.board_cols = inner_corners.width;
  r.board_rows = inner_corners.height;
  r.square_size = square_size;

  // The board in its own plane, row by row as findChessboardCorners orders the corners.
  std::vector<cv::Point3f> board;
  for (int y = 0; y < inner_corners.height; ++y)
    for (int x = 0; x < inner_corners.width; ++x)
      board.emplace_back(static_cast<float>(x * square_size), static_cast<float>(y * square_size), 0.f);

  cv::Size image_size;
  std::vector<std::vector<cv::Point2f>> image_points;
  std::vector<std::vector<cv::Point3f>> object_points;
  for (const fs::path& f : files) {
    const std::string name = f.filename().string();
    cv::Mat gray = cv::imread(f.string(), cv::IMREAD_GRAYSCALE);
    auto reject = [&](const std::string& why) {
      r.images_rejected.push_back({name, why});
      if (log) *log << name << ": not used (" << why << ")\n";
    };
    if (gray.empty()) {
      reject("cannot be decoded");
      continue;
    }
    // All views must share one image size: the intrinsics are only defined for it.
    if (image_size.empty()) image_size = gray.size();
    if (gray.size() != image_size) {
      reject("size " + size_str(gray.size()) + " differs from " + size_str(image_size));
      continue;
    }
    std::vector<cv::Point2f> corners;
    const bool found = cv::findChessboardCorners(gray, inner_corners, corners,
                                                 cv::CALIB_CB_ADAPTIVE_THRESH | cv::CALIB_CB_NORMALIZE_IMAGE);
    if (!found) {
      reject("no " + size_str(inner_corners) + " chessboard found");
      continue;
    }
    cv::cornerSubPix(gray, corners, cv::Size(11, 11), cv::Size(-1, -1),
                     cv::TermCriteria(cv::TermCriteria::EPS + cv::TermCriteria::COUNT, 30, 0.001));
    image_points.push_back(std::move(corners));
    object_points.push_back(board);
    r.images_used.push_back(name);
    if (log) *log << name << ": board found\n";
  }
  if (image_points.size() < 3)
    throw Error("calibration folder '" + folder.string() + "': only " + std::to_string(image_points.size()) +
                " of " + std::to_string(files.size()) + " images show a " + size_str(inner_corners) +
                " chessboard; at least 3 are needed");

  cv::Mat K, dist;
  std::vector<cv::Mat> rvecs, tvecs;
  r.rms_px = cv::calibrateCamera(object_points, image_points, image_size, K, dist, rvecs, tvecs);
  r.image_width = image_size.width;
  r.image_height = image_size.height;
  r.fx = K.at<double>(0, 0);
  r.fy = K.at<double>(1, 1);
  r.cx = K.at<double>(0, 2);
  r.cy = K.at<double>(1, 2);
  r.distortion.assign(dist.begin<double>(), dist.end<double>());
  if (log)
    *log << "used " << r.images_used.size() << " of " << files.size() << " images, RMS reprojection error "
         << r.rms_px << " px\n";
  return r;
}

void write_calibration(const CalibrationResult& r, const fs::path& yaml) {
  YAML::Emitter e;
  e.SetDoublePrecision(12);
  e << YAML::Comment(
      "HazardForge camera calibration: pinhole intrinsics + OpenCV distortion (k1 k2 p1 p2 k3)");
  e << YAML::BeginMap;
  e << YAML::Key << "image_width" << YAML::Value << r.image_width;
  e << YAML::Key << "image_height" << YAML::Value << r.image_height;
  e << YAML::Key << "fx" << YAML::Value << r.fx;
  e << YAML::Key << "fy" << YAML::Value << r.fy;
  e << YAML::Key << "cx" << YAML::Value << r.cx;
  e << YAML::Key << "cy" << YAML::Value << r.cy;
  e << YAML::Key << "distortion" << YAML::Value << YAML::Flow << r.distortion;
  e << YAML::Key << "rms_px" << YAML::Value << r.rms_px;
  e << YAML::Key << "board" << YAML::Value << YAML::Flow << YAML::BeginMap << YAML::Key << "cols"
    << YAML::Value << r.board_cols << YAML::Key << "rows" << YAML::Value << r.board_rows << YAML::Key
    << "square_size" << YAML::Value << r.square_size << YAML::EndMap;
  e << YAML::Key << "images_used" << YAML::Value << YAML::BeginSeq;
  for (const auto& n : r.images_used) e << n;
  e << YAML::EndSeq;
  e << YAML::Key << "images_rejected" << YAML::Value << YAML::BeginSeq;
  for (const auto& rej : r.images_rejected)
    e << YAML::Flow << YAML::BeginMap << YAML::Key << "file" << YAML::Value << rej.file << YAML::Key
      << "reason" << YAML::Value << rej.reason << YAML::EndMap;
  e << YAML::EndSeq;
  e << YAML::EndMap;
  if (!e.good()) throw Error("cannot format calibration for '" + yaml.string() + "': " + e.GetLastError());

  try {
    write_file_atomic(yaml, std::string(e.c_str()) + "\n");
  } catch (const Error& err) {
    throw Error("cannot write calibration: " + std::string(err.what()));
  }
}

CalibrationResult read_calibration(const fs::path& yaml) {
  const CalibrationFile f = read_calibration_file(yaml);  // checks the file and the intrinsics
  CalibrationResult r;
  r.image_width = f.width;
  r.image_height = f.height;
  r.fx = f.fx;
  r.fy = f.fy;
  r.cx = f.cx;
  r.cy = f.cy;
  r.distortion = f.distortion;
  // The calibration's own record (board, error, images) is optional in the file.
  const std::string file = yaml.string();
  const YAML::Node root = YAML::LoadFile(file);
  auto number = [&](const char* name) -> double {
    const YAML::Node n = root[name];
    try {
      return n.as<double>();
    } catch (const YAML::Exception&) {
      throw Error(file + ":" + std::to_string(n.Mark().line + 1) + ": error: calibration field '" + name +
                  "' is not a number");
    }
  };
  if (root["rms_px"]) r.rms_px = number("rms_px");
  if (YAML::Node b = root["board"]; b && b.IsMap()) {
    r.board_cols = b["cols"] ? b["cols"].as<int>() : 0;
    r.board_rows = b["rows"] ? b["rows"].as<int>() : 0;
    r.square_size = b["square_size"] ? b["square_size"].as<double>() : 1.0;
  }
  if (YAML::Node u = root["images_used"]; u && u.IsSequence())
    for (const auto& n : u) r.images_used.push_back(n.as<std::string>());
  if (YAML::Node u = root["images_rejected"]; u && u.IsSequence())
    for (const auto& n : u)
      r.images_rejected.push_back({n["file"].as<std::string>(""), n["reason"].as<std::string>("")});
  return r;
}

}  // namespace hf
