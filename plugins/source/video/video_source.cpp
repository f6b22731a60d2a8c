// VideoSource (video files) and CameraSource (live devices / stream URLs) on OpenCV VideoCapture.
#include "video_source.hpp"

#include <cmath>
#include <filesystem>

#include "hazardforge/image_file.hpp"
#include "hazardforge/run_signals.hpp"

#include <algorithm>

namespace hf::source {

namespace fs = std::filesystem;

ComponentInfo VideoSource::describe() {
  ComponentInfo i = base_info("video", "frames of a video file (OpenCV/FFmpeg) with a pinhole camera model");
  i.doc =
      "Decodes a video file, or reads an image folder in name order. Timestamps are emitted index / fps "
      "(fps from the file unless set); an image folder whose file names end in 13/16/18-19-digit ms/us/ns "
      "timestamps (nuScenes and many recorders' exports) is timed by them. The camera model "
      "comes from a calibration file, fx/fy/cx/cy, or a horizontal FOV; with none of them the focal length is "
      "estimated from views of the clip 0.5 s apart that turn (else 60 deg is assumed, with a warning). "
      "With "
      "a calibration that has distortion, frames are undistorted with the calibrated K and the model's "
      "distortion is cleared. Resizing scales the model. What is not stated is estimated from the footage "
      "before the first frame is emitted (self_calibrate): the camera's pitch and roll from the horizon (with "
      "the direction of travel between those views as one of its cues), the "
      "ego's speed from ground-plane odometry, its yaw rate from that and the whole picture's rotation "
      "between frames (essential matrix); every frame then carries them (EgoState source "
      "'video') and the clip's ego track. The run folder gets camera.json (the geometry used and where each "
      "value came from) and ego_motion.jsonl (one line per frame).";
  i.params = {
      ParamSpec::path("path", std::nullopt)
          .describe("video file, or a folder of images (png/jpg/jpeg/bmp/tif, sorted by name)"),
      ParamSpec::number("fps", 0.0)
          .range(0, 1000)
          .describe("frame rate for timestamps (0 = from the file; an image folder needs it stated unless "
                    "its file names carry times, else 10 fps is assumed with a warning)"),
      ParamSpec::integer("start_frame", 0).range(0, std::nullopt).describe("first file frame to emit"),
      ParamSpec::integer("max_frames", -1).range(-1, std::nullopt).describe("frames to emit (-1 = all)"),
      ParamSpec::boolean("allow_partial", false)
          .describe("when the file decodes fewer frames than its container declares (truncated or corrupt), "
                    "use the frames that decode and end the run 'incomplete' instead of failing"),
  };
  for (ParamSpec& p : CameraSetup::params()) i.params.push_back(std::move(p));
  return i;
}

namespace {

bool is_image_file(const fs::path& p) {
  std::string e = p.extension().string();
  for (char& c : e) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return e == ".png" || e == ".jpg" || e == ".jpeg" || e == ".bmp" || e == ".tif" || e == ".tiff";
}

}  // namespace

void VideoSource::open(StageContext& ctx) {
  const Params& p = ctx.params();
  path_ = p.get_path("path").string();
  if (!fs::exists(path_)) throw Error("video file or image folder '" + path_ + "' does not exist");
  // A FIFO or socket would block the open until a writer comes (and a stop signal cannot end it): refused.
  if (const auto t = fs::status(path_).type(); t == fs::file_type::fifo || t == fs::file_type::socket)
    throw Error("'" + path_ + "' is a FIFO or socket, not a video file, image folder or camera device");
  setup_.configure(ctx);
  start_ = p.get_int("start_frame");
  max_frames_ = p.get_int("max_frames");
  allow_partial_ = p.get_bool("allow_partial");
  fps_ = p.get_double("fps");
  fps_source_ = "stated";
  if (fs::is_directory(path_)) {
    for (const auto& e : fs::directory_iterator(path_))
      if (e.is_regular_file() && is_image_file(e.path())) files_.push_back(e.path());
    std::sort(files_.begin(), files_.end());
    if (files_.empty()) throw Error("image folder '" + path_ + "' has no png/jpg/jpeg/bmp/tif image");
    if (start_ >= static_cast<int64_t>(files_.size()))
      throw Error("image folder '" + path_ + "' has " + std::to_string(files_.size()) + " images, start_frame is " +
                  std::to_string(start_));
    files_.erase(files_.begin(), files_.begin() + start_);
    if (max_frames_ >= 0 && static_cast<size_t>(max_frames_) < files_.size())
      files_.resize(static_cast<size_t>(max_frames_));
    count_ = static_cast<int64_t>(files_.size());
    // Per-frame times from the file names when they carry them, else index / fps.
    clock_ = folder_clock(files_, fps_, path_, "source.fps");
    fps_ = clock_.fps;
    fps_source_ = clock_.source;
    if (clock_.warning) ctx.log(LogLevel::kWarning, *clock_.warning);
    setup_.set_frame_times(clock_.times);
    pending_ = read_image(0);
    setup_.init(pending_.size(), "image '" + files_[0].string() + "'", ctx);
  } else {
    if (!cap_.open(path_, cv::CAP_FFMPEG) || !cap_.isOpened())
      throw Error("cannot open video file '" + path_ + "': not a video OpenCV/FFmpeg can decode");
    if (fps_ <= 0) {
      fps_ = cap_.get(cv::CAP_PROP_FPS);
      fps_source_ = "the video container";
      if (!(fps_ > 0 && fps_ < 1000))
        throw Error("video file '" + path_ + "' reports no usable frame rate; set the 'fps' parameter");
    }
    clock_.fps = fps_;
    const double n = cap_.get(cv::CAP_PROP_FRAME_COUNT);
    file_frames_ = n > 0 ? static_cast<int64_t>(std::llround(n)) : -1;
    // Skip by decoding rather than seeking: FFmpeg seeks land on keyframes, which would shift the start.
    for (int64_t k = 0; k < start_; ++k)
      if (!cap_.grab())
        throw Error("video file '" + path_ + "' ends at frame " + std::to_string(k) + ", before start_frame " +
                    std::to_string(start_));
    if (!cap_.grab())
      throw Error("video file '" + path_ + "' has no decodable frame at frame " + std::to_string(start_));
    if (!cap_.retrieve(pending_) || pending_.empty())
      throw Error("video file '" + path_ + "': frame " + std::to_string(start_) + " cannot be decoded");
    setup_.init(pending_.size(), "video file '" + path_ + "'", ctx);
    if (file_frames_ > 0) {
      int64_t c = std::max<int64_t>(file_frames_ - start_, 0);
      if (max_frames_ >= 0) c = std::min(c, max_frames_);
      count_ = c;
    } else if (max_frames_ >= 0) {
      count_ = max_frames_;
    }
  }
  ctx.record_resource(path_);
  // What the footage must tell: two passes over the clip before the first frame is emitted.
  setup_.estimate_from_footage(
      [this]() -> CameraSetup::FrameReader {
        if (!files_.empty()) {
          auto k = std::make_shared<size_t>(0);
          return [this, k](cv::Mat& out, std::string& what) {
            if (*k >= files_.size()) return false;
            what = "image '" + files_[*k].string() + "'";
            out = read_image((*k)++);
            return true;
          };
        }
        auto cap = std::make_shared<cv::VideoCapture>(path_, cv::CAP_FFMPEG);
        auto k = std::make_shared<int64_t>(0);
        for (int64_t s = 0; s < start_ && cap->grab(); ++s) {
        }
        return [this, cap, k](cv::Mat& out, std::string& what) {
          if (max_frames_ >= 0 && *k >= max_frames_) return false;
          if (!cap->grab() || !cap->retrieve(out) || out.empty()) return false;
          what = "video file '" + path_ + "' frame " + std::to_string(start_ + *k);
          ++*k;
          return true;
        };
      },
      count_.value_or(-1), fps_, ctx);
  written_frames_ = count_.value_or(0);
  setup_.write_reports(ctx, written_frames_, fps_, fps_source_);
  const auto& cam = setup_.camera();
  ctx.log(LogLevel::kInfo, "'" + path_ + "': " + std::to_string(pending_.cols) + "x" + std::to_string(pending_.rows) +
                               " at " + std::to_string(fps_) + " fps (" + fps_source_ + "), " +
                               (count_ ? std::to_string(*count_) : std::string("unknown")) +
                               " frames; intrinsics from " + setup_.intrinsics_source() + "; pitch " +
                               std::to_string(cam.pitch() * 180 / CV_PI) + " deg");
}

cv::Mat VideoSource::read_image(size_t k) const {
  return read_color_image(files_[k], "image '" + files_[k].string() + "' (frame " + std::to_string(k) + ")");
}

bool VideoSource::next(StageContext& /*ctx*/, Outputs& out) {
  if (max_frames_ >= 0 && emitted_ >= max_frames_) return false;
  const int64_t file_frame = start_ + emitted_;
  cv::Mat raw;
  if (!pending_.empty()) {
    raw = pending_;
    pending_.release();
  } else if (!files_.empty()) {
    if (static_cast<size_t>(emitted_) >= files_.size()) return false;
    raw = read_image(static_cast<size_t>(emitted_));
  } else {
    // grab() false = end of stream; grab() true but retrieve() false = a frame that is there but broken.
    if (!cap_.grab()) {
      // Containers estimate their frame count; one frame less is within that error, more is a damaged file.
      if (file_frames_ > 0 && file_frame < file_frames_ - 1) {
        const std::string what = "video file '" + path_ + "' decodes " + std::to_string(file_frame) +
                                 " of the " + std::to_string(file_frames_) +
                                 " frames its container declares (decoding stops at frame " +
                                 std::to_string(file_frame) + "): the file is truncated or corrupt";
        if (!allow_partial_) throw Error(what + "; set allow_partial: true to use the frames that decode");
        report_incomplete(what);
      }
      return false;
    }
    if (!cap_.retrieve(raw) || raw.empty())
      throw Error("video file '" + path_ + "': frame " + std::to_string(file_frame) + " cannot be decoded");
  }
  Frame f;
  f.index = emitted_;
  f.timestamp = clock_.at(static_cast<size_t>(emitted_));
  f.image = setup_.prepare(raw, "'" + path_ + "' frame " + std::to_string(file_frame));
  f.camera = setup_.camera_at(emitted_);
  f.ego = setup_.ego_at(emitted_);
  f.ego_track = setup_.ego_track();
  f.road_markings = setup_.road_markings();
  if (count_ && *count_ > 0) f.stream_end = clock_.at(static_cast<size_t>(*count_ - 1));
  f.origin.dataset = files_.empty() ? "video" : "images";
  f.origin.scene = files_.empty() ? fs::path(path_).stem().string() : fs::path(path_).filename().string();
  if (!files_.empty()) {
    f.source_id = files_[static_cast<size_t>(emitted_)].filename().string();
    f.meta = {{"file", files_[static_cast<size_t>(emitted_)].string()}, {"intrinsics", setup_.intrinsics_source()}};
  } else {
    f.source_id = fs::path(path_).filename().string() + ":" + std::to_string(file_frame);
    f.meta = {{"file", path_}, {"file_frame", file_frame}, {"intrinsics", setup_.intrinsics_source()}};
  }
  const double ts = f.timestamp;
  out.emit_packet("frames", Packet::make<Frame>(std::move(f), ts));
  ++emitted_;
  return true;
}

// ---- CameraSource
// -------------------------------------------------------------------------------------------

ComponentInfo CameraSource::describe() {
  ComponentInfo i = base_info("camera", "frames of a live camera device or stream URL");
  i.doc =
      "Opens `device` (an index like \"0\" or a device path) or `url` (rtsp://, http://, a file URL). "
      "Timestamps come from a steady clock, starting at 0 with the first frame. The frame count is unknown.";
  i.params = {
      ParamSpec::string("device", "").describe("device index (\"0\") or path (/dev/video0)"),
      ParamSpec::string("url", "").describe("stream URL, e.g. rtsp://host/stream"),
      ParamSpec::integer("max_frames", -1)
          .range(-1, std::nullopt)
          .describe("frames to emit (-1 = until stopped)"),
  };
  for (ParamSpec& p : CameraSetup::params()) i.params.push_back(std::move(p));
  return i;
}

void CameraSource::open(StageContext& ctx) {
  const Params& p = ctx.params();
  const std::string device = p.get_string("device"), url = expand_vars(p.get_string("url"));
  if (device.empty() == url.empty()) throw Error("camera source: give exactly one of 'device' and 'url'");
  setup_.configure(ctx);
  max_frames_ = p.get_int("max_frames");
  bool ok = false;
  if (!device.empty()) {
    what_ = "camera device '" + device + "'";
    const bool numeric = device.find_first_not_of("0123456789") == std::string::npos;
    ok = numeric ? cap_.open(std::stoi(device), cv::CAP_ANY) : cap_.open(device, cv::CAP_ANY);
  } else {
    what_ = "stream '" + url + "'";
    ok = cap_.open(url, cv::CAP_FFMPEG);
  }
  if (!ok || !cap_.isOpened())
    throw Error("cannot open " + what_ + ": no such device or the stream is unreachable");
}

bool CameraSource::next(StageContext& ctx, Outputs& out) {
  if (max_frames_ >= 0 && emitted_ >= max_frames_) return false;
  if (ctx.stop_requested()) return false;
  cv::Mat raw;
  if (!cap_.read(raw) || raw.empty()) {
    // A live stream that stops is the end of the run, not corrupt input; say so and end cleanly.
    ctx.log(LogLevel::kWarning,
            what_ + " delivered no frame after " + std::to_string(emitted_) + " frames; stopping");
    return false;
  }
  const auto now = std::chrono::steady_clock::now();
  if (emitted_ == 0) {
    t0_ = now;
    setup_.init(raw.size(), what_, ctx);
  }
  Frame f;
  f.index = emitted_;
  f.timestamp = std::chrono::duration<double>(now - t0_).count();
  f.image = setup_.prepare(raw, what_ + " frame " + std::to_string(emitted_));
  f.camera = setup_.camera();
  f.ego = setup_.ego_at(-1);
  f.source_id = what_;
  f.origin = {"camera", what_, "", std::nullopt};
  f.meta = {{"intrinsics", setup_.intrinsics_source()}};
  const double ts = f.timestamp;
  out.emit_packet("frames", Packet::make<Frame>(std::move(f), ts));
  ++emitted_;
  return true;
}

}  // namespace hf::source
