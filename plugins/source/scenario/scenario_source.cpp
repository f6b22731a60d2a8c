// ScenarioSource: a scenario package's pictures as a frame stream.
#include "scenario_source.hpp"

#include "hazardforge/error.hpp"
#include "hazardforge/image_file.hpp"

namespace hf::source {

namespace fs = std::filesystem;

ComponentInfo ScenarioSource::describe() {
  ComponentInfo i = base_info("scenario", "the frames of a scenario package (a hazard run's scenario/)");
  i.doc =
      "Reads the package a hazard run's scenario_package sink wrote (scenario.json, frames.jsonl, the "
      "pictures) and emits its augmented or its original frames, with the camera, timestamps, ego speed and "
      "yaw rate the package records. hazardforge test runs a system's graph on it "
      "(docs/testing-a-system.md).";
  i.params = {
      ParamSpec::path("path", std::nullopt).describe("the package folder, or a run folder holding scenario/"),
      ParamSpec::string("view", "augmented")
          .one_of({"augmented", "original"})
          .describe("the pictures emitted: after augmentation, or the recording's own (the control)"),
  };
  return i;
}

void ScenarioSource::open(StageContext& ctx) {
  pkg_ = scenario::read_package(ctx.params().get_path("path"));
  augmented_ = ctx.params().get_string("view") == "augmented";
}

bool ScenarioSource::next(StageContext& /*ctx*/, Outputs& out) {
  if (pos_ >= pkg_.frames.size()) return false;
  const scenario::PackageFrame& pf = pkg_.frames[pos_];
  const fs::path file = fs::absolute(pkg_.picture(pf, augmented_));
  Frame f;
  f.index = pf.frame;
  f.timestamp = pf.timestamp;
  f.image = read_color_image(
      file, "scenario picture '" + file.string() + "' (frame " + std::to_string(pf.frame) + ")");
  if (f.image.cols != pf.camera.width || f.image.rows != pf.camera.height)
    throw Error("scenario picture '" + file.string() + "' (frame " + std::to_string(pf.frame) + ") is " +
                std::to_string(f.image.cols) + "x" + std::to_string(f.image.rows) + ", its camera " +
                std::to_string(pf.camera.width) + "x" + std::to_string(pf.camera.height));
  f.camera = pf.camera;
  f.ego.speed_mps = pf.ego_speed_mps;
  f.ego.yaw_rate = pf.ego_yaw_rate;
  f.ego.source = "scenario";
  f.source_id = file.string();
  f.origin = pkg_.header.origin;
  f.stream_end = pkg_.frames.back().timestamp;
  const double ts = f.timestamp;
  out.emit_packet("frames", Packet::make<Frame>(std::move(f), ts));
  ++pos_;
  return true;
}

}  // namespace hf::source
