// Camera params -> CameraModel; undistortion maps and resizing applied to every frame of a source.
#include "camera_setup.hpp"

#include <algorithm>
#include <cmath>

#include <opencv2/calib3d.hpp>

#include <opencv2/imgproc.hpp>
#include "hazardforge/atomic_file.hpp"
#include "hazardforge/footage/attitude.hpp"
#include "hazardforge/footage/camera_height.hpp"
#include "hazardforge/footage/ego_motion.hpp"
#include "hazardforge/footage/horizon.hpp"
#include "hazardforge/footage/lever_arm.hpp"
#include "hazardforge/footage/two_view_calibration.hpp"
#include "hazardforge/json_text.hpp"
#include "hazardforge/output_path.hpp"

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
          .from_scene("camera.calibration")
          .describe("calibration YAML (from `hazardforge calibrate`); overrides fx/fy/cx/cy/hfov_deg"),
      ParamSpec::number("fx", 0.0)
          .range(0, 1e6)
          .from_scene("camera.fx")
          .describe("focal length x in px at the native size (0 = unset)"),
      ParamSpec::number("fy", 0.0)
          .range(0, 1e6)
          .from_scene("camera.fy")
          .describe("focal length y in px (0 = fx)"),
      ParamSpec::number("cx", 0.0)
          .range(0, 1e6)
          .from_scene("camera.cx")
          .describe("principal point x in px (0 = image centre)"),
      ParamSpec::number("cy", 0.0)
          .range(0, 1e6)
          .from_scene("camera.cy")
          .describe("principal point y in px (0 = image centre)"),
      ParamSpec::number("hfov_deg", 0.0)
          .from_scene("camera.hfov_deg")
          .range(0, 179)
          .describe("horizontal field of view when no calibration/fx is given (0 = estimated from the footage's "
                    "turns, else 60 deg assumed, warned)"),
      ParamSpec::number("camera_height", 1.5)
          .range(0.1, 10)
          .from_scene("camera.height_m")
          .describe("camera height above the ground, m"),
      ParamSpec::number("camera_pitch_deg", 0.0)
          .range(-45, 45)
          .from_scene("camera.pitch_deg")
          .describe("downward pitch of the camera, deg (not stated = estimated from the video's horizon)"),
      ParamSpec::number("camera_roll_deg", 0.0)
          .range(-30, 30)
          .from_scene("camera.roll_deg")
          .describe("camera roll, deg, + = the horizon rises to the right (not stated = estimated)"),
      ParamSpec::int_list("intrinsics_size", {})
          .from_scene("camera.intrinsics_size")
          .describe("[width, height] of the images fx/fy/cx/cy refer to (empty = the native frames)"),
      ParamSpec::number("camera_forward", 1.5)
          .from_scene("camera.forward_m")
          .range(-10, 10)
          .describe("camera position ahead of the rear axle, m"),
      ParamSpec::boolean("self_calibrate", true)
          .describe(
              "estimate from the footage what is not stated: pitch and roll from the horizon, ego speed "
              "and yaw rate from ground-plane odometry and the picture's rotation between frames (written "
              "to camera.json and ego_motion.jsonl)"),
      ParamSpec::boolean("follow_attitude", true)
          .describe(
              "with self_calibrate: each frame's camera follows its own pitch and roll, the clip's attitude "
              "plus the frame's deviation from it measured on the far scene's motion between consecutive "
              "frames (a bump, a braking dip, the body rolling in a bend); false = one attitude for the "
              "whole clip"),
      ParamSpec::boolean("undistort", true)
          .describe("undistort frames with the calibrated K when the calibration has distortion"),
      ParamSpec::integer("resize_width", 0)
          .range(0, 16384)
          .describe("output width (0 = keep; aspect kept if only one is set)"),
      ParamSpec::integer("resize_height", 0).range(0, 16384).describe("output height (0 = keep)"),
      ParamSpec::number("ego_speed_mps", -1.0)
          .from_scene("ego.speed_mps")
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
  roll_deg_ = p.get_double("camera_roll_deg");
  pitch_stated_ = p.stated("camera_pitch_deg");
  roll_stated_ = p.stated("camera_roll_deg");
  height_stated_ = p.stated("camera_height");
  speed_stated_ = p.stated("ego_speed_mps") && p.get_double("ego_speed_mps") >= 0;
  self_calibrate_ = p.get_bool("self_calibrate");
  follow_attitude_ = p.get_bool("follow_attitude");
  intrinsics_size_ = p.get_ints("intrinsics_size");
  if (!intrinsics_size_.empty() &&
      (intrinsics_size_.size() != 2 || intrinsics_size_[0] <= 0 || intrinsics_size_[1] <= 0))
    throw Error("parameter 'intrinsics_size' is [width, height] in px, got " + Json(intrinsics_size_).dump());
  forward_ = p.get_double("camera_forward");
  forward_stated_ = p.stated("camera_forward");
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
    if (!intrinsics_size_.empty()) {
      const cv::Size ref(static_cast<int>(intrinsics_size_[0]), static_cast<int>(intrinsics_size_[1]));
      if (cx_ <= 0) cx = ref.width / 2.0;
      if (cy_ <= 0) cy = ref.height / 2.0;
      if (ref != native) {
        const double ra = static_cast<double>(ref.width) / ref.height, rb = static_cast<double>(w) / h;
        if (std::abs(ra / rb - 1.0) > 0.01)
          throw Error("fx/fy/cx/cy are stated for " + size_str(ref) + " images (intrinsics_size) but " + what +
                      " is " + size_str(native) + " (different aspect ratio: a crop, which the intrinsics do not "
                      "describe)");
        const double sx = static_cast<double>(w) / ref.width, sy = static_cast<double>(h) / ref.height;
        fx *= sx, cx *= sx, fy *= sy, cy *= sy;
        ctx.log(LogLevel::kInfo, "scaling the stated intrinsics from " + size_str(ref) + " to " + size_str(native));
      }
    } else {
      // Without the size they refer to, check that they fit these frames: a principal point far from the
      // centre, or a field of view no dash camera has, means they were measured on another image size.
      const bool centre_off = (cx_ > 0 && std::abs(cx_ - w / 2.0) > 0.2 * w) ||
                              (cy_ > 0 && std::abs(cy_ - h / 2.0) > 0.2 * h);
      if (centre_off)
        throw Error("the stated principal point (" + std::to_string(cx) + ", " + std::to_string(cy) +
                    ") is far from the centre of the " + size_str(native) + " frames of " + what +
                    "; it fits a " + size_str({static_cast<int>(std::lround(2 * cx)), static_cast<int>(std::lround(2 * cy))}) +
                    " image: state camera.intrinsics_size: [W, H] for the size fx/cx/cy were measured on");
      const double hfov = 2 * std::atan(w / (2 * fx)) * 180 / CV_PI;
      if (hfov < 20 || hfov > 140) {
        const double fits_w = 2 * fx * std::tan(30 * CV_PI / 180);
        ctx.log(LogLevel::kWarning,
                "fx " + std::to_string(fx) + " px gives a " + std::to_string(static_cast<int>(hfov)) +
                    " deg horizontal field of view on the " + size_str(native) + " frames of " + what +
                    "; it fits images about " + std::to_string(static_cast<int>(fits_w)) +
                    " px wide for a 60 deg dash camera: if fx was measured on another size, state "
                    "camera.intrinsics_size");
      }
    }
  } else {
    double hfov = hfov_deg_;
    intrinsics_source_ = "hfov";
    if (hfov <= 0) {
      hfov = kAssumedHfovDeg;
      intrinsics_source_ = "assumed_hfov";
      ctx.log(LogLevel::kInfo, "no calibration, fx or hfov_deg given for " + what +
                                   ": the focal length is estimated from the footage's turns, else a " +
                                   std::to_string(static_cast<int>(kAssumedHfovDeg)) +
                                   " deg horizontal field of view is assumed");
    }
    fx = fy = (w / 2.0) / std::tan(hfov * CV_PI / 360.0);
    cx = w / 2.0;
    cy = h / 2.0;
  }
  CameraModel cam = CameraModel::pinhole(w, h, fx, fy, cx, cy, height_, pitch_deg_ * CV_PI / 180.0, forward_,
                                         roll_deg_ * CV_PI / 180.0);
  provenance_["intrinsics"] = intrinsics_source_ == "calibration" ? "calibration file " + calib_path_.string()
                              : intrinsics_source_ == "params"    ? std::string("stated fx/fy/cx/cy")
                              : intrinsics_source_ == "hfov"      ? "stated hfov_deg " + std::to_string(hfov_deg_)
                                                                  : "assumed " + std::to_string(static_cast<int>(kAssumedHfovDeg)) +
                                                                        " deg horizontal field of view (nothing stated)";
  provenance_["height_m"] = height_stated_ ? "stated" : "default 1.5 m (not stated; distances and speeds scale with it)";
  provenance_["pitch_deg"] = pitch_stated_ ? "stated" : "default 0 (not stated, not estimated)";
  provenance_["roll_deg"] = roll_stated_ ? "stated" : "default 0 (not stated, not estimated)";
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

CameraModel CameraSetup::camera_at(int64_t k) const {
  if (k < 0 || static_cast<size_t>(k) >= attitude_.size()) return camera_;
  return footage::with_attitude(camera_, attitude_[static_cast<size_t>(k)]);
}

EgoState CameraSetup::ego_at(int64_t k) const {
  EgoState e;
  if (k >= 0 && static_cast<size_t>(k) < ego_.size()) e = ego_[static_cast<size_t>(k)];
  if (speed_stated_) {
    e.speed_mps = ego_speed_;
    e.source = "param";
  }
  return e;
}

std::vector<footage::TwoViewCalibration::Epipole> CameraSetup::two_view_pass(const FramePass& open_pass,
                                                                            int64_t frames, double fps,
                                                                            StageContext& ctx) {
  // Views about 0.5 s apart, each paired with the two before it (0.5 and 1 s): far enough for a turning car to
  // turn by a few degrees, near enough to match. The whole clip at that spacing up to kMaxViews views; a longer
  // clip in segments of three views spread over it.
  constexpr int64_t kMaxViews = 240, kSegment = 3;
  const int64_t step = std::max<int64_t>(1, std::llround(0.5 * fps));
  const bool segmented = frames > 0 && frames / step > kMaxViews;
  const int64_t seg_stride = segmented ? frames / (kMaxViews / kSegment) : 0;
  footage::TwoViewCalibration views({camera_.width, camera_.height});
  {
    auto next_native = open_pass();
    cv::Mat native;
    std::string what;
    int64_t pushed = 0;
    for (int64_t k = 0; next_native(native, what); ++k) {
      if (ctx.stop_requested()) return {};
      const int64_t r = segmented ? k % seg_stride : k;
      if (r % step != 0 || (segmented && r / step >= kSegment)) continue;
      if (!segmented && pushed >= kMaxViews) break;
      views.add(prepare(native, what), static_cast<int>(k), segmented && r == 0);
      ++pushed;
    }
  }
  if (intrinsics_source_ != "assumed_hfov") return views.epipoles();
  const std::string assumed = std::to_string(static_cast<int>(kAssumedHfovDeg)) + " deg";
  if (const auto f = views.result()) {
    const double deg = 180.0 / CV_PI;
    const double hfov = 2 * std::atan(camera_.width / (2 * f->fx)) * deg;
    camera_.fx = camera_.fy = f->fx;
    intrinsics_source_ = "estimated";
    provenance_["intrinsics"] = "focal length estimated from the video (" + f->note + "; " +
                                std::to_string(hfov).substr(0, 5) + " deg horizontal field of view, sigma " +
                                std::to_string(f->sigma).substr(0, 5) +
                                " px); principal point assumed at the image centre, square pixels";
    ctx.log(LogLevel::kInfo, "focal length " + std::to_string(f->fx).substr(0, 7) + " px (" +
                                 std::to_string(hfov).substr(0, 5) + " deg horizontal field of view) estimated "
                                 "from the footage's turns: " + f->note);
  } else {
    provenance_["intrinsics"] = "assumed " + assumed + " horizontal field of view (nothing stated; " +
                                views.why_not() + ")";
    ctx.log(LogLevel::kWarning, "the footage does not fix the focal length (" + views.why_not() +
                                    "): assuming a " + assumed +
                                    " horizontal field of view; metric distances and speeds scale with it "
                                    "(state camera.hfov_deg or a calibration)");
  }
  return views.epipoles();
}

void CameraSetup::estimate_from_footage(const FramePass& open_pass, int64_t frames, double fps,
                                        StageContext& ctx) {
  if (!self_calibrate_ || frames == 0) {
    if (!speed_stated_) provenance_["ego_speed"] = "unknown (not stated; self_calibrate off)";
    if (intrinsics_source_ == "assumed_hfov")
      ctx.log(LogLevel::kWarning, "no calibration, fx or hfov_deg given and self_calibrate is off: assuming a " +
                                      std::to_string(static_cast<int>(kAssumedHfovDeg)) +
                                      " deg horizontal field of view; metric distances rest on that assumption");
    return;
  }
  // Pass 0, views about a second apart: the focal length when nothing describes the lens, and the direction of
  // travel (a horizon cue).
  std::vector<footage::TwoViewCalibration::Epipole> epipoles;
  if (intrinsics_source_ == "assumed_hfov" || !pitch_stated_ || !roll_stated_)
    epipoles = two_view_pass(open_pass, frames, fps, ctx);
  // Pass 1, horizon: every frame of short clips; pairs of consecutive frames spread over long ones (about 300
  // frames in all keeps long clips cheap).
  const int64_t stride = frames > 300 ? (frames + 149) / 150 : 1;
  footage::HorizonEstimator horizon(camera_);
  for (const auto& e : epipoles) horizon.add_epipole(e.point, e.frame);
  {
    auto next_native = open_pass();
    cv::Mat native;
    std::string what;
    for (int64_t k = 0; next_native(native, what); ++k) {
      if (ctx.stop_requested()) return;
      if (stride == 1 || k % stride <= 1) horizon.add(prepare(native, what), time_at(k, fps));
    }
  }
  const auto est = horizon.result();
  const double deg = 180.0 / CV_PI;
  if (est) {
    const double est_pitch = est->pitch_rad * deg;
    const std::string how = est->method + ", confidence " + std::to_string(est->confidence).substr(0, 4) + ", " +
                            std::to_string(est->frames_used) + " frames";
    if (pitch_stated_) {
      if (std::abs(est_pitch - pitch_deg_) > 1.0)
        ctx.log(LogLevel::kWarning, "the stated camera pitch " + std::to_string(pitch_deg_) +
                                        " deg disagrees with the footage's horizon, which gives " +
                                        std::to_string(est_pitch) + " deg (" + how +
                                        "); keeping the stated value");
      provenance_["pitch_deg_estimated"] = est_pitch;
    }
    if (!pitch_stated_ || !roll_stated_) {
      footage::HorizonEstimate use = *est;
      if (pitch_stated_) use.pitch_rad = pitch_deg_ / deg;
      if (roll_stated_) use.roll_rad = roll_deg_ / deg;
      camera_ = footage::HorizonEstimator::apply(camera_, use);
      if (!pitch_stated_) provenance_["pitch_deg"] = "estimated from the video (" + how + ")";
      bool roll_seen = true;
      for (const std::string& n : est->notes) roll_seen = roll_seen && n.find("roll not observable") == std::string::npos;
      if (!roll_stated_)
        provenance_["roll_deg"] = roll_seen ? "estimated from the video (" + how + ")"
                                            : std::string("default 0: roll is not observable from this clip");
    }
    provenance_["horizon_confidence"] = est->confidence;
    if (!est->notes.empty()) provenance_["horizon_notes"] = est->notes;
  } else if (!pitch_stated_) {
    provenance_["pitch_deg"] = "default 0: the footage gave no usable horizon evidence";
    ctx.log(LogLevel::kWarning, "no horizon could be estimated from the footage; camera pitch 0 assumed (state "
                                "camera.pitch_deg): ground distances rest on that assumption");
  }
  if (speed_stated_ && height_stated_ && !follow_attitude_) {
    // A stated speed is a constant-speed, straight ego (EgoState source "param"; no track: planners and the
    // exporter then use a straight line at that speed); the video's yaw rate is not mixed in. Leave
    // ego.speed_mps unstated to follow the footage's speed and turns.
    provenance_["ego_speed"] = "stated (constant, straight ahead)";
    return;
  }
  // Pass 2, ego motion (ground-plane odometry over every frame with the final camera) and, when the height is
  // not stated, the camera height from the lane-line spacing (speeds scale with the height, so the odometry runs
  // at the default height and its speeds are rescaled).
  std::optional<footage::GroundOdometry> odo;
  if (!speed_stated_) odo.emplace(camera_);
  // The lane lines give the camera height (when not stated) and the lane markings beside the ego lane.
  footage::CameraHeightEstimator height_est(camera_);
  std::optional<footage::AttitudeTracker> attitude;
  if (follow_attitude_ || odo) {  // the far scene also gives the odometry its turn
    footage::AttitudeOptions ao;
    if (est) ao.travel_x = est->travel_x;  // the far scene expands about the direction of travel
    attitude.emplace(camera_, ao);
  }
  std::vector<footage::EgoMotionSample> raw;
  {
    auto next_native = open_pass();
    cv::Mat native;
    std::string what;
    for (int64_t k = 0; next_native(native, what); ++k) {
      if (ctx.stop_requested()) return;
      const cv::Mat img = prepare(native, what);
      // The far scene's shift first: between video frames it is the ego's turn, more precise than the road's.
      if (attitude) attitude->add(img, time_at(k, fps));
      if (odo)
        raw.push_back(
            odo->add(img, k, time_at(k, fps), attitude ? attitude->last_turn() : std::nullopt));
      height_est.add(img);
    }
  }
  if (attitude && follow_attitude_) {
    attitude_ = attitude->result();
    size_t measured = 0;
    double ss_pitch = 0, ss_roll = 0;
    for (const auto& a : attitude_) {
      measured += a.measured ? 1 : 0;
      ss_pitch += a.pitch_rad * a.pitch_rad;
      ss_roll += a.roll_rad * a.roll_rad;
    }
    const double n = static_cast<double>(std::max<size_t>(attitude_.size(), 1));
    provenance_["attitude_per_frame"] =
        "the clip's pitch and roll plus each frame's deviation, from the far scene's motion between "
        "consecutive "
        "frames (" +
        std::to_string(measured) + " of " + std::to_string(attitude_.size()) + " steps measured" +
        (1.0 / fps > attitude->options().max_interval_s
             ? std::string(": frames " + std::to_string(1.0 / fps).substr(0, 4) +
                           " s apart are too far apart to measure a nod between them, so every frame has the "
                           "clip's attitude")
             : std::string()) +
        "; deviation rms pitch " + std::to_string(std::sqrt(ss_pitch / n) * 180.0 / CV_PI).substr(0, 5) +
        " deg, roll " + std::to_string(std::sqrt(ss_roll / n) * 180.0 / CV_PI).substr(0, 5) + " deg)";
  }
  if (auto m = height_est.markings()) {
    markings_ = std::make_shared<const RoadMarkings>(*m);
    provenance_["road_markings"] = "measured from the lane lines (" + m->note + ")";
  }
  if (!height_stated_) {
    const double h0 = camera_.height_above_ground();
    if (const auto he = height_est.result()) {
      camera_ = footage::with_height(camera_, he->height_m);
      footage::rescale_height(raw, he->height_m / h0);
      provenance_["height_m"] = "estimated from the lane lines (" + he->note + "; sigma " +
                                std::to_string(he->sigma_m).substr(0, 4) + " m, confidence " +
                                std::to_string(he->confidence).substr(0, 4) + ")";
    } else {
      provenance_["height_m"] = "default 1.5 m (not stated; no lane lines to measure it from in " +
                                std::to_string(frames) + " frames; distances and speeds scale with it)";
    }
  }
  if (speed_stated_) {
    provenance_["ego_speed"] = "stated (constant, straight ahead)";
    return;
  }
  if (raw.empty()) return;
  // In the bends, where the road view is weakest, the distance from the camera's lever arm ahead of the rear
  // axle (frames 0.15 s and more apart, where the whole picture's geometry is computed; independent of the
  // height). The mounting yaw comes from the clip's straight pairs, else the lane lines' vanishing point.
  const bool lane_column = est && std::isfinite(est->travel_x);
  const footage::LeverArmOptions lever_opt =
      est ? footage::with_travel_column({}, camera_, est->travel_x) : footage::LeverArmOptions{};
  const footage::LeverArmScale lever =
      footage::apply_lever_arm(raw, camera_.cam_to_ego({0, 0, 0})[0], lever_opt);
  footage::SmoothReport smoothing;
  const auto smooth = footage::smooth_ego_motion(raw, {}, &smoothing);
  size_t measured = 0;
  for (const auto& r : raw) measured += r.measured ? 1 : 0;
  if (measured == 0) {
    provenance_["ego_speed"] = "unknown: the road gave no usable odometry";
    ctx.log(LogLevel::kWarning, "the ego's speed could not be estimated from the footage (no usable road "
                                "texture); state ego.speed_mps");
    return;
  }
  ego_.assign(smooth.size(), EgoState{});
  auto track = std::make_shared<EgoTrack>();
  track->source = "video";
  double x = 0, y = 0, yaw = 0;
  for (size_t i = 0; i < smooth.size(); ++i) {
    const double v = smooth[i].speed_mps;
    if (i > 0) {
      const double dt = smooth[i].t - smooth[i - 1].t;
      const double v0 = smooth[i - 1].speed_mps;
      const double mid_yaw = yaw + 0.5 * smooth[i - 1].yaw_rate * dt;
      x += 0.5 * (v0 + v) * dt * std::cos(mid_yaw);
      y += 0.5 * (v0 + v) * dt * std::sin(mid_yaw);
      yaw += 0.5 * (smooth[i - 1].yaw_rate + smooth[i].yaw_rate) * dt;
    }
    EgoState& e = ego_[i];
    e.speed_mps = v;
    e.yaw_rate = smooth[i].yaw_rate;
    e.source = "video";
    track->samples.push_back({smooth[i].t, x, y, yaw, v, smooth[i].yaw_rate});
  }
  track->validate("ego track estimated from the video");
  track_ = track;
  raw_motion_ = raw;
  smooth_motion_ = smooth;
  size_t by_lever = 0, lever_only = 0;
  for (const auto& r : raw) {
    by_lever += r.speed_cue == footage::EgoMotionSample::SpeedCue::kRoadAndLeverArm ? 1 : 0;
    lever_only += r.speed_cue == footage::EgoMotionSample::SpeedCue::kLeverArm ? 1 : 0;
  }
  std::string ego_speed = "estimated from the video (ground-plane odometry, " + std::to_string(measured) +
                          " of " + std::to_string(raw.size()) + " frames measured";
  if (by_lever + lever_only > 0)
    ego_speed +=
        "; in the bends the camera's lever arm (" + std::to_string(lever.lever_m()).substr(0, 4) +
        " m ahead of the rear axle, " + (forward_stated_ ? "stated" : "default") + ") gave " +
        std::to_string(lever_only) + " frames' speed and was averaged into " + std::to_string(by_lever) +
        ", straight travel " +
        std::to_string(lever.bias() * 180.0 / CV_PI).substr(0, lever.bias() < 0 ? 5 : 4) +
        " deg off the camera axis (" +
        (lever.from_straight_pairs()
             ? "from " + std::to_string(lever.straight_pairs()) + " straight pairs"
             : std::string(lane_column ? "from the lane lines' vanishing point"
                                                                    : "assumed 0")) +
        ")";
  // How the whole-clip smoother weighed the readings.
  const bool too_few = smoothing.scatter_frames < footage::SmoothOptions{}.min_scatter_samples;
  ego_speed += "; smoothed over the clip with ";
  ego_speed += smoothing.noise_scale > 1.0
                   ? "the readings' sigmas scaled by " + std::to_string(smoothing.noise_scale).substr(0, 4) +
                         " to their own scatter over " + std::to_string(smoothing.scatter_frames) + " frames"
                   : "the readings' own sigmas (their scatter over " + std::to_string(smoothing.scatter_frames) +
                         " frames " + (too_few ? "too few to tell" : "within them") + ")";
  ego_speed += ", " + std::to_string(smoothing.rejected) + " readings rejected, " +
               std::to_string(smoothing.restarts) + " restarts";
  provenance_["ego_speed"] = ego_speed + ")";
  size_t turned = 0;
  for (const auto& r : raw) turned += r.yaw_measured ? 1 : 0;
  const bool video_rate = 1.0 / fps < footage::OdometryOptions{}.two_view_min_interval_s;
  provenance_["ego_yaw_rate"] = std::string("estimated from the video (") +
                                (video_rate ? "the far scene's sideways shift between frames"
                                            : "the whole picture's rotation between frames") +
                                " on " + std::to_string(turned) + " of " + std::to_string(raw.size()) +
                                " frames, and ground-plane odometry)";
}

void CameraSetup::write_reports(StageContext& ctx, int64_t frames, double fps, const std::string& fps_source) const {
  const double deg = 180.0 / CV_PI;
  Json cam = {{"image_size", {camera_.width, camera_.height}},
              {"native_size", {native_.width, native_.height}},
              {"fx", camera_.fx},
              {"fy", camera_.fy},
              {"cx", camera_.cx},
              {"cy", camera_.cy},
              {"hfov_deg", 2 * std::atan(camera_.width / (2 * camera_.fx)) * deg},
              {"height_m", camera_.height_above_ground()},
              {"pitch_deg", camera_.pitch() * deg},
              {"roll_deg", camera_.roll() * deg},
              {"horizon_y", camera_.horizon_y(camera_.cx).value_or(std::numeric_limits<double>::quiet_NaN())},
              {"fps", fps},
              {"frames", frames},
              {"undistorted", !map1_.empty()},
              {"sources", provenance_}};
  cam["sources"]["fps"] = fps_source;
  if (markings_) cam["road_markings"] = *markings_;
  write_file_atomic(resolve_output_path(ctx.output_dir(), "camera.json", "camera.json"), json_text(cam, 2) + "\n");
  std::string lines;
  for (int64_t k = 0; k < frames; ++k) {
    const EgoState e = ego_at(k);
    Json l = {{"frame", k}, {"timestamp", time_at(k, fps)}};
    l["speed_mps"] = e.speed_mps ? Json(*e.speed_mps) : Json();
    l["yaw_rate_dps"] = e.yaw_rate ? Json(*e.yaw_rate * deg) : Json();
    l["source"] = e.source.empty() ? "unknown" : e.source;
    if (static_cast<size_t>(k) < attitude_.size()) {
      const CameraModel c = camera_at(k);
      l["pitch_deg"] = c.pitch() * deg;  // this frame's camera (the clip's attitude + its deviation)
      l["roll_deg"] = c.roll() * deg;
      l["attitude_measured"] = attitude_[static_cast<size_t>(k)].measured;
    }
    if (static_cast<size_t>(k) < smooth_motion_.size()) {
      const auto& m = smooth_motion_[static_cast<size_t>(k)];
      l["speed_sigma_mps"] = m.speed_sigma;
      l["yaw_rate_sigma_dps"] = m.yaw_rate_sigma * deg;
      l["measured"] = m.measured;          // this frame's speed (and turn) measured on the road
      l["yaw_measured"] = m.yaw_measured;  // this frame's turn measured (road or whole picture)
      if (static_cast<size_t>(k) < raw_motion_.size()) {
        const auto& r = raw_motion_[static_cast<size_t>(k)];
        if (r.measured) {
          l["raw_speed_mps"] = r.speed_mps;
          l["raw_speed_from"] = footage::speed_cue_name(r.speed_cue);  // road, lever_arm or road+lever_arm
        }
        if (r.road_speed_mps) l["road_speed_mps"] = *r.road_speed_mps;
        if (r.lever_speed_mps) l["lever_arm_speed_mps"] = *r.lever_speed_mps;
        // The camera's pitch change from the previous frame (the whole picture's rotation), + = further down.
        if (r.two_view) l["pitch_change_deg"] = r.two_view->pitch * deg;
        // The road's pitch under this frame and the one before, relative to the clip's camera, where the
        // road's motion fixed it (OdometryOptions::pair_pitch).
        if (r.ground_pitch_offset) l["road_pitch_offset_deg"] = *r.ground_pitch_offset * deg;
      }
    }
    lines += json_text(l) + "\n";
  }
  write_file_atomic(resolve_output_path(ctx.output_dir(), "ego_motion.jsonl", "ego_motion.jsonl"), lines);
}

}  // namespace hf::source
