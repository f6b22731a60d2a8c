// xosc sink: writes each planned hazard as an ASAM OpenSCENARIO 1.2 scenario file.
#pragma once

#include <string>

#include "hazardforge/hazard/kinematics.hpp"
#include "hazardforge/stage.hpp"

namespace hf {

// Stage xosc (kind sink).
// Inputs: `trajectory` (HazardTrajectory, sticky), `frames` (Frame, optional: the anchor frame's ego pose
// places the scenario in the dataset's world frame, and its meta.ego_track gives the road beyond the plan).
// Outputs: none. When a trajectory arrives writes <output>/<file> and its road <stem>.xodr beside it
// (<stem>_<n>.* for the n-th of a run), and once per run the hazard maneuver catalog; all atomically, so an
// interrupted run keeps them. The road's lanes come from the spec's road (HazardSpec::road, the road the
// generator settled). Params: file, catalog, author, description, coordinates (auto | anchor | world), ego (controlled |
// replay), lead_in_s, after_s, ego_name, hazard_name, ego_front_m, limits, class_sizes.
class XoscSink : public Stage {
 public:
  static ComponentInfo describe();
  void open(StageContext& ctx) override;
  void process(StageContext& ctx, const Inputs& in, Outputs& out) override;

 private:
  std::string file_, coordinates_, catalog_, ego_mode_;
  double lead_in_ = 3, after_ = 3;
  bool catalog_written_ = false;
  std::string author_, description_, ego_name_, hazard_name_;
  LimitsTable limits_;
  cv::Vec3d ego_size_{4.5, 1.85, 1.52};
  double ego_front_ = 3.4;
  const void* last_ = nullptr;
  int written_ = 0;
};

}  // namespace hf
