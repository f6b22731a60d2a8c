// Camera params -> CameraModel; undistortion maps and resizing applied to every frame of a source.
#include "camera_setup.hpp"

#include <algorithm>
#include <cmath>

#include <opencv2/calib3d.hpp>
#include <opencv2/imgproc.hpp>

namespace hf::source {

namespace fs = std::filesystem;

namespace {
std::string size_str(cv::Size s) {
  return std::to_string(s.width) + "x" + std::to_string(s.height);
}
}  // namespace

std::vector<ParamSpec> CameraSetup::params() {
  return {
      ParamSpec::path("calibration", "")
          .describe("calibration YAML (from `hazardforge calibrate`); overrides fx/fy/cx/cy/hfov_deg"),
      ParamSpec::number("fx", 0.0).range(0, 1e6).describe(
          "focal length x in px at the native size (0 = unset)"),
      ParamSpec::number("fy", 0.0).range(0, 1e6).describe("focal length y in px (0 = fx)"),
      ParamSpec::number("cx", 0.0).range(0, 1e6).describe("principal point x in px (0 = image centre)"),
      ParamSpec::number("cy", 0.0).range(0, 1e6).describe("principal point y in px (0 = image centre)"),
      ParamSpec::number("hfov_deg", 0.0)
          .range(0, 179)
          .describe("horizontal field of view when no calibration/fx is given (0 = assume 60 deg, warned)"),
      ParamSpec::number("camera_height", 1.5).range(0.1, 10).describe("camera height above the ground, m"),
      ParamSpec::number("camera_pitch_deg", 0.0).range(-45, 45).describe("downward pitch of the camera, deg"),
      ParamSpec::number("camera_forward", 1.5)
          .range(-10, 10)
          .describe("camera position ahead of the rear axle, m"),
      ParamSpec::boolean("undistort", true)
          .describe("undistort frames with the calibrated K when the calibration has distortion"),
      ParamSpec::integer("resize_width", 0)
          .range(0, 16384)
          .describe("output width (0 = keep; aspect kept if only one is set)"),
      ParamSpec::integer("resize_height", 0).range(0, 16384).describe("output height (0 = keep)"),
      ParamSpec::number("ego_speed_mps", -1.0)
          .range(-1, 100)
          .describe("constant ego speed, m/s (-1 = unknown)"),
  };
}

void CameraSetup::configure(StageContext& ctx) {
  const Params& p = ctx.params();
  calib_path_ = p.get_path("calibration");
  if (!calib_path_.empty()) {
    calib_ = read_calibration_file(calib_path_);
    ctx.record_resource(calib_path_);
  }
  fx_ = p.get_double("fx");
  fy_ = p.get_double("fy");
  cx_ = p.get_double("cx");
  cy_ = p.get_double("cy");
  hfov_deg_ = p.get_double("hfov_deg");
  height_ = p.get_double("camera_height");
  pitch_deg_ = p.get_double("camera_pitch_deg");
  forward_ = p.get_double("camera_forward");
  undistort_ = p.get_bool("undistort");
  resize_w_ = static_cast<int>(p.get_int("resize_width"));
  resize_h_ = static_cast<int>(p.get_int("resize_height"));
  ego_speed_ = p.get_double("ego_speed_mps");
  if (calib_ && (fx_ > 0 || hfov_deg_ > 0))
    ctx.log(LogLevel::kWarning, "both 'calibration' and fx/hfov_deg are given; using the calibration file " +
                                    calib_path_.string());
  if (fx_ <= 0 && (fy_ > 0 || cx_ > 0 || cy_ > 0))
    throw Error("parameter 'fx' is needed when fy/cx/cy are given");
}

void CameraSetup::init(cv::Size native, const std::string& what, StageContext& ctx) {
  native_ = native;
  const int w = native.width, h = native.height;
  double fx, fy, cx, cy;
  std::vector<double> dist;
  if (calib_) {
    CameraModel c;
    c.width = calib_->width;
    c.height = calib_->height;
    c.fx = calib_->fx;
    c.fy = calib_->fy;
    c.cx = calib_->cx;
    c.cy = calib_->cy;
    if (c.width != w || c.height != h) {
      // A pure rescale keeps the normalised distortion model; a different aspect ratio means a crop we
      // cannot know, so the calibration does not apply.
      const double ra = static_cast<double>(c.width) / c.height, rb = static_cast<double>(w) / h;
      if (std::abs(ra / rb - 1.0) > 0.01)
        throw Error("calibration '" + calib_path_.string() + "' is for " + size_str({c.width, c.height}) +
                    " images but " + what + " is " + size_str(native) + " (different aspect ratio)");
      ctx.log(LogLevel::kInfo,
              "scaling calibration " + size_str({c.width, c.height}) + " to " + size_str(native));
      c = c.scaled_to(w, h);
    }
    fx = c.fx, fy = c.fy, cx = c.cx, cy = c.cy;
    dist = calib_->distortion;
    intrinsics_source_ = "calibration";
  } else if (fx_ > 0) {
    fx = fx_;
    fy = fy_ > 0 ? fy_ : fx_;
    cx = cx_ > 0 ? cx_ : w / 2.0;
    cy = cy_ > 0 ? cy_ : h / 2.0;
    intrinsics_source_ = "params";
  } else {
    double hfov = hfov_deg_;
    intrinsics_source_ = "hfov";
    if (hfov <= 0) {
      hfov = kAssumedHfovDeg;
      intrinsics_source_ = "assumed_hfov";
      ctx.log(LogLevel::kWarning,
              "no calibration, fx or hfov_deg given for " + what + ": assuming a " +
                  std::to_string(static_cast<int>(kAssumedHfovDeg)) +
                  " deg horizontal field of view; metric distances rest on that assumption");
    }
    fx = fy = (w / 2.0) / std::tan(hfov * CV_PI / 360.0);
    cx = w / 2.0;
    cy = h / 2.0;
  }
  CameraModel cam = CameraModel::pinhole(w, h, fx, fy, cx, cy, height_, pitch_deg_ * CV_PI / 180.0, forward_);
  const bool has_dist = std::any_of(dist.begin(), dist.end(), [](double d) { return d != 0.0; });
  map1_.release();
  map2_.release();
  if (has_dist && undistort_) {
    // newCameraMatrix = K, as cv::undistort does: the undistorted image keeps the calibrated intrinsics.
    cv::initUndistortRectifyMap(cam.K(), dist, cv::noArray(), cam.K(), native, CV_16SC2, map1_, map2_);
  } else if (has_dist) {
    cam.distortion = dist;
  }
  int ow = resize_w_, oh = resize_h_;
  if (ow == 0 && oh == 0) {
    ow = w;
    oh = h;
  } else if (ow == 0) {
    ow = static_cast<int>(std::lround(static_cast<double>(w) * oh / h));
  } else if (oh == 0) {
    oh = static_cast<int>(std::lround(static_cast<double>(h) * ow / w));
  }
  camera_ = (ow == w && oh == h) ? cam : cam.scaled_to(ow, oh);
}

cv::Mat CameraSetup::prepare(const cv::Mat& native, const std::string& what) const {
  if (native.size() != native_)
    throw Error(what + " is " + size_str(native.size()) + " but the stream started at " + size_str(native_));
  cv::Mat img = native;
  if (img.type() != CV_8UC3) {
    cv::Mat bgr;
    if (img.depth() != CV_8U) throw Error(what + " is not an 8-bit image");
    if (img.channels() == 1)
      cv::cvtColor(img, bgr, cv::COLOR_GRAY2BGR);
    else if (img.channels() == 4)
      cv::cvtColor(img, bgr, cv::COLOR_BGRA2BGR);
    else
      throw Error(what + " has " + std::to_string(img.channels()) + " channels; expected 1, 3 or 4");
    img = bgr;
  }
  if (!map1_.empty()) {
    cv::Mat u;
    cv::remap(img, u, map1_, map2_, cv::INTER_LINEAR, cv::BORDER_CONSTANT);
    img = u;
  }
  if (img.cols != camera_.width || img.rows != camera_.height) {
    cv::Mat r;
    const bool shrink = camera_.width < img.cols;
    cv::resize(img, r, cv::Size(camera_.width, camera_.height), 0, 0,
               shrink ? cv::INTER_AREA : cv::INTER_LINEAR);
    img = r;
  }
  // Sources hand out frames that nobody else writes to; a clone detaches decoder-owned buffers.
  return img.data == native.data ? img.clone() : img;
}

EgoState CameraSetup::ego() const {
  EgoState e;
  if (ego_speed_ >= 0) {
    e.speed_mps = ego_speed_;
    e.source = "param";
  }
  return e;
}

}  // namespace hf::source
