// Sink writing the frames with boxes, tracks, distances, metric values and Safe/Unsafe banners to an MP4.
#pragma once

#include <filesystem>
#include <string>
#include <vector>

#include "hazardforge/sink/video_file_writer.hpp"
#include "hazardforge/stage.hpp"

namespace hf::sink {

// Ports: in `frames` (Frame), optional `tracks` (Tracks), optional `states` (ObjectStates), optional multi
// `risk` (RiskAssessment), optional `detections` (Detections). No outputs.
// Timestamps: the video's frame rate is `fps`, or the median spacing of the first frames' timestamps.
// The file is written as <stem>.partial<ext> and renamed in finish(), so a finished run never leaves a
// half-written video under the final name. H.264 (avc1) is tried first, then MPEG-4 Part 2 (mp4v); H.264 goes
// through the ffmpeg program (VideoFileWriter) so encoding is cheap, bounded per frame and controllable.
// Params: file, fps, codec, png_every, png_dir, thickness, scale, encoder, preset, threads, crf.
class AnnotatedVideoSink : public Stage {
 public:
  static ComponentInfo describe();
  void open(StageContext& ctx) override;
  void process(StageContext& ctx, const Inputs& in, Outputs& out) override;
  void finish(StageContext& ctx, Outputs& out) override;

  const std::string& codec_used() const { return codec_; }

 private:
  void start_writer(StageContext& ctx);
  void write(StageContext& ctx, const cv::Mat& img);

  std::filesystem::path file_, png_dir_;
  double fps_param_ = 0;
  std::string codec_param_, codec_;
  int png_every_ = 0;
  int thickness_ = 2;
  double scale_ = 1.0;
  cv::Size frame_size_;         // of the incoming frames; size_ is the video's
  VideoWriterOptions encoder_;  // encoder, preset, threads, crf from the params
  VideoFileWriter writer_;
  cv::Size size_;
  // Frames held back until the frame rate is known from their timestamps.
  std::vector<cv::Mat> pending_;
  std::vector<double> pending_ts_;
  int64_t written_ = 0;
};

}  // namespace hf::sink
