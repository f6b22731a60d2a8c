// AnnotatedVideoSink: overlays drawn per frame, encoded with H.264 when available, else MPEG-4.
#include "annotated_video_sink.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>

#include <opencv2/imgcodecs.hpp>

#include "overlay.hpp"

namespace hf::sink {

namespace fs = std::filesystem;

namespace {
// Frames buffered to estimate the frame rate from timestamps.
constexpr size_t kRateProbeFrames = 8;
constexpr double kFallbackFps = 10.0;
}  // namespace

ComponentInfo AnnotatedVideoSink::describe() {
  ComponentInfo i;
  i.name = "annotated_video";
  i.kind = kind::kSink;
  i.summary = "MP4 of the frames with boxes, track ids, distances, metric values and Safe/Unsafe banners";
  i.doc =
      "Draws detections (thin), tracks or object states (class-coloured boxes with id, distance and each "
      "metric's "
      "per-object value), one banner per risk metric (red when Unsafe) and the frame index/time. The frame "
      "rate is "
      "`fps` or the median timestamp spacing of the first frames. Tries H.264 (avc1), falls back to mp4v.";
  i.inputs = {port<Frame>("frames", "the frames to draw on"),
              optional(port<Tracks>("tracks", "tracked boxes")),
              optional(port<ObjectStates>("states", "distances and velocities per track")),
              optional(multi(port<RiskAssessment>("risk", "one or more risk metrics"))),
              optional(port<Detections>("detections", "raw detections, drawn thin"))};
  i.params = {
      ParamSpec::string("file", "annotated.mp4").describe("video file, relative to the run folder"),
      ParamSpec::number("fps", 0.0).range(0, 1000).describe("frame rate (0 = from the frame timestamps)"),
      ParamSpec::string("codec", "auto")
          .one_of({"auto", "avc1", "mp4v", "MJPG"})
          .describe("fourcc; auto = avc1 (H.264), falling back to mp4v"),
      ParamSpec::integer("png_every", 0)
          .range(0, std::nullopt)
          .describe("also save every Nth frame as PNG (0 = off)"),
      ParamSpec::string("png_dir", "annotated_frames")
          .describe("folder for the PNGs, relative to the run folder"),
      ParamSpec::integer("thickness", 2).range(1, 20).describe("box line thickness, px"),
  };
  return i;
}

void AnnotatedVideoSink::open(StageContext& ctx) {
  const Params& p = ctx.params();
  file_ = ctx.output_dir() / p.get_string("file");
  partial_ = file_.parent_path() / (file_.stem().string() + ".partial" + file_.extension().string());
  png_dir_ = ctx.output_dir() / p.get_string("png_dir");
  fps_param_ = p.get_double("fps");
  codec_param_ = p.get_string("codec");
  png_every_ = static_cast<int>(p.get_int("png_every"));
  thickness_ = static_cast<int>(p.get_int("thickness"));
  fs::create_directories(file_.parent_path());
  if (png_every_ > 0) fs::create_directories(png_dir_);
}

void AnnotatedVideoSink::start_writer(StageContext& ctx) {
  double fps = fps_param_;
  if (fps <= 0) {
    std::vector<double> d;
    for (size_t i = 1; i < pending_ts_.size(); ++i)
      if (pending_ts_[i] > pending_ts_[i - 1]) d.push_back(pending_ts_[i] - pending_ts_[i - 1]);
    if (d.empty()) {
      fps = kFallbackFps;
      ctx.log(LogLevel::kWarning, "annotated video: cannot derive a frame rate from " +
                                      std::to_string(pending_ts_.size()) + " frame(s); writing at 10 fps");
    } else {
      std::nth_element(d.begin(), d.begin() + static_cast<std::ptrdiff_t>(d.size() / 2), d.end());
      fps = 1.0 / d[d.size() / 2];
    }
  }
  std::vector<std::string> codecs;
  if (codec_param_ == "auto")
    codecs = {"avc1", "mp4v"};
  else
    codecs = {codec_param_};
  for (const std::string& c : codecs) {
    const int fourcc = cv::VideoWriter::fourcc(c[0], c[1], c[2], c[3]);
    if (writer_.open(partial_.string(), cv::CAP_FFMPEG, fourcc, fps, size_) && writer_.isOpened()) {
      codec_ = c;
      break;
    }
  }
  if (!writer_.isOpened())
    throw Error("cannot write video '" + partial_.string() + "': no encoder for " +
                (codec_param_ == "auto" ? std::string("avc1 or mp4v") : codec_param_));
  char buf[64];
  std::snprintf(buf, sizeof buf, "%.3f", fps);
  ctx.log(LogLevel::kInfo, "annotated video: " + codec_ + " at " + buf + " fps, " +
                               std::to_string(size_.width) + "x" + std::to_string(size_.height));
}

void AnnotatedVideoSink::write(const cv::Mat& img) {
  writer_.write(img);
  ++written_;
}

void AnnotatedVideoSink::process(StageContext& ctx, const Inputs& in, Outputs& /*out*/) {
  const Frame& frame = in.require<Frame>("frames");
  if (frame.image.empty())
    throw Error("annotated video: frame " + std::to_string(frame.index) + " has no image");
  if (frame.image.type() != CV_8UC3)
    throw Error("annotated video: frame " + std::to_string(frame.index) + " is not BGR 8-bit");
  cv::Mat img = frame.image.clone();  // packets are shared and immutable; draw on a copy
  if (size_.empty()) size_ = img.size();
  if (img.size() != size_)
    throw Error("annotated video: frame " + std::to_string(frame.index) + " is " + std::to_string(img.cols) +
                "x" + std::to_string(img.rows) + " but the video is " + std::to_string(size_.width) + "x" +
                std::to_string(size_.height));

  OverlayInputs ov;
  ov.tracks = in.get<Tracks>("tracks");
  ov.states = in.get<ObjectStates>("states");
  ov.detections = in.get<Detections>("detections");
  const auto risks = in.packets("risk");
  const auto producers = in.producers("risk");
  for (size_t i = 0; i < risks.size(); ++i)
    if (risks[i] && !risks[i]->empty()) {
      const RiskAssessment& r = risks[i]->get<RiskAssessment>();
      ov.risks.emplace_back(!r.metric.empty() ? r.metric : (i < producers.size() ? producers[i] : "risk"),
                            &r);
    }
  draw_overlay(img, frame.index, frame.timestamp, ov, thickness_);

  if (png_every_ > 0 && frame.index % png_every_ == 0) {
    char name[48];
    std::snprintf(name, sizeof name, "frame_%06lld.png", static_cast<long long>(frame.index));
    if (!cv::imwrite((png_dir_ / name).string(), img))
      throw Error("cannot write '" + (png_dir_ / name).string() + "'");
  }

  if (!writer_.isOpened()) {
    pending_.push_back(img);
    pending_ts_.push_back(frame.timestamp);
    if (fps_param_ <= 0 && pending_.size() < kRateProbeFrames) return;
    start_writer(ctx);
    for (const cv::Mat& m : pending_) write(m);
    pending_.clear();
    return;
  }
  write(img);
}

void AnnotatedVideoSink::finish(StageContext& ctx, Outputs& /*out*/) {
  if (!writer_.isOpened() && !pending_.empty()) {
    start_writer(ctx);
    for (const cv::Mat& m : pending_) write(m);
    pending_.clear();
  }
  if (!writer_.isOpened()) {
    ctx.log(LogLevel::kWarning, "annotated video: no frames, nothing written");
    return;
  }
  writer_.release();
  std::error_code ec;
  fs::rename(partial_, file_, ec);
  if (ec)
    throw Error("cannot rename '" + partial_.string() + "' to '" + file_.string() + "': " + ec.message());
  ctx.log(LogLevel::kInfo, "wrote " + std::to_string(written_) + " frames to " + file_.string());
}

}  // namespace hf::sink
