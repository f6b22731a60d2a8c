// AnnotatedVideoSink: overlays drawn per frame, encoded with H.264 when available, else MPEG-4.
#include "annotated_video_sink.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "hazardforge/atomic_file.hpp"
#include "hazardforge/output_path.hpp"
#include "overlay.hpp"

namespace hf::sink {

namespace fs = std::filesystem;

namespace {
// Frames buffered to estimate the frame rate from timestamps.
constexpr size_t kRateProbeFrames = 8;
constexpr double kFallbackFps = 10.0;

double seconds_since(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}
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
      "`fps` or the median timestamp spacing of the first frames. H.264 (avc1) is written by piping the "
      "frames "
      "to the `ffmpeg` program (libx264, `preset`, `threads`, `crf`, no lookahead) when it is installed, "
      "else by "
      "OpenCV's VideoWriter (with a warning); mp4v and MJPG are written by OpenCV. Records the inner timings "
      "`draw` and `encode` per frame.";
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
      ParamSpec::number("scale", 1.0)
          .range(0.1, 1.0)
          .describe(
              "size of the video (and PNGs) relative to the frames; the frame is shrunk before drawing, so "
              "0.5 costs about a quarter of the encoding"),
  };
  for (ParamSpec& e : encoder_params()) i.params.push_back(std::move(e));
  return i;
}

void AnnotatedVideoSink::open(StageContext& ctx) {
  const Params& p = ctx.params();
  file_ = output_param_path(ctx, "file");
  fps_param_ = p.get_double("fps");
  codec_param_ = p.get_string("codec");
  png_every_ = static_cast<int>(p.get_int("png_every"));
  thickness_ = static_cast<int>(p.get_int("thickness"));
  scale_ = p.get_double("scale");
  read_encoder_params(p, encoder_);
  if (png_every_ > 0) png_dir_ = output_param_path(ctx, "png_dir", /*is_dir=*/true);
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
  VideoWriterOptions o = encoder_;
  o.file = file_;
  o.fps = fps;
  o.size = size_;
  o.codecs = codec_param_ == "auto" ? std::vector<std::string>{"avc1", "mp4v"}
                                    : std::vector<std::string>{codec_param_};
  writer_.open(o, [&](const std::string& w) { ctx.log(LogLevel::kWarning, "annotated video: " + w); });
  codec_ = writer_.codec();
  char buf[64];
  std::snprintf(buf, sizeof buf, "%.3f", fps);
  ctx.log(LogLevel::kInfo, "annotated video: " + writer_.description() + " at " + buf + " fps, " +
                               std::to_string(size_.width) + "x" + std::to_string(size_.height));
}

void AnnotatedVideoSink::write(StageContext& ctx, const cv::Mat& img) {
  const auto t0 = std::chrono::steady_clock::now();
  writer_.write(img);
  ctx.record_timing("encode", seconds_since(t0));
  ++written_;
}

void AnnotatedVideoSink::process(StageContext& ctx, const Inputs& in, Outputs& /*out*/) {
  const Frame& frame = in.require<Frame>("frames");
  if (frame.image.empty())
    throw Error("annotated video: frame " + std::to_string(frame.index) + " has no image");
  if (frame.image.type() != CV_8UC3)
    throw Error("annotated video: frame " + std::to_string(frame.index) + " is not BGR 8-bit");
  const auto t0 = std::chrono::steady_clock::now();
  if (frame_size_.empty()) frame_size_ = frame.image.size();
  if (frame.image.size() != frame_size_)
    throw Error("annotated video: frame " + std::to_string(frame.index) + " is " +
                std::to_string(frame.image.cols) + "x" + std::to_string(frame.image.rows) +
                " but the video is " + std::to_string(frame_size_.width) + "x" +
                std::to_string(frame_size_.height));
  // Packets are shared and immutable: draw on a copy, shrunk first when scale < 1 (even sides for H.264).
  cv::Mat img;
  if (scale_ < 1.0) {
    const cv::Size s(std::max(2, static_cast<int>(std::lround(frame_size_.width * scale_ / 2)) * 2),
                     std::max(2, static_cast<int>(std::lround(frame_size_.height * scale_ / 2)) * 2));
    cv::resize(frame.image, img, s, 0, 0, cv::INTER_AREA);
  } else {
    img = frame.image.clone();
  }
  if (size_.empty()) size_ = img.size();

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
  draw_overlay(img, frame.index, frame.timestamp, ov, thickness_,
               static_cast<double>(img.cols) / frame_size_.width);
  ctx.record_timing("draw", seconds_since(t0));

  if (png_every_ > 0 && frame.index % png_every_ == 0) {
    char name[48];
    std::snprintf(name, sizeof name, "frame_%06lld.png", static_cast<long long>(frame.index));
    std::vector<uchar> png;
    if (!cv::imencode(".png", img, png)) throw Error("cannot encode '" + (png_dir_ / name).string() + "'");
    write_file_atomic(png_dir_ / name,
                      std::string_view(reinterpret_cast<const char*>(png.data()), png.size()));
  }

  if (!writer_.is_open()) {
    pending_.push_back(img);
    pending_ts_.push_back(frame.timestamp);
    if (fps_param_ <= 0 && pending_.size() < kRateProbeFrames) return;
    start_writer(ctx);
    for (const cv::Mat& m : pending_) write(ctx, m);
    pending_.clear();
    return;
  }
  write(ctx, img);
}

void AnnotatedVideoSink::finish(StageContext& ctx, Outputs& /*out*/) {
  if (!writer_.is_open() && !pending_.empty()) {
    start_writer(ctx);
    for (const cv::Mat& m : pending_) write(ctx, m);
    pending_.clear();
  }
  if (!writer_.is_open()) {
    ctx.log(LogLevel::kWarning, "annotated video: no frames, nothing written");
    return;
  }
  writer_.close();
  ctx.log(LogLevel::kInfo, "wrote " + std::to_string(written_) + " frames to " + file_.string());
}

}  // namespace hf::sink
