// Camera model, undistortion and resizing shared by the video, camera and image_sequence sources.
#pragma once

#include <filesystem>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "hazardforge/calibration_file.hpp"
#include "hazardforge/footage/attitude.hpp"
#include "hazardforge/footage/ego_motion.hpp"
#include "hazardforge/footage/two_view_calibration.hpp"
#include "hazardforge/stage.hpp"

namespace hf::source {

// Turns the camera params into a CameraModel once the native image size is known, and prepares each frame
// (undistort with the calibrated K, then resize) so the image and the model always agree.
class CameraSetup {
 public:
  // calibration, fx, fy, cx, cy, hfov_deg, camera_height, camera_pitch_deg, camera_forward, undistort,
  // resize_width, resize_height, ego_speed_mps.
  static std::vector<ParamSpec> params();

  // Reads the params (and the calibration file, recorded as a run resource).
  void configure(StageContext& ctx);
  // Builds the camera model for frames of `native` size. `what` names the input in messages.
  void init(cv::Size native, const std::string& what, StageContext& ctx);
  bool initialised() const { return camera_.valid(); }

  // Undistorted, resized copy of a native frame. Throws when the frame's size differs from the native size.
  cv::Mat prepare(const cv::Mat& native, const std::string& what) const;

  const CameraModel& camera() const { return camera_; }
  // Frame k's camera: camera() with the frame's pitch and roll deviation when they were measured
  // (follow_attitude), else camera().
  CameraModel camera_at(int64_t k) const;
  cv::Size native_size() const { return native_; }
  cv::Size output_size() const { return {camera_.width, camera_.height}; }
  // The ego state of frame k: the stated speed, else the speed and yaw rate estimated from the video.
  EgoState ego_at(int64_t k) const;
  // The clip's ego track (estimated from the video, or a stated constant speed); null when unknown.
  std::shared_ptr<const EgoTrack> ego_track() const { return track_; }
  // The lane markings beside the ego lane measured over the clip; null when not measured.
  std::shared_ptr<const RoadMarkings> road_markings() const { return markings_; }
  // Where the intrinsics came from: "calibration", "params", "hfov", "estimated" (the focal length from the
  // footage's turns), "assumed_hfov".
  const std::string& intrinsics_source() const { return intrinsics_source_; }

  // Reads the clip from its first frame (native frames in order, false at the end), twice, and
  // estimates what was not stated: the camera's pitch and roll from the horizon (vanishing point of the road's
  // lines, focus of expansion, road homography) and the ego's speed and yaw rate from ground-plane odometry.
  // A stated pitch that the footage contradicts by more than 1 deg is kept, with a warning naming both.
  // `open_pass` starts a new pass over the clip and returns its reader.
  using FrameReader = std::function<bool(cv::Mat& native, std::string& what)>;  // what: names the frame in errors
  using FramePass = std::function<FrameReader()>;
  void estimate_from_footage(const FramePass& open_pass, int64_t frames, double fps, StageContext& ctx);
  // Each frame's time (s from the first) when the frames are not evenly spaced (an image folder whose names
  // carry times); empty = index / fps. Set before estimate_from_footage.
  void set_frame_times(std::vector<double> times) { times_ = std::move(times); }
  // Writes camera.json (the geometry used and where each value came from) and ego_motion.jsonl (one line per
  // frame) below the run folder.
  void write_reports(StageContext& ctx, int64_t frames, double fps, const std::string& fps_source) const;

 private:
  // Pass 0, views about 0.5 s apart: when nothing describes the lens, the focal length from the views that turn
  // (else the assumed field of view stays, with a warning saying why); the epipoles of forward travel, for the
  // horizon.
  std::vector<footage::TwoViewCalibration::Epipole> two_view_pass(const FramePass& open_pass, int64_t frames,
                                                                  double fps, StageContext& ctx);

  std::optional<CalibrationFile> calib_;
  std::filesystem::path calib_path_;
  double fx_ = 0, fy_ = 0, cx_ = 0, cy_ = 0, hfov_deg_ = 0;
  double height_ = 1.5, pitch_deg_ = 0, roll_deg_ = 0, forward_ = 1.5;
  bool pitch_stated_ = false, roll_stated_ = false, height_stated_ = false, speed_stated_ = false,
       forward_stated_ = false;
  std::vector<double> times_;
  double time_at(int64_t k, double fps) const {
    return static_cast<size_t>(k) < times_.size() ? times_[static_cast<size_t>(k)] : static_cast<double>(k) / fps;
  }
  bool self_calibrate_ = true;
  bool follow_attitude_ = true;
  std::vector<long long> intrinsics_size_;
  bool undistort_ = true;
  int resize_w_ = 0, resize_h_ = 0;
  double ego_speed_ = -1;

  cv::Size native_;
  CameraModel camera_;
  cv::Mat map1_, map2_;  // undistortion maps at native size; empty = no undistortion
  std::string intrinsics_source_;
  Json provenance_ = Json::object();  // value name -> where it came from
  std::vector<EgoState> ego_;         // per frame, from the video (empty = not estimated)
  std::vector<footage::EgoMotionSample> raw_motion_, smooth_motion_;
  std::vector<footage::AttitudeSample> attitude_;  // per frame (empty = not followed)
  std::shared_ptr<const EgoTrack> track_;
  std::shared_ptr<const RoadMarkings> markings_;
};

// Horizontal field of view assumed when nothing else describes the camera.
inline constexpr double kAssumedHfovDeg = 60.0;

}  // namespace hf::source
