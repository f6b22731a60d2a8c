// Stage `ground_odometry`: the ego's speed and yaw rate measured on the frames themselves, for sources that
// carry neither dataset poses nor an ego track.
#pragma once

#include <memory>
#include <optional>

#include "hazardforge/atomic_file.hpp"
#include "hazardforge/footage/ego_motion.hpp"
#include "hazardforge/footage/lever_arm.hpp"
#include "hazardforge/stage.hpp"

namespace hf::filter {

// Ports: in `frames`; out `frames` (the same frames, image, camera and meta untouched, with `ego.speed_mps`,
// `ego.yaw_rate` and `ego.source` = "video" filled from the odometry). Each output keeps its input's
// timestamp, one per input, in order.
// Frame by frame, with the first frame's camera, the footage kit's GroundOdometry (the road view warped to a
// bird's-eye view, coarse search, KLT, rigid fit; the whole picture's turn between far-apart frames) measures
// the interval since the previous frame; measured samples are smoothed exponentially (`smoothing`), frames it
// cannot measure hold the last estimate. Causal: nothing of later frames is used (the video source, which
// reads its file twice, smooths over the whole clip instead). Frames that already carry an ego speed (dataset
// poses, a video source's track) pass through unchanged unless `replace`; with `replace`, their own speed
// stays on the frames the odometry cannot measure. Params: smoothing, replace, file.
class GroundOdometryStage : public Stage {
 public:
  static ComponentInfo describe();
  void open(StageContext& ctx) override;
  void process(StageContext& ctx, const Inputs& in, Outputs& out) override;
  void finish(StageContext& ctx, Outputs& out) override;

 private:
  double smoothing_ = 0.5;
  bool replace_ = false;
  std::unique_ptr<footage::GroundOdometry> odometry_;  // created on the first frame it runs on
  std::unique_ptr<footage::LeverArmScale> lever_;      // the same
  std::optional<double> speed_, yaw_rate_;             // the smoothed estimate so far
  RecordFile log_;
  int64_t frames_ = 0, estimated_ = 0, measured_ = 0, passed_ = 0;
  bool warned_unmeasured_ = false;
};

}  // namespace hf::filter
