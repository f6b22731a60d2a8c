// GroundOdometryStage: the footage kit's ground-plane odometry frame by frame, into each frame's ego state.
#include "ground_odometry_stage.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <string>

#include "hazardforge/angles.hpp"
#include "hazardforge/error.hpp"
#include "hazardforge/json_text.hpp"
#include "hazardforge/output_path.hpp"

namespace hf::filter {

namespace {}  // namespace

ComponentInfo GroundOdometryStage::describe() {
  ComponentInfo i;
  i.name = "ground_odometry";
  i.kind = kind::kFilter;
  i.summary = "the ego's speed and yaw rate from the frames' road view, for sources without ego motion";
  i.doc =
      "Runs the footage kit's ground-plane odometry (the one the video source runs over its whole clip) "
      "frame "
      "by frame on the frames it receives, with the first frame's camera: the road 3-22 m ahead warped to a "
      "bird's-eye view, a coarse search over distance and turn, KLT, a rigid fit on the ground, and the "
      "whole "
      "picture's turn between frames 0.15 s or more apart; between those, in the bends, the distance from "
      "the camera's lever arm ahead of the rear axle (the straight travel from the straight pairs seen so "
      "far). Measured intervals are smoothed exponentially; "
      "frames it cannot measure hold the last estimate. Each frame leaves with ego.speed_mps, ego.yaw_rate "
      "and ego.source = \"video\", which the estimators (the ego speed in TTC), the generator, the planner "
      "and the renderer read. Causal: no later "
      "frame is used. Frames that already carry an ego speed (dataset poses, a video source's track) pass "
      "through unchanged unless replace is set. Writes one line per frame to `file`.";
  i.inputs = {port<Frame>("frames", "frames without ego motion (image and camera model)")};
  i.outputs = {port<Frame>("frames", "the same frames with the measured ego speed and yaw rate; same time")};
  i.params = {
      ParamSpec::number("smoothing", 0.5)
          .range(0.0, 0.95)
          .describe("exponential smoothing of the measured speed and yaw rate (0 = the raw measurement)"),
      ParamSpec::boolean("replace", false)
          .describe("also measure frames that carry an ego speed (dataset poses), keeping their own speed "
                    "where the road view gives no measurement; off = such frames pass unchanged"),
      ParamSpec::string("file", "ego_odometry.jsonl")
          .describe(
              "one JSON line per frame (speed, yaw rate, measured, the raw sample), relative to the run "
              "folder; empty = none"),
  };
  return i;
}

void GroundOdometryStage::open(StageContext& ctx) {
  const Params& p = ctx.params();
  smoothing_ = p.get_double("smoothing");
  replace_ = p.get_bool("replace");
  if (!p.get_string("file").empty()) log_.open(output_param_path(ctx, "file"), RecordFile::Mode::kTruncate);
}

void GroundOdometryStage::process(StageContext& ctx, const Inputs& in, Outputs& out) {
  const Frame& f = in.require<Frame>("frames");
  ++frames_;
  Frame o = f;  // the image is shared, not copied
  Json line = {{"frame", f.index}, {"timestamp", f.timestamp}};
  if (!replace_ && f.ego.speed_mps) {
    ++passed_;
  } else {
    if (f.image.empty() || !f.camera.valid())
      throw Error(frame_name(f) + ": ground_odometry needs the frame's image and camera model");
    const auto t0 = std::chrono::steady_clock::now();
    if (!odometry_)
      odometry_ = std::make_unique<footage::GroundOdometry>(f.camera, footage::OdometryOptions{});
    if (!lever_) lever_ = std::make_unique<footage::LeverArmScale>(f.camera.cam_to_ego({0, 0, 0})[0]);
    // In the bends, the distance from the camera's lever arm (causal: the straight travel from the straight
    // pairs seen so far).
    footage::EgoMotionSample s = odometry_->add(f.image, f.index, f.timestamp);
    lever_->observe(s);
    s = lever_->fuse(s);
    ctx.record_timing("odometry",
                      std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count());
    line["measured"] = s.measured;
    if (s.measured) {
      ++measured_;
      line["raw_speed_mps"] = s.speed_mps;
      line["raw_speed_from"] = footage::speed_cue_name(s.speed_cue);
      line["raw_yaw_rate_dps"] = s.yaw_rate * kDegPerRad;
      if (s.ground_pitch_offset) line["road_pitch_offset_deg"] = *s.ground_pitch_offset * kDegPerRad;
      // A front camera's ego does not drive backwards (the kit's smoother holds the same floor).
      double v = std::max(0.0, s.speed_mps), w = s.yaw_rate;
      if (speed_) {
        v = smoothing_ * *speed_ + (1.0 - smoothing_) * v;
        w = smoothing_ * yaw_rate_.value_or(w) + (1.0 - smoothing_) * w;
      }
      speed_ = v;
      yaw_rate_ = w;
    } else if (f.ego.speed_mps) {
      // replace: the frame's own speed where the road view measured nothing; the estimate continues from it.
      speed_ = f.ego.speed_mps;
      yaw_rate_ = f.ego.yaw_rate;
    } else if (s.yaw_measured && speed_) {
      // The whole picture's turn alone: the speed is held, the turn follows.
      line["raw_yaw_rate_dps"] = s.yaw_rate * kDegPerRad;
      yaw_rate_ = smoothing_ * yaw_rate_.value_or(s.yaw_rate) + (1.0 - smoothing_) * s.yaw_rate;
    }
    if (s.measured || !f.ego.speed_mps) {
      if (speed_) {
        o.ego.speed_mps = speed_;
        o.ego.yaw_rate = yaw_rate_;
        o.ego.source = "video";
        ++estimated_;
      } else if (frames_ > 1 && !warned_unmeasured_) {
        ctx.log(LogLevel::kWarning,
                frame_name(f) +
                    ": the road view has given no motion measurement yet (too little texture, or the road "
                    "hidden): the frames pass without an ego speed until one is measured");
        warned_unmeasured_ = true;
      }
    }
  }
  line["speed_mps"] = o.ego.speed_mps ? Json(*o.ego.speed_mps) : Json();
  line["yaw_rate_dps"] = o.ego.yaw_rate ? Json(*o.ego.yaw_rate * kDegPerRad) : Json();
  line["source"] = o.ego.source.empty() ? "unknown" : o.ego.source;
  if (log_.is_open()) log_.write(json_text(line) + "\n");
  out.emit("frames", std::move(o));
}

void GroundOdometryStage::finish(StageContext& ctx, Outputs& /*out*/) {
  log_.close();
  ctx.log(LogLevel::kInfo, std::to_string(frames_) + " frames: " + std::to_string(measured_) +
                               " measured by the road view, " + std::to_string(estimated_) +
                               " leave with its estimate, " + std::to_string(passed_) +
                               " passed with their own ego speed");
}

}  // namespace hf::filter
