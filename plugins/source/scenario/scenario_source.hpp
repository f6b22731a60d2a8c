// Frame source over a scenario package (hazardforge/scenario_package.hpp).
#pragma once

#include <optional>

#include "hazardforge/scenario_package.hpp"
#include "hazardforge/stage.hpp"

namespace hf::source {

// Stage "scenario" (kind source): the frames of a scenario package, the augmented pictures or the original
// ones, each with the package's camera, timestamp and ego speed and yaw rate (what a vehicle's bus gives a
// system), its frame number the recording's. Frame::source_id is the picture's absolute path.
// Ports: out `frames` (Frame, BGR 8-bit). Params: path (a package or a run folder), view.
class ScenarioSource : public SourceStage {
 public:
  static ComponentInfo describe();
  void open(StageContext& ctx) override;
  bool next(StageContext& ctx, Outputs& out) override;
  std::optional<int64_t> frame_count() const override { return static_cast<int64_t>(pkg_.frames.size()); }

 private:
  scenario::Package pkg_;
  bool augmented_ = true;
  size_t pos_ = 0;
};

}  // namespace hf::source
