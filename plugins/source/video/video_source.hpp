// Frame sources backed by OpenCV VideoCapture: video files (`video`) and live devices/streams (`camera`).
#pragma once

#include <chrono>
#include <filesystem>
#include <vector>
#include <optional>
#include <string>

#include <opencv2/videoio.hpp>

#include "camera_setup.hpp"
#include "folder_clock.hpp"
#include "hazardforge/stage.hpp"

namespace hf::source {

// Reads a video file through OpenCV/FFmpeg.
// Ports: out `frames` (Frame, BGR 8-bit, undistorted when calibrated, resized when asked).
// Timestamps: emitted index / fps (the file's rate unless `fps` is set), so the first emitted frame is t = 0;
//   meta.file_frame keeps the frame's position in the file.
// Params: path, fps, start_frame, max_frames, allow_partial + the camera params of CameraSetup. A file that
// decodes fewer frames than its container declares fails unless allow_partial (then the run ends incomplete).
class VideoSource : public SourceStage {
 public:
  static ComponentInfo describe();
  void open(StageContext& ctx) override;
  bool next(StageContext& ctx, Outputs& out) override;
  std::optional<int64_t> frame_count() const override { return count_; }

 private:
  cv::VideoCapture cap_;
  std::string path_;
  CameraSetup setup_;
  double fps_ = 0;
  int64_t start_ = 0;
  bool allow_partial_ = false;
  int64_t max_frames_ = -1;
  int64_t emitted_ = 0;
  int64_t file_frames_ = -1;  // as reported by the container; an estimate for some formats
  std::optional<int64_t> count_;
  cv::Mat pending_;  // the first frame, decoded in open() to validate the file
  std::vector<std::filesystem::path> files_;  // image-folder mode
  FolderClock clock_;  // frame times: the folder's file names' or index / fps
  std::string fps_source_;
  int64_t written_frames_ = 0;
  cv::Mat read_image(size_t k) const;
};

// Reads a live device (`device: "0"` or a device path) or a stream URL (`url: rtsp://...`).
// Ports: out `frames`. Timestamps: steady-clock seconds since the first frame was received.
// Params: device | url, max_frames + the camera params of CameraSetup. The frame count is unknown.
class CameraSource : public SourceStage {
 public:
  static ComponentInfo describe();
  void open(StageContext& ctx) override;
  bool next(StageContext& ctx, Outputs& out) override;

 private:
  cv::VideoCapture cap_;
  std::string what_;
  CameraSetup setup_;
  int64_t max_frames_ = -1;
  int64_t emitted_ = 0;
  std::chrono::steady_clock::time_point t0_;
};

}  // namespace hf::source
