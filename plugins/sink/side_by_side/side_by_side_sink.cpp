// The side_by_side sink: original | augmented composites written as H.264 (or MPEG-4) video and PNG stills.
#include "side_by_side_sink.hpp"

#include <chrono>
#include <cmath>
#include <cstdio>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "hazardforge/atomic_file.hpp"
#include "hazardforge/error.hpp"
#include "hazardforge/output_path.hpp"
#include "hazardforge/realism/compare.hpp"

namespace hf::render {

namespace fs = std::filesystem;

namespace {

void label(cv::Mat& img, const std::string& text, cv::Point org, double scale) {
  const int font = cv::FONT_HERSHEY_SIMPLEX;
  const double fs = std::max(0.45, 0.9 * scale);
  const int th = std::max(1, static_cast<int>(std::lround(2 * scale)));
  int base = 0;
  const cv::Size ts = cv::getTextSize(text, font, fs, th, &base);
  const cv::Rect bg = cv::Rect(org.x - 6, org.y - ts.height - 8, ts.width + 12, ts.height + base + 14) &
                      cv::Rect(0, 0, img.cols, img.rows);
  cv::Mat roi = img(bg);
  roi.convertTo(roi, -1, 0.35, 0);  // darkened backdrop keeps the text readable on any scene
  cv::putText(img, text, org, font, fs, cv::Scalar(255, 255, 255), th, cv::LINE_AA);
}

}  // namespace

ComponentInfo SideBySideSink::describe() {
  ComponentInfo i;
  i.name = "side_by_side";
  i.kind = kind::kSink;
  i.summary = "writes original and augmented frames side by side (before_after.mp4) and PNG stills";
  i.doc =
      "Each frame pair becomes one labelled picture (original left or top, augmented right or bottom). The "
      "video "
      "is H.264 ('avc1'), written by piping the frames to the `ffmpeg` program (libx264, `preset`, "
      "`threads`, "
      "`crf`, no lookahead) or, when ffmpeg is missing, by OpenCV's VideoWriter (with a warning); MPEG-4 "
      "('mp4v') when no H.264 encoder exists. It is written under a temporary name and renamed when the "
      "stream "
      "ends, so an interrupted run keeps a playable file.";
  i.inputs = {
      port<Frame>("original", "frames before augmentation"),
      port<Frame>("augmented", "the same frames after augmentation"),
      optional(port<HazardInstance>("hazard", "where the hazard is (outlined when draw_hazard_box)"))};
  i.params = {
      ParamSpec::string("file", "before_after.mp4").describe("video file name below the run's output folder"),
      ParamSpec::number("fps", 0.0).range(0.0, 240.0).describe("video rate; 0 = from the frames' timestamps"),
      ParamSpec::string("fourcc", "avc1").describe("preferred codec; 'mp4v' is the fallback"),
      ParamSpec::number("scale", 0.5).range(0.05, 2.0).describe("scale of each half in the video"),
      ParamSpec::string("layout", "horizontal")
          .one_of({"horizontal", "vertical"})
          .describe("halves side by side or stacked"),
      ParamSpec::string_list("labels", {"original", "augmented"}).describe("captions of the two halves"),
      ParamSpec::int_list("stills", {}).describe("frame indices written as PNG stills"),
      ParamSpec::string("stills_dir", "stills")
          .describe("folder for stills, relative to the run's output folder"),
      ParamSpec::number("stills_scale", 0.5).range(0.05, 2.0).describe("scale of each half in the stills"),
      ParamSpec::boolean("draw_hazard_box", false)
          .describe("outline the inserted object on the augmented half"),
      ParamSpec::boolean("critical_still", true)
          .describe("also write <stills_dir>/critical.png: the visible hazard frame with the lowest intended "
                    "TTC (the moment the scenario is about; galleries use it)"),
      ParamSpec::boolean("realism_stills", true)
          .describe(
              "also write <stills_dir>/realism/<metric>_best.png and _worst.png for every realism metric "
              "the hazard packets carry: the close-up (original | augmented) of the visible frame whose "
              "value of the inserted object lies nearest to / farthest from the median of the recording's "
              "real objects of its class (by percentile rank), captioned with both"),
  };
  for (ParamSpec& e : sink::encoder_params()) i.params.push_back(std::move(e));
  return i;
}

void SideBySideSink::open(StageContext& ctx) {
  const Params& p = ctx.params();
  const fs::path file = p.get_string("file");
  if (file.empty() || file.extension() != ".mp4")
    throw Error("file '" + file.string() + "' must end in .mp4");
  file_ = output_param_path(ctx, "file");
  critical_still_ = p.get_bool("critical_still");
  realism_stills_ = p.get_bool("realism_stills");
  if (!p.get_ints("stills").empty() || critical_still_ || realism_stills_)
    stills_dir_ = output_param_path(ctx, "stills_dir", /*is_dir=*/true);
  fps_ = p.get_double("fps");
  fourcc_ = p.get_string("fourcc");
  if (fourcc_.size() != 4) throw Error("fourcc '" + fourcc_ + "' must have four characters");
  scale_ = p.get_double("scale");
  stills_scale_ = p.get_double("stills_scale");
  layout_ = p.get_string("layout");
  labels_ = p.get_strings("labels");
  if (labels_.size() != 2) throw Error("labels must list two captions (original, augmented)");
  for (long long s : p.get_ints("stills")) stills_.insert(s);
  draw_box_ = p.get_bool("draw_hazard_box");
  sink::read_encoder_params(p, encoder_);
}

cv::Mat SideBySideSink::compose(const Frame& a, const Frame& b, const HazardInstance* hz,
                                double scale) const {
  if (a.image.empty() || b.image.empty())
    throw Error("frame " + std::to_string(a.index) + ": an input frame has no image");
  if (a.image.size() != b.image.size())
    throw Error("frame " + std::to_string(a.index) + ": original is " + std::to_string(a.image.cols) + "x" +
                std::to_string(a.image.rows) + " but augmented is " + std::to_string(b.image.cols) + "x" +
                std::to_string(b.image.rows));
  const cv::Size half(std::max(2, static_cast<int>(std::lround(a.image.cols * scale / 2)) * 2),
                      std::max(2, static_cast<int>(std::lround(a.image.rows * scale / 2)) * 2));
  cv::Mat l, r;
  cv::resize(a.image, l, half, 0, 0, cv::INTER_AREA);
  cv::resize(b.image, r, half, 0, 0, cv::INTER_AREA);
  if (draw_box_ && hz && hz->visible) {
    const double sx = static_cast<double>(half.width) / a.image.cols,
                 sy = static_cast<double>(half.height) / a.image.rows;
    cv::rectangle(r,
                  cv::Rect(cvRound(hz->box.x * sx), cvRound(hz->box.y * sy), cvRound(hz->box.width * sx),
                           cvRound(hz->box.height * sy)),
                  cv::Scalar(0, 200, 255), std::max(1, cvRound(2 * scale)), cv::LINE_AA);
  }
  const double ts = std::clamp(half.height / 450.0, 0.5, 2.0);
  const cv::Point org(12, static_cast<int>(30 * ts) + 8);
  label(l, labels_[0], org, ts);
  label(r, labels_[1], org, ts);
  char info[64];
  std::snprintf(info, sizeof info, "frame %lld  t=%.2f s", static_cast<long long>(b.index), b.timestamp);
  label(r, info, cv::Point(12, half.height - 14), ts * 0.8);
  cv::Mat out;
  if (layout_ == "vertical") {
    cv::vconcat(l, r, out);
  } else {
    cv::hconcat(l, r, out);
  }
  return out;
}

void SideBySideSink::open_writer(StageContext& ctx, double fps, cv::Size size) {
  sink::VideoWriterOptions o = encoder_;
  o.file = file_;
  o.fps = fps;
  o.size = size;
  o.codecs = {fourcc_};
  if (fourcc_ != "mp4v") o.codecs.push_back("mp4v");
  writer_.open(o, [&](const std::string& w) { ctx.log(LogLevel::kWarning, "side_by_side: " + w); });
  codec_ = writer_.codec();
  ctx.log(LogLevel::kInfo, "side_by_side: " + writer_.description());
}

void SideBySideSink::write(StageContext& ctx, const cv::Mat& img) {
  const auto t0 = std::chrono::steady_clock::now();
  writer_.write(img);
  ctx.record_timing("encode", std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count());
  ++written_;
}

void SideBySideSink::process(StageContext& ctx, const Inputs& in, Outputs& /*out*/) {
  const Frame& a = in.require<Frame>("original");
  const Frame& b = in.require<Frame>("augmented");
  if (a.index != b.index)
    throw Error("side_by_side: original frame " + std::to_string(a.index) +
                " is paired with augmented frame " + std::to_string(b.index));
  const HazardInstance* hz = in.get<HazardInstance>("hazard");
  if (stills_.count(b.index)) {
    const fs::path still = stills_dir_ / ("before_after_" + std::to_string(b.index) + ".png");
    std::vector<uchar> png;
    if (!cv::imencode(".png", compose(a, b, hz, stills_scale_), png))
      throw Error("cannot encode '" + still.string() + "'");
    write_file_atomic(still, std::string_view(reinterpret_cast<const char*>(png.data()), png.size()));
  }
  if (critical_still_ && hz && hz->visible && std::isfinite(hz->intended_ttc_s) &&
      (!critical_ttc_ || hz->intended_ttc_s < *critical_ttc_)) {
    critical_ttc_ = hz->intended_ttc_s;
    critical_ = compose(a, b, hz, stills_scale_);
  }
  if (realism_stills_ && hz) {
    for (const AppearanceStats& r : hz->references) references_.push_back(r);
    if (hz->visible && hz->appearance && hz->box.area() > 0) {
      // The object and as much again around it, at most 240 px tall per half.
      const cv::Rect2f& bx = hz->box;
      const cv::Rect img_rect(0, 0, b.image.cols, b.image.rows);
      const cv::Rect around =
          cv::Rect(cv::Rect2f(bx.x - bx.width / 2, bx.y - bx.height / 2, 2 * bx.width, 2 * bx.height)) &
          img_rect;
      if (around.area() > 0) {
        const double k = std::min(1.0, 240.0 / around.height);
        const cv::Size sz(std::max(1, cvRound(around.width * k)), std::max(1, cvRound(around.height * k)));
        cv::Mat l, r, pair;
        cv::resize(a.image(around), l, sz, 0, 0, cv::INTER_AREA);
        cv::resize(b.image(around), r, sz, 0, 0, cv::INTER_AREA);
        cv::hconcat(l, r, pair);
        closeups_.push_back({b.index, *hz->appearance, pair});
        object_class_ = hz->object_class;
      }
    }
  }
  cv::Mat img = compose(a, b, hz, scale_);
  if (!writer_.is_open()) {
    if (fps_ > 0) {
      open_writer(ctx, fps_, img.size());
    } else if (!pending_) {
      pending_ = img;
      first_t_ = b.timestamp;
      return;
    } else {
      const double dt = b.timestamp - *first_t_;
      open_writer(ctx, dt > 1e-6 ? 1.0 / dt : 1.0, img.size());
    }
    if (pending_) {
      write(ctx, *pending_);
      pending_.reset();
    }
  }
  write(ctx, img);
}

void SideBySideSink::write_realism_stills(StageContext& ctx) const {
  if (closeups_.empty()) return;
  const std::vector<AppearanceStats> real = realism::references_for(object_class_, references_, 5);
  if (real.empty()) {
    ctx.log(LogLevel::kInfo, "side_by_side: no real objects were measured, so no realism stills");
    return;
  }
  const fs::path dir = stills_dir_ / "realism";
  fs::create_directories(dir);
  int written = 0;
  for (const realism::MetricDef& m : realism::metric_defs()) {
    std::vector<double> values;
    for (const AppearanceStats& r : real) values.push_back(m.get(r));
    const realism::Spread sp = realism::spread(values);
    if (sp.n == 0) continue;
    // How far from the recording's median each frame's value is: |percentile rank - 0.5|, ties broken by the
    // distance in the metric's own unit.
    const Closeup *best = nullptr, *worst = nullptr;
    double best_d = 0, worst_d = 0;
    for (const Closeup& c : closeups_) {
      const double v = m.get(c.stats);
      if (!std::isfinite(v)) continue;
      const double d = std::abs(realism::percentile_rank(values, v) - 0.5) * 1e6 + std::abs(v - sp.median);
      if (!best || d < best_d) best = &c, best_d = d;
      if (!worst || d > worst_d) worst = &c, worst_d = d;
    }
    if (!best) continue;
    for (const auto& [which, c] : {std::pair{"best", best}, std::pair{"worst", worst}}) {
      cv::Mat img = c->pair.clone();
      char text[200];
      std::snprintf(
          text, sizeof text, "%s %s: inserted %.3g (frame %lld); real median %.3g, p10-p90 %.3g-%.3g (n=%d)",
          m.name, which, m.get(c->stats), static_cast<long long>(c->frame), sp.median, sp.p10, sp.p90, sp.n);
      // The caption on a strip below the pair, wide enough for it.
      const int font = cv::FONT_HERSHEY_SIMPLEX;
      int base = 0;
      const cv::Size ts = cv::getTextSize(text, font, 0.45, 1, &base);
      cv::Mat canvas(img.rows + ts.height + base + 12, std::max(img.cols, ts.width + 12), CV_8UC3,
                     cv::Scalar(32, 32, 32));
      img.copyTo(canvas(cv::Rect(0, 0, img.cols, img.rows)));
      cv::putText(canvas, text, cv::Point(6, img.rows + ts.height + 5), font, 0.45, cv::Scalar(255, 255, 255),
                  1, cv::LINE_AA);
      const fs::path still = dir / (std::string(m.name) + "_" + which + ".png");
      std::vector<uchar> png;
      if (!cv::imencode(".png", canvas, png)) throw Error("cannot encode '" + still.string() + "'");
      write_file_atomic(still, std::string_view(reinterpret_cast<const char*>(png.data()), png.size()));
      ++written;
    }
  }
  ctx.log(LogLevel::kInfo, "side_by_side: " + std::to_string(written) + " realism stills in " + dir.string());
}

void SideBySideSink::finish(StageContext& ctx, Outputs& /*out*/) {
  if (realism_stills_) write_realism_stills(ctx);
  if (critical_) {
    const fs::path still = stills_dir_ / "critical.png";
    std::vector<uchar> png;
    if (!cv::imencode(".png", *critical_, png)) throw Error("cannot encode '" + still.string() + "'");
    write_file_atomic(still, std::string_view(reinterpret_cast<const char*>(png.data()), png.size()));
  }
  if (pending_) {  // a single frame: no interval to derive the rate from
    open_writer(ctx, fps_ > 0 ? fps_ : 1.0, pending_->size());
    write(ctx, *pending_);
    pending_.reset();
  }
  if (!writer_.is_open()) return;
  writer_.close();
  ctx.log(LogLevel::kInfo, "side_by_side: " + std::to_string(written_) + " frames written to " +
                               file_.string() + " (" + codec_ + ")");
}

}  // namespace hf::render
