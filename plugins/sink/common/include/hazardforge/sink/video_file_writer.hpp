// MP4 writer shared by the video sinks: H.264 by piping raw BGR frames to the ffmpeg program (libx264 with a
// chosen preset, no lookahead), or cv::VideoWriter; written under <stem>.partial<ext> and renamed on close().
#pragma once

#include <cstdint>
#include <filesystem>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include <opencv2/core.hpp>
#include <opencv2/videoio.hpp>

#include "hazardforge/params.hpp"

namespace hf::sink {

struct VideoWriterOptions {
  std::filesystem::path file;  // final name; frames go to <stem>.partial<ext> until close() renames it
  double fps = 10.0;
  cv::Size size;
  // FOURCCs to try in order ("avc1", "mp4v", "MJPG"). A later one is used only when an earlier one has no
  // encoder, with a warning.
  std::vector<std::string> codecs = {"avc1", "mp4v"};
  // "ffmpeg": H.264 through the ffmpeg program when it is on PATH with libx264 (else cv::VideoWriter, with a
  // warning); "opencv": always cv::VideoWriter. Other codecs always use cv::VideoWriter.
  std::string encoder = "ffmpeg";
  std::string preset = "ultrafast";       // x264 preset (ffmpeg encoder only)
  int threads = 1;                        // x264 threads (ffmpeg encoder only); 0 = x264 chooses
  int crf = 23;                           // x264 constant rate factor (ffmpeg encoder only), 0..51
  std::string ffmpeg_program = "ffmpeg";  // a name looked up on PATH, or a path
};

// x264's presets, fastest first.
const std::vector<std::string>& x264_presets();

// The encoder params every video sink declares (encoder, preset, threads, crf) and their reading into
// options.
std::vector<ParamSpec> encoder_params();
void read_encoder_params(const Params& p, VideoWriterOptions& options);

// Full path of an executable: `name` itself when it contains a '/', else the first match on PATH; empty
// when there is none.
std::string find_program(const std::string& name);

// <stem>.partial<ext> beside `file`.
std::filesystem::path partial_path(const std::filesystem::path& file);

// One MP4 file. Every failure throws hf::Error naming the file (and, for ffmpeg, its exit status and stderr).
// Not thread-safe; one sink owns one writer.
class VideoFileWriter {
 public:
  using Warn = std::function<void(const std::string&)>;

  VideoFileWriter();
  ~VideoFileWriter();  // an unclosed writer lets ffmpeg finish the .partial file and leaves it there
  VideoFileWriter(const VideoFileWriter&) = delete;
  VideoFileWriter& operator=(const VideoFileWriter&) = delete;

  // Creates the file's folder and starts the encoder. Warnings (fallbacks) go to `warn`.
  void open(const VideoWriterOptions& options, const Warn& warn = {});
  bool is_open() const;
  // `frame` must be 8-bit BGR of the opened size.
  void write(const cv::Mat& frame);
  // Flushes the encoder, checks it succeeded, renames the .partial file to the final name.
  void close();

  const std::string& codec() const { return codec_; }      // FOURCC written, empty before open()
  const std::string& backend() const { return backend_; }  // "ffmpeg" or "opencv"
  // E.g. "avc1 via ffmpeg/libx264 (preset ultrafast, 1 thread, crf 23)" or "mp4v via OpenCV".
  std::string description() const;
  const std::filesystem::path& partial() const { return partial_; }
  int64_t frames() const { return frames_; }

 private:
  struct Ffmpeg;
  void start_ffmpeg(const std::string& program);
  [[noreturn]] void ffmpeg_failed(const std::string& what);

  VideoWriterOptions opt_;
  std::filesystem::path partial_;
  std::string codec_, backend_;
  std::unique_ptr<Ffmpeg> ffmpeg_;
  cv::VideoWriter cv_;
  int64_t frames_ = 0;
};

}  // namespace hf::sink
