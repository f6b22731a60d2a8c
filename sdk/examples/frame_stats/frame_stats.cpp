// Example plugin: a sink that writes one CSV row per frame (brightness, optional detection count).
// It is the whole plugin — one file — and shows params, an optional input, open/process/finish.
#include <fstream>
#include <iomanip>

#include <opencv2/core.hpp>

#include "hazardforge/plugin.hpp"

namespace {

// Ports: in `frames` (Frame), in `detections` (Detections, optional). Writes `file` (CSV) in the run folder,
// one row per frame with the frame's timestamp; rows are flushed as they are written.
class FrameStatsSink : public hf::Stage {
 public:
  static hf::ComponentInfo describe() {
    hf::ComponentInfo i;
    i.name = "frame_stats";
    i.kind = hf::kind::kSink;
    i.summary = "CSV of per-frame brightness and detection count";
    i.inputs = {hf::port<hf::Frame>("frames", "frames to measure"),
                hf::optional(hf::port<hf::Detections>("detections", "counted when connected"))};
    i.params = {hf::ParamSpec::string("file", "frame_stats.csv").describe("CSV file in the run folder"),
                hf::ParamSpec::integer("precision", 3).range(0, 10).describe("decimals written")};
    return i;
  }

  void open(hf::StageContext& ctx) override {
    const auto path = ctx.output_dir() / ctx.params().get_string("file");
    out_.open(path);
    if (!out_) throw hf::Error(path.string() + ": cannot write");
    out_ << std::fixed << std::setprecision(static_cast<int>(ctx.params().get_int("precision")));
    out_ << "frame,timestamp,mean_brightness,detections\n";
  }

  void process(hf::StageContext&, const hf::Inputs& in, hf::Outputs&) override {
    const hf::Frame& f = in.require<hf::Frame>("frames");
    const cv::Scalar m = cv::mean(f.image);
    const double brightness = (m[0] + m[1] + m[2]) / 3.0;
    const auto* dets = in.get<hf::Detections>("detections");
    out_ << f.index << "," << f.timestamp << "," << brightness << "," << (dets ? static_cast<long>(dets->items.size()) : -1)
         << "\n"
         << std::flush;
  }

 private:
  std::ofstream out_;
};

}  // namespace

HAZARDFORGE_PLUGIN("frame_stats", "1.0.0", "Apache-2.0", "Example out-of-tree sink: per-frame statistics") {
  reg.add<FrameStatsSink>();
}
