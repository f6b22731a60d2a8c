// The side_by_side sink: original and augmented frames next to each other, as an MP4 and optional PNG stills.
#pragma once

#include <filesystem>
#include <optional>
#include <set>
#include <string>
#include <vector>

#include <opencv2/core.hpp>
#include "hazardforge/sink/video_file_writer.hpp"
#include "hazardforge/stage.hpp"

namespace hf::render {

// Stage "side_by_side" (kind sink).
//  inputs:  original (Frame), augmented (Frame) — the same frame before and after augmentation; hazard
//           (HazardInstance, optional) — outlined on the augmented half when draw_hazard_box is set.
//  outputs: none; writes <output_dir>/<file> (H.264 'avc1' through the ffmpeg program or OpenCV, falling back
//  to
//           MPEG-4 'mp4v' when no encoder exists; written under a temporary name and renamed in finish())
//           and, for the frame indices in `stills`, PNGs <stills_dir>/before_after_<index>.png, plus
//           <stills_dir>/critical.png at the visible hazard frame with the lowest intended TTC, and
//           <stills_dir>/realism/<metric>_best.png / _worst.png (realism_stills). Timestamps:
//           the video's rate is `fps`, or the first two frames' interval when fps is 0.
//  params:  file, fps, fourcc, scale, layout, labels, stills, stills_dir, stills_scale, draw_hazard_box,
//  encoder,
//           preset, threads, crf.
class SideBySideSink : public Stage {
 public:
  static ComponentInfo describe();
  void open(StageContext& ctx) override;
  void process(StageContext& ctx, const Inputs& in, Outputs& out) override;
  void finish(StageContext& ctx, Outputs& out) override;

  // Composes one pair at `scale` (labels drawn); public for tests.
  cv::Mat compose(const Frame& original, const Frame& augmented, const HazardInstance* hazard,
                  double scale) const;
  // The FOURCC the video was finally written with ("avc1" or "mp4v"), empty before the writer opened.
  const std::string& codec() const { return codec_; }

 private:
  void open_writer(StageContext& ctx, double fps, cv::Size size);
  void write(StageContext& ctx, const cv::Mat& img);

  std::filesystem::path file_, stills_dir_;
  double fps_ = 0, scale_ = 0.5, stills_scale_ = 0.5;
  std::string fourcc_, layout_;
  std::vector<std::string> labels_;
  std::set<long long> stills_;
  bool draw_box_ = false;
  bool critical_still_ = true;
  std::optional<double> critical_ttc_;
  std::optional<cv::Mat> critical_;  // the composite at the lowest intended TTC so far
  // Realism stills: every visible frame's close-up pair and the inserted object's appearance there, and the
  // recording's real objects measured alongside; the best and worst frame per metric are written at the end.
  struct Closeup {
    int64_t frame = 0;
    AppearanceStats stats;
    cv::Mat pair;  // original | augmented around the inserted object
  };
  bool realism_stills_ = true;
  std::string object_class_;
  std::vector<Closeup> closeups_;
  std::vector<AppearanceStats> references_;
  void write_realism_stills(StageContext& ctx) const;
  sink::VideoWriterOptions encoder_;  // encoder, preset, threads, crf from the params
  sink::VideoFileWriter writer_;
  std::string codec_;
  std::optional<cv::Mat> pending_;  // first composite, held until the second frame gives the rate
  std::optional<double> first_t_;
  int64_t written_ = 0;
};

}  // namespace hf::render
